"""Normal equations JᵀJ δ = −Jᵀr assembled from the Jacobian groups, dense or sparse.

The scatter indices depend only on the topology, so they are computed once
(:class:`NormalEquations`); each assembly is one ``einsum`` per group (the 6×6 blocks of every
constraint's member pairs) and one ``bincount``. Small systems use a dense Cholesky
factorization; large ones a sparse LU (SuperLU, symmetric mode, minimum-degree ordering) of the
block-sparse matrix with its exact zeros dropped (a planar linkage decouples into in-plane and
out-of-plane unknowns, which the ordering then exploits).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from linkedit.gcs.system import Group

#: unknowns above which the sparse factorization is used
SPARSE_ABOVE = 120


class Factor:
    """A factorized damped normal matrix; ``solve(g)`` returns H⁻¹ g."""

    def __init__(self, H_dense: np.ndarray | None = None, H_sparse: scipy.sparse.csc_matrix | None = None) -> None:
        if H_sparse is not None:
            H_sparse.eliminate_zeros()
            lu = scipy.sparse.linalg.splu(H_sparse, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                          options={"SymmetricMode": True})
            self.solve = lu.solve
        else:
            cho = scipy.linalg.cho_factor(H_dense, check_finite=False)
            self.solve = lambda g: scipy.linalg.cho_solve(cho, g, check_finite=False)


class NormalEquations:
    """Scatter plan from the Jacobian groups to JᵀJ and Jᵀr (N = 6M unknowns)."""

    def __init__(self, groups: list[Group], n_members: int) -> None:
        M = n_members
        N = 6 * M
        self.N = N
        self.sparse = N > SPARSE_ABOVE
        six = np.arange(6)
        grad, keys = [], []
        for g in groups:
            mem = g.members  # (n, m)
            col = 6 * mem[:, :, None] + six  # (n, m, 6)
            grad.append(np.where(mem[:, :, None] < M, col, N).ravel())
            # (n, m·6, m·6) keys row·N + col; pairs touching the world go to a dump slot
            flat = col.reshape(len(mem), -1)
            out = np.repeat(mem >= M, 6, axis=1)
            world = out[:, :, None] | out[:, None, :]
            keys.append(np.where(world, -1, flat[:, :, None] * N + flat[:, None, :]).ravel())
        self.grad_index = np.concatenate(grad) if grad else np.zeros(0, dtype=int)
        keys_all = np.concatenate(keys) if keys else np.zeros(0, dtype=int)
        diag = np.arange(N) * (N + 1)
        valid = keys_all >= 0
        if self.sparse:
            uniq, inverse = np.unique(np.concatenate([keys_all[valid], diag]), return_inverse=True)
            self.nnz = uniq.size
            index = np.full(keys_all.size, self.nnz)
            index[valid] = inverse[: valid.sum()]
            self.diag_index = inverse[valid.sum():]
            self.indices = (uniq % N).astype(np.int32)
            self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // N, minlength=N))]).astype(np.int32)
        else:
            self.nnz = N * N
            index = np.where(valid, keys_all, self.nnz)
            self.diag_index = diag
        self.index = index
        self.groups = groups

    def gradient(self, jac: list[np.ndarray], r: np.ndarray) -> np.ndarray:
        """Jᵀr, (N,)."""
        w = np.concatenate([(r[g.rows][:, None, :] @ J.reshape(J.shape[0], J.shape[1], -1)).ravel()
                            for g, J in zip(self.groups, jac)])
        return np.bincount(self.grad_index, w, minlength=self.N + 1)[: self.N]

    def matrix_data(self, jac: list[np.ndarray]) -> np.ndarray:
        """The entries of JᵀJ in this plan's storage order (dense row-major, or CSC data)."""
        flat = [J.reshape(J.shape[0], J.shape[1], -1) for J in jac]
        w = np.concatenate([(np.swapaxes(F, 1, 2) @ F).ravel() for F in flat])
        return np.bincount(self.index, w, minlength=self.nnz + 1)[: self.nnz]

    def factor(self, data: np.ndarray, damping: float, floor: float) -> Factor:
        """Factorize JᵀJ + damping·diag(JᵀJ) + floor·I (Levenberg–Marquardt), from ``matrix_data``."""
        data = data.copy()
        d = data[self.diag_index]
        data[self.diag_index] = d + damping * d + floor
        if self.sparse:
            H = scipy.sparse.csc_matrix((data, self.indices.copy(), self.indptr.copy()), shape=(self.N, self.N))
            return Factor(H_sparse=H)
        return Factor(H_dense=data.reshape(self.N, self.N))

    def diagonal(self, data: np.ndarray) -> np.ndarray:
        return data[self.diag_index]
