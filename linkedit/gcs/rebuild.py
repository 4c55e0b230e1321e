"""The closed form's poses checked before and after they are solved in a wave
(:mod:`linkedit.gcs.closed_form`): which would pass the acceptance test (:func:`screened`), a
sparse system's poses factorized one by one as the continuation's steps are (:func:`verify`),
and poses with a link's canonical spin checked at once (:func:`canonical_as_is`)."""

from __future__ import annotations

import numpy as np

from linkedit.gcs import accept
from linkedit.gcs import quaternions as quat
from linkedit.gcs.factors import BatchedFactors
from linkedit.gcs import canonical as canon
from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs.system import Evaluation, State


def screened(batch: BatchedFactors, P: np.ndarray, Q: np.ndarray, valid: np.ndarray, steps: np.ndarray,
              before: tuple[np.ndarray, np.ndarray, np.ndarray], t_before: float) -> int:
    """How many of the closed form's consecutive poses P (B, M, 3), Q (B, M, 4) at the
    table's ``steps`` (B,), after the solved pose ``before`` (position, quaternions, scaled
    velocity) at ``t_before``, are rebuilt (``valid`` (B,)) and pass the acceptance test
    (:meth:`Waves.accepted`) with the velocity before each taken from the poses around it
    (secant over two steps; the first's exact): a step that fails it so is left to the
    continuation, not factorized first (the test proper comes after the solve)."""
    opt = batch.solver.options
    n = accept.leading(valid)
    if n == 0:
        return 0
    P0 = np.concatenate([before[0][None], P[:n - 1]])
    Q0 = np.concatenate([before[1][None], Q[:n - 1]])
    moved = batch.displacement(P[:n], Q[:n], P0, Q0)  # (n, N)
    h = np.diff(np.concatenate([[t_before], batch.table.t[steps[:n]]]))
    v = np.empty_like(moved)
    v[0] = before[2]
    v[1:] = (moved[:-1] + moved[1:]) / (h[:-1] + h[1:])[:, None]
    return accept.leading(accept.passes(moved, h, v, opt))


def verify(batch: BatchedFactors, P: np.ndarray, Q: np.ndarray, steps: np.ndarray,
           incoming: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The closed form's poses P (B, M, 3), Q (B, M, 4) at the table's ``steps`` (B,) of a
    system with the sparse factorization: residuals and Jacobians evaluated for all at
    once, then each pose that converged as it is (largest scaled residual row ≤ ``tol``)
    linearized, factorized and given its exact velocity as the continuation's step does
    (:meth:`Solver.linearize`: the same pivots, null space and rank). Returns the residuals
    (B, R), scaled velocities (B, N), linear solves and factorizations (B, 2), whether each
    is solved with no free direction (B,), and J's rank (B,) (−1 where the pivots cannot
    tell, as for the continuation's steps). At a singular pose (a change point) the velocity
    is the one nearest the step's before (``incoming``, scaled (N,): the solved pose's
    before the first), as the continuation's (:meth:`Linear.continued`)."""
    solver, B = batch.solver, len(steps)
    r, jacs = batch.evaluate(P, Q, steps, True)
    rt = batch.time_derivative(Q, steps, jacs)
    velocity = np.zeros((B, batch.system.n_unknowns))
    work = np.zeros((B, 2), dtype=np.int32)
    ok = np.abs(r * solver.row).max(axis=1) <= solver.options.tol
    rank = np.full(B, -1)
    for b in np.flatnonzero(ok):
        ev = Evaluation(r[b], [J[b] for J in jacs if J is not None])
        linear = solver.linearize(State(P[b], Q[b]), batch.table, int(steps[b]), ev)
        velocity[b] = incoming = linear.continued(-rt[b] * solver.row, incoming)
        ok[b], rank[b] = linear.null is None, linear.rank
        work[b] = 1
    return r, velocity, work, ok, rank


def canonical_as_is(batch: BatchedFactors, closed: ClosedForm, P: np.ndarray, Q: np.ndarray,
                    steps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The closed form's poses P (B, M, 3), Q (B, M, 4) at the table's ``steps`` (B,) of a
    system whose one free direction is a link's spin (placed at its canonical pose: where the
    slope of the scaled distance from rest along the spin, :meth:`ClosedForm.spin_slope`, is
    zero), evaluated and factorized once, as a wave's solve does a pose that converges at its
    first evaluation: each solved where it converged as it is (largest scaled residual row ≤
    ``tol``) with a sound factorization and J zero off its blocks, and at the canonical pose
    (the Newton move along J's null vector n that zeroes the slope at most ``still_tol``).
    The velocity is the canonical pose's tangent v₀ + β n (v₀ least norm, J v₀ = −∂r/∂t):
    the slope kept zero, β = −s_v₀ / s_n with s_w the slope's derivative along w (central
    differences of the step of :mod:`linkedit.gcs.canonical`; the link's pose alone, so no
    Jacobian at moved poses as :func:`~linkedit.gcs.free.canonical` needs). Returns the
    residuals (B, R), scaled velocities (B, N), linear solves and factorizations (B, 2) and
    whether each is solved (B,)."""
    solver, B = batch.solver, len(steps)
    r, jacs = batch.evaluate(P, Q, steps, True)
    J = batch.jacobian(jacs)
    F = batch._factor(J)
    assert F.null is not None
    n = F.null
    v0 = batch.least_norm(F, batch._gradient(J, -batch.time_derivative(Q, steps, jacs) * solver.row))
    hn = np.full(B, canon.STEP)
    hv = canon.STEP / np.maximum(1.0, np.abs(v0).max(axis=1))
    h = np.concatenate([0.0 * hn, hn, -hn, hv, -hv])
    u = closed.spun  # the link alone moved
    link = slice(6 * u, 6 * u + 6)
    e = np.concatenate([n[:, link], n[:, link], n[:, link], v0[:, link], v0[:, link]]) * h[:, None] * solver.col[link]
    moved = np.tile(P[:, u], (5, 1)) + e[:, :3], quat.turned(np.tile(Q[:, u], (5, 1)), e[:, 3:])
    slope = closed.spin_slope(*moved, solver.reference).reshape(5, B)
    along_n, along_v = (slope[1] - slope[2]) / (2 * hn), (slope[3] - slope[4]) / (2 * hv)
    move = np.abs(slope[0] / along_n)[:, None] * np.abs(n)
    ok = ((np.abs(r * solver.row).max(axis=1) <= solver.options.tol) & F.sound & batch._apart(J, np.arange(B))
          & (move.max(axis=1) <= solver.options.still_tol))
    return r, v0 - (along_v / along_n)[:, None] * n, np.ones((B, 2), dtype=np.int32), ok
