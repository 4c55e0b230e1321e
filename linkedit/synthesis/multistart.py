"""Levenberg–Marquardt over many starts at once: the multistart least squares of the function and
motion generators (:mod:`linkedit.synthesis.function`, :mod:`linkedit.synthesis.motion`).

Every start is its own problem with its own damping; one call of the residual function
evaluates all of them (and, for the forward-difference Jacobian, all their perturbations) as
one array. A step is taken only where it lowers that start's cost; a residual row that is not
finite (the caller's wall: a linkage that does not work) is an infinite cost, never accepted.
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
          tolerance: float = 1e-30) -> tuple[np.ndarray, np.ndarray]:
    """Minimize ½‖r(x)‖² from every start ``x0`` (K, n): ``residuals(x, start)`` maps rows x (L, n)
    of the starts ``start`` (L,) (indices into x0) to residuals (L, M).

    Iterates stay within [lower, upper] (n,) (projected). A start stops when its cost is below
    ``tolerance`` or its damping reaches the upper bound (no step lowers the cost). Returns the
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
        h = STEP * np.maximum(1.0, np.abs(xa))  # (A, n)
        moved = (xa[:, None, :] + h[:, :, None] * eye[None]).reshape(-1, n)
        rm = residuals(moved, np.repeat(idx, n)).reshape(idx.size, n, -1)
        jac = np.transpose((rm - ra[:, None, :]) / h[:, :, None], (0, 2, 1))  # (A, M, n)
        jac = np.where(np.isfinite(jac), jac, 0.0)
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
    return x, c
