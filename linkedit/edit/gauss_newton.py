"""Levenberg–Marquardt (damped Gauss–Newton) on E(v) = ½‖r(v)‖², never accepting a step at
which the linkage stops working.

Each iteration solves (JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr with the Jacobian from forward-mode
derivatives (with ``symmetric``, in the directions that keep mirrored parts mirrored, δ = N·y,
then projected back onto the symmetry exactly: mirrored legs share their variables instead of
being tied by a stiff penalty alone), evaluates the trial v + δ once (residuals and Jacobian together) and accepts it
when the linkage works there and E decreases. λ follows Nielsen's gain-ratio rule; a trial at
which the linkage does not work counts as a rejected step and raises λ. A step is shortened
where, to first order, it would take a triangle deep into its barrier band in one go
(:meth:`Problem.barrier_step`), since the model cannot see the barrier before it is active.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from linkedit.edit.bfgs import BfgsResult as SolverResult
from linkedit.edit.objectives import Problem


def minimize(problem: Problem, v0: np.ndarray, *, max_iterations: int = 200, rtol: float = 1e-12,
             xtol: float = 1e-12, stall: float = 1e-3, callback: Callable[[int, float], None] | None = None) -> SolverResult:
    """Minimize the operation's energy from a working ``v0``.

    Converged when E reaches rounding level, when an accepted step is shorter than ``xtol``·L or
    decreases E by less than ``rtol`` (relative) twice in a row, or when no working decrease is
    left (λ > 1e16). *Stalled* (reported as such, not as converged) when the last 10 accepted
    steps together decreased E by less than ``stall`` (relative): typically creeping along the
    edge of the barrier, where each step uncovers another near-toggle sample.
    """
    v = np.asarray(v0, dtype=float).copy()
    ev, r, J = problem.residuals(v, jacobian=True)
    if not ev.works:
        raise ValueError(f"the starting point does not work: {ev.why}")
    assert J is not None  # asked for with jacobian=True
    e = 0.5 * float(r @ r)
    history = [e]
    lam, nu = 1e-4, 2.0
    evaluations, rejected, small = 1, 0, 0
    converged = stalled = False
    it = 0
    for it in range(1, max_iterations + 1):
        if e <= 1e-30 or v.size == 0:
            converged, it = True, it - 1
            break
        A = (J.T @ J).toarray()
        g = J.T @ r
        basis = problem.symmetric_basis(v)  # mirrored parts: a step in the variables they share
        if basis is not None:
            A, g = basis.T @ A @ basis, basis.T @ g
        d = np.maximum(np.diag(A), 1e-12 * max(float(np.diag(A).max(initial=0.0)), 1e-300))
        try:
            y = cho_solve(cho_factor(A + lam * np.diag(d)), -g)
        except np.linalg.LinAlgError:
            lam, nu = lam * nu, 2 * nu
            continue
        fraction = problem.barrier_step(ev, y if basis is None else basis @ y)
        y *= fraction
        step = y if basis is None else problem.keep_symmetric(v, basis @ y)
        trial, r_new, J_new = problem.residuals(v + step, jacobian=True)
        evaluations += 1
        if not trial.works:
            rejected += 1
            lam, nu = lam * nu, 2 * nu
            if lam > 1e16:
                converged = True
                break
            continue
        assert J_new is not None  # asked for with jacobian=True
        e_new = 0.5 * float(r_new @ r_new)
        predicted = 0.5 * float(y @ (lam * d * y - g))
        if e_new < e and predicted > 0:
            rho = (e - e_new) / predicted
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            decrease = (e - e_new) / max(e, 1e-300)
            v, e, r, J, ev = v + step, e_new, r_new, J_new, trial
            history.append(e)
            if callback is not None:
                callback(it, e)
            small = small + 1 if decrease < rtol else 0
            if small >= 2 or np.abs(step).max(initial=0.0) <= xtol * problem.size:
                converged = True
                break
            if len(history) > 10 and history[-11] - e < stall * history[-11]:
                stalled = True
                break
        else:
            lam, nu = lam * nu, 2 * nu
            if lam > 1e16:
                converged = True
                break
    return SolverResult(x=v, energy=e, iterations=it, evaluations=evaluations, converged=converged,
                        history=history, rejected=rejected, stalled=stalled)
