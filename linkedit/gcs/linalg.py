"""Normal equations JᵀJ δ = −Jᵀr assembled from the Jacobian groups, dense or sparse.

The scatter indices depend only on the topology, so they are computed once
(:class:`NormalEquations`). Small systems assemble the dense Jacobian and factorize JᵀJ by
LAPACK's Cholesky directly (no sparse machinery, no argument checks). Large ones assemble
JᵀJ with one batched product per group (the 6×6 blocks of every constraint's member pairs) and
one ``bincount``, and factorize it by a sparse LU (SciPy's sparse modules are loaded only then:
start-up) (SuperLU, symmetric mode, no pivoting) on its
exact nonzeros (a planar linkage decouples into in-plane and out-of-plane unknowns). The
minimum-degree ordering is computed for the first pattern and kept: later factorizations with
no new nonzeros take the matrix already permuted and skip the ordering. Jᵀ is kept as a CSR
matrix whose structure is computed once.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from linkedit.gcs.system import Evaluation, Group
from linkedit.gcs.tolerances import NULL_APART, NULL_CLEAN, NULL_SINGULAR, RANK_TOL

if TYPE_CHECKING:
    import scipy.sparse

#: unknowns above which the sparse factorization is used
SPARSE_ABOVE = 120
#: Jacobians with at most this many entries get one dense SVD (no block decomposition)
WHOLE_SVD = 120 * 180

_potrf, _potrs, _geqrf, _orgqr = scipy.linalg.get_lapack_funcs(("potrf", "potrs", "geqrf", "orgqr"),
                                                              dtype=np.float64)


def orthonormal(Y: np.ndarray) -> np.ndarray:
    """An orthonormal basis (N, f) of the columns of Y (N, f), N ≥ f: Householder QR by LAPACK
    directly (``np.linalg.qr(Y)[0]`` without its checks)."""
    qr, tau, _, _ = _geqrf(Y)
    return _orgqr(qr, tau)[0]


class Factor:
    """A factorized damped normal matrix H (N, N); ``solve(g)`` returns H⁻¹ g (N,) or (N, k);
    ``pivots()`` the pivots (N,) of its elimination (Cholesky diagonal squared, LU's U diagonal),
    in elimination order: a direction H hardly sees shows as a pivot near the damping floor."""

    def __init__(self, solve: Callable[[np.ndarray], np.ndarray], pivots: Callable[[], np.ndarray]) -> None:
        self.solve = solve
        self.pivots = pivots

    @classmethod
    def dense(cls, H: np.ndarray) -> "Factor":
        """Cholesky factorization of a dense symmetric positive definite H (Fortran order)."""
        c, info = _potrf(H, lower=False, clean=False, overwrite_a=True)
        if info != 0:
            raise np.linalg.LinAlgError(f"the normal matrix is not positive definite (potrf info {info})")
        return cls(lambda g: _potrs(c, g, lower=False)[0], lambda: c.diagonal() ** 2)

    @classmethod
    def sparse(cls, H: scipy.sparse.csc_matrix, order: str) -> tuple["Factor", np.ndarray]:
        """LU factorization of a sparse symmetric H without pivoting, with SuperLU's column
        ordering ``order``; also returns that ordering (N,) (H[p][:, p] needs no reordering)."""
        from scipy.sparse.linalg import splu

        lu = splu(H, permc_spec=order, diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        return cls(lu.solve, lu.U.diagonal), np.argsort(lu.perm_c)

    @classmethod
    def permuted(cls, B: scipy.sparse.csc_matrix, p: np.ndarray, inverse: np.ndarray) -> "Factor":
        """LU factorization of H from B = H[p][:, p], already in a fill-reducing order:
        H x = g is B y = g[p] with x = y[inverse]."""
        from scipy.sparse.linalg import splu

        lu = splu(B, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        return cls(lambda g: lu.solve(g.take(p, axis=0)).take(inverse, axis=0), lu.U.diagonal)


@dataclass
class _Ordering:
    """A fill-reducing order p of the unknowns for a sparsity pattern of JᵀJ, and the CSC
    structure of H[p][:, p] on that pattern (``take``: its entries in the plan's storage)."""

    p: np.ndarray
    inverse: np.ndarray
    pattern: np.ndarray  #: (nnz,) bool, in the plan's storage
    take: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray


class Linearization:
    """The Jacobian at one state: JᵀJ entries (``data``, in the plan's storage order) and Jᵀ."""

    def __init__(self, data: np.ndarray, JT: np.ndarray | scipy.sparse.csr_matrix) -> None:
        self.data = data
        self.JT = JT

    def gradient(self, r: np.ndarray) -> np.ndarray:
        """Jᵀr (N,) for a residual r (R,)."""
        return self.JT @ r


class NormalEquations:
    """Scatter plan from the Jacobian groups (R residual rows, N = 6M unknowns) to J, JᵀJ and Jᵀr;
    ``scale``: per group, factors broadcastable to its Jacobian (n, k, m, 6), applied by
    ``linearize(jac, scaled=True)`` (the solver's dimensionless rows and columns)."""

    def __init__(self, groups: list[Group], n_members: int, n_rows: int,
                 scale: list[np.ndarray] | None = None) -> None:
        M = n_members
        N = 6 * M
        self.N = N
        self.R = n_rows
        self.group_scale = scale
        self.scale = None if scale is None else np.concatenate(
            [np.broadcast_to(s, g.rows.shape + (g.members.shape[1], 6)).ravel() for g, s in zip(groups, scale)]
            or [np.zeros(0)])
        self.sparse = N > SPARSE_ABOVE
        self.ordering: _Ordering | None = None  #: sparse: the last fill-reducing ordering
        six = np.arange(6)
        jrow, jcol, keys = [], [], []
        for g in groups:
            mem = g.members  # (n, m)
            n, k = g.rows.shape
            col = 6 * mem[:, :, None] + six  # (n, m, 6)
            # every Jacobian entry (n, k, m, 6): its row and column (N for the world)
            jrow.append(np.broadcast_to(g.rows[:, :, None, None], (n, k) + col.shape[1:]).ravel())
            jcol.append(np.broadcast_to(np.where(mem[:, :, None] < M, col, N)[:, None], (n, k) + col.shape[1:]).ravel())
            # (n, m·6, m·6) JᵀJ keys row·N + col; pairs touching the world go to a dump slot
            flat = col.reshape(n, -1)
            out = np.repeat(mem >= M, 6, axis=1)
            world = out[:, :, None] | out[:, None, :]
            keys.append(np.where(world, -1, flat[:, :, None] * N + flat[:, None, :]).ravel())
        cat = lambda xs: np.concatenate(xs) if xs else np.zeros(0, dtype=int)  # noqa: E731
        rows_all, cols_all, keys_all = cat(jrow), cat(jcol), cat(keys)
        diag = np.arange(N) * (N + 1)
        if self.sparse:
            self._sparse_plan(rows_all, cols_all, keys_all, diag)
        else:
            # dense J (R, N + 1): world entries land in the last column, dropped; a member's
            # entries in one row are never repeated, so they are put, not summed, unless a
            # constraint ties a member to itself
            self.entry_index = rows_all * (N + 1) + cols_all
            keep = self.entry_index[cols_all < N]
            self.unique_entries = np.unique(keep).size == keep.size
            self.nnz = N * N
            self.diag_index = diag

    def _sparse_plan(self, jrow: np.ndarray, jcol: np.ndarray, keys: np.ndarray, diag: np.ndarray) -> None:
        """CSC storage of JᵀJ (``index``: slot of each product entry) and CSR structure of Jᵀ."""
        N = self.N
        valid = keys >= 0
        uniq, inverse = np.unique(np.concatenate([keys[valid], diag]), return_inverse=True)
        self.nnz = uniq.size
        self.index = np.full(keys.size, self.nnz)
        self.index[valid] = inverse[: valid.sum()]
        self.diag_index = inverse[valid.sum():]
        self.indices = (uniq % N).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // N, minlength=N))]).astype(np.int32)
        # Jᵀ in CSR: entries not on the world, sorted by (unknown, row); duplicates stay separate
        keep = np.flatnonzero(jcol < N)
        order = keep[np.lexsort((jrow[keep], jcol[keep]))]
        self.jt_take = order
        self.jt_indices = jrow[order].astype(np.int32)
        self.jt_indptr = np.concatenate([[0], np.cumsum(np.bincount(jcol[order], minlength=N))]).astype(np.int32)

    def linearize(self, jac: list[np.ndarray], scaled: bool = False) -> Linearization:
        """JᵀJ entries and Jᵀ from the Jacobian groups of an evaluation (times ``scale`` when
        ``scaled``)."""
        flat = np.concatenate([J.ravel() for J in jac]) if len(jac) != 1 else jac[0].ravel()
        if scaled:
            flat = flat * self.scale
        if not self.sparse:
            N = self.N
            J: np.ndarray
            if self.unique_entries:
                J = np.zeros((self.R, N + 1))
                J.put(self.entry_index, flat)
            else:
                J = np.bincount(self.entry_index, flat, minlength=self.R * (N + 1)).reshape(self.R, N + 1)
            J = J[:, :N]
            return Linearization((J.T @ J).ravel(), J.T)
        if scaled:
            if self.group_scale is None:
                raise ValueError("these normal equations were built without a scale")
            jac = [J * s for J, s in zip(jac, self.group_scale)]
        F = [J.reshape(J.shape[0], J.shape[1], -1) for J in jac]
        w = np.concatenate([(np.swapaxes(f, 1, 2) @ f).ravel() for f in F])
        data = np.bincount(self.index, w, minlength=self.nnz + 1)[: self.nnz]
        from scipy.sparse import csr_matrix

        JT = csr_matrix((flat.take(self.jt_take), self.jt_indices.copy(), self.jt_indptr.copy()),
                                     shape=(self.N, self.R))
        JT.eliminate_zeros()  # in place; Jᵀr is taken several times per factorization
        return Linearization(data, JT)

    def factor(self, data: np.ndarray, damping: float, floor: float) -> Factor:
        """Factorize JᵀJ + damping·diag(JᵀJ) + floor·I (Levenberg–Marquardt), from ``Linearization.data``."""
        data = data.copy()
        d = data[self.diag_index]
        data[self.diag_index] = (d + damping * d if damping else d) + floor
        if not self.sparse:
            return Factor.dense(data.reshape(self.N, self.N).T)  # symmetric: the Fortran-ordered view
        from scipy.sparse import csc_matrix

        pattern = data != 0.0
        o = self.ordering
        if o is None or (pattern & ~o.pattern).any():
            # a new pattern: minimum-degree ordering on its exact nonzeros, kept for the next ones
            H = csc_matrix((data, self.indices.copy(), self.indptr.copy()), shape=(self.N, self.N))
            H.eliminate_zeros()  # in place
            factor, p = Factor.sparse(H, "MMD_AT_PLUS_A")
            self.ordering = self._ordering(pattern, p)
            return factor
        B = csc_matrix((data.take(o.take), o.indices, o.indptr), shape=(self.N, self.N))
        return Factor.permuted(B, o.p, o.inverse)

    def _ordering(self, pattern: np.ndarray, p: np.ndarray) -> _Ordering:
        """The CSC structure of H[p][:, p] on the entries of ``pattern``."""
        inverse = np.argsort(p)
        entries = np.flatnonzero(pattern)
        col = np.repeat(np.arange(self.N), np.diff(self.indptr))[entries]
        row = self.indices[entries]
        new_row, new_col = inverse[row], inverse[col]
        order = np.lexsort((new_row, new_col))
        indptr = np.concatenate([[0], np.cumsum(np.bincount(new_col, minlength=self.N))]).astype(np.int32)
        return _Ordering(p=p, inverse=inverse, pattern=pattern, take=entries[order],
                         indices=new_row[order].astype(np.int32), indptr=indptr)

    def diagonal(self, data: np.ndarray) -> np.ndarray:
        """The diagonal (N,) of JᵀJ from ``Linearization.data``."""
        return data[self.diag_index]


@dataclass
class Linear:
    """A pose's Jacobian (scaled), its factorization and, where J has a null space, an
    orthonormal basis of it (N, f) (None when J has full column rank)."""

    ev: Evaluation
    lin: Linearization
    factor: Factor
    null: np.ndarray | None
    #: rank of J read from the factorization (N minus the null space), −1 where it cannot
    #: tell (small pivots that are not a clean null space: the diagnostics take an SVD)
    rank: int = -1
    #: small pivots where J has no null space for these inputs: a singular pose (a change
    #: point, a lock-up), where J alone leaves the velocity undetermined along a direction
    singular: bool = False

    def least_norm(self, b: np.ndarray) -> np.ndarray:
        """The least-norm y (N,) of J y = b (R,): the normal equations' solution (regularized
        by μ) without its component along the null space (there it is rounding amplified by 1/μ)."""
        return self.still(self.factor.solve(self.lin.gradient(b)))

    def continued(self, b: np.ndarray, incoming: np.ndarray | None) -> np.ndarray:
        """The least-norm y (N,) of J y = b (R,); at a singular pose (a change point, where
        branches cross and J cannot tell their tangents apart) with the ``incoming`` velocity
        (N,) the motion arrived with, the one nearest it, y = w + J⁺(b − J w) (J⁺ damped: along
        the directions J hardly sees, w is kept), so the motion keeps the branch it was on."""
        if incoming is None or not self.singular:
            return self.least_norm(b)
        return incoming + self.least_norm(b - self.lin.JT.T @ incoming)

    def still(self, d: np.ndarray) -> np.ndarray:
        """d (N,) without its component along the null space of J."""
        return d if self.null is None else d - self.null @ (self.null.T @ d)



@cache
def probes(N: int, f: int) -> np.ndarray:
    """The fixed random vectors (N, f) inverse iteration starts from for f small pivots (the
    same for every scheduler: read only)."""
    Y = np.random.default_rng(f).standard_normal((N, f))
    Y.setflags(write=False)
    return Y


def null_space(J: np.ndarray | scipy.sparse.csr_matrix, factor: Factor, f: int,
               top: float) -> tuple[np.ndarray | None, int]:
    """An orthonormal basis (N, k) of the null space of the scaled J (R, N) and the rank of J,
    for f small pivots of its factorized JᵀJ + μI (k ≤ f: a small pivot may also be a direction
    J sees weakly), ``top`` its largest diagonal entry: two inverse iterations with the
    factorization from :func:`probes` (the damping μ sets the null eigenvalues apart from the
    others by a factor of at least FREE_PIVOT / DAMPING) span the null space; an SVD of J on
    that span (N × f) picks it out when its singular values are clearly zero or clearly not
    (rank N − k); otherwise an SVD of J decides (rank −1: the pivots cannot tell)."""
    N = J.shape[1]
    Y = factor.solve(factor.solve(probes(N, f)))
    scale = math.sqrt(top)
    if f == 1:  # the usual case (one idle spin): no decomposition needed
        span = Y / math.sqrt(Y[:, 0] @ Y[:, 0])
        seen = J @ span[:, 0]
        if math.sqrt(seen @ seen) <= NULL_CLEAN * scale:
            return span, N - 1
    else:
        span = orthonormal(Y)
        _, sv, Vt = np.linalg.svd(np.asarray(J @ span))
        sv = np.concatenate([sv, np.zeros(f - sv.size)])  # fewer rows than f: the rest are zero
        zero = sv <= NULL_CLEAN * scale
        if zero.any() and (sv[~zero] >= NULL_APART * scale).all():
            return span @ Vt[zero].T, N - int(zero.sum())
    _, sv, Vt = np.linalg.svd(J.toarray() if hasattr(J, "toarray") else J)
    rank = int(np.sum(sv > NULL_SINGULAR * sv[0])) if sv.size else 0
    return (Vt[rank:].T if rank < Vt.shape[0] else None), -1


def decoupled_blocks(J: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The blocks a matrix (R, N) decouples into: (row indices, column indices) of each
    connected component of the bipartite graph of its nonzero entries (zero rows and columns
    belong to none). J's singular values are those of its blocks together. A small matrix (up
    to :data:`WHOLE_SVD` entries) is one block of its nonzero rows and columns: separate blocks
    would save little, and finding them loads SciPy's sparse graph modules (start-up)."""
    if J.size <= WHOLE_SVD:
        nonzero = J != 0
        rows, cols = np.flatnonzero(nonzero.any(axis=1)), np.flatnonzero(nonzero.any(axis=0))
        return [(rows, cols)] if rows.size else []
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    R, N = J.shape
    i, j = np.nonzero(J)
    graph = coo_matrix((np.ones(i.size), (i, R + j)), shape=(R + N, R + N))
    _, label = connected_components(graph, directed=False)
    rows, cols = label[:R], label[R:]
    return [(np.flatnonzero(rows == k), np.flatnonzero(cols == k)) for k in np.unique(label[i])]


def jacobian_rank(J: np.ndarray) -> int:
    """Numerical rank of a matrix (R, N): singular values above RANK_TOL times the largest,
    taken block by block (:func:`decoupled_blocks`): exact, and a fraction of the work when it
    decouples (a planar linkage: in-plane and out-of-plane unknowns)."""
    blocks = decoupled_blocks(J)
    if not blocks:
        return 0
    s = np.concatenate([np.linalg.svd(J[np.ix_(r, c)], compute_uv=False) for r, c in blocks])
    return int(np.sum(s > RANK_TOL * s.max()))


def left_null_space(J: np.ndarray) -> np.ndarray:
    """An orthonormal basis Y (R, R − rank) of the vectors y with yᵀJ = 0 (rank as
    :func:`jacobian_rank`), assembled block by block."""
    R = J.shape[0]
    blocks = decoupled_blocks(J)
    svds = [np.linalg.svd(J[np.ix_(r, c)], full_matrices=True) for r, c in blocks]
    top = max((float(s[0]) for _, s, _ in svds if s.size), default=0.0)
    basis = [np.eye(R)[:, np.abs(J).max(axis=1, initial=0.0) == 0]]  # zero rows
    for (rows, _), (U, s, _) in zip(blocks, svds):
        Y = np.zeros((R, rows.size - int(np.sum(s > RANK_TOL * top))))
        Y[rows] = U[:, rows.size - Y.shape[1]:]
        basis.append(Y)
    return np.concatenate(basis, axis=1)
