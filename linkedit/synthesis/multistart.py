"""Levenberg–Marquardt over many starts at once: the multistart least squares of the function and
motion generators (:mod:`linkedit.synthesis.function`, :mod:`linkedit.synthesis.motion`).

Every start is its own problem with its own damping; one call of the residual function
evaluates all of them (and, for the forward-difference Jacobian, all their perturbations) as
one array. A step is taken only where it lowers that start's cost; a residual row that is not
finite (the caller's wall: a linkage that does not work) is an infinite cost, never accepted.

Near an ill-conditioned root (a weak direction, its singular value ~1e-6, curving the cost's valley) those
damped, cost-lowering steps crawl: they stop ~1e-8 off. Full Gauss–Newton steps cross the valley (the first may
raise the cost) and then converge quadratically, so ``polish`` takes a few of them at the end, each start keeping
its best working iterate.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: relative forward-difference step of the Jacobian
STEP = 1e-7
#: damping bounds of a start (λ·diag(JᵀJ) is added to JᵀJ)
DAMPING = (1e-12, 1e8)


def cost(r: np.ndarray) -> np.ndarray:
    """½‖r‖² per row of residuals (K, M); inf where a residual is not finite."""
    with np.errstate(invalid="ignore", over="ignore"):
        out = 0.5 * np.sum(r * r, axis=1)
    return np.where(np.isfinite(out), out, np.inf)


def solve(residuals: Callable[[np.ndarray, np.ndarray], np.ndarray], x0: np.ndarray, *, iterations: int = 100,
          lower: np.ndarray | float = -np.inf, upper: np.ndarray | float = np.inf,
          tolerance: float = 1e-30, polish: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Minimize ½‖r(x)‖² from every start ``x0`` (K, n): ``residuals(x, start)`` maps rows x (L, n)
    of the starts ``start`` (L,) (indices into x0) to residuals (L, M).

    Iterates stay within [lower, upper] (n,) (projected). A start stops when its cost is below
    ``tolerance`` or its damping reaches the upper bound (no step lowers the cost). Then up to ``polish`` full
    (undamped) Gauss–Newton steps from each start above ``tolerance``, its best iterate kept. Returns the
    final x (K, n) and costs (K,) (inf: the start never had a finite cost).
    """
    x = np.clip(np.array(x0, dtype=float), lower, upper)
    k, n = x.shape
    r = residuals(x, np.arange(k))
    c = cost(r)
    lam = np.full(k, 1e-3)
    active = np.isfinite(c) & (c > tolerance)
    eye = np.eye(n)
    for _ in range(iterations):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        xa, ra = x[idx], r[idx]
        jac = _jacobian(residuals, xa, ra, idx)
        jtj = np.einsum("amn,amp->anp", jac, jac)
        grad = np.einsum("amn,am->an", jac, ra)
        diag = np.einsum("ann->an", jtj)
        damped = jtj + (lam[idx, None] * np.maximum(diag, 1e-12 * (1.0 + diag.max(axis=1, keepdims=True))))[:, :, None] * eye
        try:
            delta = -np.linalg.solve(damped, grad[..., None])[..., 0]
        except np.linalg.LinAlgError:
            delta = -np.stack([np.linalg.lstsq(m, g, rcond=None)[0] for m, g in zip(damped, grad)])
        trial = np.clip(xa + delta, lower, upper)
        rt = residuals(trial, idx)
        ct = cost(rt)
        better = ct < c[idx]
        x[idx[better]], r[idx[better]], c[idx[better]] = trial[better], rt[better], ct[better]
        lam[idx] = np.clip(np.where(better, lam[idx] / 3.0, lam[idx] * 4.0), *DAMPING)
        stalled = ~better & (lam[idx] >= DAMPING[1])
        small = better & (np.abs(trial - xa).max(axis=1) <= 1e-15 * (1.0 + np.abs(xa).max(axis=1)))
        active[idx[(c[idx] <= tolerance) | stalled | small]] = False
    return _polish(residuals, x, r, c, polish, lower, upper, tolerance)


def _jacobian(residuals: Callable[[np.ndarray, np.ndarray], np.ndarray], x: np.ndarray, r: np.ndarray,
              idx: np.ndarray) -> np.ndarray:
    """Forward-difference Jacobians (A, M, n) of the starts ``idx`` (A,) at x (A, n), residuals r (A, M);
    0 where a perturbation hits the wall."""
    n = x.shape[1]
    h = STEP * np.maximum(1.0, np.abs(x))  # (A, n)
    moved = (x[:, None, :] + h[:, :, None] * np.eye(n)[None]).reshape(-1, n)
    rm = residuals(moved, np.repeat(idx, n)).reshape(len(idx), n, -1)
    with np.errstate(invalid="ignore"):
        jac = np.transpose((rm - r[:, None, :]) / h[:, :, None], (0, 2, 1))
    return np.where(np.isfinite(jac), jac, 0.0)


def _polish(residuals: Callable[[np.ndarray, np.ndarray], np.ndarray], x: np.ndarray, r: np.ndarray,
            c: np.ndarray, steps: int, lower: np.ndarray | float, upper: np.ndarray | float,
            tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Up to ``steps`` full Gauss–Newton steps (least-norm, within [lower, upper]) from each start of x (K, n)
    with a finite cost c (K,) above ``tolerance`` (residuals r (K, M)); a start stops where an iterate hits the
    wall. Returns each start's best x and cost."""
    best, low = x.copy(), c.copy()
    active = np.isfinite(c) & (c > tolerance)
    for _ in range(steps):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        jac = _jacobian(residuals, x[idx], r[idx], idx)
        x[idx] = np.clip(x[idx] - (np.linalg.pinv(jac) @ r[idx, :, None])[..., 0], lower, upper)
        r[idx] = residuals(x[idx], idx)
        c[idx] = cost(r[idx])
        better = c < low
        best[better], low[better] = x[better], c[better]
        active &= np.isfinite(c) & (low > tolerance)
    return best, low
