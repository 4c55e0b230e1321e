"""Exact accelerations of a solved pose: J a = −γ with the pose's factorization.

Along the solved motion x(t) the residual stays zero: J v + ∂r/∂t = 0, and once more
differentiated, J a + γ = 0 with γ = d/dσ [J(x ⊕ σv, t + σ) v + ∂r/∂t(x ⊕ σv, t + σ)] at σ = 0,
the second-order terms (the change of the velocity equations along the velocity itself).
γ is taken by a central difference of those exact first-order terms (error ~1e-10 of the
size per unit t², far below the 1e-6 of a position difference), with the inputs' parameters
moved along their exact rates (so a keyframe or the end of a window is not straddled), and
``a`` is the least-norm solution with the factorization the pose already has. Where J has a
null space (a free degree of freedom, at its canonical pose: :mod:`linkedit.gcs.canonical`),
the part of ``a`` along it is that of the change of the canonical velocity, a central
difference of the velocities at σ = ±:data:`NULL_STEP` (each the canonical pose's tangent
there; error ~1e-7 relative). At a step with an input outside its window (a free member held:
P v = 0, P the projector on the null space), P a = −Ṗ v from the null spaces at σ = ±h.

Accelerations are d²/dt² of the member positions and the world-frame angular accelerations
dω/dt (rotation increments q ← exp(δθ) ⊗ q agree with them to second order).
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.system import Evaluation, State, StepTable, System

#: the central difference's step, in scaled pose units along the velocity
STEP = 1e-5
#: ... of the canonical velocity along a free direction (its own central differences take
#: canonical.STEP: rounding ~1e-11, over this)
NULL_STEP = 2e-4


def advanced(table: StepTable, step: int | np.ndarray, s: float | np.ndarray) -> StepTable:
    """A table at t + s for one step or steps (B,) of ``table`` (s scalar or (B,)), whose
    driven parameters moved from their values there by s along their rates
    (:meth:`~linkedit.gcs.inputs.Schedule.rate`; exact inside the keyframe segment that starts
    at the step); activity and rates are those of the step."""
    sys = table.system
    steps = np.atleast_1d(step)
    shift = np.broadcast_to(np.asarray(s, dtype=float), steps.shape)
    B = len(steps)
    vectors: list[np.ndarray] = []
    rel_inverse: list[np.ndarray] = []
    values: list[np.ndarray | None] = []
    col = 0
    for blk, rate, value in zip(sys.blocks, table.rates, table.values):
        if rate is None:
            values.append(None)
            continue
        w = shift[:, None, None] * rate[steps]  # (B, S, 6)
        if blk.kind in kinds.VALUE_KINDS:
            assert value is not None  # a driven value kind has its values
            v = value[steps].copy()
            v[:, blk.scheduled] += w[..., 0]
            values.append(v)
            continue
        values.append(None)
        turn = quat.exp(w[..., 3:])
        if blk.kind == "orientation":  # one block per kind: every driven orientation
            rel_inverse.append(quat.multiply(table.rel_inverse[steps], quat.conjugate(turn)))
        else:
            base = table.vectors[steps, col:col + w.shape[1], :3]
            vectors.append(np.tile(quat.rotate(turn, base) + w[..., :3], 3))
            col += w.shape[1]
    stack = lambda xs, k: np.concatenate(xs, axis=1) if xs else np.zeros((B, 0, k))  # noqa: E731
    return StepTable(t=table.t[steps] + shift, vectors=stack(vectors, 9), rel_inverse=stack(rel_inverse, 4),
                     active=[None if a is None else a[steps] for a in table.active],
                     partial=table.partial[steps], system=sys,
                     rates=[None if r is None else r[steps] for r in table.rates], values=values)


def jacobian_product(system: System, ev: Evaluation, v: np.ndarray) -> np.ndarray:
    """J v (R,) from the Jacobian groups of ``ev`` and local velocities v (6M,)."""
    V = np.concatenate([v.reshape(-1, 6), np.zeros((1, 6))])
    out = np.zeros(system.n_rows)
    for grp, jac in zip(system.groups, ev.jacobians()):
        out[grp.rows] += np.einsum("nkmj,nmj->nk", jac, V[grp.members])
    return out


def along(P: np.ndarray, Q: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions P (..., M, 3) and quaternions Q (..., M, 4) moved by local coordinates ``delta``
    (..., 6M) with the exact exponential (q ← exp(δθ) ⊗ q; :meth:`State.moved`'s retraction
    agrees with it to second order only)."""
    d = delta.reshape(P.shape[:-1] + (6,))
    return P + d[..., :3], quat.multiply(quat.exp(d[..., 3:]), Q)


def _along(x: State, delta: np.ndarray) -> State:
    """x moved by local coordinates ``delta`` (6M,) (:func:`along`)."""
    return State(*along(x.position, x.orientation, delta))


def _first_order(solver, ev: Evaluation, x: State, table: StepTable, step: int, real: np.ndarray) -> np.ndarray:
    """The velocity equations' left side J v + ∂r/∂t (R,), scaled rows, for real velocities (6M,)."""
    system = solver.system
    return (jacobian_product(system, ev, real) + system.time_derivative(x, table, step, ev)) * solver.row


def _near(solver, x: State, table: StepTable, ev: Evaluation, f: int):
    """The linearization at a pose x near a solved one whose J has f free directions, with J's
    null space there (from its factorization as at a pose; where the pivots cannot tell, an SVD)."""
    linear = solver.linearize(x, table, 0, ev)
    if linear.null is None or linear.null.shape[1] != f:
        J = solver.system.dense_jacobian(ev) * solver.row[:, None] * solver.col
        linear.null = np.linalg.svd(J)[2][-f:].T
    return linear


def _canonical_change(solver, state: State, table: StepTable, step: int, null: np.ndarray,
                      velocity: np.ndarray) -> np.ndarray:
    """The part (6M,) along J's null space ``null`` (6M, f) of the scaled acceleration of the
    canonical pose: the change of the canonical velocity along the motion, by a central
    difference of :meth:`Solver.velocity` at x ⊕ ±σv, t ± σ (the poses off the motion by
    ½σ²a alike, which the difference cancels)."""
    system = solver.system
    h = NULL_STEP / max(1.0, float(np.abs(velocity).max(initial=0.0)))
    real = velocity * solver.col
    sides = []
    for s in (h, -h):
        x = _along(state, s * real)
        tab = advanced(table, step, s)
        ev = system.evaluate(x, tab, 0, jacobian=True)
        sides.append(solver.velocity(x, tab, 0, _near(solver, x, tab, ev, null.shape[1])))
    return null @ (null.T @ ((sides[0] - sides[1]) / (2 * h)))


def acceleration(solver, state: State, table: StepTable, step: int, linear, velocity: np.ndarray) -> np.ndarray:
    """The scaled acceleration (6M,) at a solved pose with its :class:`~linkedit.gcs.linalg.Linear`
    and scaled velocity (module docstring)."""
    system = solver.system
    h = STEP / max(1.0, float(np.abs(velocity).max(initial=0.0)))
    real = velocity * solver.col
    terms, nulls = [], []
    for s in (h, -h):
        x = _along(state, s * real)
        tab = advanced(table, step, s)
        ev = system.evaluate(x, tab, 0, jacobian=True)
        terms.append(_first_order(solver, ev, x, tab, 0, real))
        if linear.null is not None and table.partial[step]:
            nulls.append(_near(solver, x, tab, ev, linear.null.shape[1]).null)
    a = linear.least_norm(-(terms[0] - terms[1]) / (2 * h))
    if linear.null is not None and not table.partial[step]:
        return a + _canonical_change(solver, state, table, step, linear.null, velocity)
    if nulls:
        Pv = [N @ (N.T @ velocity) for N in nulls]
        N = linear.null
        a -= N @ (N.T @ ((Pv[0] - Pv[1]) / (2 * h)))
    return a
