"""Run an edit script: operations in order, each solved to convergence, then a final check.

One time axis: phase 0 is the rest pose of the linkage being edited, exactly as in ``simulate``.
The plan is compiled once; every result is re-simulated through ``simulate`` on the edited rest
pose, and the final linkage is checked at 4× the samples with the same predicate the solver uses
(:mod:`linkedit.edit.feasibility`). If it fails there, the last operation whose result works is
kept and :class:`EditFailed` says which one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from linkedit.curves.polyline import arc_resample, distances_to
from linkedit.edit import bfgs, gauss_newton
from linkedit.edit.bfgs import BfgsResult as SolverResult
from linkedit.edit.feasibility import failure
from linkedit.edit.goals import Envelope, Track
from linkedit.edit.steps import check as check_steps
from linkedit.edit.objectives import Problem
from linkedit.edit.operation import build_problem, select
from linkedit.edit.variables import parametrize
from linkedit.errors import InputError, MechanismError
from linkedit.planar.plan import Plan, compile_plan
from linkedit.planar.simulate import DEFAULT_SAMPLES, Motion, motor_input, motor_phases, motor_turn, simulate
from linkedit.spec.edit_script import EditScript, Operation
from linkedit.spec.linkage import LinkageSpec, LinkTrack


#: A goal is met when its error is at most this fraction of the linkage's size L (the largest
#: extent of its rest pose): a displaced point's distance to its target, a transform's RMS over
#: its joints, a curve's RMS from its target (preserve, retarget, drag, follow), an envelope's
#: largest excess.
GOAL_TOLERANCE = 0.01

#: Fractions of the script's regularization weight tried in turn, each from the last result,
#: while a goal is not met: the regularization must not hold back a goal that can be reached.
RELAXED = (1e-2, 1e-4, 0.0)


@dataclass
class Goal:
    """One goal of an operation: its error (spec units) before and after, against ``tolerance``."""

    name: str  # its label: ``displace C``, ``preserve foot``, ``transform``, ``envelope``
    measure: str  # what the error is: ``from its target``, ``RMS from its target``, ``outside the box``
    before: float
    error: float
    tolerance: float
    units: str
    held_back_by: str | None = None  # the part of the energy that holds it back, where one does

    @property
    def met(self) -> bool:
        return self.error <= self.tolerance

    def describe(self) -> str:
        u = self.units
        text = (f"{self.name}: {self.error:.3g} {u} {self.measure} (from {self.before:.3g} {u}; tolerance "
                f"{self.tolerance:.3g} {u}, {GOAL_TOLERANCE:.0%} of the linkage's size)")
        if self.held_back_by is not None:
            the = "the " if self.held_back_by in ("singularity barrier", "regularization", "symmetry") else ""
            text += f", held back by {the}{self.held_back_by}"
        return text


@dataclass
class OperationReport:
    """What one operation did: iterations, time, energy history, objective errors before/after."""

    name: str
    iterations: int
    evaluations: int
    rejected_steps: int
    seconds: float
    converged: bool
    energy: list[float]
    before: dict[str, float]
    after: dict[str, float]
    goals: list[Goal] = field(default_factory=list)
    regularization: float = 0.0  # μ_r of the result kept: the script's, or relaxed (:data:`RELAXED`)
    targets: dict[str, np.ndarray] = field(default_factory=dict)  # label → (T, 2) target curve (4T once checked)
    polylines: frozenset[str] = frozenset()  # labels of targets given as points (follow, timing: false): (P, 2)
    open_targets: frozenset[str] = frozenset()  # labels of targets that are open curves (follow, closed: false)
    discarded: bool = False  # its result did not pass the final check
    stalled: bool = False  # the solver stopped for slow progress, not converged

    @property
    def unmet(self) -> list[str]:
        """The goals the result does not meet, readable."""
        return [g.describe() for g in self.goals if not g.met]

    @property
    def goals_met(self) -> bool:
        return all(g.met for g in self.goals)

    @property
    def barrier_active(self) -> bool:
        """Whether the result lies in some triangle's barrier band."""
        return self.after.get("energy singularity", 0.0) > 0.0


@dataclass(repr=False)
class EditResult:
    """An edit: the spec before and after, a report per operation, and the motions of both."""

    original: LinkageSpec
    edited: LinkageSpec
    operations: list[OperationReport]
    before: Motion  # the original, as ``simulate`` gives it
    after: Motion  # the edited spec, as ``simulate`` gives it
    warnings: list[str] = field(default_factory=list)  # unmet goals first, then a near-toggle result

    @property
    def goals_met(self) -> bool:
        """Every goal of every operation kept is met (:data:`GOAL_TOLERANCE`)."""
        return all(op.goals_met for op in self.operations if not op.discarded)

    def __repr__(self) -> str:
        goals = "every goal met" if self.goals_met else "goals NOT met"
        return (f"<{type(self).__name__} {self.original.name!r}: {len(self.operations)} operation(s), {goals}, "
                f"{len(self.warnings)} warning(s)>")


class EditFailed(MechanismError):
    """The edit could not finish with a working linkage; ``result`` holds the last one that works."""

    def __init__(self, message: str, result: EditResult) -> None:
        super().__init__(message)
        self.result = result


def with_rest_pose(spec: LinkageSpec, plan: Plan, x: np.ndarray, note: str) -> LinkageSpec:
    """A copy of ``spec`` with joints at ``x`` (J, 2); its link tracks move with their link."""
    points = plan.points_for(x)
    joints = {n: (float(p[0]), float(p[1])) for n, p in zip(plan.joint_names, x)}
    tracks = {}
    for name, track in spec.tracks.items():
        if isinstance(track, LinkTrack):
            p = points[plan.track_points[plan.track_names.index(name)]]
            track = LinkTrack(link=track.link, at=(float(p[0]), float(p[1])))
        tracks[name] = track
    description = f"{spec.description.strip()}\n{note}" if spec.description else note
    return spec.model_copy(update={"joints": joints, "tracks": tracks, "description": description})


def _probes(linkage: LinkageSpec, script: EditScript) -> tuple[LinkageSpec, list[dict[int, str]]]:
    """The linkage with a hidden link track for every displaced link point, and their names."""
    tracks = dict(linkage.tracks)
    names: list[dict[int, str]] = []
    for o, op in enumerate(script.operations):
        mine = {}
        for n, d in enumerate(op.listed("displace")):
            if d.link is not None:
                mine[n] = f"__displace_{o}_{n}"
                tracks[mine[n]] = LinkTrack(link=d.link, at=d.at)
        names.append(mine)
    return (linkage.model_copy(update={"tracks": tracks}) if len(tracks) > len(linkage.tracks) else linkage), names


def _goals(problem: Problem, before: dict[str, float], after: dict[str, float], units: str) -> list[Goal]:
    """Every goal of the operation with its error before and after (see :data:`GOAL_TOLERANCE`)."""
    tol = GOAL_TOLERANCE * problem.size
    out = [Goal(tr.label, "RMS from its target" if tr.timing or tr.phases is not None else
                "RMS from its target shape (each curve to the other)", before[f"{tr.label} RMS"],
                after[f"{tr.label} RMS"], tol, units) for tr in problem.tracking]
    out += [Goal(d.label, "from its target", before[f"{d.label} error"], after[f"{d.label} error"], tol, units)
            for d in problem.displacements if not d.label.startswith("transform")]
    moved = [f"{d.label} error" for d in problem.displacements if d.label.startswith("transform")]
    if moved:
        rms = [float(np.sqrt(np.mean([e[k] ** 2 for k in moved]))) for e in (before, after)]
        out.append(Goal("transform", "RMS from their targets (its joints)", rms[0], rms[1], tol, units))
    key = "envelope max excess"
    if key in after:
        out.append(Goal("envelope", "outside the box", before[key], after[key], tol, units))
    return out


def _hold_back(problem: Problem, v: np.ndarray, goals: list[Goal]) -> None:
    """Name, for every unmet goal, the part of the energy that pulls against it the most, when
    that part balances at least half of the goal's own gradient at ``v``."""
    unmet = [g for g in goals if not g.met]
    if not unmet:
        return
    grads = problem.gradients(v)
    for g in unmet:
        own = grads[g.name]
        norm2 = float(own @ own)
        if norm2 <= 0.0:
            continue
        shares = {k: -float(h @ own) / norm2 for k, h in grads.items() if k != g.name}
        name = max(shares, key=lambda k: shares[k], default=None)
        if name is not None and shares[name] >= 0.5:
            g.held_back_by = name


def _check(plan: Plan, spec: LinkageSpec, samples: int, arm: complex | None) -> tuple[Motion | None, str | None]:
    """Simulate ``spec`` (``plan`` re-based on it) at ``samples``; (motion, None) if it works there
    and between the samples, as ``simulate`` checks it.
    ``arm``: the crank direction the rest pose must keep, or None (its angle was free)."""
    rest = np.array([spec.joints[n] for n in plan.joint_names], dtype=float)
    z = rest[:, 0] + 1j * rest[:, 1]
    t = motor_phases(spec, samples)
    turn = motor_input(spec.motor, t) if plan.linear else np.degrees(motor_turn(spec.motor, t))
    ones = np.ones((plan.n_ds, samples))
    why = failure(plan, z, ones, turn, arm) or check_steps(plan, z)  # rest branches first: re-basing needs them
    if why is not None:
        return None, why
    motion = simulate(replan(plan, spec), samples, partial=True)
    if motion.lockups:  # at the samples, or between them as simulate checks (CHECK_SAMPLES)
        return None, "; ".join(lk.describe() for lk in motion.lockups)
    return motion, failure(plan, z, motion.rule_ds()[0].T, turn, arm)


def replan(plan: Plan, spec: LinkageSpec) -> Plan:
    """``plan`` at the rest pose of ``spec``: re-based, or compiled again when it has steps (their
    constants come from the rest pose; :func:`check_steps` has kept their branches)."""
    return compile_plan(spec) if plan.steps else plan.rebased(spec)


def _warnings(operations: list[OperationReport], motion: Motion, eps: float) -> list[str]:
    """Every unmet goal of the operations kept, then a result within ``eps``/10 of a toggle
    (``motion``: the final check's)."""
    out = [f"{op.name}: goal not met: {text}" for op in operations if not op.discarded for text in op.unmet]
    worst = motion.min_singularity()
    if worst is not None and worst[0] < eps / 10:
        out.append(f"joint {worst[1]} comes within d_s = {worst[0]:.3g} of its toggle position at "
                   f"{motion.describe_input(worst[2])} (below singularity_epsilon/10 = {eps / 10:.3g}): "
                   "it works, but only just")
    return out


def _solve(script: EditScript, problem: Problem, op: Operation, tick: Callable[[int, float], None],
           v0: np.ndarray):
    if script.solver == "bfgs":  # in units of the mechanism's size, so that it is unit-free too
        L = problem.size

        def energy(u: np.ndarray) -> tuple:
            e, g, ev = problem.energy(L * u)
            return e, (None if g is None else L * g), ev

        result = bfgs.minimize(energy, v0 / L, max_iterations=op.max_iterations, max_step=0.1, callback=tick)
        result.x = L * result.x
        return result
    return gauss_newton.minimize(problem, v0, max_iterations=op.max_iterations, callback=tick)


def _relaxed(script: EditScript, problem: Problem, op: Operation, tick: Callable[[int, float], None],
             before: dict[str, float], units: str) -> tuple[SolverResult, float, list[Goal], tuple[int, int, int]]:
    """Solve ``problem`` with the script's regularization μ_r. Where the regularization is what
    holds a goal back (:func:`_hold_back`), solve again from there with μ_r relaxed in steps
    (:data:`RELAXED`) and keep the most relaxed result that meets every goal; else the first.
    ``before``: :meth:`Problem.errors` at the start. Returns (result, its μ_r, its goals,
    (iterations, evaluations, rejected steps) of every solve)."""
    me, ms, mu = problem.weights
    result = best = _solve(script, problem, op, tick, np.zeros(problem.var.n))
    spent = np.array([result.iterations, result.evaluations, result.rejected])
    goals = _goals(problem, before, problem.errors(result.x), units)
    _hold_back(problem, result.x, goals)
    best_mu, best_goals = mu, goals
    if mu > 0.0 and any(g.held_back_by == "regularization" for g in goals if not g.met):
        for factor in RELAXED:
            problem.weights = (me, ms, factor * mu)
            trial = _solve(script, problem, op, tick, result.x)
            spent += (trial.iterations, trial.evaluations, trial.rejected)
            trial.history = result.history + trial.history
            now = _goals(problem, before, problem.errors(trial.x), units)
            if all(g.met for g in now):
                best, best_mu, best_goals = trial, factor * mu, now
            elif not any(n.error < 0.99 * g.error for g, n in zip(goals, now) if not g.met):
                break  # relaxing it further does not bring the goals closer
            result, goals = trial, now
    problem.weights = (me, ms, best_mu)
    return best, best_mu, best_goals, (int(spent[0]), int(spent[1]), int(spent[2]))


def _fine_measures(reports: list[OperationReport], kept: int, motion: Motion, earlier: list[LinkageSpec],
                   plan: Plan, fine: int, boxes: list[Envelope | None], curves: list[list[Track]]) -> None:
    """Report min d_s, every envelope's largest excess and every curve goal's RMS as the final
    check measures them too (``fine`` samples: a box or a curve met only at the script's samples
    is not met), the larger of the two kept: ``motion`` is the kept result's (after operation
    ``kept``), ``earlier`` the rest poses before it (the original first); ``boxes`` each operation's
    envelope over joint indices, or None; ``curves`` each operation's curve goals."""
    def least(m: Motion) -> float:
        worst = m.min_singularity()
        return 1.0 if worst is None else worst[0]

    motions = [simulate(replan(plan, spec), fine, partial=True) for spec in earlier] + [motion]
    for n, report in enumerate(reports[:kept + 1]):
        if "min d_s" in report.before:
            report.before["min d_s"] = least(motions[n])
            if n < kept:
                report.after["min d_s"] = least(motions[n + 1])
        box, key = boxes[n], "envelope max excess"
        if box is not None:
            goal = next(g for g in report.goals if g.name == "envelope")
            goal.before = report.before[key] = max(report.before[key], _excess(box, motions[n]))
            if n < kept:
                goal.error = report.after[key] = max(report.after[key], _excess(box, motions[n + 1]))
        for track in curves[n] if n < kept else ():
            goal, key = next(g for g in report.goals if g.name == track.label), f"{track.label} RMS"
            before, after, target = _off_target(track, motions[n:n + 2])
            if track.label in report.targets and track.label not in report.polylines:  # the target measured
                report.targets[track.label] = np.column_stack([target.real, target.imag])
            goal.before = report.before[key] = max(goal.before, before)
            goal.error = report.after[key] = max(goal.error, after)


def _off_target(track: Track, motions: list[Motion]) -> tuple[float, float, np.ndarray]:
    """The RMS of curve goal ``track`` from its target before and after its operation (``motions``,
    at the same samples), over its window, in the sense (timing or shape) of the goal; its target
    aimed again from the curve at these samples. A shape (``timing: false``, whole cycle) is
    measured both ways, the larger kept: the curve's samples to the target, and the target's points
    (as many, evenly by arc length) to the curve: the whole shape must be traced, not only approached.
    Returns the RMS before, after, and the target (N,) complex at these samples."""
    before, after = ((m.tracks[track.track].position @ (1.0, 1j)) for m in motions)
    t = motor_phases(motions[0].plan.spec, before.size)
    target = track.aim(before, t) if track.aim is not None else before
    shape = None if track.shape is None else target[: (target.size + 1) // 2 + 1]  # a rocking input's outward half
    fine = replace(track, row=0, target=target, select=select(t, track.phases), shape=shape)
    rms = [float(np.sqrt(np.mean(np.abs(fine.deviation(c[None, :])[0]) ** 2))) for c in (before, after)]
    if not track.timing and track.phases is None:
        line = target if shape is None else shape
        points = arc_resample(line, before.size, track.cyclic and shape is None)
        back = [float(np.sqrt(np.mean(distances_to(points, c, motions[0].cyclic) ** 2))) for c in (before, after)]
        rms = [max(a, b) for a, b in zip(rms, back)]
    return rms[0], rms[1], target


def _excess(box: Envelope, motion: Motion) -> float:
    """The largest distance of ``box``'s joints outside it over ``motion``'s samples (spec units)."""
    z = (motion.positions[..., 0] + 1j * motion.positions[..., 1]).T  # (J, samples)
    return float(np.nanmax(np.abs(box.outside(z, z.shape[1])), initial=0.0))


def run_script(linkage: LinkageSpec, script: EditScript,
               progress: Callable[[str, int, float], None] | None = None) -> EditResult:
    """Apply ``script`` to ``linkage``; raises :class:`EditFailed` if the result does not work."""
    augmented, probe_names = _probes(linkage, script)
    plan = compile_plan(augmented)
    out_plan = plan if augmented is linkage else compile_plan(linkage)
    before_motion = simulate(out_plan, linkage.samples or DEFAULT_SAMPLES, partial=True)
    if not before_motion.assembled.all():
        raise MechanismError(f"{linkage.name} does not work before any edit: "
                             + "; ".join(lk.describe() for lk in before_motion.lockups))
    T = script.samples
    t = motor_phases(linkage, T)
    turn = motor_input(linkage.motor, t)
    index = {n: i for i, n in enumerate(plan.joint_names)}
    locked = {index[n]: axes for n, axes in script.locked().items()}
    x = plan.graph.rest.copy()
    size = float(np.ptp(x, axis=0).max())
    reports: list[OperationReport] = []
    boxes: list[Envelope | None] = []  # each operation's envelope over joint indices (motion positions)
    curves: list[list[Track]] = []  # each operation's curve goals
    accepted = [x.copy()]
    for n, op in enumerate(script.operations):
        name = op.name or f"operation {n + 1}"
        var = parametrize(plan, x, locked, script.motor.free_angle)
        if var.n == 0:
            raise InputError("nothing is left for the edit to change: every coordinate is locked "
                             "(the motor joint is locked whole unless motor: {free_angle: true})", field=("lock",))
        probes = {k: int(plan.track_points[plan.track_names.index(v)]) for k, v in probe_names[n].items()}
        problem = build_problem(plan, script, op, var, turn, t, size, probes)
        before = problem.errors(np.zeros(var.n))
        start = time.perf_counter()

        def tick(it: int, e: float, label: str = name) -> None:
            if progress is not None:
                progress(label, it, e)

        solved, mu, goals, spent = _relaxed(script, problem, op, tick, before, linkage.units)
        boxes.append(None if problem.envelope is None else replace(problem.envelope, rows=np.array(
            [index[j] for j in op.envelope.joints] if op.envelope and op.envelope.joints else range(len(index)))))
        curves.append(problem.tracking)
        seconds = time.perf_counter() - start
        x = var.rest(solved.x)
        accepted.append(x.copy())
        after = problem.errors(solved.x)
        targets = {tr.label: np.column_stack([tr.target.real, tr.target.imag]) for tr in problem.tracking
                   if not tr.label.startswith("preserve")}
        reports.append(OperationReport(name=name, iterations=spent[0], evaluations=spent[1], rejected_steps=spent[2],
                                       seconds=seconds, converged=solved.converged, stalled=solved.stalled,
                                       energy=solved.history, before=before, after=after, goals=goals,
                                       regularization=mu, targets=targets, polylines=frozenset(
                                           tr.label for tr in problem.tracking if not tr.timing and tr.label in targets),
                                       open_targets=frozenset(
                                           tr.label for tr in problem.tracking if not tr.cyclic and tr.label in targets)))

    fine = 4 * T
    g = out_plan.graph
    arm = None if script.motor.free_angle or out_plan.linear else complex(*(g.rest[g.motor] - g.rest[g.pivot]))
    note = f"edited by linkedit ({len(script.operations)} operations)"
    failure_why = None
    for k in range(len(accepted) - 1, -1, -1):
        edited = with_rest_pose(linkage, out_plan, accepted[k], note)
        motion, why = _check(out_plan, edited, fine, arm)
        if motion is not None and why is None:
            _fine_measures(reports, k, motion, [with_rest_pose(linkage, out_plan, a, note) for a in accepted[:k]],
                           out_plan, fine, boxes, curves)
            for report in reports[k:]:
                report.discarded = True
            after_motion = simulate(replan(out_plan, edited), linkage.samples or DEFAULT_SAMPLES)
            result = EditResult(original=linkage, edited=edited if k else linkage, operations=reports,
                                before=before_motion, after=after_motion,
                                warnings=_warnings(reports, motion, script.singularity_epsilon))
            if k == len(accepted) - 1:
                return result
            kept = f"kept the linkage as it was after operation {reports[k - 1].name!r}" if k else \
                "kept the original linkage unchanged"
            raise EditFailed(f"the result of operation {reports[-1].name!r} does not work at {fine} samples "
                             f"({failure_why}); {kept}", result)
        failure_why = failure_why or why
    raise AssertionError("the original linkage always passes its own check")  # pragma: no cover
