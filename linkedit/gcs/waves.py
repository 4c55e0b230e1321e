"""Many time steps solved at once, each kept only where the step-by-step continuation would
have accepted it.

The continuation of :mod:`linkedit.gcs.continuation` pays Python's per-call cost at every step.
Where the scaled Jacobian has full column rank (nothing free to keep still), the pose at a
time is the root of the constraints nearest its prediction whatever the anchor, so a *block*
of steps can be solved together:

1. every few steps first (:data:`STRIDE`, adapted to the prediction error, up to
   :data:`WIDEST_STRIDE`), roughly, in *waves* of up to :data:`WIDEST` steps: each predicted
   by the osculating polynomial through the last :data:`NODES` such poses and their
   velocities (within ~1e-9 of the size one stride ahead), then :data:`CORRECTIONS`
   Gauss–Newton steps for all of them at once (the error after each about the square of the
   one before: ~1e-10 of the size or better), and the velocity from the last linearization —
   leaving out the parts of J that stay still (:class:`Compiled`: a planar linkage's
   out-of-plane unknowns, whose rows and time derivatives are zero to rounding) and the
   constraint groups that are theirs alone (a planar linkage's axis alignments): step 3
   checks every row and pivot;
2. then all the steps of the block at once: the rough ones from where they are, the ones
   between from the osculating polynomial through the rough poses around them (typically
   within 1e-10 of the size);
3. Gauss–Newton on all of them as array operations to convergence
   (:mod:`linkedit.gcs.gauss_newton`): the elementary kinds'
   kernels of :data:`linkedit.gcs.kernels.EVALUATE` run on B times their constraints, the
   scaled Jacobians are placed straight from the kernels' arrays into dense blocks
   (B × rows × unknowns, one per diagonal block of J where it decouples, as a planar
   linkage's in-plane and out-of-plane unknowns do) and factorized by a batched Cholesky; a
   factorization is kept while it contracts the residual (chord) and serves the exact
   velocity (J v = −∂r/∂t at the solved pose): as is where it is of that pose, by iterative
   refinement where the pose moved little since;
4. each step is put to the continuation's own acceptance test, taken from the step before it:
   converged (largest scaled residual row ≤ ``tol``), no small pivot, J zero off its blocks
   (to :data:`TIED`) at the solved pose, within
   ``predictor_tol`` of the tangent prediction x_{k−1} ⊕ h·v_{k−1} and moving at most
   ``max_motion``. The accepted run of steps is kept — the poses the continuation accepts (the
   same branch, equal to rounding) — and the continuation solves the first rejected step
   (sub-steps, Levenberg–Marquardt), after which blocks resume (:data:`SHORTEST` steps,
   doubling).

**Closed-form predictions.** Where every member of the system is rebuilt in closed form from
placed ones (:mod:`linkedit.gcs.closed_form`: a crank set by its input, revolute dyads about
parallel axes — planar linkages, in any plane — and links pinned between placed members) and
the rebuilt pose reproduces the solved one before the block (:meth:`ClosedForm.sides`), steps 1
and 2 are replaced by the closed form's poses (exact to rounding: most converge at their first
evaluation), in chunks, each up to the first step it cannot rebuild (a dyad that cannot close)
or that the poses show would fail the acceptance test (:func:`~linkedit.gcs.rebuild.screened`: left to the
continuation, not solved in vain); steps 3 and 4 are as above, so a closed form that misleads
costs time, never a result. Where J has a free direction, a link's spin placed at its canonical
pose (the RSSR's coupler), the rebuilt poses are checked as they are, with one evaluation and
factorization each (:func:`~linkedit.gcs.rebuild.canonical_as_is`).

**A free direction** (one passive degree of freedom: J has rank N − 1, such as an RSSR
coupler's idle spin): the corrections are least norm (nothing along J's null vector, taken by
inverse iteration as the continuation does), and the steps are moved along their null vectors
to their canonical pose, the one nearest the rest pose (:func:`~linkedit.gcs.free.canonical`: the
continuation's Newton step of :mod:`linkedit.gcs.canonical`, for all of them at once, then
solved again: converging quadratically over a few passes), with its velocity the canonical
pose's tangent; the acceptance test adds that the last move is at most ``still_tol``. The rough
steps are moved there by one Newton step, and the polynomials go through poses only (a rough
pose's velocity is taken before that move).

What this needs beyond the system — J's diagonal blocks and the parts that stay still (found
before the first wave from :data:`~linkedit.gcs.structure.SPLIT_FROM` poses along the tangent
of the last solved one, :meth:`Waves._survey`, or else from the first batch of as many), where each Jacobian entry
goes, the layouts per batch size — is built at a system's first run and kept on it for the
later ones in the caller's :class:`~linkedit.gcs.structure.StructureCache`, as the system itself is compiled once. They are guesses
that cost time only when wrong (every solved step is checked on every row and pivot, and on J
zero off its blocks) and they correct themselves: blocks that a run's solved poses tie
(entries off them beyond rounding, :data:`TIED`) are merged from its next block on, and still
parts whose rows a block's poses do not satisfy (an input held when they were found moves)
are still no longer. The rough steps' predictions hold the still parts where they are:
extrapolation from the last pose keeps equal coordinates exact, and where the poses before
differ there by rounding (steps solved step by step) they are held explicitly
(:meth:`Waves._held`), or the extrapolation would amplify it wave after wave.

Steps with an input outside its window, systems with custom constraints and more free
directions go step by step (a run's accelerations are batched after it:
:mod:`linkedit.gcs.accelerations`); so do systems with the sparse
factorization (above 120 unknowns) unless the closed form rebuilds them: their rebuilt poses
are then evaluated together and each factorized as the continuation's step is
(:func:`~linkedit.gcs.rebuild.verify`), instead of step 3.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from linkedit.gcs import accept
from linkedit.gcs.continuation import Solver
from linkedit.gcs.evaluate import KEPT_POSES, _Layout
from linkedit.gcs.free import canonical
from linkedit.gcs.gauss_newton import BatchedGaussNewton
from linkedit.gcs.predict import NODES, Extrapolation, flat, lagrange
from linkedit.gcs.rebuild import canonical_as_is, screened, verify
from linkedit.gcs.structure import STRIDE, WIDEST_STRIDE, Compiled, Part, StructureCache
from linkedit.gcs.system import StepTable

#: steps of a block after a rejected step (doubling after each block accepted whole); the
#: first block is the whole run
SHORTEST = 16
#: steps of the widest wave
WIDEST = 16
#: Gauss–Newton steps of a wave's rough poses, and the largest last one (scaled) for a pose to
#: be predicted from
CORRECTIONS = 2
ROUGH = 1e-4
#: passes moving the poses to their canonical pose along a free direction (:func:`~linkedit.gcs.free.canonical`)
CANONICAL_PASSES = 4
#: the largest prediction error (scaled) a wave's width aims for, and the first prediction
#: error of a wave below which the spacing doubles and above which it halves; where J has a
#: free direction (predictions from poses only, rough poses kept whatever their first error) the
#: second ones
REACH, LOW, HIGH = 1e-4, 1e-9, 1e-6
REACH_FREE, LOW_FREE, HIGH_FREE = 1e-1, 1e-7, 1e-4
#: ... where J has a free direction: poses only, for the polynomial through them (a rough
#: pose's velocity is taken before its move to the canonical pose)
VALUES = 6
#: converged steps a block starts from (one where the closed form predicts: :meth:`Waves.start`)
START = 2
#: the chunks of a sparse system's closed-form poses (:meth:`Waves.rebuilt`): its evaluation's
#: arrays take ~0.3 MB per pose for 726 unknowns
CHUNK = 256


@dataclasses.dataclass
class Solved:
    """A block's result for B steps: positions (B, M, 3), quaternions (B, M, 4), residuals
    (B, R), scaled velocities (B, N), linear solves and factorizations (B, 2), and how many
    steps, from the first, pass the continuation's acceptance test (``accepted``)."""

    position: np.ndarray
    orientation: np.ndarray
    residual: np.ndarray
    velocity: np.ndarray
    work: np.ndarray
    accepted: int
    #: the rank of J at each step where it was read pose by pose (:func:`~linkedit.gcs.rebuild.verify`), else
    #: None (full column rank less the free directions)
    rank: np.ndarray | None = None


class Waves(Extrapolation, BatchedGaussNewton):
    """Batched evaluation and solution of one system over a step table (module docstring)."""

    def __init__(self, solver: Solver, table: StepTable, cache: StructureCache) -> None:
        self.solver = solver
        self.system = solver.system
        self.table = table
        #: the caller's cache: what earlier runs compiled, and where this run leaves a copy of its own
        self.cache = cache
        kept = cache.waves
        self.compiled = kept.copy() if kept is not None else Compiled([self._whole()], closed=cache.closed_form())
        #: the closed form predicting this run's poses (None: the waves' own predictions)
        self.closed = self.compiled.closed
        #: layouts of more poses than the cache keeps, for this run
        self._layouts: dict[int, _Layout] = {}
        self._kept_layouts = self.compiled.layouts
        #: pairs of blocks (K, 2) that Jacobian entries of this run's poses tied: merged before
        #: the next block
        self.tied = np.zeros((0, 2), dtype=int)
        #: free directions of J at every pose (0, or 1: a passive degree of freedom, canonical)
        self.free = 0

    def _whole(self) -> Part:
        s = self.system
        return Part(np.arange(s.n_rows), np.arange(s.n_unknowns))

    @staticmethod
    def applies(solver: Solver, cache: StructureCache) -> bool:
        """Whether the system's structure allows waves (see the module docstring; the rank is
        checked at the first pose by the caller)."""
        o, s, normal = solver.options, solver.system, solver.normal
        return (o.solver == "lm" and not s.customs
                and (normal.unique_entries if not normal.sparse else cache.closed_form() is not None))

    def start(self) -> int:
        """The converged steps a block starts from: one where the closed form predicts its
        steps (it reads its branch from the pose before them and needs no curve through
        earlier ones: :meth:`rebuilt`), else :data:`START`."""
        closed = self.closed is not None and (self.solver.normal.sparse or not self.free or self.closed.spins)
        return 1 if closed else START

    def _none(self) -> Solved:
        """A block that solved no step."""
        M, R, N = self.system.n_members, self.system.n_rows, self.system.n_unknowns
        return Solved(np.zeros((0, M, 3)), np.zeros((0, M, 4)), np.zeros((0, R)), np.zeros((0, N)),
                      np.zeros((0, 2), dtype=np.int32), 0)

    # ---- a block of steps -----------------------------------------------------------------

    def block(self, k: int, stop: int, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray, first: int) -> Solved:
        """Solve the steps k … stop − 1 given the accepted ones before k (positions (T, M, 3),
        quaternions (T, M, 4), real velocities (T, M, 6) of the run, converged from step
        ``first`` on, k − first ≥ :meth:`start`): steps about :data:`STRIDE` apart (and the
        last) first, roughly (:meth:`correct`), in waves from the osculating polynomial through
        the poses before them (where J has a free direction, the polynomial through
        :data:`VALUES` poses); then all of them at once, the steps between from the polynomial
        through the poses around them, and where J has a free direction, passes moving them to
        their canonical pose  (:func:`~linkedit.gcs.free.canonical`, converging quadratically: at most
        :data:`CANONICAL_PASSES`); then the continuation's acceptance test."""
        col, M = self.solver.col, self.system.n_members
        if self.solver.normal.sparse:  # the closed form's poses, or none
            rebuilt = self.rebuilt(k, stop, pos, ori, vel) if self.closed is not None else None
            return rebuilt or self._none()
        if self.tied.size:  # the blocks kept in the cache do not hold for this run's poses
            self._merge()
        if not self.compiled.decided and not self.free and np.abs(vel[k - 1]).max() > 0.0:
            self._survey(pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col, k - 1)
        if self.closed is not None and (not self.free or self.closed.spins):
            rebuilt = self.rebuilt(k, stop, pos, ori, vel)
            if rebuilt is not None:
                return rebuilt
        if k - first < START:  # too few poses before to predict from
            return self._none()
        t = self.table.t
        coarse: list[np.ndarray] = []
        rough: list[tuple[np.ndarray, np.ndarray]] = []
        # where J has a free direction, the poses only (the rough poses' velocities are not
        # quite their canonical motion's: taken before their last move along it)
        count = VALUES if self.free else NODES
        prior = np.unique(np.clip(k - 1 - STRIDE * np.arange(count), first, None))
        node_t = list(t[prior])
        v = vel[prior]
        # the rough steps leave what stays still as predicted: predictions must not move it —
        # by the rounding of the velocities before, or of the poses before (amplified by the
        # extrapolation, wave after wave), where they are not exact (steps solved step by step)
        hold = False
        if self._moving():
            still = self._still_cols()
            P0, Q0 = (np.broadcast_to(x[prior[-1]], x[prior].shape) for x in (pos, ori))
            hold = bool(self.displacement(pos[prior], ori[prior], P0, Q0)[:, still].any())
            v = v.copy()
            v.reshape(len(prior), -1)[:, still] = 0.0
        z, dz = flat(pos[prior], ori[prior], v)
        node_z, node_dz = list(z), list(dz)
        reach, low, high = (REACH_FREE, LOW_FREE, HIGH_FREE) if self.free else (REACH, LOW, HIGH)
        here, stride, width = k - 1, STRIDE, 1 if len(prior) < count else 4
        while here < stop - 1:
            ahead = np.unique(np.minimum(here + stride * np.arange(1, width + 1), stop - 1))
            if 0 < stop - 1 - ahead[-1] <= stride // 2:  # the block's last step, within half a stride: now
                ahead = np.append(ahead, stop - 1)
            if self.free:
                P, Q = self._split(lagrange(np.array(node_t[-count:]), np.array(node_z[-count:]),
                                            np.zeros(len(ahead), dtype=int), t[ahead], count))
            else:
                P, Q = self.extrapolated(np.array(node_t[-count:]), np.array(node_z[-count:]),
                                         np.array(node_dz[-count:]), t[ahead])
            if hold:
                last = self._split(node_z[-1][None])
                P, Q = self._held(P, Q, last[0][0], last[1][0])
            v, error, good = self.correct(P, Q, ahead)
            n = int(np.argmin(good)) if not good.all() else len(ahead)
            if n == 0:
                if len(ahead) == 1 and stride == 1:
                    break  # the block ends here
                stride, width = max(1, stride // 2), 1
                continue
            coarse.append(ahead[:n])
            rough.append((P[:n], Q[:n]))
            node_t += list(t[ahead[:n]])
            z, dz = flat(P[:n], Q[:n], (v[:n] * col).reshape(n, M, 6))
            node_z += list(z)
            node_dz += list(dz)
            here = int(ahead[n - 1])
            # the spacing keeps the first prediction's error between low and high (of the size)
            if error > high:
                stride = max(1, stride // 2)
            elif error < low:
                stride = min(2 * stride, WIDEST_STRIDE)
            # as many steps as the extrapolation reaches within ``reach`` of the size (its error
            # grows about as the fifth power of the distance)
            far = (reach / max(error, 1e-16)) ** 0.2 * (1 if error > high else 0.5 if error < low else 1)
            width = int(np.clip(far, 1, WIDEST))
        if not coarse:
            self.cache.waves = self.compiled.copy()
            return self._none()
        at = np.concatenate(coarse) - k
        steps = np.arange(k, k + int(at[-1]) + 1)
        B = steps.size
        P, Q = np.empty((B, M, 3)), np.empty((B, M, 4))
        P[at], Q[at] = np.concatenate([x[0] for x in rough]), np.concatenate([x[1] for x in rough])
        fine = np.setdiff1d(np.arange(B), at)
        if fine.size:
            # each from the osculating polynomial through the NODES poses around it
            nt, nz, ndz = np.array(node_t), np.array(node_z), np.array(node_dz)
            right = np.searchsorted(nt, t[k + fine])  # the node after each fine step
            around = np.clip(right - count // 2, 0, max(len(nt) - count, 0))
            if self.free:
                P[fine], Q[fine] = self._split(lagrange(nt, nz, around, t[k + fine], count))
            else:
                P[fine], Q[fine] = self.osculating(nt, nz, ndz, around, t[k + fine])
        R, V, work, ok, null = self.solve(P, Q, steps)
        work[at] += CORRECTIONS  # the rough corrections: a linear solve and a factorization each
        for i in range(CANONICAL_PASSES if self.free else 0):
            # the free direction moved to the canonical pose, then solved again there (until
            # the move is at most still_tol; the velocities the canonical pose's tangent)
            V, move = canonical(self, P, Q, V, steps)
            if np.abs(move).max() <= self.solver.options.still_tol or i == CANONICAL_PASSES - 1:
                # the last moves need no correction (the constraints change by |move|²)
                last = np.abs(move).max(axis=1) <= self.solver.options.still_tol
                P[:], Q[:] = self.moved(P, Q, move * last[:, None])
                R[last] = self.evaluate(P[last], Q[last], steps[last], False)[0]
                ok &= last
                break
            P[:], Q[:] = self.moved(P, Q, move)
            R, V, again, ok, null = self.solve(P, Q, steps)
            work += again
        before = (pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col)
        n = self.accepted(P, Q, V, ok, steps, before, float(t[k - 1]))
        self.cache.waves = self.compiled.copy()  # for later runs (Compiled)
        return Solved(P, Q, R, V, work, n)

    def rebuilt(self, k: int, stop: int, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray) -> Solved | None:
        """Solve the steps k … stop − 1 as :meth:`block` does, from the closed form's poses
        (:mod:`linkedit.gcs.closed_form`: exact to rounding, so most steps converge at once), in
        chunks (a dense system's of :data:`KEPT_POSES` steps; a sparse one's, each pose
        factorized, of :data:`CHUNK`)
        up to the first step it cannot rebuild, that fails the acceptance test, or that clearly
        would (:func:`~linkedit.gcs.rebuild.screened`: no pose is solved in vain); None where it solves none — or
        does not reproduce the solved pose k − 1 (:meth:`ClosedForm.sides`): its rules do not
        hold for this mechanism (this run's later blocks and the system's later runs go
        without it)."""
        closed, col, t = self.closed, self.solver.col, self.table.t
        assert closed is not None
        signs = closed.sides(pos[k - 1], ori[k - 1], self.table, k - 1, self.solver.reference)
        if signs is None:
            self.closed = self.compiled.closed = None
            return None
        sparse = self.solver.normal.sparse
        before = (pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col)
        t_before = float(t[k - 1])
        chunk, here = CHUNK if sparse else KEPT_POSES, k
        kept: list[tuple[np.ndarray, ...]] = []
        ranks: list[np.ndarray] = []
        while here < stop:
            steps = np.arange(here, min(stop, here + chunk))
            P, Q, valid = closed.poses(self.table, steps, before[1], signs, self.solver.reference)
            n = screened(self, P, Q, valid, steps, before, t_before)
            if n == 0:
                break
            steps, P, Q = steps[:n], P[:n], Q[:n]
            if sparse:
                R, V, work, ok, rank = verify(self, P, Q, steps, before[2])
            elif self.free:  # a link's spin: the canonical pose, checked as it is
                R, V, work, ok = canonical_as_is(self, closed, P, Q, steps)
            else:
                R, V, work, ok, _ = self.solve(P, Q, steps)
            a = self.accepted(P, Q, V, ok, steps, before, t_before)
            kept.append((P[:a], Q[:a], R[:a], V[:a], work[:a]))
            if sparse:
                ranks.append(rank[:a])
            if a < len(valid):
                break
            before, t_before, here = (P[-1], Q[-1], V[-1]), float(t[steps[-1]]), int(steps[-1]) + 1
        if not kept:
            return None
        self.cache.waves = self.compiled.copy()  # for later runs (Compiled)
        P, Q, R, V, work = (np.concatenate([part[i] for part in kept]) for i in range(5))
        return Solved(P, Q, R, V, work, len(P), np.concatenate(ranks) if sparse else None)

    def correct(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """Rough poses at the table's ``steps`` (B,) from predictions P (B, M, 3), Q (B, M, 4)
        (moved in place), good enough to predict from: :data:`CORRECTIONS` least-norm
        Gauss–Newton steps (the error after each about the square of the one before); where J
        has a free direction, then one Newton step along it towards the canonical pose
         (:func:`~linkedit.gcs.free.canonical`, with the last linearization). Returns the scaled velocities (B, N)
        at the last linearization (exact to about the size of the last correction), the first
        pose's prediction error (its first correction, or its move along the free direction),
        and which poses are good (B,): a sound factorization (:meth:`_factor`) and a last
        correction (or the square of that move: what it leaves) of at most :data:`ROUGH`."""
        row, c = self.solver.row, self.compiled
        # rough poses need not move what stays still (the block's solve checks all of it)
        moving = self._moving()
        quick = bool(moving)
        error = np.inf
        for i in range(CORRECTIONS):
            r, jacs = self.evaluate(P, Q, steps, True, c.skip if quick else ())
            J = self.jacobian(jacs)
            if quick:
                J = J.only(moving)
            F = self._factor(J)
            step = -self.least_norm(F, self._gradient(J, r * row))
            size = np.abs(step).max(axis=1)
            error = float(size[0]) if i == 0 else error
            if i == CORRECTIONS - 1:
                rt = self.time_derivative(Q, steps, jacs)
            P[:], Q[:] = self.moved(P, Q, step)
        velocity = self.least_norm(F, self._gradient(J, -rt * row))
        if F.null is not None:  # along the free direction, the canonical pose and its tangent
            velocity, move = canonical(self, P, Q, velocity, steps, (J, F))
            P[:], Q[:] = self.moved(P, Q, move)
            # the prediction's error along it; a Newton move leaves about its square
            along = np.abs(move).max(axis=1)
            error = max(error, float(along[0]))
            size = np.maximum(size, along * along)
        return velocity, error, F.sound & (size <= ROUGH)

    def accepted(self, P: np.ndarray, Q: np.ndarray, velocity: np.ndarray, done: np.ndarray,
                 steps: np.ndarray, before: tuple[np.ndarray, np.ndarray, np.ndarray], t_before: float) -> int:
        """How many of the consecutive ``steps`` (B,), solved (P, Q, scaled velocities,
        ``done``: converged, and where J has a free direction at the canonical pose), pass the
        continuation's acceptance test, each from the step before it; the first from ``before``
        (position (M, 3), quaternions (M, 4), scaled velocity (N,)) at ``t_before``."""
        opt = self.solver.options
        P0 = np.concatenate([before[0][None], P[:-1]])
        Q0 = np.concatenate([before[1][None], Q[:-1]])
        v0 = np.concatenate([before[2][None], velocity[:-1]])
        h = np.diff(np.concatenate([[t_before], self.table.t[steps]]))
        moved = self.displacement(P, Q, P0, Q0)
        return accept.leading(done & accept.passes(moved, h, v0, opt))


