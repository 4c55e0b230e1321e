"""BFGS with a backtracking line search that never accepts an infeasible step.

The energy is +inf where the linkage cannot be assembled somewhere in the cycle (or a triangle
of the rest pose has flipped); such a trial step is shrunk until it is feasible and decreases
the energy (Armijo condition), so every accepted iterate is a working linkage.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

Energy = Callable[[np.ndarray], tuple[float, np.ndarray | None, object]]


@dataclass
class BfgsResult:
    x: np.ndarray
    energy: float
    iterations: int
    evaluations: int
    converged: bool
    history: list[float] = field(default_factory=list)  # energy after each iteration
    rejected: int = 0  # trial steps rejected because the linkage could not be assembled
    stalled: bool = False  # stopped for slow progress (see linkedit.edit.gauss_newton), not converged


def minimize(energy: Energy, x0: np.ndarray, *, max_iterations: int = 500, max_step: float = np.inf,
             rtol: float = 1e-10, gtol: float = 1e-9, callback: Callable[[int, float], None] | None = None) -> BfgsResult:
    """Minimize ``energy(x) -> (E, ∇E, extra)`` from a feasible ``x0``.

    Stops when the relative decrease of E stays below ``rtol`` twice in a row, when
    ‖∇E‖∞ ≤ gtol·max(1, |E|), or after ``max_iterations``. ``max_step`` caps the length of the
    first trial step of each line search (in the units of x).
    """
    x = np.asarray(x0, dtype=float).copy()
    e, g0, _ = energy(x)
    if not np.isfinite(e):
        raise ValueError("the starting point is infeasible")
    g = _gradient(g0)
    n = x.size
    H = np.eye(n)
    scaled = False
    history = [e]
    evaluations, rejected, small = 1, 0, 0
    converged = False
    it = 0
    for it in range(1, max_iterations + 1):
        if np.max(np.abs(g), initial=0.0) <= gtol * max(1.0, abs(e)):
            converged = True
            break
        p = -H @ g
        slope = float(g @ p)
        if slope >= 0.0:  # lost positive definiteness: restart from steepest descent
            H = np.eye(n)
            scaled = False
            p, slope = -g, -float(g @ g)
        alpha = min(1.0, max_step / max(float(np.linalg.norm(p)), 1e-300))
        accepted = False
        for _ in range(60):
            x_new = x + alpha * p
            e_new, g_new, _ = energy(x_new)
            evaluations += 1
            if not np.isfinite(e_new):
                rejected += 1
                alpha *= 0.25
                continue
            if e_new <= e + 1e-4 * alpha * slope:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            if scaled:  # the curvature model may be stale: retry once from steepest descent
                H, scaled = np.eye(n), False
                continue
            converged = True  # no feasible decrease along the search direction: a minimum to precision
            break
        g_new = _gradient(g_new)
        s, y = x_new - x, g_new - g
        sy = float(s @ y)
        if sy > 1e-12 * np.linalg.norm(s) * np.linalg.norm(y):
            if not scaled:
                H = np.eye(n) * (sy / float(y @ y))
                scaled = True
            rho = 1.0 / sy
            Hy = H @ y
            H += (rho * rho * float(y @ Hy) + rho) * np.outer(s, s) - rho * (np.outer(Hy, s) + np.outer(s, Hy))
        decrease = (e - e_new) / max(1.0, abs(e))
        x, e, g = x_new, e_new, g_new
        history.append(e)
        if callback is not None:
            callback(it, e)
        small = small + 1 if decrease < rtol else 0
        if small >= 2:
            converged = True
            break
    return BfgsResult(x=x, energy=e, iterations=it, evaluations=evaluations, converged=converged,
                      history=history, rejected=rejected)


def _gradient(g: np.ndarray | None) -> np.ndarray:
    """The gradient the energy gives at a working point (it gives none only where E = inf)."""
    if g is None:
        raise ValueError("the energy gave no gradient at a working point")
    return g
