"""The general numeric group solved in its joints' coordinates: its rows as real quadratics
(:class:`RealForm`), Newton's method on one sample (:func:`_newton`) and on every sample at once
(:func:`_polish`), continued along the samples by :func:`~.continuation.trace`
(:func:`solve_group`), and its singularity distance, the Hadamard ratio of its Jacobian
(:func:`conditioning`). A triad is solved in its body's pose instead (:mod:`.triad`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.rules.continuation import GROUP_ITERATIONS, GROUP_TOLERANCE, accepted, advance, largest, trace


def det_signs(rows: Rows, z: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """The sign (K,) of the group Jacobian's determinant at each rest pose ``z`` (J, *L, 1) of its
    ``rows`` (1 for a non-square group, and where it is singular)."""
    jac = rows.jacobian(z, joints)[..., 0, :, :].reshape(-1, rows.m, 2 * joints.size)
    if jac.shape[1] != jac.shape[2]:
        return np.ones(jac.shape[0])
    sign = np.sign(np.linalg.det(jac))
    return np.where(sign == 0.0, 1.0, sign)


@dataclass(frozen=True)
class RealForm:
    """The group's rows as real quadratics in X = (x_0, y_0, x_1, …, 1) of its local joints (and a
    last entry 1): F(X) = Xᵀ·Q·X − drive·s, Q (m, W, W) symmetric, stored as ``twice`` = 2·Q
    (m·W, W) so that one product gives the Jacobian 2·Q·X; drive (m,). K linkages' forms stack
    their Q: ``twice`` (K, m·W, W), acting on X (K, T, W); :meth:`linkage` is one of them."""

    twice: np.ndarray
    drive: np.ndarray
    driven: bool  # some row has a linear input
    m: int  # rows

    @classmethod
    def of(cls, rows: Rows) -> "RealForm":
        """The form of ``rows``: of K linkages ((K, m·W, W)) when they have a linkage axis, else of one."""
        many = rows.dc.ndim > 2

        def lead(a: np.ndarray) -> np.ndarray:  # the linkage axis first: (K, m, …)
            return np.moveaxis(a, -1, 0) if many else a[None]

        def real_cols(coef: np.ndarray, const: np.ndarray) -> np.ndarray:  # z_n = x_n + i·y_n, then 1
            out = np.empty((*coef.shape[:-1], 2 * coef.shape[-1] + 1), dtype=complex)
            out[..., 0:-1:2], out[..., 1:-1:2], out[..., -1] = coef, 1j * coef, const
            return out

        ad, ae = real_cols(lead(rows.dc), lead(rows.d0)), real_cols(lead(rows.ec), lead(rows.e0))
        quad = np.conj(ad)[..., :, None] * ae[..., None, :]  # (K, m, W, W)
        quad = np.where(rows.imag[:, None, None], quad.imag, quad.real)
        quad[..., -1, -1] -= lead(rows.rhs)
        twice = quad + np.swapaxes(quad, -1, -2)
        twice = twice.reshape(twice.shape[0], -1, twice.shape[-1])
        return cls(twice=np.ascontiguousarray(twice if many else twice[0]), drive=rows.drive,
                   driven=bool(rows.drive.any()), m=rows.m)

    @property
    def count(self) -> int:
        """K: how many linkages' forms it stacks (1 for one linkage's)."""
        return self.twice.shape[0] if self.twice.ndim == 3 else 1

    def linkage(self, k: int) -> "RealForm":
        """The form of linkage ``k`` alone."""
        return self if self.twice.ndim == 2 else RealForm(self.twice[k], self.drive, self.driven, self.m)

    def residual_jacobian(self, x: np.ndarray, s: np.ndarray | float, unknowns: int,
                          of: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """F (…, m) and ∂F/∂X of the first ``unknowns`` real variables (…, m, unknowns) at X (…, W)
        and input s (…): one sample (X (W,), s a float) or a batch (X (T, W) or (K, T, W), s (T,) or (K, T));
        ``of``: rows of several linkages (:meth:`gradient`)."""
        grad = self.gradient(x, of)
        f = 0.5 * (grad @ x) if x.ndim == 1 else 0.5 * (grad @ x[..., None])[..., 0]
        if self.driven:
            f -= self.drive * np.asarray(s)[..., None]
        return f, grad[..., :unknowns]

    def gradient(self, x: np.ndarray, of: np.ndarray | None = None) -> np.ndarray:
        """∂F/∂X (…, m, W) at X (…, W): one sample (W,) or a batch (T, W) of one linkage's form, or
        (K, T, W) of K linkages' (each its own Q): 2·Q·X by row (Q symmetric). With ``of`` (N,), nondecreasing:
        rows X (N, W) of K linkages' form, row n of linkage ``of[n]`` (one product per linkage present)."""
        m, width = self.m, self.twice.shape[-1]
        if of is not None and self.twice.ndim == 3:
            out = np.empty((x.shape[0], m * width))
            cuts = np.concatenate([[0], np.flatnonzero(np.diff(of)) + 1, [of.size]])
            for a, b in zip(cuts[:-1], cuts[1:]):
                out[a:b] = x[a:b] @ self.twice[of[a]].T
            return out.reshape(-1, m, width)
        if x.ndim == 1:
            return (self.twice @ x).reshape(m, width)
        if x.ndim == 3:
            twice = self.twice if self.twice.ndim == 3 else self.twice[None]
            return (x @ np.swapaxes(twice, 1, 2)).reshape(*x.shape[:2], m, width)
        return (x @ self.twice.T).reshape(x.shape[0], m, width)

    def quadratic(self, v: np.ndarray) -> np.ndarray:
        """d²F[V, V] = Vᵀ·2Q·V (…, m) along V (…, W) (as :meth:`gradient`)."""
        return (self.gradient(v) @ v[..., None])[..., 0]


def _newton(form: RealForm, x: np.ndarray, s: float, k: int, tol: float = GROUP_TOLERANCE) -> tuple[bool, float, float]:
    """Newton's method on the first ``k`` real variables of X (updated in place), one sample,
    until every row is within ``tol`` of 0. Returns (converged, size of the first step, sign of
    det J (square groups; 0: singular) from the LU of its last step — at the iterate one step from
    the end, on the same side of every singular position unless one lies within that step,
    which :func:`_polish` checks again at the solution — or of J at the start when it took none)."""
    from scipy.linalg import lapack  # LAPACK's solver without numpy's per-call checks: 5× less overhead

    first = 0.0
    square = form.m == k
    lu: tuple[np.ndarray, np.ndarray] | None = None
    for it in range(GROUP_ITERATIONS):
        f, jac = form.residual_jacobian(x, s, k)
        size = float(np.maximum.reduce(np.abs(f)))
        if size <= tol:
            if not square:
                return True, first, 1.0
            return True, first, _lu_sign(*(lu or lapack.dgetrf(jac)[:2]))
        if not size < np.inf:
            return False, first, 0.0
        if square:
            factors, pivots, step, singular = lapack.dgesv(jac, -f)
            if singular:
                return False, first, 0.0
            lu = factors, pivots
        else:
            step = np.linalg.lstsq(jac, -f, rcond=None)[0]
        if it == 0:
            first = float(np.abs(step).max())
        x[:k] += step
    return False, first, 0.0


def _lu_sign(lu: np.ndarray, piv: np.ndarray) -> float:
    """The sign of det A (0: exactly singular or NaN) from LAPACK's LU of A (k, k): ``lu`` and
    its row interchanges ``piv`` (0-based)."""
    diagonal = lu.diagonal().tolist()
    if not all(abs(v) > 0.0 for v in diagonal):  # singular (or NaN)
        return 0.0
    flips = sum(v < 0.0 for v in diagonal) + sum(p != i for i, p in enumerate(piv.tolist()))
    return -1.0 if flips % 2 else 1.0


def _continue(form: RealForm, det_sign: float, X: np.ndarray, s: np.ndarray, k: int, x: np.ndarray,
              path: np.ndarray, out: np.ndarray, tol: float = GROUP_TOLERANCE) -> int:
    """Continue the group sequentially from X-row ``x`` (known at sample ``path[0]``) through the
    samples ``path`` in order, writing ``out`` rows. Each move from one sample to the next is a
    homotopy in the known joints (interpolated linearly, :func:`~.continuation.advance`); Newton's
    first step is the tangent predictor, and a move is accepted only when Newton converges close to
    it (:func:`accepted`) without the Jacobian's determinant leaving ``det_sign``.
    Newton stops within ``tol``. Returns the position in ``path`` where it fails, or −1."""
    square = form.m == k
    x = x.copy()
    prev = path[0]
    for n, t in enumerate(path):

        def attempt(f: float) -> bool:  # Newton at the fraction f of the move from prev to t
            nonlocal x
            trial = x.copy()
            trial[k:] = X[t, k:] if f == 1.0 else X[prev, k:] + f * (X[t, k:] - X[prev, k:])
            ok, first, sign = _newton(form, trial, s[prev] + f * (s[t] - s[prev]), k, tol)
            if ok:
                ok = bool(accepted(float(np.maximum.reduce(np.abs(trial[:k] - x[:k]))), first))
                if ok and square and sign != det_sign:
                    ok = False  # passed a singular position: another assembly branch
            if ok:
                x = trial
            return ok

        if not advance(attempt):
            return n
        out[t] = x[:k]
        prev = t
    return -1


def _polish(form: RealForm, signs: np.ndarray, X: np.ndarray, s: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton's method on every row of X (K, T, W) at once — K linkages' (``form``'s), T samples
    each —, from the predictor in X[..., :k] (updated in place; NaN rows are left alone). Returns
    which rows (K, T) are accepted: converged, close to their predictor (:func:`accepted`), on
    their rest pose's side of every singular position (sign of det J: ``signs`` (K,)); and det J
    (K, T) at each accepted row's solution (NaN elsewhere, and for a non-square group)."""
    square = form.m == k
    K, T, width = X.shape
    flat = X.reshape(K * T, width)
    inputs = np.broadcast_to(s, (K, T)).reshape(K * T)
    start = flat[:, :k].copy()
    first = np.zeros(K * T)
    with np.errstate(invalid="ignore", over="ignore"):
        f, jac = form.residual_jacobian(X, s, k)  # every linkage's rows at once; then the live rows' alone
        f, jac = f.reshape(K * T, -1), np.ascontiguousarray(jac.reshape(K * T, *jac.shape[2:]))
        size = largest(f)
        done = size <= GROUP_TOLERANCE
        live = np.flatnonzero(size > GROUP_TOLERANCE)  # the rows still iterated (not converged, not NaN)
        for it in range(GROUP_ITERATIONS):
            if not live.size:
                break
            a, b = jac[live], -f[live]
            if not square:
                at = np.swapaxes(a, 1, 2)
                a, b = at @ a, (at @ b[..., None])[..., 0]
            try:
                delta = np.linalg.solve(a, b[..., None])[..., 0]
            except np.linalg.LinAlgError:  # an exactly singular row: left to the sequential fallback
                regular = np.abs(np.linalg.det(a)) > 0.0
                live, a, b = live[regular], a[regular], b[regular]
                delta = np.linalg.solve(a, b[..., None])[..., 0]
            if it == 0:
                first[live] = largest(delta)
            flat[live, :k] += delta
            f[live], jac[live] = form.residual_jacobian(flat[live], inputs[live], k, live // T)
            size = largest(f[live])
            done[live[size <= GROUP_TOLERANCE]] = True
            live = live[size > GROUP_TOLERANCE]  # neither converged nor NaN
    accept = done & accepted(largest(flat[:, :k] - start), first)
    det = np.full(K * T, np.nan)
    if square and accept.any():
        det[accept] = np.linalg.det(jac[accept])
        accept &= np.sign(det) == np.repeat(signs, T)
        det[~accept] = np.nan
    return accept.reshape(K, T), det.reshape(K, T)


def solve_group(form: RealForm, signs: np.ndarray, known: np.ndarray, s: np.ndarray,
                start: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continue K linkages' group (``form``: each its own rows; ``signs`` (K,) the sign of det J
    at each one's rest pose) from ``start`` (n, K) complex through the samples of its inputs
    ``known`` (J_in, K, T) complex and ``s`` (K, T), in order (:func:`~.continuation.trace`, in the
    group's joints' coordinates: :class:`_Joints`). Returns X (K, T, W) — :class:`RealForm`'s
    variables: the group's joints (NaN from the first sample where the linkage fails), its inputs,
    1 —, det J (K, T) of the group Jacobian at each placed sample (NaN elsewhere, and for a
    non-square group) for :func:`conditioning`, and which samples are placed (K, T)."""
    n = start.shape[0]
    k = 2 * n
    X = variables(np.ones((n, *s.shape)), known)
    x0 = X[:, 0, :k].copy()
    x0[:, 0:k:2], x0[:, 1:k:2] = start.real.T, start.imag.T
    out, det, placed = trace(_Joints(form, signs, X, s, x0), known, s)
    X[..., :k] = out
    missing = placed & np.isnan(det)  # continued sequentially
    if form.m == k and missing.any():
        det[missing] = np.linalg.det(form.residual_jacobian(X, s, k)[1][missing])
    return X, det, placed


@dataclass
class _Joints:
    """The general group continued in its joints' coordinates (:class:`~.continuation.Continued`):
    X (K, T, W) its variables with the inputs filled in, ``start`` (K, k) at rest."""

    form: RealForm
    signs: np.ndarray
    X: np.ndarray
    s: np.ndarray
    rest: np.ndarray

    @property
    def width(self) -> int:
        return self.rest.shape[1]

    def start(self, c: int) -> np.ndarray:
        return self.rest[c]

    def follow(self, c: int, x: np.ndarray, path: np.ndarray, out: np.ndarray, travel: np.ndarray,
               tol: float) -> int:
        k = self.width
        return _continue(self.form.linkage(c), self.signs[c], self.X[c], self.s[c], k,
                         np.concatenate([x, self.X[c, path[0], k:]]), path, out, tol)

    def polish(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = self.width
        full = self.X.copy()
        full[..., :k] = X
        accept, det = _polish(self.form, self.signs, full, self.s, k)
        X[:] = full[..., :k]
        return accept, det


def variables(joints: np.ndarray, known: np.ndarray) -> np.ndarray:
    """:class:`RealForm`'s variables X (K, T, W) of a group's ``joints`` (n, K, T) and its inputs
    ``known`` (J_in, K, T), complex: x_0, y_0, x_1, …, then the inputs', then 1."""
    k = 2 * joints.shape[0]
    X = np.ones((*joints.shape[1:], k + 2 * known.shape[0] + 1))
    X[..., 0:k:2], X[..., 1:k:2] = np.moveaxis(joints.real, 0, -1), np.moveaxis(joints.imag, 0, -1)
    X[..., k:-1:2], X[..., k + 1:-1:2] = np.moveaxis(known.real, 0, -1), np.moveaxis(known.imag, 0, -1)
    return X


def conditioning(jac: np.ndarray, det: np.ndarray, placed: np.ndarray) -> np.ndarray:
    """d_s (…) of the group Jacobians ``jac`` (…, m, k) at the solution; NaN where not ``placed``
    (…). A square group's is (det J / ∏ ‖row‖)² (``det`` (…) given: the Hadamard ratio, the
    dyad's sin² of the angle between its two rows generalized: 1 for orthogonal rows, 0 exactly
    at a singular position); a least-squares group's (m > k) is (σ_min/σ_max)² of its
    row-scaled Jacobian."""
    ds = np.full(placed.shape, np.nan)
    if not placed.any():
        return ds
    jacs = jac[placed]  # (N, m, k)
    if jac.shape[-2] == jac.shape[-1]:
        norms = np.einsum("tij,tij->it", jacs, jacs)  # (m, N) squared row norms
        rows = norms[0].copy()
        for more in norms[1:]:  # their product (a few rows: faster than a reduction along them)
            rows *= more
        d = det[placed]
        ds[placed] = np.minimum(d * d / np.maximum(rows, 1e-300), 1.0)
    else:
        scaled = jacs / np.maximum(np.abs(jacs).max(axis=2, keepdims=True), 1e-300)
        eig = np.linalg.eigvalsh(np.swapaxes(scaled, 1, 2) @ scaled)  # σ², ascending
        ds[placed] = np.maximum(eig[:, 0], 0.0) / eig[:, -1]
    return ds
