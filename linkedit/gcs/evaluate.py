"""Batched evaluation: the residuals, Jacobians and time derivatives of B poses of one system
at once, with the elementary kinds' kernels of :data:`linkedit.gcs.kernels.EVALUATE` run on B
times their constraints (member-major layouts), and poses moved and compared in the scaled
local coordinates of the continuation (:meth:`State.moved`, :meth:`State.minus`) — for the
waves (:mod:`linkedit.gcs.waves`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.continuation import Solver
from linkedit.gcs.kernels import EVALUATE, Block, StepParameters
from linkedit.gcs.system import StepTable, System

#: the layouts of this many batch sizes, of at most KEPT_POSES poses, are kept in the caller's
#: cache for the system's later runs (the last built)
KEPT_LAYOUTS, KEPT_POSES = 16, 1024


@dataclasses.dataclass
class _Layout:
    """An evaluation's fixed parts for B poses, member-major (member or vector i of pose b at
    i·B + b, so each kernel sees B times its constraints, constraint-major): the blocks with
    spread indices, the member of each member vector (K·B,), the member vectors (K, B, 9) and
    the inverse relative orientations (n, B, 4)."""

    blocks: list[Block]
    member: np.ndarray
    vectors: np.ndarray
    rel_inverse: np.ndarray


class BatchedEvaluation:
    """Evaluation of B poses of :attr:`system` at steps of :attr:`table` (the waves' part)."""

    system: System
    solver: Solver
    table: StepTable
    #: layouts per batch size kept for the system's later runs (the caller's cache), and this run's own (larger ones)
    _kept_layouts: dict[int, "_Layout"]
    _layouts: dict[int, "_Layout"]

    def _layout(self, B: int) -> "_Layout":
        """What an evaluation of B poses needs that does not change between calls: kept in the
        caller's cache for the :data:`KEPT_LAYOUTS` batch sizes of at most :data:`KEPT_POSES` poses last
        built (a few MB at most), else for this run."""
        layouts = self._kept_layouts if B <= KEPT_POSES else self._layouts
        lay = layouts.get(B)
        if lay is None:
            s = self.system
            lanes = np.arange(B)
            spread = lambda idx: (idx[:, None] * B + lanes).ravel()  # noqa: E731
            blocks = [dataclasses.replace(blk, a=spread(blk.a), b=spread(blk.b),
                                          vectors=tuple(slice(v.start * B, v.stop * B) for v in blk.vectors))
                      for blk in s.blocks]
            lay = layouts[B] = _Layout(blocks, spread(s.vector_member), np.repeat(s.vectors[:, None], B, axis=1),
                                       np.repeat(s.rel_inverse[:, None], B, axis=1))
            for old in list(layouts)[:-KEPT_LAYOUTS]:  # (a copy of the keys: other runs may add)
                layouts.pop(old, None)
        return lay

    def evaluate(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray, jacobian: bool,
                 skip: tuple[int, ...] = (), table: StepTable | None = None) -> tuple[np.ndarray, list[np.ndarray | None]]:
        """Residuals (B, R) at positions P (B, M, 3) and quaternions Q (B, M, 4) at the
        ``steps`` (B,) of the run's table (or of ``table``), and with ``jacobian`` the Jacobian
        per group (B, n, k, 2, 6); the groups ``skip`` are not evaluated (rows zero, Jacobian
        None)."""
        s, tab = self.system, table or self.table
        B, M = P.shape[0], s.n_members
        lay = self._layout(B)
        # member-major layouts (M + 1, B, ·), the world last
        members_p, members_q = np.empty((M + 1, B, 3)), np.empty((M + 1, B, 4))
        members_p[:M], members_p[M] = np.swapaxes(P, 0, 1), 0.0
        members_q[:M], members_q[M] = np.swapaxes(Q, 0, 1), (1.0, 0.0, 0.0, 0.0)
        Pm, Qm = members_p.reshape(-1, 3), members_q.reshape(-1, 4)
        V = lay.vectors
        if tab.vectors.shape[1]:
            V = V.copy()
            V[s.driven_vectors] = np.swapaxes(tab.vectors[steps], 0, 1)
        R = quat.to_matrix(Qm).reshape(-1, 9)
        W = np.einsum("nij,nj->ni", R.take(lay.member, axis=0).reshape(-1, 3, 3), V.reshape(-1, 9)[:, :3])
        X = Pm.take(lay.member, axis=0) + W
        rel = lay.rel_inverse
        if tab.rel_inverse.shape[1]:
            rel = rel.copy()
            rel[s.driven_rel] = np.swapaxes(tab.rel_inverse[steps], 0, 1)
        values = {blk.kind: np.repeat(blk.value, B) if v is None else v[steps].T.ravel()
                  for blk, v in zip(s.blocks, tab.values) if blk.kind in kinds.VALUE_KINDS}
        # the kernels read only the relative orientations and the values; every input is active
        par = StepParameters(0.0, np.zeros((0, 9)), rel.reshape(-1, 4), [None] * len(s.blocks),
                             np.zeros(0, dtype=int), values)
        r = np.empty((B, s.n_rows))
        jacs: list[np.ndarray | None] = []
        for i, (blk, wide) in enumerate(zip(s.blocks, lay.blocks)):
            if i in skip:
                r[:, blk.start:blk.stop] = 0.0
                jacs.append(None)
                continue
            n, k = blk.rows.shape
            out = np.empty((n * B, k))
            J = EVALUATE[blk.kind](wide, X, W, Qm, par, out, jacobian)
            r[:, blk.start:blk.stop] = np.swapaxes(out.reshape(n, B, k), 0, 1).reshape(B, -1)
            if J is not None:
                jacs.append(np.swapaxes(J.reshape((n, B) + J.shape[1:]), 0, 1))
        return r, jacs

    def time_derivative(self, Q: np.ndarray, steps: np.ndarray, jacs: list[np.ndarray | None]) -> np.ndarray:
        """∂r/∂t (B, R) at quaternions Q (B, M, 4) (as :meth:`System.time_derivative`, batched)."""
        s = self.system
        B = Q.shape[0]
        out = np.zeros((B, s.n_rows))
        for blk, jac, rate in zip(s.blocks, jacs, self.table.rates):
            if rate is None or jac is None:
                continue
            sel = blk.scheduled
            if blk.kind in kinds.VALUE_KINDS:
                out[:, blk.rows[sel]] = -rate[steps]
                continue
            w = rate[steps]  # (B, S, 6): u, ω in b's frame
            if not blk.on_world:
                Qe = np.concatenate([Q, np.tile([1.0, 0.0, 0.0, 0.0], (B, 1, 1))], axis=1)
                Rb = quat.to_matrix(Qe[:, blk.b[sel]])  # (B, S, 3, 3)
                w = (w.reshape(B, -1, 2, 3) @ np.swapaxes(Rb, 2, 3)).reshape(B, -1, 6)
            out[:, blk.rows[sel]] = (jac[:, sel][..., 1, :] * w[:, :, None, :]).sum(axis=3)
        return out

    def moved(self, P: np.ndarray, Q: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses after scaled local steps e (B, N) (as :meth:`State.moved`)."""
        B, M = P.shape[:2]
        d = (e * self.solver.col).reshape(B, M, 6)
        return P + d[..., :3], quat.turned(Q.reshape(-1, 4), d[..., 3:].reshape(-1, 3)).reshape(B, M, 4)

    def displacement(self, P: np.ndarray, Q: np.ndarray, P0: np.ndarray, Q0: np.ndarray) -> np.ndarray:
        """Scaled local coordinates (B, N) from poses 0 to poses (as :meth:`State.minus`)."""
        B, M = P.shape[:2]
        phi = quat.log(quat.multiply(Q.reshape(-1, 4), quat.conjugate(Q0.reshape(-1, 4)))).reshape(B, M, 3)
        return np.concatenate([P - P0, phi], axis=2).reshape(B, 6 * M) / self.solver.col
