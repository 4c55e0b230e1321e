"""Solve a compiled system at every time step: damped Gauss–Newton (Levenberg–Marquardt) on the
residual vector with analytic Jacobians, warm-started from the previous steps.

Per step:

1. *Prediction*: the state is extrapolated from the last solved steps (Lagrange polynomial in
   time through up to 4 of them; orientations through rotation vectors relative to the last).
2. *Simplified Newton*: while the last factorized JᵀJ still contracts the residual quickly
   (by 10× per iteration), it is reused (a back-substitution per iteration, no new Jacobian)
   — across iterations and across time steps.
3. *Levenberg–Marquardt*: otherwise a fresh Jacobian, damping λ·diag(JᵀJ) raised on failure and
   lowered on success, until the residual is below tolerance (**converged**), the cost stops
   decreasing above tolerance (**inconsistent**: the constraints contradict each other), or the
   iteration budget runs out (**did not converge**).

Under-constrained directions get no step (the gradient has no component there and the damping
floor keeps the matrix definite), so free members stay where they were.

The alternative ``slsqp-fd`` is the paper's method: SciPy SLSQP on the summed scalar cost with
2-point finite-difference gradients.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.linalg import Factor, NormalEquations
from linkedit.gcs.system import State, StepTable, System

CONVERGED, INCONSISTENT, NOT_CONVERGED = 0, 1, 2
STATUS_NAMES = ("converged", "inconsistent", "did not converge")
SOLVERS = ("lm", "slsqp-fd")


@dataclass
class Options:
    """Solver settings. ``tol``: largest residual row (lengths divided by the system's length
    scale, angles in radians) counted as satisfied; ``predict_order``: degree of the
    extrapolation from previous steps; ``reuse_ratio``: keep reusing a factorization while
    each iteration shrinks the residual by at least this factor (0: a fresh Jacobian always)."""

    tol: float = 1e-12
    max_iterations: int = 100
    predict_order: int = 5
    reuse_ratio: float = 0.1
    solver: str = "lm"


@dataclass
class StepResult:
    status: int
    iterations: int  #: linear solves
    factorizations: int


@dataclass
class _Reuse:
    """The last factorization and the Jacobian entries it came from."""

    factor: Factor | None = None
    jac: list[np.ndarray] | None = None


@dataclass
class Solver:
    """Solves one system step by step, keeping the factorization to reuse (see module docstring)."""

    system: System
    options: Options = field(default_factory=Options)

    def __post_init__(self) -> None:
        s = self.system
        self.normal = NormalEquations(s.groups, s.n_members)
        self.reuse = _Reuse()

    def _error(self, r: np.ndarray) -> float:
        return float(np.max(np.abs(r) * self.system.row_scale, initial=0.0))

    def solve(self, start: State, table: StepTable, step: int) -> tuple[State, np.ndarray, StepResult]:
        """Solve one step from ``start``: (state, residual (R,), StepResult)."""
        if self.options.solver == "slsqp-fd":
            return solve_slsqp(self.system, start, table, step, self.options)
        sys, opt = self.system, self.options
        x = start
        r = sys.evaluate(x, table, step).r
        iterations = factorizations = 0
        if self._error(r) <= opt.tol:
            return x, r, StepResult(CONVERGED, 0, 0)
        # simplified Newton with the kept factorization
        if self.reuse.factor is not None and opt.reuse_ratio > 0:
            norm = np.sqrt(r @ r)
            while iterations < opt.max_iterations:
                g = self.normal.gradient(self.reuse.jac, r)
                x1 = x.moved(-self.reuse.factor.solve(g))
                r1 = sys.evaluate(x1, table, step).r
                iterations += 1
                norm1 = np.sqrt(r1 @ r1)
                if norm1 < norm:
                    x, r = x1, r1
                if self._error(r1) <= opt.tol:
                    return x, r, StepResult(CONVERGED, iterations, 0)
                if not norm1 < opt.reuse_ratio * norm:
                    break
                norm = norm1
        # Levenberg–Marquardt with fresh Jacobians
        lam, lam_min = 1e-10, 1e-12
        f = float(r @ r)
        ev = sys.evaluate(x, table, step, jacobian=True)
        stalls = 0
        while iterations < opt.max_iterations:
            data = self.normal.matrix_data(ev.jac)
            g = self.normal.gradient(ev.jac, ev.r)
            floor = 1e-13 * max(float(self.normal.diagonal(data).max(initial=0.0)), 1.0)
            factor = self.normal.factor(data, lam, floor)
            factorizations += 1
            x1 = x.moved(-factor.solve(g))
            iterations += 1
            r1 = sys.evaluate(x1, table, step).r
            f1 = float(r1 @ r1)
            if f1 < f:
                if lam <= 1e-8:
                    self.reuse = _Reuse(factor, ev.jac)
                stalls = stalls + 1 if f - f1 <= 1e-9 * f else 0
                x, r, f = x1, r1, f1
                lam = max(lam / 10.0, lam_min)
                if self._error(r) <= opt.tol:
                    return x, r, StepResult(CONVERGED, iterations, factorizations)
                if stalls >= 3:
                    return x, r, StepResult(INCONSISTENT, iterations, factorizations)
                ev = sys.evaluate(x, table, step, jacobian=True)
            else:
                lam *= 10.0
                if lam > 1e10:
                    return x, r, StepResult(INCONSISTENT, iterations, factorizations)
        return x, r, StepResult(NOT_CONVERGED, iterations, factorizations)


def predict(times: np.ndarray, positions: np.ndarray, orientations: np.ndarray, t: float) -> State:
    """Extrapolate member states to time ``t`` by the Lagrange polynomial through the k last
    solved steps (oldest first): positions (k, M, 3) and quaternions (k, M, 4), the latter
    component-wise then normalized (consecutive solved quaternions never flip sign)."""
    k = len(times)
    w = np.ones(k)
    for j in range(k):
        for i in range(k):
            if i != j:
                w[j] *= (t - times[i]) / (times[j] - times[i])
    P = np.tensordot(w, positions, axes=1)
    Q = np.tensordot(w, orientations, axes=1)
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
    solved: list[int] = []  # the last consecutive converged steps, for the prediction
    current = (start or system.rest).copy()
    for k in range(T):
        if solved:
            guess = predict(t[solved], pos[solved], ori[solved], t[k]) if len(solved) > 1 else current
        else:
            guess = current
        state, r, info = solver.solve(guess, table, k)
        if info.status != CONVERGED and solved:
            # the prediction may have overshot: retry from the last solved state
            state2, r2, info2 = solver.solve(current, table, k)
            if info2.status == CONVERGED or r2 @ r2 < r @ r:
                state, r, info = state2, r2, StepResult(info2.status, info.iterations + info2.iterations,
                                                        info.factorizations + info2.factorizations)
        pos[k], ori[k], res[k] = state.position, state.orientation, r
        status[k], iters[k], facts[k] = info.status, info.iterations, info.factorizations
        if info.status == CONVERGED:
            solved = (solved + [k])[-(options.predict_order + 1):]
        else:
            solved = []  # restart the prediction after a failed step
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
    status = CONVERGED if err <= options.tol else NOT_CONVERGED
    return x, r, StepResult(status, int(out.nit), 0)
