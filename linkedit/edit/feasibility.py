"""Whether an edited linkage works: the planar predicate plus what an edit can break.

A linkage works when every dyad triangle (i) has, at the rest pose, the orientation the plan
was compiled with (so phase 0 rebuilds exactly the rest pose: no branch change), and (ii) can
be closed at every sample; every slider rule and numeric group can be placed at every sample on
the side (determinant sign) it had at rest (:mod:`linkedit.edit.steps`). "Closed" is the one
planar predicate, :func:`linkedit.planar.feasibility.assembles` (d_s above the toggle rounding,
as ``simulate`` has it). The input must keep working: a crank its length (and its rest direction
unless freed), a linear input's guide link its length. Rigid placements are exact by construction and are never checked: a joint collinear with its link's two reference joints (Hoekens' tracer) or a mirrored
plate is a working linkage.

The line search, the final re-check at 4× the samples (a ``simulate``, which checks lock-ups at
:data:`~linkedit.planar.feasibility.CHECK_SAMPLES` too) and the report all call :func:`failure`.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.diagnostics import degrees_text
from linkedit.planar.feasibility import assembles
from linkedit.planar.plan import Plan


def flipped(plan: Plan, rest: np.ndarray) -> np.ndarray:
    """Dyad rules (indices into ``plan.table``) whose rest triangle lost its orientation.

    ``rest`` (J,) complex joint positions.
    """
    t = plan.table
    dyad = np.flatnonzero(~t.rigid)
    i, j, k = t.joints[dyad].T
    u, v = rest[j] - rest[i], rest[k] - rest[i]
    cross = u.real * v.imag - u.imag * v.real
    return dyad[~(cross * t.orientation[dyad] > 0)]


def failure(plan: Plan, rest: np.ndarray, ds: np.ndarray, turn_deg: np.ndarray,
            arm: complex | None = None) -> str | None:
    """Why the linkage does not work, naming the joint and motor angle; None if it works.

    ``rest`` (J,) complex; ``ds`` (N, T) singularity distance per row of the plan's rules
    (``Plan.ds_rows``; rows of :attr:`~linkedit.planar.rules.Rule.exact` rules ignored), NaN where not
    computed; a row fails where it does not :func:`~linkedit.planar.feasibility.assembles`, and the
    first one in evaluation order is named. ``turn_deg`` (T,) motor rotation of each sample
    from the rest pose, degrees (a linear input: its stroke, spec units);
    ``arm`` the direction the crank must keep at rest (its rest angle is fixed), or None (and for a
    linear input, whose guide link must keep a length instead).
    """
    names = plan.joint_names
    g = plan.graph
    why = _drive(plan, rest) if plan.linear else _crank(plan, rest, arm)
    if why is not None:
        return why
    bad = flipped(plan, rest)
    if bad.size:
        i, j, k = plan.table.joints[bad[0]]
        return (f"joint {names[k]} changes branch: triangle {names[i]}-{names[j]}-{names[k]} "
                "of the rest pose flipped")
    owner, within = plan.ds_rule()
    checked = np.flatnonzero([not plan.rules[o].exact for o in owner])
    closed = assembles(ds[checked])
    if closed.all():
        return None
    r, t = np.argwhere(~closed)[0]
    row = checked[r]
    if plan.linear:
        angle = f"stroke {turn_deg[t]:.6g} {plan.spec.units}"
    else:
        rest_deg = np.degrees(np.angle(rest[g.motor] - rest[g.pivot]))
        angle = f"motor angle {degrees_text(rest_deg + turn_deg[t])}"
    return f"{plan.rules[owner[row]].culprit(names, int(within[row]))} cannot be assembled at {angle}"


def _crank(plan: Plan, rest: np.ndarray, arm: complex | None) -> str | None:
    """The crank keeps a length (above 1e-9 of the linkage's size: a spec's joints closer than that
    are one point) and, unless freed, its rest direction ``arm``."""
    names, g = plan.joint_names, plan.graph
    crank = rest[g.motor] - rest[g.pivot]
    size = float(np.abs(rest - rest[g.ground[0]]).max())
    if abs(crank) <= 1e-9 * size or (crank.conjugate() * (arm if arm is not None else crank)).real <= 0.0:
        return (f"the crank {names[g.pivot]}-{names[g.motor]} vanishes or turns away from its rest angle "
                "(free it with motor: {free_angle: true})")
    return None


def _drive(plan: Plan, rest: np.ndarray) -> str | None:
    """A linear input: the guide link carrying its slot keeps a length (the slot line stays
    defined; a slot in the frame always is)."""
    names, g = plan.joint_names, plan.graph
    slider = g.sliders[g.drive]
    if g.fixed(slider.guide):
        return None
    a, b = g.frame_pair(slider.guide)
    size = float(np.abs(rest - rest[g.ground[0]]).max())
    if abs(rest[b] - rest[a]) <= 1e-9 * size:
        return (f"linear input {slider.name}: its guide {g.link_names[slider.guide]} vanishes "
                f"({names[a]} and {names[b]} meet)")
    return None
