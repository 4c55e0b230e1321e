"""The same crank-driven linkage built in pylinkage (≥ 1.3, the optional ``bench`` extra), to time
``linkedit``'s positions side by side with pylinkage's numba solver (``Linkage.step_fast``).

The linkage is rebuilt from the compiled plan, rule for rule: ground joints → ``Ground``, the
motor joint → ``Crank`` (its radius, rest angle and 2π/T per step), each triangle-table entry in
evaluation order → ``RRRDyad`` (two distances from the rest pose, started at the rest position so
pylinkage keeps the same branch) or ``FixedDyad`` (a joint on a link: distance and angle from the
rest pose). Only dyadic linkages (no sliders, no numeric groups) have this one-to-one form.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from linkedit.planar.plan import Plan


def dyadic(plan: Plan) -> bool:
    """Whether the plan is crank-driven dyads and joints on links only (what :func:`build` rebuilds)."""
    return not plan.steps and not plan.linear


def build(plan: Plan, samples: int) -> tuple[Any, np.ndarray]:
    """The plan's linkage as a ``pylinkage.Linkage`` turning its crank once in ``samples`` steps,
    and the joint index (J,) of each of its components. Its ``step_fast(samples)`` row t is
    ``linkedit``'s sample t + 1 (pylinkage steps before it records)."""
    import pylinkage as pl

    rest = plan.rest_points[:, 0] + 1j * plan.rest_points[:, 1]
    names, graph = plan.joint_names, plan.graph
    made: dict[int, Any] = {int(k): pl.Ground(rest[k].real, rest[k].imag, name=names[k]) for k in graph.ground}
    motor, pivot = int(graph.motor), int(graph.pivot)
    arm = rest[motor] - rest[pivot]
    made[motor] = pl.Crank(made[pivot], abs(arm), angular_velocity=plan.direction * math.tau / samples,
                           initial_angle=float(np.angle(arm)), name=names[motor])

    def anchor(k: int) -> Any:
        return made[k].output if isinstance(made[k], pl.Crank) else made[k]

    for (i, j, k), rigid in zip(plan.table.joints.tolist(), plan.table.rigid.tolist()):
        if rigid:
            made[k] = pl.FixedDyad(anchor(i), anchor(j), abs(rest[k] - rest[i]),
                                   float(np.angle((rest[k] - rest[i]) / (rest[j] - rest[i]))), name=names[k])
        else:
            made[k] = pl.RRRDyad(anchor(i), anchor(j), abs(rest[k] - rest[i]), abs(rest[k] - rest[j]),
                                 x=rest[k].real, y=rest[k].imag, name=names[k])
    return pl.Linkage(list(made.values())), np.array(list(made), dtype=int)
