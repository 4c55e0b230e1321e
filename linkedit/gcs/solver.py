"""Solve a compiled system at every time step: damped Gauss–Newton (Levenberg–Marquardt) on the
residual vector with analytic Jacobians, warm-started from the previous steps.

Per step:

1. *Prediction*: the state is extrapolated from the last solved steps (Lagrange polynomial in
   time through up to ``predict_order`` + 1 of them; quaternions component-wise, then
   normalized). The weights of the usual stencil (the steps just before) are computed for the
   whole run at once.
2. *Simplified Newton*: while the last factorized JᵀJ still contracts the residual quickly
   (by ``reuse_ratio`` per iteration), it is reused (a back-substitution per iteration, no new
   Jacobian) — across iterations and across time steps. Once an iteration contracts by less
   than ``refresh_ratio`` the factorization is stale: the next step evaluates the Jacobian with
   the residual at its predicted state and takes a full Newton step from there (which usually
   converges at once), and that factorization is kept for the following steps.
3. *Levenberg–Marquardt*: otherwise (and for a stale or missing factorization) fresh Jacobians,
   damping λ·diag(JᵀJ) raised on failure and lowered on success, until the residual is below
   tolerance (**converged**), the cost stops decreasing above tolerance (**inconsistent**: the
   constraints contradict each other), or the iteration budget runs out (**did not converge**).

Under-constrained directions get no step (the gradient has no component there and the damping
floor keeps the matrix definite), so free members stay where they were.

The alternative ``slsqp-fd`` is the paper's method: SciPy SLSQP on the summed scalar cost with
2-point finite-difference gradients. Finite differences and a summed (squared) cost cannot
reach the 1e-12 of the analytic path (the squared residual reaches the rounding level of the
cost first; SLSQP typically stops near 1e-7), so it is judged by its own tolerance
:data:`SLSQP_TOL`: a step is **converged** when SLSQP reports success and the largest scaled
residual row is ≤ ``SLSQP_TOL`` (1e-6), **inconsistent** when SLSQP reports success (a
minimum of the cost) above it, and **did not converge** when SLSQP reports failure.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.linalg import Factor, Linearization, NormalEquations
from linkedit.gcs.system import Evaluation, State, StepTable, System

CONVERGED, INCONSISTENT, NOT_CONVERGED = 0, 1, 2
STATUS_NAMES = ("converged", "inconsistent", "did not converge")
SOLVERS = ("lm", "slsqp-fd")
#: largest scaled residual row of a converged ``slsqp-fd`` step (``Options.tol`` is the LM one)
SLSQP_TOL = 1e-6


@dataclass
class Options:
    """Solver settings. ``tol``: largest residual row (lengths divided by the system's length
    scale, angles in radians) counted as satisfied; ``predict_order``: degree of the
    extrapolation from previous steps; ``reuse_ratio``: keep reusing a factorization within a
    step while each iteration shrinks the residual by at least this factor (0: a fresh Jacobian
    always); ``refresh_ratio``: refactorize at the next step once an iteration shrinks it by
    less than this."""

    tol: float = 1e-12
    max_iterations: int = 100
    predict_order: int = 9
    reuse_ratio: float = 0.3
    refresh_ratio: float = 0.05
    solver: str = "lm"

    @property
    def satisfied_tol(self) -> float:
        """The largest scaled residual row the chosen solver counts as satisfied."""
        return SLSQP_TOL if self.solver == "slsqp-fd" else self.tol


@dataclass
class StepResult:
    status: int
    iterations: int  #: linear solves
    factorizations: int


@dataclass
class _Reuse:
    """The last factorization and the linearization it came from."""

    factor: Factor | None = None
    lin: Linearization | None = None
    stale: bool = False  #: refactorize at the start of the next step


@dataclass
class Solver:
    """Solves one system step by step, keeping the factorization to reuse (see module docstring)."""

    system: System
    options: Options = field(default_factory=Options)

    def __post_init__(self) -> None:
        s = self.system
        self.normal = NormalEquations(s.groups, s.n_members, s.n_rows)
        self.reuse = _Reuse()

    def _error(self, r: np.ndarray) -> float:
        """The largest scaled residual row."""
        return float((np.abs(r) * self.system.row_scale).max()) if r.size else 0.0

    def solve(self, start: State, table: StepTable, step: int) -> tuple[State, np.ndarray, StepResult]:
        """Solve one step from ``start``: (state, residual (R,), StepResult)."""
        if self.options.solver == "slsqp-fd":
            return solve_slsqp(self.system, start, table, step, self.options)
        fresh = self.reuse.factor is None or self.reuse.stale or self.options.reuse_ratio <= 0
        ev = self.system.evaluate(start, table, step, jacobian=fresh)
        error = self._error(ev.r)
        if error <= self.options.tol:
            return start, ev.r, StepResult(CONVERGED, 0, 0)
        x, iterations = start, 0
        if not fresh:
            x, r, iterations, converged = self._chord(start, ev.r, table, step)
            if converged:
                return x, r, StepResult(CONVERGED, iterations, 0)
            ev = self.system.evaluate(x, table, step, jacobian=True)
            error = self._error(r)
        return self._levenberg_marquardt(x, ev, error, table, step, iterations)

    def _chord(self, x: State, r: np.ndarray, table: StepTable, step: int) -> tuple[State, np.ndarray, int, bool]:
        """Simplified Newton with the kept factorization while it contracts the residual by
        ``reuse_ratio`` per iteration: the best (state, residual), the iterations taken and
        whether that state is converged. Marks the factorization stale when an iteration
        contracts by less than ``refresh_ratio``."""
        opt, kept = self.options, self.reuse
        norm = r @ r
        iterations = 0
        while iterations < opt.max_iterations:
            x1 = x.moved(-kept.factor.solve(kept.lin.gradient(r)))
            r1 = self.system.evaluate(x1, table, step).r
            iterations += 1
            norm1 = r1 @ r1
            if norm1 > opt.refresh_ratio**2 * norm:
                kept.stale = True
            if self._error(r1) <= opt.tol:
                return x1, r1, iterations, True
            if norm1 < norm:
                x, r = x1, r1
            if not norm1 < opt.reuse_ratio**2 * norm:
                break
            norm = norm1
        return x, r, iterations, False

    def _levenberg_marquardt(self, x: State, ev: Evaluation, error: float, table: StepTable, step: int,
                             iterations: int) -> tuple[State, np.ndarray, StepResult]:
        """Levenberg–Marquardt from ``x`` (evaluated with its Jacobian; scaled ``error``).

        Far from the solution (error above tol^¼) a trial point is evaluated with its Jacobian
        at once (it is needed if the step is accepted). Close to it, a step that shrank the error
        by a factor c leaves error·c to the next step with the same factorization (the
        contraction of a reused factorization is about that of the step that moved away from
        it), so when that is below tolerance the factorization is reused; a reused one that
        fails is replaced by a fresh linearization, a fresh one that fails gets more damping."""
        sys, opt = self.system, self.options
        lam, lam_min = 1e-10, 1e-12
        r = ev.r
        f = float(r @ r)
        lin, factor, fresh = self.normal.linearize(ev.jac), None, True
        factorizations = stalls = 0
        while iterations < opt.max_iterations:
            if factor is None:
                diagonal = self.normal.diagonal(lin.data)
                floor = 1e-13 * max(float(diagonal.max()) if diagonal.size else 0.0, 1.0)
                factor = self.normal.factor(lin.data, lam, floor)
                factorizations += 1
            x1 = x.moved(-factor.solve(lin.gradient(r)))
            iterations += 1
            ev1 = sys.evaluate(x1, table, step, jacobian=error > opt.tol**0.25)
            f1 = float(ev1.r @ ev1.r)
            if f1 < f:
                if fresh and lam <= 1e-8:
                    self.reuse = _Reuse(factor, lin)
                stalls = stalls + 1 if f - f1 <= 1e-9 * f else 0
                error1 = self._error(ev1.r)
                x, r, f, error, contraction = x1, ev1.r, f1, error1, error1 / error
                lam = max(lam / 10.0, lam_min)
                if error <= opt.tol:
                    return x, r, StepResult(CONVERGED, iterations, factorizations)
                if stalls >= 3:
                    return x, r, StepResult(INCONSISTENT, iterations, factorizations)
                if ev1.jac is None and error * contraction <= 0.1 * opt.tol:
                    fresh = False
                    continue
                ev = ev1 if ev1.jac is not None else sys.evaluate(x, table, step, jacobian=True)
            elif fresh:
                lam *= 10.0
                factor = None
                if lam > 1e10:
                    return x, r, StepResult(INCONSISTENT, iterations, factorizations)
                continue
            else:
                ev = sys.evaluate(x, table, step, jacobian=True)
            lin, factor, fresh = self.normal.linearize(ev.jac), None, True
        return x, r, StepResult(NOT_CONVERGED, iterations, factorizations)


def lagrange_weights(nodes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Weights (..., k) of the Lagrange polynomial through ``nodes`` (..., k) at ``t`` (...):
    w_j = ∏_{i≠j} (t − t_i) / (t_j − t_i)."""
    k = nodes.shape[-1]
    ratio = (t[..., None] - nodes)[..., None, :] / (nodes[..., :, None] - nodes[..., None, :] + np.eye(k))
    ratio[..., np.arange(k), np.arange(k)] = 1.0
    return ratio.prod(axis=-1)


def predict(weights: np.ndarray, positions: np.ndarray, orientations: np.ndarray) -> State:
    """Extrapolate member states with Lagrange ``weights`` (k,) from the k last solved steps:
    positions (k, M, 3) and quaternions (k, M, 4), the latter component-wise then normalized
    (consecutive solved quaternions never flip sign)."""
    k = len(weights)
    P = (weights @ positions.reshape(k, -1)).reshape(positions.shape[1:])
    Q = (weights @ orientations.reshape(k, -1)).reshape(orientations.shape[1:])
    return State(P, quat.normalize(Q))


@dataclass
class Run:
    """Member states and per-step diagnostics over T steps."""

    t: np.ndarray  #: (T,)
    position: np.ndarray  #: (T, M, 3)
    orientation: np.ndarray  #: (T, M, 4)
    residual: np.ndarray  #: (T, R) residual vector at each solved step
    status: np.ndarray  #: (T,) int8: 0 converged, 1 inconsistent, 2 did not converge
    iterations: np.ndarray  #: (T,) linear solves
    factorizations: np.ndarray  #: (T,)

    def state(self, step: int) -> State:
        return State(self.position[step], self.orientation[step])


def solve_run(system: System, t: np.ndarray, options: Options | None = None,
              start: State | None = None, table: StepTable | None = None) -> Run:
    """Solve every time step of ``t`` (T,), each warm-started from the previous ones."""
    options = options or Options()
    t = np.asarray(t, dtype=float)
    table = table or system.step_table(t)
    solver = Solver(system, options)
    T, M = t.size, system.n_members
    pos = np.empty((T, M, 3))
    ori = np.empty((T, M, 4))
    res = np.empty((T, system.n_rows))
    status = np.empty(T, dtype=np.int8)
    iters = np.empty(T, dtype=np.int32)
    facts = np.empty(T, dtype=np.int32)
    n = options.predict_order + 1  # steps in a full stencil
    usual = lagrange_weights(np.lib.stride_tricks.sliding_window_view(t, n)[:-1], t[n:]) if T > n else None
    first = 0  # steps first..k−1 converged: the prediction goes through the last n of them
    current = (start or system.rest).copy()
    for k in range(T):
        first = max(first, k - n)
        if k - first < 2:
            guess = current
        else:
            w = usual[k - n] if k - first == n else lagrange_weights(t[first:k], t[k])
            guess = predict(w, pos[first:k], ori[first:k])
        state, r, info = solver.solve(guess, table, k)
        if info.status != CONVERGED and k > first:
            # the prediction may have overshot: retry from the last solved state
            state2, r2, info2 = solver.solve(current, table, k)
            if info2.status == CONVERGED or r2 @ r2 < r @ r:
                state, r, info = state2, r2, StepResult(info2.status, info.iterations + info2.iterations,
                                                        info.factorizations + info2.factorizations)
        pos[k], ori[k], res[k] = state.position, state.orientation, r
        status[k], iters[k], facts[k] = info.status, info.iterations, info.factorizations
        if info.status != CONVERGED:
            first = k + 1  # restart the prediction after a failed step
        current = state
    return Run(t=t, position=pos, orientation=ori, residual=res, status=status, iterations=iters, factorizations=facts)


def solve_slsqp(system: System, start: State, table: StepTable, step: int,
                options: Options) -> tuple[State, np.ndarray, StepResult]:
    """The paper's method: SLSQP on the summed cost Σ|r|², 2-point finite-difference gradients."""
    from scipy.optimize import minimize

    def moved(z: np.ndarray) -> State:
        return start.moved(z)

    def cost(z: np.ndarray) -> float:
        r = system.evaluate(moved(z), table, step).r
        return float(r @ r)

    out = minimize(cost, np.zeros(system.n_unknowns), method="SLSQP",
                   options={"maxiter": 1000, "ftol": 1e-16})
    x = moved(out.x)
    r = system.evaluate(x, table, step).r
    err = float(np.max(np.abs(r) * system.row_scale, initial=0.0))
    if not out.success:
        status = NOT_CONVERGED
    else:
        status = CONVERGED if err <= SLSQP_TOL else INCONSISTENT
    return x, r, StepResult(status, int(out.nit), 0)
