"""Solve a compiled system at every time step: least-norm Gauss–Newton with analytic
Jacobians, canonical free directions, branch-safe continuation, exact velocities.

**Dimensionless.** Residual rows are divided by the mechanism's size L (lengths; angles are
radians already) and position unknowns are measured in L, so the normal matrix, the steps and
every tolerance are the same for a mechanism in mm, m or km.

**Least norm, canonical free directions.** Gauss–Newton corrections are least norm: with J
the Jacobian, an iteration moves by −J⁺r. Where J has a null space (a coupler's idle spin), the
converged pose is then moved along it to the *canonical* pose, the one nearest the rest pose
(:attr:`Solver.reference`) in the scaled metric (:mod:`linkedit.gcs.canonical`: Newton steps
along the null space, each followed by least-norm corrections), and its velocity is that
pose's time derivative — so the poses do not depend on the steps taken. At a step with an
input outside its window, the corrections and the converged pose keep the *minimum change*
from an anchor pose (the step before) instead: with d the scaled displacement from the anchor,
the correction ε = −d + J⁺(J d − r), whose fixed points have d ⊥ null(J), so what that input
left free (a crank whose window has closed) holds. J⁺ comes from the Cholesky (or sparse LU)
factorization of JᵀJ + μI, μ = 1e-13 of its
largest diagonal. Whether J has a null space is decided once per set of active inputs (a rank
at the first pose that has it) and, at each pose, by small pivots; only then is the null space
taken (two inverse iterations with that factorization, checked against J; an SVD where they
are not clean — the normal equations' solution is rounding there, amplified by 1/μ), its
component removed from every correction and velocity, and the pose moved along it as above to
:attr:`Options.still_tol`. The rank of J read off the same
factorization is kept per step (:attr:`Run.rank`) for the diagnostics.

**Continuation.** From a solved pose x at time s, with its factorization and exact velocity v
(J v = −∂r/∂t, least norm), a step of length h starts from the polynomial through the last eight
accepted poses (or, where that strays from it, from x ⊕ (h·v + ½h²·a), a the change of velocity
since the pose before), and corrects it once with the factorization of x (one back-substitution);
the Jacobian at the corrected pose is evaluated with its residual and factorized, and corrects
the rest (simplified Newton); falling back to Levenberg–Marquardt with fresh Jacobians. At a
singular pose (small pivots where J has no null space for its inputs: a change point, where
assembly branches cross) the velocity is the one nearest the velocity the motion arrived with
(:meth:`Solver.velocity`), so the next step follows the branch whose tangent continues it. A (sub-)step is accepted when it converges to a
pose within :attr:`Options.predictor_tol` of its tangent prediction x ⊕ h·v and moves at most
:attr:`Options.max_motion`; otherwise it is halved. So a coarse run solves the same poses as a
fine one (the same branch), or fails at the time where the step fell below
:attr:`Options.min_fraction` of a time step (a lock-up, a singular pose). A failed step is not
continued from: the next one starts again from the last good pose (continuation, then a direct
solve from it).

Each accepted pose is factorized once (at its first corrected iterate, when the later
corrections moved it at most :data:`REUSE`, else afresh): that factorization gives its
velocity, its null space and rank and the first correction of the next step.

Status per step: **converged** (largest scaled residual row ≤ tol), **inconsistent** (the
least-squares cost stopped decreasing above tol, or creeps where its gradient is small: the
constraints contradict each other) or
**did not converge** (iteration budget, or the step shrank below the smallest sub-step).

The alternative ``slsqp-fd`` is the paper's method: SciPy SLSQP on the summed scaled cost with
2-point finite-difference gradients, each step started from the previous one. It cannot reach
the 1e-12 of the analytic path (SLSQP typically stops near 1e-7), so it is judged by
:data:`SLSQP_TOL`: **converged** when SLSQP reports success and the largest scaled residual
row is ≤ 1e-6, **inconsistent** when it reports success above it, **did not converge** when
it reports failure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs import accept
from linkedit.gcs import canonical as canon
from linkedit.gcs.acceleration import advanced, jacobian_product
from linkedit.gcs.linalg import Linear, Linearization, NormalEquations, jacobian_rank, null_space
from linkedit.gcs.predict import Pose
from linkedit.gcs.system import Evaluation, State, StepTable, System
from linkedit.gcs.tolerances import CONVERGED, DAMPING, FREE_PIVOT, INCONSISTENT, NOT_CONVERGED, SLSQP_TOL, Options

#: a Levenberg–Marquardt iterate is near a stationary point of the cost when |Jᵀr| is at most
#: this fraction of √(largest diagonal of JᵀJ)·|r| (scaled); there, a cost decreasing by less than
#: CREEP of itself per iteration (three in a row) is a least-squares minimum: inconsistent
STATIONARY = 1e-2
CREEP = 1e-3
#: Levenberg–Marquardt iterations a continuation (sub-)step may take before it is halved
SUBSTEP_ITERATIONS = 20
#: largest scaled move of a pose after its Jacobian was taken for that Jacobian to serve it
#: (velocity, null space, next step): the velocity is then exact to this relative order
REUSE = 1e-10
#: a continuation that failed within this fraction of its step from the step's time arrived
#: there (the direct solve from the last good pose then finishes it); short of it, something
#: (a lock-up, a singular pose) stopped it, and a pose found directly is not on its branch
ARRIVED = 1e-6


@dataclass
class StepResult:
    status: int
    iterations: int  #: linear solves
    factorizations: int


@dataclass
class Solver:
    """Solves one system pose by pose (see module docstring)."""

    system: System
    options: Options = field(default_factory=Options)

    def __post_init__(self) -> None:
        s = self.system
        L = s.length_scale
        self.col = np.tile(np.r_[np.full(3, L), np.ones(3)], s.n_members)  #: scaled → real unknowns
        self.row = s.row_scale
        six = np.r_[np.full(3, L), np.ones(3)]
        self.normal = NormalEquations(s.groups, s.n_members, s.n_rows,
                                      [self.row[g.rows][:, :, None, None] * six for g in s.groups])
        self.iterations = self.factorizations = 0
        self.structure: dict[bytes, bool] = {}  #: active-input pattern → J has a null space
        #: the pose that free directions are canonical against (:mod:`linkedit.gcs.canonical`)
        self.reference: State = s.rest

    # ---- building blocks --------------------------------------------------------------------

    def error(self, r: np.ndarray) -> float:
        """The largest scaled residual row."""
        return float((np.abs(r) * self.row).max()) if r.size else 0.0

    def linearize(self, x: State, table: StepTable, step: int, ev: Evaluation | None = None) -> Linear:
        """Factorize the scaled JᵀJ + μI at x (from ``ev``, its evaluation with the Jacobian,
        when given); where J has a null space, take its basis (:func:`~linkedit.gcs.linalg.null_space`)."""
        if ev is None:
            ev = self.system.evaluate(x, table, step, jacobian=True)
        lin = self.normal.linearize(ev.jacobians(), scaled=True)
        diagonal = self.normal.diagonal(lin.data)
        top = max(float(diagonal.max()) if diagonal.size else 0.0, 1.0)
        factor = self.normal.factor(lin.data, 0.0, DAMPING * top)
        self.factorizations += 1
        small = factor.pivots() < FREE_PIVOT * top
        if not small.any():
            return Linear(ev, lin, factor, None, self.system.n_unknowns)
        if not self._free(table, step, lin, ev.r):
            return Linear(ev, lin, factor, None, singular=True)
        return Linear(ev, lin, factor, *null_space(lin.JT.T, factor, int(small.sum()), top))

    def _key(self, table: StepTable, step: int) -> bytes:
        """The set of inputs active at a step, as :attr:`structure` keys it."""
        return table.at(step).inactive_rows.tobytes() if table.partial[step] else b""

    def _free(self, table: StepTable, step: int, lin: Linearization, r: np.ndarray) -> bool:
        """Whether J has a null space for the inputs active at this step: its rank is taken
        (block by block) at the first *solved* pose (residual ``r`` within tolerance) with each
        set of active inputs, and kept. Off the constraints a residual hides a free direction
        (a world-fixed turn is conjugated by an unsolved relative orientation: J's smallest
        singular value is about the residual), so there it is taken afresh, not kept."""
        key = self._key(table, step)
        if key in self.structure:
            return self.structure[key]
        J = lin.JT.T
        free = jacobian_rank(J.toarray() if hasattr(J, "toarray") else np.asarray(J)) < self.system.n_unknowns
        if self.error(r) <= self.options.tol:
            self.structure[key] = free
        return free

    def moved(self, x: State, e: np.ndarray) -> State:
        return x.moved(e * self.col)

    def displacement(self, x: State, anchor: State) -> np.ndarray:
        """Scaled local coordinates (N,) from the anchor to x."""
        return x.minus(anchor) / self.col

    def velocity(self, x: State, table: StepTable, step: int, linear: Linear,
                 incoming: np.ndarray | None = None) -> np.ndarray:
        """The least-norm scaled velocity v (N,) of J v = −∂r/∂t; at a singular pose, the one
        nearest the ``incoming`` velocity (N,) when given (:meth:`Linear.continued`), so the
        continuation keeps the branch whose tangent continues the motion."""
        rt = self.system.time_derivative(x, table, step, linear.ev)
        v0 = linear.continued(-rt * self.row, incoming)
        if linear.null is None or table.partial[step]:
            return v0
        # the canonical pose's tangent (:mod:`linkedit.gcs.canonical`)
        null, d = linear.null[None], self.displacement(x, self.reference)[None]
        G = canon.hessian(null, d, self._bend(x, table, step, linear, d[0])[None])
        return canon.velocity(v0[None], null, d, G, self._bend(x, table, step, linear, d[0], v0)[None])[0]

    def _bend(self, x: State, table: StepTable, step: int, linear: Linear, d: np.ndarray,
              w: np.ndarray | None = None) -> np.ndarray:
        """λᵀ J̇ n_i for J's null vectors n_i (the columns of ``linear.null``) at a solved pose
        x with displacement d (N,) from the reference, λ = J⁺ᵀ d: along every n_j (f, f), or
        along w (N,) with the inputs advanced in time (f,), by central differences of the
        scaled J (:mod:`linkedit.gcs.canonical`)."""
        assert linear.null is not None
        null, system = linear.null, self.system
        lam = linear.lin.JT.T @ linear.still(linear.factor.solve(linear.still(d))) * self.row
        moves = null.T if w is None else w[None]
        out = np.empty((null.shape[1], len(moves)))
        for j, m in enumerate(moves):
            h = canon.STEP / max(1.0, float(np.abs(m).max(initial=0.0)))
            sides = []
            for s in (h, -h):
                tab, k = (table, step) if w is None else (advanced(table, step, s), 0)
                ev = system.evaluate(self.moved(x, s * m), tab, k, jacobian=True)
                sides.append([lam @ jacobian_product(system, ev, n * self.col) for n in null.T])
            out[:, j] = (np.array(sides[0]) - np.array(sides[1])) / (2 * h)
        return out if w is None else out[:, 0]

    def _residual(self, x: State, table: StepTable, step: int) -> np.ndarray:
        return self.system.evaluate(x, table, step).r

    def scaled(self, r: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The scaled residual (R,), its largest row (as :meth:`error`) and its norm."""
        rs = r * self.row
        return rs, float(np.abs(rs).max()) if rs.size else 0.0, math.sqrt(rs @ rs)

    def correction(self, x: State, rs: np.ndarray, anchor: State | None, linear: Linear,
                   d: np.ndarray | None = None) -> np.ndarray:
        """The correction (N,) at x for the scaled residual ``rs``: least norm; with an
        ``anchor`` (minimum change), the change from it along the null space of J taken back
        (``d``: x's displacement from the anchor (N,), when known)."""
        y = linear.factor.solve(linear.lin.gradient(rs))
        if linear.null is None:
            return -y
        if anchor is None:
            return -linear.still(y)
        if d is None:
            d = self.displacement(x, anchor)
        return linear.null @ (linear.null.T @ (y - d)) - y  # −(y − P y) − P d, P the null projector

    # ---- one pose ---------------------------------------------------------------------------

    def chord(self, x: State, r: np.ndarray, anchor: State | None, linear: Linear, table: StepTable, step: int,
              scaled: tuple[np.ndarray, float, float] | None = None) -> tuple[State, np.ndarray, bool, np.ndarray]:
        """Simplified Newton (least norm, or minimum change from an ``anchor``) with a kept factorization while it contracts the
        residual at least twofold (``scaled``: :meth:`scaled` of r, when known): the best
        (state, residual), whether it converged, and the sum of the corrections that led to the
        state (N,)."""
        tol = self.options.tol
        rs, err, norm = scaled or self.scaled(r)
        total = np.zeros(self.system.n_unknowns)
        while err > tol:
            e = self.correction(x, rs, anchor, linear)
            x1 = self.moved(x, e)
            r1 = self._residual(x1, table, step)
            self.iterations += 1
            rs1, err1, norm1 = self.scaled(r1)
            if not norm1 < 0.5 * norm or not math.isfinite(norm1):
                return (x1, r1, False, total + e) if norm1 < norm else (x, r, False, total)
            x, r, rs, err, norm, total = x1, r1, rs1, err1, norm1, total + e
        return x, r, True, total

    def newton(self, x: State, r: np.ndarray, anchor: State | None, linear: Linear, table: StepTable, step: int,
               d: np.ndarray | None = None) -> tuple[State, np.ndarray, bool, Linear | None, np.ndarray]:
        """Newton (as :meth:`chord`) from a predicted pose (``d``: its displacement from the anchor
        (N,), when known): one correction with ``linear`` (a nearby pose's factorization), the
        Jacobian evaluated with the residual there and factorized, then :meth:`chord` with it.
        Returns the best (state, residual), whether it converged, the new linearization when
        the pose moved at most :data:`REUSE` since it (it then serves the pose: velocity, null
        space, next step) else None, and the sum of the corrections (N,)."""
        rs, err, norm = self.scaled(r)
        if err <= self.options.tol:
            return x, r, True, None, np.zeros(self.system.n_unknowns)
        e = self.correction(x, rs, anchor, linear, d)
        x1 = self.moved(x, e)
        ev = self.system.evaluate(x1, table, step, jacobian=True)
        self.iterations += 1
        scaled = self.scaled(ev.r)
        norm1 = scaled[2]
        if not norm1 < 0.5 * norm or not math.isfinite(norm1):
            return (x1, ev.r, False, None, e) if norm1 < norm else (x, r, False, None, 0.0 * e)
        linear = self.linearize(x1, table, step, ev)
        x, r, ok, more = self.chord(x1, ev.r, anchor, linear, table, step, scaled)
        return x, r, ok, linear if np.abs(more).max(initial=0.0) <= REUSE else None, e + more

    def levenberg_marquardt(self, x: State, r: np.ndarray, table: StepTable, step: int,
                            budget: int | None = None) -> tuple[State, np.ndarray, int, Evaluation]:
        """Levenberg–Marquardt with fresh Jacobians from x: (state, residual, status, evaluation
        with the Jacobian at the state). Damping λ·diag(JᵀJ) is raised on failure and lowered on
        success; the cost stalling above tol (or creeping near a stationary point:
        :data:`STATIONARY`) is INCONSISTENT, the iteration ``budget`` (default
        ``max_iterations``) running out NOT_CONVERGED."""
        opt = self.options
        lam, stalls, f = 1e-10, 0, float(np.sum((r * self.row) ** 2))
        ev = self.system.evaluate(x, table, step, jacobian=True)
        budget = self.iterations + (budget or opt.max_iterations)
        while self.iterations < budget:
            lin = self.normal.linearize(ev.jacobians(), scaled=True)
            diagonal = self.normal.diagonal(lin.data)
            top = max(float(diagonal.max()) if diagonal.size else 0.0, 1.0)
            floor = DAMPING * top
            g = lin.gradient(r * self.row)
            flat = math.sqrt(g @ g) <= STATIONARY * math.sqrt(top * f)
            while True:
                factor = self.normal.factor(lin.data, lam, floor)
                self.factorizations += 1
                x1 = self.moved(x, -factor.solve(g))
                ev1 = self.system.evaluate(x1, table, step, jacobian=True)
                self.iterations += 1
                f1 = float(np.sum((ev1.r * self.row) ** 2))
                if f1 < f:
                    break
                lam *= 10.0
                if lam > 1e10 or self.iterations >= budget:
                    return x, r, INCONSISTENT if lam > 1e10 else NOT_CONVERGED, ev
            # the cost stops decreasing above tol (or creeps, |Jᵀr| ≪ |J||r|: a least-squares
            # minimum where J is singular, such as a loop stretched straight that cannot close)
            stalls = stalls + 1 if f - f1 <= (CREEP if flat else 1e-9) * f else 0
            x, r, f, ev = x1, ev1.r, f1, ev1
            lam = max(lam / 10.0, 1e-12)
            if self.error(r) <= opt.tol:
                return x, r, CONVERGED, ev
            if stalls >= 3:
                return x, r, INCONSISTENT, ev
        return x, r, NOT_CONVERGED, ev

    def settle(self, x: State, r: np.ndarray, anchor: State, table: StepTable, step: int,
               known: Linear | Evaluation | None = None) -> tuple[State, np.ndarray, Linear]:
        """Linearize a converged pose (``known``: its linearization, or its evaluation with the
        Jacobian); where J has a null space, move the pose along it to the canonical pose
        (:meth:`canonical`), or, at a step with an input outside its window, remove the pose's
        change along it from the anchor (minimum change: what the input left free holds) with
        fresh Jacobians until below ``still_tol``."""
        opt = self.options
        if isinstance(known, Linear) and known.singular and self._key(table, step) not in self.structure:
            known = None  # taken off the constraints, where J's rank could not be told (:meth:`_free`)
        linear = known if isinstance(known, Linear) else self.linearize(x, table, step, known)
        if not table.partial[step]:
            return self.canonical(x, r, table, step, linear)
        for _ in range(8):
            if linear.null is None:
                break
            d = self.displacement(x, anchor)
            free = linear.null @ (linear.null.T @ d)
            if np.abs(free).max(initial=0.0) <= opt.still_tol:
                break
            done = self._corrected(self.moved(x, -free - linear.least_norm(r * self.row)), anchor, linear, table, step)
            if done is None:
                break  # best effort: the converged pose stands
            x, r, linear = done
        return x, r, linear

    def _corrected(self, x1: State, anchor: State | None, linear: Linear, table: StepTable,
                   step: int) -> tuple[State, np.ndarray, Linear] | None:
        """A pose moved off a converged one (along J's null space) brought back onto the
        constraints by chord steps (one iteration counted), with its residual and linearization;
        None where the correction fails."""
        r1 = self._residual(x1, table, step)
        self.iterations += 1
        x1, r1, ok, _ = self.chord(x1, r1, anchor, linear, table, step)
        if not ok:
            return None
        return x1, r1, self.linearize(x1, table, step)

    def canonical(self, x: State, r: np.ndarray, table: StepTable, step: int,
                  linear: Linear) -> tuple[State, np.ndarray, Linear]:
        """Move a converged pose along J's null space to the canonical pose (the one nearest
        :attr:`reference`, :mod:`linkedit.gcs.canonical`): Newton steps along it (the reduced
        Hessian taken at the first), each followed by least-norm corrections back onto the
        constraints, until the step is at most ``still_tol`` (that last one taken as it is)."""
        G = None
        for _ in range(canon.ITERATIONS):
            if linear.null is None:
                break
            null, d = linear.null[None], self.displacement(x, self.reference)[None]
            if G is None or G.shape[1] != null.shape[2]:
                G = canon.hessian(null, d, self._bend(x, table, step, linear, d[0])[None])
            e = canon.step(null, d, G)[0]
            if np.abs(e).max(initial=0.0) <= self.options.still_tol:
                # the last move needs no correction (the constraints change by |e|²) and leaves
                # the linearization as good as REUSE does
                x = self.moved(x, e)
                r = self._residual(x, table, step)
                break
            done = self._corrected(self.moved(x, e), None, linear, table, step)
            if done is None:
                break  # best effort: the converged pose stands
            x, r, linear = done
        return x, r, linear

    def pose(self, start: State, anchor: State, table: StepTable, step: int, linear: Linear | None = None,
             budget: int | None = None, d: np.ndarray | None = None
             ) -> tuple[State, np.ndarray, int, Linear | Evaluation | None, np.ndarray | None]:
        """Solve one time from ``start``, closest to ``anchor``: :meth:`newton` with ``linear``
        if given (``d``: the start's displacement from the anchor, when known), then
        Levenberg–Marquardt (``budget`` iterations). Returns (state, residual, status, what is
        known of the state's linearization: a Linear, an Evaluation or None, the sum of the
        corrections from ``start`` (N,) or None when Levenberg–Marquardt took it)."""
        r = self._residual(start, table, step)
        x = start
        toward = anchor if table.partial[step] else None  # free directions: canonical (settle)
        if linear is not None:
            x, r, ok, known, total = self.newton(start, r, toward, linear, table, step, d)
            if ok:
                return x, r, CONVERGED, known, total
        if self.error(r) <= self.options.tol:
            return x, r, CONVERGED, None, (None if x is not start else np.zeros(self.system.n_unknowns))
        return (*self.levenberg_marquardt(x, r, table, step, budget), None)

    def solve(self, start: State, table: StepTable, step: int) -> tuple[State, np.ndarray, StepResult]:
        """Solve one step of ``table`` from ``start`` (closest to it): (state, residual, StepResult)."""
        if self.options.solver == "slsqp-fd":
            return solve_slsqp(self, start, table, step)
        it0, f0 = self.iterations, self.factorizations
        x, r, status, known, _ = self.pose(start, start, table, step)
        if status == CONVERGED:
            x, r, _ = self.settle(x, r, start, table, step, known)
        return x, r, StepResult(status, self.iterations - it0, self.factorizations - f0)

    # ---- continuation -----------------------------------------------------------------------

    def first(self, anchor: State, table: StepTable, step: int) -> tuple[State, np.ndarray, int, Pose | None]:
        """Assemble at one step from ``anchor``: (state, residual, status, pose if converged)."""
        x, r, status, known, _ = self.pose(anchor, anchor, table, step)
        if status != CONVERGED:
            return x, r, status, None
        x, r, linear = self.settle(x, r, anchor, table, step, known)
        return x, r, status, Pose(float(table.t[step]), x, r, linear, self.velocity(x, table, step, linear))

    def advance(self, good: Pose, table: StepTable, step: int) -> tuple[State, np.ndarray, int, Pose | None, float]:
        """Continue from a solved pose to step ``step`` of ``table`` by accepted sub-steps
        (module docstring): (state, residual, status, pose if converged, time reached); where
        it fails, the best try at the step's own time (an infinite residual where the
        sub-steps never got to try it)."""
        opt = self.options
        t1 = float(table.t[step])
        span = t1 - good.t
        if span == 0.0:  # the same time again: the same pose
            return good.state, good.r, CONVERGED, good, t1
        here, anchor = good, good.state
        h = span
        # the best try at the step's own time (none yet: an infinite residual)
        best = (good.state, np.full_like(good.r, np.inf), NOT_CONVERGED)
        while True:  # h has the sign of the span: time may run either way
            if abs(h) > abs(t1 - here.t):
                h = t1 - here.t
            speed = float(np.abs(here.velocity).max(initial=0.0))
            if not accept.within_motion(speed, h, opt):
                h = math.copysign(opt.max_motion / speed, span)
            if abs(h) < opt.min_fraction * abs(span):
                return (*best, None, here.t)
            s = t1 if abs(h) >= abs(t1 - here.t) else here.t + h
            tab, k = (table, step) if s == t1 else (self.system.step_table(np.array([s])), 0)
            tangent = h * here.velocity
            second = tangent if here.trend is None else tangent + 0.5 * h * h * here.trend
            guess, g = here.extrapolated(s), second
            if guess is not None:
                g = self.displacement(guess, here.state)
            exact = guess is not None and here is good  # g: the guess's displacement from the anchor
            if guess is None or np.abs(g - second).max() >= opt.predictor_tol:
                guess, g, exact = self.moved(here.state, second), second, False
            x, r, status, known, total = self.pose(guess, anchor, tab, k, here.linear, SUBSTEP_ITERATIONS,
                                                   g if exact else None)
            # the pose's displacement from here: the prediction's and the corrections' (to first
            # order in the corrections, ample for the test), or taken afresh after LM
            moved = g + total if total is not None else self.displacement(x, here.state)
            near = status == CONVERGED and bool(accept.near(moved, tangent, opt))
            if not near:
                if s == t1 and np.sum(r * r) < np.sum(best[1] * best[1]):
                    best = (x, r, status if status != CONVERGED else NOT_CONVERGED)
                h *= 0.5
                continue
            x, r, linear = self.settle(x, r, anchor, tab, k, known)
            incoming = here.velocity if here.trend is None else here.velocity + h * here.trend
            here = here.followed_by(s, x, r, linear, self.velocity(x, tab, k, linear, incoming))
            if s == t1:
                return x, r, CONVERGED, here, s
            h *= 2.0



def solve_slsqp(solver: Solver, start: State, table: StepTable, step: int) -> tuple[State, np.ndarray, StepResult]:
    """The paper's method: SLSQP on the summed scaled cost Σ|r|², 2-point finite-difference gradients."""
    from scipy.optimize import minimize

    system = solver.system

    def cost(z: np.ndarray) -> float:
        r = system.evaluate(solver.moved(start, z), table, step).r * solver.row
        return float(r @ r)

    out = minimize(cost, np.zeros(system.n_unknowns), method="SLSQP",
                   options={"maxiter": 1000, "ftol": 1e-16})
    x = solver.moved(start, out.x)
    r = system.evaluate(x, table, step).r
    err = solver.error(r)
    if not out.success:
        status = NOT_CONVERGED
    else:
        status = CONVERGED if err <= SLSQP_TOL else INCONSISTENT
    return x, r, StepResult(status, int(out.nit), 0)
