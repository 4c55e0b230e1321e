"""The free direction of B poses at once (one passive degree of freedom: J has rank N − 1):
each moved towards its canonical pose, the one nearest the rest pose, as the continuation's
:meth:`~linkedit.gcs.continuation.Solver.canonical` moves one (:mod:`linkedit.gcs.canonical`) — for the waves."""

from __future__ import annotations

import numpy as np

from linkedit.gcs import canonical as canon
from linkedit.gcs.acceleration import advanced
from linkedit.gcs.factors import BatchedFactors, Factors
from linkedit.gcs.structure import Jacobians
from linkedit.gcs.system import StepTable


def canonical(batch: BatchedFactors, P: np.ndarray, Q: np.ndarray, v0: np.ndarray, steps: np.ndarray,
              known: tuple["Jacobians", "Factors"] | None = None,
              table: StepTable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """For B solved poses (P (B, M, 3), Q (B, M, 4)) with one free direction, at the table's
    ``steps`` (B,), with least-norm scaled velocities v0 (B, N): the canonical pose's
    velocities (B, N) and the Newton moves (B, N) along J's null vectors towards it
    (:mod:`linkedit.gcs.canonical`; zero at the canonical pose), as the continuation's
    :meth:`Solver.canonical` and :meth:`Solver.velocity` take them; J and its
    factorization at the poses are evaluated, or ``known`` (a rough pose's, nearby); ``steps`` of ``table`` when given (else the run's)."""
    if known is None:
        J = batch.jacobian(batch.evaluate(P, Q, steps, True, table=table)[1])
        F = batch._factor(J)
    else:
        J, F = known
    assert F.null is not None
    n = F.null
    B = len(steps)
    ref = batch.solver.reference
    d = batch.displacement(P, Q, np.broadcast_to(ref.position, P.shape), np.broadcast_to(ref.orientation, Q.shape))
    # λ = J⁺ᵀ d, block by block
    flat = d - n * (n * d).sum(axis=1)[:, None]
    y = batch.least_norm(F, [flat[:, p.cols] for p in F.parts])
    lam = [(Jp @ y[:, p.cols, None])[..., 0] for p, Jp in zip(F.parts, J.blocks)]
    # λᵀ J̇ n by central differences along n, then along v0 with the inputs advanced in
    # time, all 4B poses in one evaluation
    hn = np.full(B, canon.STEP)
    hv = canon.STEP / np.maximum(1.0, np.abs(v0).max(axis=1))
    h = np.concatenate([hn, -hn, hv, -hv])
    moves = np.concatenate([n, n, v0, v0]) * h[:, None]
    four = np.tile(steps, 4)
    Pm, Qm = batch.moved(np.tile(P, (4, 1, 1)), np.tile(Q, (4, 1, 1)), moves)
    tab = advanced(table or batch.table, four, np.concatenate([0.0 * hn, 0.0 * hn, hv, -hv]))
    Jm = batch.jacobian(batch.evaluate(Pm, Qm, np.arange(4 * B), True, table=tab)[1])
    if Jm.parts is not J.parts:  # J's blocks were first split at these many poses: J again in them
        return canonical(batch, P, Q, v0, steps)
    n4 = np.tile(n, (4, 1))
    seen = sum(((np.tile(lp, (4, 1))[:, :, None] * Jp).sum(axis=1) * n4[:, p.cols]).sum(axis=1)
               for lp, p, Jp in zip(lam, J.parts, Jm.blocks)).reshape(4, B)
    null = n[:, :, None]
    G = canon.hessian(null, d, ((seen[0] - seen[1]) / (2 * hn))[:, None, None])
    velocity = canon.velocity(v0, null, d, G, ((seen[2] - seen[3]) / (2 * hv))[:, None])
    return velocity, canon.step(null, d, G)
