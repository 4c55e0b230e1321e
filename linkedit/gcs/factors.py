"""Batched factorization: B poses' scaled JᵀJ + μI factorized block by block of J's diagonal
blocks (batched Cholesky), their least-norm solves and J's null vector where it has one free
direction, taken as the step-by-step continuation takes them (:mod:`linkedit.gcs.linalg`: the
same probes and thresholds) — for the waves."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from linkedit.gcs.linalg import probes
from linkedit.gcs.structure import Blocks, Jacobians, Part, _take
from linkedit.gcs.tolerances import DAMPING, FREE_PIVOT, NULL_APART, NULL_CLEAN

#: batches of at most this many poses solve their triangular systems pose by pose
FEW = 24

_potrs = scipy.linalg.get_lapack_funcs("potrs", dtype=np.float64)


@dataclasses.dataclass
class Factors:
    """Factorizations of B poses' scaled JᵀJ + μI, block by block of ``parts`` (B, Np, Np)
    each (the other unknowns are not solved for: zero), whether each is sound (B,), and J's
    unit null vectors (B, N) where it has a free direction."""

    factors: list[np.ndarray]
    sound: np.ndarray
    null: np.ndarray | None
    parts: list[Part]

    def take(self, idx: np.ndarray) -> "Factors":
        return Factors([_take(L, idx) for L in self.factors], _take(self.sound, idx),
                       None if self.null is None else _take(self.null, idx), self.parts)


class BatchedFactors(Blocks):
    """Factorizations of B poses block by block of :attr:`parts` (the waves' linear algebra)."""

    def _factor(self, J: Jacobians) -> "Factors":
        """Cholesky factors (B, Np, Np) of the scaled JᵀJ + μI, block by block (μ as the
        continuation's: 1e-13 of the largest diagonal entry, at least 1e-13), and whether each
        pose's is sound (B,): positive definite with exactly :attr:`free` pivots below
        :data:`FREE_PIVOT` of that entry (no other free or singular direction) and, where J has
        a free direction, its null vector (:meth:`_null`) clean (J zero off its blocks is
        checked at the solved pose: :meth:`_apart`)."""
        normal = [np.swapaxes(Jp, 1, 2) @ Jp for Jp in J.blocks]
        B = len(J.leaves)
        top = np.ones(B)
        for H in normal:
            np.maximum(top, np.diagonal(H, axis1=1, axis2=2).max(axis=1), out=top)
        factors = []
        sound = np.ones(B, dtype=bool)
        small = np.zeros(B, dtype=int)
        for H in normal:
            n = H.shape[1]
            H.reshape(B, n * n)[:, ::n + 1] += (DAMPING * top)[:, None]
            try:
                L = np.linalg.cholesky(H)
            except np.linalg.LinAlgError:  # some pose is not positive definite: one by one
                L = np.tile(np.eye(n), (B, 1, 1))
                for i, h in enumerate(H):
                    try:
                        L[i] = np.linalg.cholesky(h)
                    except np.linalg.LinAlgError:
                        sound[i] = False
            factors.append(L)
            small += (np.diagonal(L, axis1=1, axis2=2) ** 2 < FREE_PIVOT * top[:, None]).sum(axis=1)
        sound &= small == self.free
        null = None
        if self.free:
            null, clean = self._null(factors, J, top)
            sound &= clean
            weak = np.flatnonzero(small == self.free + 1)  # a direction J sees weakly besides
            if weak.size:
                null[weak], clean = self._null_apart([L[weak] for L in factors], J.take(weak), top[weak])
                sound[weak] = clean
        return Factors(factors, sound, null, J.parts)

    def _null(self, factors: list[np.ndarray], J: Jacobians, top: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit null vectors (B, N) of J where it has one free direction, as the continuation
        takes them: two inverse iterations with the factorization from a fixed random vector
        (μ sets the null eigenvalue apart by FREE_PIVOT / 1e-13 at least); and whether each is
        clean (B,): |J n| at most NULL_CLEAN of √(largest diagonal of JᵀJ)."""
        B, N = len(top), self.system.n_unknowns
        probe = probes(N, 1)[:, 0]  # as the continuation's
        parts = self.parts
        y = self._assemble(self._solve(factors, [np.broadcast_to(probe[p.cols], (B, len(p.cols))) for p in parts]),
                           parts)
        y = self._assemble(self._solve(factors, [y[:, p.cols] for p in parts]), parts)
        y /= np.sqrt((y * y).sum(axis=1))[:, None]
        seen = sum(((Jp @ y[:, p.cols, None])[..., 0] ** 2).sum(axis=1) for p, Jp in zip(self.parts, J.blocks))
        return y, np.sqrt(seen) <= NULL_CLEAN * np.sqrt(top)

    def _null_apart(self, factors: list[np.ndarray], J: Jacobians, top: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`_null` where two pivots are small (a direction J sees weakly besides the
        free one), as the continuation takes it: two inverse iterations from two fixed random
        vectors span both; of the two directions of that span, the one J does not see is the
        null vector, clean when J's two singular values there are at most NULL_CLEAN and at
        least NULL_APART of √(largest diagonal of JᵀJ)."""
        B, N = len(top), self.system.n_unknowns
        start = probes(N, 2)  # as the continuation's
        Y = np.empty((B, N, 2))
        for j in range(2):
            y = self._assemble(self._solve(factors, [np.broadcast_to(start[p.cols, j], (B, len(p.cols)))
                                                     for p in self.parts]), self.parts)
            Y[:, :, j] = self._assemble(self._solve(factors, [y[:, p.cols] for p in self.parts]), self.parts)
        # an orthonormal basis of the span (Gram–Schmidt), J on it (B, R, 2) and its 2 × 2 Gram matrix
        Y[:, :, 0] /= np.sqrt((Y[:, :, 0] ** 2).sum(axis=1))[:, None]
        Y[:, :, 1] -= Y[:, :, 0] * (Y[:, :, 0] * Y[:, :, 1]).sum(axis=1)[:, None]
        Y[:, :, 1] /= np.sqrt((Y[:, :, 1] ** 2).sum(axis=1))[:, None]
        JY = np.concatenate([Jp @ Y[:, p.cols] for p, Jp in zip(self.parts, J.blocks)], axis=1)
        values, vectors = np.linalg.eigh(np.swapaxes(JY, 1, 2) @ JY)  # ascending
        scale = np.sqrt(top)
        sv = np.sqrt(np.maximum(values, 0.0))
        clean = (sv[:, 0] <= NULL_CLEAN * scale) & (sv[:, 1] >= NULL_APART * scale)
        return (Y @ vectors[:, :, :1])[..., 0], clean

    def _assemble(self, x: list[np.ndarray], parts: list[Part]) -> np.ndarray:
        """One vector (B, N) from its blocks (B, Np) of ``parts`` (zero elsewhere)."""
        full = len(parts) == len(self.parts)
        out = (np.empty if full else np.zeros)((len(x[0]), self.system.n_unknowns))
        for p, xp in zip(parts, x):
            out[:, p.cols] = xp
        return out

    def least_norm(self, F: "Factors", b: list[np.ndarray]) -> np.ndarray:
        """y (B, N) of (JᵀJ + μI) y = b (blocks (B, Np)) without its component along J's null
        vector (there it is rounding amplified by 1/μ): the least-norm solution."""
        y = self._assemble(self._solve(F.factors, b), F.parts)
        return y if F.null is None else y - F.null * (F.null * y).sum(axis=1)[:, None]

    @staticmethod
    def _solve(factors: list[np.ndarray], b: list[np.ndarray]) -> list[np.ndarray]:
        """x of L Lᵀ x = b block by block: factors (B, Np, Np) and right-hand sides (B, Np)."""
        return [cholesky_solve(L, bp) if bp.any() else np.zeros_like(bp)  # a planar linkage's out-of-plane
                for L, bp in zip(factors, b)]                                 # part rarely is

    @staticmethod
    def _gradient(J: Jacobians, r: np.ndarray) -> list[np.ndarray]:
        """Jᵀ r block by block (B, Np) for residual rows r (B, R)."""
        return [(r[:, p.rows][:, None, :] @ Jp)[:, 0] for p, Jp in zip(J.parts, J.blocks)]


def cholesky_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x (B, N) of L Lᵀ x = b for lower-triangular L (B, N, N) and b (B, N): forward and back
    substitution, each a loop over the N unknowns of array operations over B (LAPACK's potrs
    pose by pose for at most :data:`FEW` poses, where that loop's fixed cost dominates)."""
    if len(L) <= FEW:
        return np.array([_potrs(c, x, lower=True)[0] for c, x in zip(L, b)]).reshape(b.shape)
    n = L.shape[1]
    d = np.diagonal(L, axis1=1, axis2=2)
    y = np.empty_like(b)
    for i in range(n):
        y[:, i] = (b[:, i] - np.einsum("bj,bj->b", L[:, i, :i], y[:, :i])) / d[:, i]
    x = np.empty_like(b)
    for i in range(n - 1, -1, -1):
        x[:, i] = (y[:, i] - np.einsum("bj,bj->b", L[:, i + 1:, i], x[:, i + 1:])) / d[:, i]
    return x
