"""Solve a compiled system at every time step (:func:`solve_run`): the driver of the two
schedulers over one core — the step-by-step continuation (:mod:`linkedit.gcs.continuation`)
and the waves (:mod:`linkedit.gcs.waves`) — with its statuses and options from
:mod:`linkedit.gcs.tolerances`.

**Waves.** Where J has full column rank or one free direction, :func:`solve_run` solves many
steps at once (:mod:`linkedit.gcs.waves`) and keeps each only where the step-by-step
acceptance test above, taken from the step before it, passes: the same poses (the same branch),
far fewer Python calls. The first rejected step is solved by the continuation, which the waves
then resume from. Waves begin at the first pose with every input active (where J's free
directions are read), and stop at every input keyframe (the input's rate jumps there); none
starts where the last two velocities show that the next step's second-order move takes half
the acceptance test's bound (steps that coarse are sub-stepped by the continuation). Where the
closed form predicts the steps (:meth:`Waves.start`), they may start right after the first
pose (its branch read there, its poses screened by the acceptance test before they are
solved); a try there that keeps none leaves the schedule as it was.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from linkedit.blas import single_threaded
from linkedit.gcs.accept import curving, within_motion
from linkedit.gcs.accelerations import run_accelerations
from linkedit.gcs.continuation import ARRIVED, Solver
from linkedit.gcs.predict import PREDICT_ORDER, Pose
from linkedit.gcs.structure import StructureCache
from linkedit.gcs.system import State, StepTable, System
from linkedit.gcs.tolerances import CONVERGED, NOT_CONVERGED, Options
from linkedit.gcs.waves import SHORTEST, START, Waves


@dataclass
class Run:
    """Member states, velocities and per-step diagnostics over T steps."""

    t: np.ndarray  #: (T,)
    position: np.ndarray  #: (T, M, 3)
    orientation: np.ndarray  #: (T, M, 4)
    velocity: np.ndarray  #: (T, M, 6): d position / dt and world angular velocity
    acceleration: np.ndarray | None  #: (T, M, 6): d² position / dt² and world angular acceleration (None: not asked)
    residual: np.ndarray  #: (T, R) residual vector at each solved step
    status: np.ndarray  #: (T,) int8: 0 converged, 1 inconsistent, 2 did not converge
    iterations: np.ndarray  #: (T,) linear solves
    factorizations: np.ndarray  #: (T,)
    #: (T,) time up to which a failed step's continuation got (t of the step when converged)
    reached: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: (T,) rank of the scaled Jacobian at each converged step, read from its factorization;
    #: −1 where the factorization cannot tell (or the step failed)
    rank: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    #: (T,) bool: the step was solved in a wave (:mod:`linkedit.gcs.waves`), not step by step
    batched: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def state(self, step: int) -> State:
        return State(self.position[step], self.orientation[step])

    def take(self, steps: np.ndarray) -> "Run":
        """The run at some of its steps (indices (T',))."""
        return Run(t=self.t[steps], position=self.position[steps], orientation=self.orientation[steps],
                   velocity=self.velocity[steps],
                   acceleration=None if self.acceleration is None else self.acceleration[steps],
                   residual=self.residual[steps], status=self.status[steps], iterations=self.iterations[steps],
                   factorizations=self.factorizations[steps], reached=self.reached[steps], rank=self.rank[steps],
                   batched=self.batched[steps])


def solve_run(system: System, t: np.ndarray, options: Options | None = None, start: State | None = None,
              table: StepTable | None = None, progress: Callable[[int, int], None] | None = None,
              cache: StructureCache | None = None) -> Run:
    """Solve every time step of ``t`` (T,) by continuation from the first (module docstring),
    many steps at once where :mod:`linkedit.gcs.waves` applies (the same poses), BLAS on one
    thread (:mod:`linkedit.blas`); ``progress(k, T)`` is called after each step. The system is
    left as it was; what the waves compile for it is kept in ``cache`` (the caller's, for its
    later runs of this system; a fresh one when None). An input window's edge between two
    steps is solved too; its failure is returned (:func:`_requested`), never dropped."""
    t = np.asarray(t, dtype=float)
    if cache is None:
        cache = StructureCache(system)
    elif cache.system is not system:
        raise ValueError("the structure cache belongs to another system")
    # an input's window ending between two steps is solved at its edge too (not returned unless
    # it failed: _requested): the member it leaves holds the input's last value there, whatever the steps
    edges = np.unique([e for blk in system.blocks for sc in blk.schedules for e in sc.window
                       if t.size and min(t[0], t[-1]) < e < max(t[0], t[-1])])
    edges = edges[~np.isin(edges, t)]
    if edges.size == 0 or not ((np.diff(t) > 0).all() or (np.diff(t) < 0).all()):
        with single_threaded():
            return _solve_run(system, t, options, start, table, progress, cache)
    full = np.sort(np.concatenate([t, edges]))
    full = full if t[-1] > t[0] else full[::-1]
    keep = np.flatnonzero(np.isin(full, t))
    where = {int(k): i for i, k in enumerate(keep)}
    told = None if progress is None else (lambda k, T: progress(where[k], t.size) if k in where else None)
    with single_threaded():
        run = _solve_run(system, full, options, start, None, told, cache)
    return _requested(run, keep)


def _requested(run: Run, keep: np.ndarray) -> Run:
    """The run at its requested steps ``keep`` (ascending indices into ``run``, whose other
    steps are input-window edges), with the edges' failures in sight: a requested step after an
    edge that failed did not converge (the continuation to it went through the edge; its pose
    is a restart's, not one holding the edge's), and an edge where the run stopped at failure
    is its last step, at its own time."""
    kept = keep[keep < run.t.size]
    failed = np.setdiff1d(np.flatnonzero(run.status != CONVERGED), kept)  # failed edges, ascending
    after = np.searchsorted(kept, failed)  # each one's requested step after it (kept.size: none solved)
    out = run.take(np.append(kept, failed[after == kept.size]))
    late = np.unique(after[after < kept.size])
    late = late[out.status[late] == CONVERGED]
    out.status[late], out.rank[late] = NOT_CONVERGED, -1
    return out


def _solve_run(system: System, t: np.ndarray, options: Options | None, start: State | None,
               table: StepTable | None, progress: Callable[[int, int], None] | None, cache: StructureCache) -> Run:
    options = options or Options()
    t = np.asarray(t, dtype=float)
    table = table or system.step_table(t)
    solver = Solver(system, options)
    T, M = t.size, system.n_members
    pos, ori = np.empty((T, M, 3)), np.empty((T, M, 4))
    vel = np.zeros((T, M, 6))
    res = np.empty((T, system.n_rows))
    status = np.empty(T, dtype=np.int8)
    iters, facts = np.zeros(T, dtype=np.int32), np.zeros(T, dtype=np.int32)
    reached = t.copy()
    rank = np.full(T, -1)
    good: Pose | None = None
    stuck = False  # the continuation from ``good`` failed once: it would fail again at the same place
    rest = (start or system.rest).copy()
    solver.reference = rest
    # waves predict from the times of solved steps: they need them distinct, in one direction
    monotone = bool((np.diff(t) > 0).all() or (np.diff(t) < 0).all())
    waved = options.waves and monotone
    # the batched evaluator: the waves' scheduler, and the accelerations' (after the run)
    batch = Waves(solver, table, cache) if (waved or options.accelerations) and Waves.applies(solver, cache) else None
    waves = batch if waved else None
    solved = np.zeros(T, dtype=bool)  # a pose (and its velocity) at each step
    batched = np.zeros(T, dtype=bool)
    classified = False  # whether J's free directions at a pose with every input active were read
    streak = 0  #: the first of the converged steps just before k
    resting, pause = 0, SHORTEST  #: no wave before step ``resting``; the next pause after a wave accepted none
    width = T
    #: steps k0..k solved by waves and accepted since the last step-by-step pose ``good`` (−1: none)
    wave_from = -1

    def resume(k: int) -> Pose:
        """The continuation's pose at step k, solved by a wave (its factorization and history)."""
        x = State(pos[k].copy(), ori[k].copy())
        linear = solver.linearize(x, table, k)
        lo = max(0, k - PREDICT_ORDER)
        ts = t[lo:k + 1]
        Z = np.concatenate([pos[lo:k + 1].reshape(k + 1 - lo, -1), ori[lo:k + 1].reshape(k + 1 - lo, -1)], axis=1)
        v = vel[k].ravel() / solver.col
        trend = (v - vel[k - 1].ravel() / solver.col) / (t[k] - t[k - 1]) if k > 0 else None
        return Pose(float(t[k]), x, res[k].copy(), linear, v, trend, (ts, Z))

    k = 0
    # the inputs' keyframes inside their windows: their rates jump there, so the poses' motion
    # is smooth only between them; waves neither predict nor interpolate across one
    keys = np.unique([float(x) for blk in system.blocks for sc in blk.schedules for x in sc.times[1:-1]])
    piece = np.searchsorted(keys, t, side="right")
    starts = np.concatenate([[0], np.flatnonzero(np.diff(piece)) + 1])
    piece_start = starts[np.searchsorted(starts, np.arange(T), side="right") - 1]  # (T,) first step of each one's piece
    while k < T:
        since = max(streak, int(piece_start[k]))  # the converged steps just before k on k's piece
        early = waves is not None and k - since < START  # after one step: the closed form's waves only
        if waves is not None and classified and k - since >= waves.start() and k >= resting and not table.partial[k] \
                and within_motion(np.abs(vel[k - 1].ravel() / solver.col).max(), t[k] - t[k - 1], options) \
                and (early or curving(t, vel, k, solver.col) <= 0.5 * options.predictor_tol):
            # many steps at once from the accepted ones before them (not where the first of them
            # would move or turn too far for the acceptance test, nor for a while after a wave that
            # accepted none), up to the next keyframe or input window's edge
            stop = min(T, k + width)
            edge = np.flatnonzero(table.partial[k:stop] | (piece[k:stop] != piece[k]))
            stop = k + int(edge[0]) if edge.size else stop
            wave = waves.block(k, stop, pos, ori, vel, since)
            n = wave.accepted
            if n:
                done = np.arange(k, k + n)
                pos[done], ori[done], res[done] = wave.position[:n], wave.orientation[:n], wave.residual[:n]
                vel[done] = (wave.velocity[:n] * solver.col).reshape(n, M, 6)
                status[done], batched[done], solved[done] = CONVERGED, True, True
                rank[done] = system.n_unknowns - waves.free if wave.rank is None else wave.rank[:n]
                iters[done], facts[done] = wave.work[:n, 0], wave.work[:n, 1]
                wave_from = k if wave_from < 0 else wave_from
                if progress is not None:
                    for j in done:
                        progress(int(j), T)
                k += n
                width = 2 * width if k == stop else SHORTEST
                pause = SHORTEST
                continue
            if not early:  # (an early try that fails leaves the waves' schedule as it was)
                width = SHORTEST
                resting, pause = k + pause, 2 * pause
        if wave_from >= 0:  # step by step again, from the last pose a wave accepted
            good, stuck, wave_from = resume(k - 1), False, -1
        it0, f0 = solver.iterations, solver.factorizations
        if options.solver == "slsqp-fd":
            x, r, info = solver.solve(good.state if good else rest, table, k)
            st, pose = info.status, None
            if st == CONVERGED:
                linear = solver.linearize(x, table, k)
                pose = Pose(t[k], x, r, linear, solver.velocity(x, table, k, linear))
        elif good is None:
            x, r, st, pose = solver.first(rest, table, k)
        else:
            pose, tried = None, not stuck
            if tried:
                x, r, st, pose, reached[k] = solver.advance(good, table, k)
                stuck = pose is None
            else:
                reached[k] = reached[k - 1]
            if pose is None:  # continuation failed: solve directly from the last good pose
                x2, r2, st2, pose = solver.first(good.state, table, k)
                if pose is not None or not tried or r2 @ r2 < r @ r:
                    x, r = x2, r2
                # why it fails is told from the last good pose directly, whatever way the
                # sub-steps went there (a run through waves reaches it by another one)
                st = st2
                if pose is not None and tried and abs(t[k] - reached[k]) > ARRIVED * abs(t[k] - good.t):
                    # a pose, but the continuation stopped short of it from the step before (a
                    # lock-up or a singular pose between them): not that step's assembly branch
                    # (after a failed step, the next one restarts from the last good pose)
                    st, pose = NOT_CONVERGED, None
                elif pose is not None:
                    reached[k] = t[k]
        if pose is not None and batch is not None and not classified and not table.partial[k]:
            # what waves keep still is read at the first pose with every input active
            classified, null = True, pose.linear.null
            if null is not None and null.shape[1] == 1 and pose.linear.rank == system.n_unknowns - 1:
                batch.free = 1  # one free direction (a passive degree of freedom), canonical
            elif null is not None or pose.linear.rank != system.n_unknowns and not solver.normal.sparse:
                # more free directions, or a rank the pivots cannot tell: step by step (a sparse
                # system's waves read it pose by pose, as the continuation does)
                waves = batch = None
        if pose is not None:
            good, stuck = pose, False
            vel[k] = (pose.velocity * solver.col).reshape(M, 6)
            rank[k] = pose.linear.rank
            solved[k] = True
        pos[k], ori[k], res[k], status[k] = x.position, x.orientation, r, st
        if st != CONVERGED:
            streak = k + 1
        iters[k], facts[k] = solver.iterations - it0, solver.factorizations - f0
        if progress is not None:
            progress(k, T)
        k += 1
        if st != CONVERGED and options.stop_at_failure:
            break
    acc = run_accelerations(solver, table, pos, ori, vel, solved & (np.arange(T) < k), batch) \
        if options.accelerations else None
    run = Run(t=t, position=pos, orientation=ori, velocity=vel, acceleration=acc, residual=res, status=status,
              iterations=iters, factorizations=facts, reached=reached, rank=rank, batched=batched)
    return run if k == T else run.take(np.arange(k))

