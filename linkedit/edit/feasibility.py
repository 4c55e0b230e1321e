"""The one predicate that decides whether an edited linkage works.

A linkage works when every dyad triangle (i) has, at the rest pose, the orientation the plan
was compiled with (so phase 0 rebuilds exactly the rest pose: no branch change), and (ii) can
be closed at every sample (d_s > 0). Rigid placements are exact by construction and are never
checked: a joint collinear with its link's two reference joints (Hoekens' tracer) or a mirrored
plate is a working linkage.

The line search, the final re-check at 4× the samples and the report all call :func:`failure`.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.plan import Plan


def flipped(plan: Plan, rest: np.ndarray) -> np.ndarray:
    """Dyad rules (indices into ``plan.rules``) whose rest triangle lost its orientation.

    ``rest`` (J,) complex joint positions.
    """
    dyad = np.flatnonzero(~plan.rigid)
    i, j, k = plan.rules[dyad].T
    u, v = rest[j] - rest[i], rest[k] - rest[i]
    cross = u.real * v.imag - u.imag * v.real
    return dyad[~(cross * plan.orientation[dyad] > 0)]


def failure(plan: Plan, rest: np.ndarray, ds: np.ndarray, turn_deg: np.ndarray,
            arm: complex | None = None) -> str | None:
    """Why the linkage does not work, naming the joint and motor angle; None if it works.

    ``rest`` (J,) complex; ``ds`` (R, T) singularity distance per rule (rigid rows ignored),
    NaN where not computed; ``turn_deg`` (T,) motor rotation of each sample from the rest pose;
    ``arm`` the direction the crank must keep at rest (its rest angle is fixed), or None.
    """
    names = plan.joint_names
    g = plan.graph
    crank = rest[g.motor] - rest[g.pivot]
    if (crank.conjugate() * (arm if arm is not None else crank)).real <= 0.0:
        return (f"the crank {names[g.pivot]}-{names[g.motor]} vanishes or turns away from its rest angle "
                "(free it with motor: {free_angle: true})")
    bad = flipped(plan, rest)
    if bad.size:
        i, j, k = plan.rules[bad[0]]
        return (f"joint {names[k]} changes branch: triangle {names[i]}-{names[j]}-{names[k]} "
                "of the rest pose flipped")
    dyad = ~plan.rigid
    closed = ds[dyad] > 0.0
    if closed.all():
        return None
    r, t = np.argwhere(~closed)[0]
    rule = np.flatnonzero(dyad)[r]
    rest_deg = np.degrees(np.angle(rest[plan.graph.motor] - rest[plan.graph.pivot]))
    return (f"joint {names[plan.rules[rule, 2]]} cannot be assembled at motor angle "
            f"{(rest_deg + turn_deg[t] + 180.0) % 360.0 - 180.0:.1f}°")
