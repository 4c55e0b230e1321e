"""Evaluate a plan over many motor angles at once: positions, velocities, accelerations.

All arrays are complex (x + iy) with rows in the plan's internal order: shape (P, T) for P
points and T samples. One Python iteration per rule of the plan's sequence (a level's rigid or
dyad batch is one rule), never per sample; each rule writes its own rows
(:mod:`linkedit.planar.rules`). Derivatives are with respect to the motor angle, propagated analytically through
the same rules.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import assembles
from linkedit.planar.plan import Geometry, Plan
from linkedit.planar.rules import Frame, Triangles

#: largest input change between two samples a numeric group is continued across: motor
#: degrees, or a fraction of the characteristic length for a linear input
GROUP_STEP_DEG = 1.0
GROUP_STEP_LENGTH = 0.005


@dataclass
class State:
    """Evaluated plan. ``z``, ``dz``, ``ddz``: (P, T) complex in internal rows; ``ds``: (N, T)."""

    z: np.ndarray
    dz: np.ndarray | None  # None when evaluated with order 0
    ddz: np.ndarray | None  # None when evaluated with order < 2
    #: singularity distance per d_s row (``Plan.ds_rows``; 1 for rigid rules); < 0 or NaN: cannot place
    ds: np.ndarray
    #: with numeric groups: whether every intermediate continuation sample assembled too
    between_ok: bool = True

    def derivatives(self) -> tuple[np.ndarray, np.ndarray]:
        """(dz, ddz), (P, T) each, of an evaluation with order 2."""
        if self.dz is None or self.ddz is None:
            raise ValueError("the plan was evaluated without its derivatives (order < 2)")
        return self.dz, self.ddz


class Workspace:
    """Preallocated arrays for repeated :func:`positions` calls at T samples.

    The hot path then allocates nothing: every step writes into these buffers (``out=``), so
    large batches do not pay for fresh memory pages on each call.
    """

    def __init__(self, plan: Plan, samples: int) -> None:
        rows = max((r.stop - r.start for r in plan.rules if isinstance(r, Triangles)), default=0)
        self.samples = samples
        self.z = np.empty((plan.n_points, samples), dtype=complex)
        self.zi, self.zj, self.e, self.w = (np.empty((rows, samples), dtype=complex) for _ in range(4))
        self.d2, self.u, self.a, self.b = (np.empty((rows, samples)) for _ in range(4))


def positions(plan: Plan, geom: Geometry, angle: np.ndarray, work: Workspace | None = None) -> np.ndarray:
    """Positions only, (P, T) complex, for absolute motor angles ``angle`` (T,) in radians.

    NaN where the linkage cannot be assembled (see :func:`evaluate` for diagnostics). Pass a
    :class:`Workspace` to evaluate repeatedly without allocating; the result is then
    ``work.z`` (overwritten by the next call).
    """
    if plan.steps:
        return evaluate(plan, geom, angle, order=0).z
    w = work if work is not None and work.samples == angle.shape[0] else Workspace(plan, angle.shape[0])
    z = w.z
    z[plan.ground_rows] = geom.ground
    np.multiply(geom.arm, np.exp(1j * (angle - geom.rest_angle)), out=z[plan.motor_row])
    z[plan.motor_row] += geom.pivot
    with np.errstate(invalid="ignore", divide="ignore"):
        for rule, const in zip(plan.rules, geom.constants):
            rule.positions(z, const, w)
    return z


def continuation_grid(start: float, values: np.ndarray, max_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Input values from ``start`` through ``values`` (T,) at most ``max_step`` apart, and where
    each of ``values`` is in them (T,)."""
    path = np.concatenate([[start], values])
    parts = np.maximum(np.ceil(np.abs(np.diff(path)) / max_step - 1e-9), 1).astype(int)
    first = np.concatenate([[0], np.cumsum(parts)])
    piece = np.repeat(np.arange(values.size), parts)  # the move each fine value belongs to
    within = np.arange(first[-1]) - first[piece]
    fine = np.append(path[piece] + (path[piece + 1] - path[piece]) * within / parts[piece], path[-1])
    return fine, first[1:]


def evaluate(plan: Plan, geom: Geometry, angle: np.ndarray, order: int = 2) -> State:
    """Positions and up to ``order`` (0, 1, 2) derivatives, plus singularity distances.

    ``angle`` (T,): absolute motor angles, radians (for a linear input: displacements along the
    slot in the normalized frame); (K, T) or (T,) with a geometry of K linkages (then every array
    has a linkage axis after its row, see :func:`_evaluate`). A plan with slider steps needs a geometry in the normalized
    frame (``Geometry.of(plan, plan.normalized_points())``). A numeric group is continued from
    the rest pose through every sample in order, at most GROUP_STEP_DEG (GROUP_STEP_LENGTH)
    apart: intermediate inputs are evaluated and dropped.
    """
    if not plan.has_groups:
        return _evaluate(plan, geom, angle, order)
    start, step = (0.0, GROUP_STEP_LENGTH) if plan.linear else (float(geom.rest_angle), np.radians(GROUP_STEP_DEG))
    fine, keep = continuation_grid(start, np.asarray(angle, dtype=float), step)
    full = _evaluate(plan, geom, fine, order)

    def pick(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[:, keep]

    between_ok = bool(np.isfinite(full.z).all() and assembles(full.ds).all())
    return State(z=full.z[:, keep], dz=pick(full.dz), ddz=pick(full.ddz), ds=full.ds[:, keep], between_ok=between_ok)


def _evaluate(plan: Plan, geom: Geometry, angle: np.ndarray, order: int) -> State:
    """The one evaluation of a plan: every rule in order. With a geometry of K linkages
    (:attr:`Geometry.linkages`), arrays carry a linkage axis after the row: (P, K, T), and
    ``angle`` may be (K, T); every rule but a numeric group places K linkages at once (the
    non-revolute kinds their positions and d_s only: ``order`` 0)."""
    lead = geom.linkages
    if lead and (plan.has_groups or (plan.steps and order > 0)):
        raise ValueError("numeric groups, and the derivatives of sliders, are evaluated one linkage at a time")
    T = angle.shape[-1]
    P = plan.n_points
    z = np.zeros((P, *lead, T), dtype=complex)  # zeros: step rows multiply not-yet-known joints by 0
    dz = np.zeros((P, *lead, T), dtype=complex) if order >= 1 else None
    ddz = np.zeros((P, *lead, T), dtype=complex) if order >= 2 else None
    ds = np.ones((plan.n_ds, *lead, T))
    z[plan.ground_rows] = geom.ground
    if not plan.linear:
        arm = geom.arm * np.exp(1j * (angle - geom.rest_angle))
        z[plan.motor_row] = geom.pivot + arm
        if dz is not None:
            dz[plan.motor_row] = 1j * arm
        if ddz is not None:
            ddz[plan.motor_row] = -arm
    s = angle if plan.linear else np.zeros_like(angle)
    frame = Frame(z=z, dz=dz, ddz=ddz, ds=ds, joints=plan.row_of[: plan.n_joints], s=s,
                  drive=1.0 if plan.linear else 0.0, rest=geom.rest)
    with np.errstate(invalid="ignore", divide="ignore"):
        for rule, rows, const in zip(plan.rules, plan.ds_rows, geom.constants):
            rule.evaluate(frame, const, rows)
    return State(z=z, dz=dz, ddz=ddz, ds=ds)
