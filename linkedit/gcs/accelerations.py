"""The accelerations of a solved run, many steps at once: those of
:mod:`linkedit.gcs.acceleration` (J a = −γ, γ by a central difference of the velocity
equations along the velocity, and along a free direction the change of the canonical velocity),
evaluated for B poses together with the waves' batched evaluator and factorization
(:mod:`linkedit.gcs.evaluate`, :mod:`linkedit.gcs.factors`, :func:`linkedit.gcs.free.canonical`),
once the run's poses and velocities are known — so a run that asks for them is solved in waves
too. Steps the batch cannot take (an input outside its window, a pose whose factorization is
not sound or whose J leaves its blocks, systems the waves do not evaluate: custom constraints,
the sparse factorization, more free directions) are taken pose by pose, as before."""

from __future__ import annotations

import numpy as np

from linkedit.gcs.acceleration import NULL_STEP, STEP, acceleration, advanced, along
from linkedit.gcs.continuation import Solver
from linkedit.gcs.factors import BatchedFactors
from linkedit.gcs.free import canonical
from linkedit.gcs.system import State, StepTable

#: poses per batch (the free direction's evaluations take 12 times as many)
CHUNK = 256


def run_accelerations(solver: Solver, table: StepTable, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray,
                      solved: np.ndarray, batch: BatchedFactors | None) -> np.ndarray:
    """Real accelerations (T, M, 6) at the ``solved`` steps (T,) of a run (positions (T, M, 3),
    quaternions (T, M, 4), real velocities (T, M, 6) on ``table``), zero elsewhere: in
    batches of :data:`CHUNK` with ``batch`` (the run's waves; None: none), else pose by pose."""
    T, M = pos.shape[:2]
    col = solver.col
    out = np.zeros((T, M, 6))
    alone = solved & table.partial
    if batch is None or solver.normal.sparse:
        alone = solved
    else:
        steps = np.flatnonzero(solved & ~table.partial)
        for lo in range(0, steps.size, CHUNK):
            some = steps[lo:lo + CHUNK]
            a, ok = batched(batch, pos[some], ori[some], vel[some].reshape(len(some), -1) / col, some)
            out[some[ok]] = (a[ok] * col).reshape(-1, M, 6)
            alone[some[~ok]] = True
    for k in np.flatnonzero(alone):  # pose by pose
        x = State(pos[k], ori[k])
        out[k] = (acceleration(solver, x, table, int(k), solver.linearize(x, table, int(k)),
                               vel[k].ravel() / col) * col).reshape(M, 6)
    return out


def batched(batch: BatchedFactors, P: np.ndarray, Q: np.ndarray, V: np.ndarray,
            steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scaled accelerations (B, N) of solved poses P (B, M, 3), Q (B, M, 4) with scaled
    velocities V (B, N) at the table's ``steps`` (B,), every input active, as
    :func:`linkedit.gcs.acceleration.acceleration` takes them; and which are right (B,): J's
    factorization at the pose sound and J zero off its blocks (the others: pose by pose)."""
    solver = batch.solver
    row, col = solver.row, solver.col
    B = len(steps)
    if not batch.compiled.decided:  # J's blocks found first (not halfway, by a larger batch below)
        i = int(np.argmax(np.abs(V).max(axis=1)))
        batch._survey(P[i], Q[i], V[i], int(steps[i]))
    J = batch.jacobian(batch.evaluate(P, Q, steps, True)[1])
    F = batch._factor(J)
    ok = F.sound & ~J.leaves
    h = STEP / np.maximum(1.0, np.abs(V).max(axis=1))
    real = V * col
    two = np.tile(steps, 2)
    shift = np.concatenate([h, -h])
    P2, Q2 = along(np.tile(P, (2, 1, 1)), np.tile(Q, (2, 1, 1)), np.tile(real, (2, 1)) * shift[:, None])
    _, jacs = batch.evaluate(P2, Q2, np.arange(2 * B), True, table=advanced(batch.table, two, shift))
    # the velocity equations' left side J v + ∂r/∂t (2B, R) (the rates are the steps')
    terms = (_product(batch, jacs, np.tile(real, (2, 1))) + batch.time_derivative(Q2, two, jacs)) * row
    a = batch.least_norm(F, batch._gradient(J, -(terms[:B] - terms[B:]) / (2 * h[:, None])))
    if F.null is None:
        return a, ok
    # along the free direction: the change of the canonical velocity (its central difference)
    hn = NULL_STEP / np.maximum(1.0, np.abs(V).max(axis=1))
    shift = np.concatenate([hn, -hn])
    P2, Q2 = along(np.tile(P, (2, 1, 1)), np.tile(Q, (2, 1, 1)), np.tile(real, (2, 1)) * shift[:, None])
    tab = advanced(batch.table, two, shift)
    r2, jacs = batch.evaluate(P2, Q2, np.arange(2 * B), True, table=tab)
    J2 = batch.jacobian(jacs)
    F2 = batch._factor(J2)
    v0 = batch.least_norm(F2, batch._gradient(J2, -batch.time_derivative(Q2, two, jacs) * row))
    sides = canonical(batch, P2, Q2, v0, np.arange(2 * B), (J2, F2), table=tab)[0]
    n = F.null
    change = (sides[:B] - sides[B:]) / (2 * hn[:, None])
    ok &= F2.sound[:B] & F2.sound[B:]
    return a + n * (n * change).sum(axis=1)[:, None], ok


def _product(batch: BatchedFactors, jacs: list[np.ndarray | None], v: np.ndarray) -> np.ndarray:
    """J v (B, R) from the groups' Jacobians (B, n, k, 2, 6) of :meth:`evaluate` and real
    velocities v (B, N) (as :func:`linkedit.gcs.acceleration.jacobian_product`, batched)."""
    system = batch.system
    B = len(v)
    V = np.concatenate([v.reshape(B, -1, 6), np.zeros((B, 1, 6))], axis=1)
    out = np.zeros((B, system.n_rows))
    for grp, jac in zip(system.groups, jacs):
        assert jac is not None  # every group evaluated
        n, k = grp.rows.shape
        out[:, grp.rows] += (jac.reshape(B, n, k, 12) @ V[:, grp.members].reshape(B, n, 12, 1))[..., 0]
    return out
