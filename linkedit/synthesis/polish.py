"""The final polish through ``linkedit edit``: the refined linkage's spec, edited to follow the target.

One edit operation, ``follow: {track: target, curve: <the target>, timing: false}`` (with
``--timing``: ``timing: true`` and the target resampled evenly over the cycle from its first
sample, which is the rest pose), every joint free, the motor's rest angle free (the phase),
the singularity barrier on with ε = the family's margin, regularization 10⁻⁴. The edit moves the
rest pose itself, so it reaches what the family's parameters do not (a four-bar's ground pivots
and crank direction at once) but not the coupler point's place on its link; its shape distance is
one-sided (every linkage sample to the target polyline).

The polished linkage is kept only if the edit finishes with a working linkage, it works with the
family's margin by the one planar predicate (:mod:`linkedit.planar.feasibility`: its lowest d_s
over the cycle, at the dense samples and between them, at or above the margin), and its error
(measured like the refinement's: both ways for a shape, at the times with ``--timing``) is lower; otherwise the
refined linkage stands and the report says why. Open targets (part of a cycle) are not polished:
a one-sided distance from the whole cycle to part of it would fold the cycle onto the part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar import compile_plan, simulate
from linkedit.planar.feasibility import CHECK_SAMPLES, works
from linkedit.planar.simulate import Motion
from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec
from linkedit.synthesis.refine import UNIT, Frame, curve_error
from linkedit.synthesis.timed import SAMPLES as TIMED_SAMPLES
from linkedit.synthesis.timed import TimedTarget

#: Edit samples per cycle and iterations of the polish.
SAMPLES = 240
ITERATIONS = 100
REGULARIZATION = 1e-4


@dataclass
class Polish:
    kept: bool
    why: str  #: what happened, in words
    error: tuple[float, float] | None = None  #: (RMS, max) of the polished linkage, when it works
    min_singularity: float | None = None
    iterations: int = 0
    spec: LinkageSpec | None = None
    motion: Motion | None = None


def measure(spec: LinkageSpec, target: np.ndarray, size: float, samples: int, timed: TimedTarget | None,
            frame: Frame = UNIT) -> tuple[tuple[float, float], Motion]:
    """(RMS, max) error over ``size`` of the linkage ``spec``'s track ``target`` against the closed
    target (M,) complex — both ways, or with ``timed`` at the target's own samples and times — and its
    simulation. The target and ``size`` are in the unit frame, the linkage in ``frame``."""
    plan = compile_plan(spec)
    motion = simulate(plan, TIMED_SAMPLES if timed is not None else samples)
    if timed is None:
        return curve_error(target, True, frame.unit(motion.tracks["target"].position), size), motion
    return timed.error(frame.unit(simulate(plan, phases=timed.phases).tracks["target"].position)), motion


def polish(spec: LinkageSpec, target: np.ndarray, size: float, error: tuple[float, float], margin: float,
           samples: int, timed: TimedTarget | None = None) -> Polish:
    """Edit ``spec`` (the refined linkage, error ``error``) to follow ``target`` (M,) complex; see the module."""
    from linkedit.edit.runner import EditFailed, run_script

    curve = timed.points if timed is not None else target
    script = EditScript.model_validate({
        "samples": SAMPLES, "motor": {"free_angle": True}, "weights": {"regularization": REGULARIZATION},
        "singularity_epsilon": margin,
        "operations": [{"name": "polish", "max_iterations": ITERATIONS,
                        "follow": {"track": "target", "curve": np.column_stack([curve.real, curve.imag]).tolist(),
                                   "timing": timed is not None}}]})
    try:
        edited = run_script(spec, script).edited
    except (EditFailed, MechanismError) as exc:
        return Polish(False, f"the edit did not finish with a working linkage ({exc})")
    edited = edited.model_copy(update={"description": spec.description})
    polished, motion = measure(edited, target, size, samples, timed)
    worst = simulate(motion.plan, CHECK_SAMPLES).lowest_singularity()
    ds = worst[0] if worst is not None else 1.0
    if not works(ds, margin):
        return Polish(False, f"the edit crossed the singularity margin (min d_s {ds:.3g} < {margin:.3g})", polished, ds)
    if polished[0] >= error[0]:
        return Polish(False, f"the edit did not lower the error ({100 * polished[0]:.3g} % ≥ {100 * error[0]:.3g} %)",
                      polished, ds)
    return Polish(True, f"kept: {100 * error[0]:.3g} % → {100 * polished[0]:.3g} %", polished, ds, spec=edited,
                  motion=motion)
