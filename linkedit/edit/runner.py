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
from dataclasses import dataclass, field

import numpy as np

from linkedit.edit import bfgs, gauss_newton
from linkedit.edit.feasibility import failure
from linkedit.edit.steps import check as check_steps
from linkedit.edit.objectives import Problem, build_problem
from linkedit.edit.variables import parametrize
from linkedit.errors import InputError, MechanismError
from linkedit.planar.plan import Plan, compile_plan
from linkedit.planar.simulate import DEFAULT_SAMPLES, Motion, motor_input, motor_phases, motor_turn, simulate
from linkedit.spec.edit_script import EditScript, Operation
from linkedit.spec.linkage import LinkageSpec, LinkTrack


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
    unmet: list[str] = field(default_factory=list)  # goals the result does not meet, readable
    targets: dict[str, np.ndarray] = field(default_factory=dict)  # label → (T, 2) target curve
    discarded: bool = False  # its result did not pass the final check
    stalled: bool = False  # the solver stopped for slow progress, not converged

    @property
    def goals_met(self) -> bool:
        return not self.unmet


@dataclass
class EditResult:
    original: LinkageSpec
    edited: LinkageSpec
    operations: list[OperationReport]
    before: Motion  # the original, as ``simulate`` gives it
    after: Motion  # the edited spec, as ``simulate`` gives it
    warnings: list[str] = field(default_factory=list)


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


def _unmet(op: Operation, problem: Problem, before: dict[str, float], after: dict[str, float]) -> list[str]:
    """Goals the result misses: a displacement not even half-way there, a target curve left
    further than 10 % of its size, an envelope excess not halved."""
    out = []
    tiny = 1e-9 * problem.size
    for d in problem.displacements:
        key = f"{d.label} error"
        if d.label.startswith("transform") or before[key] <= tiny:
            continue
        if after[key] > 0.5 * before[key] and after[key] > tiny:
            out.append(f"{d.label}: moved less than half-way (still {after[key]:.4g} of {before[key]:.4g} away)")
    moved = [d for d in problem.displacements if d.label.startswith("transform")]
    if moved:
        rms = [float(np.sqrt(np.mean([e[f"{d.label} error"] ** 2 for d in moved]))) for e in (before, after)]
        if rms[1] > 0.5 * rms[0] and rms[1] > tiny:
            out.append(f"transform: its joints moved less than half-way (RMS {rms[1]:.4g} of {rms[0]:.4g} away)")
    for tr in problem.tracking:
        key = f"{tr.label} RMS"
        if tr.label.startswith("preserve") or before[key] <= tiny:
            continue
        if after[key] > 0.1 * tr.size:
            out.append(f"{tr.label}: {after[key]:.4g} RMS from its target, more than 10 % of the curve's size {tr.size:.4g}")
        elif after[key] > 0.5 * before[key] and after[key] > tiny:
            out.append(f"{tr.label}: less than half-way to its target (RMS {after[key]:.4g} from {before[key]:.4g})")
    key = "envelope max excess"
    if key in after and after[key] > 0.5 * before[key] and after[key] > tiny:
        out.append(f"envelope: still {after[key]:.4g} outside (from {before[key]:.4g})")
    return out


def _check(plan: Plan, spec: LinkageSpec, samples: int, arm: complex | None) -> tuple[Motion | None, str | None]:
    """Simulate ``spec`` (``plan`` re-based on it) at ``samples``; (motion, None) if it works.
    ``arm``: the crank direction the rest pose must keep, or None (its angle was free)."""
    rest = np.array([spec.joints[n] for n in plan.joint_names], dtype=float)
    z = rest[:, 0] + 1j * rest[:, 1]
    t = motor_phases(spec, samples)
    turn = motor_input(spec.motor, t) if plan.linear else np.degrees(motor_turn(spec.motor, t))
    ones = np.ones((len(plan.rules), samples))
    why = failure(plan, z, ones, turn, arm) or check_steps(plan, z)  # rest branches first: re-basing needs them
    if why is not None:
        return None, why
    motion = simulate(replan(plan, spec), samples, partial=True)
    if not motion.assembled.all():
        return None, "; ".join(lk.describe() for lk in motion.lockups)
    steps_ds = motion.step_singularity.T if motion.step_singularity is not None else np.ones((0, samples))
    return motion, failure(plan, z, np.vstack([motion.singularity.T, steps_ds]), turn, arm)


def replan(plan: Plan, spec: LinkageSpec) -> Plan:
    """``plan`` at the rest pose of ``spec``: re-based, or compiled again when it has steps (their
    constants come from the rest pose; :func:`check_steps` has kept their branches)."""
    return compile_plan(spec) if plan.steps else plan.rebased(spec)


def _warnings(motion: Motion, eps: float) -> list[str]:
    worst = motion.min_singularity()
    if worst is not None and worst[0] < eps / 10:
        return [f"joint {worst[1]} comes within d_s = {worst[0]:.3g} of its toggle position at motor angle "
                f"{worst[2]:.1f}° (below singularity_epsilon/10 = {eps / 10:.3g}): it works, but only just"]
    return []


def _solve(script: EditScript, problem: Problem, op: Operation, tick: Callable[[int, float], None]):
    v0 = np.zeros(problem.var.n)
    if script.solver == "bfgs":  # in units of the mechanism's size, so that it is unit-free too
        L = problem.size

        def energy(u: np.ndarray) -> tuple:
            e, g, ev = problem.energy(L * u)
            return e, (None if g is None else L * g), ev

        result = bfgs.minimize(energy, v0, max_iterations=op.max_iterations, max_step=0.1, callback=tick)
        result.x = L * result.x
        return result
    return gauss_newton.minimize(problem, v0, max_iterations=op.max_iterations, callback=tick)


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

        result = _solve(script, problem, op, tick)
        seconds = time.perf_counter() - start
        x = var.rest(result.x)
        accepted.append(x.copy())
        after = problem.errors(result.x)
        targets = {tr.label: np.column_stack([tr.target.real, tr.target.imag]) for tr in problem.tracking
                   if not tr.label.startswith("preserve")}
        reports.append(OperationReport(name=name, iterations=result.iterations, evaluations=result.evaluations,
                                       rejected_steps=result.rejected, seconds=seconds, converged=result.converged,
                                       stalled=result.stalled,
                                       energy=result.history, before=before, after=after,
                                       unmet=_unmet(op, problem, before, after), targets=targets))

    fine = 4 * T
    g = out_plan.graph
    arm = None if script.motor.free_angle or out_plan.linear else complex(*(g.rest[g.motor] - g.rest[g.pivot]))
    note = f"edited by linkedit ({len(script.operations)} operations)"
    failure_why = None
    for k in range(len(accepted) - 1, -1, -1):
        edited = with_rest_pose(linkage, out_plan, accepted[k], note)
        motion, why = _check(out_plan, edited, fine, arm)
        if why is None:
            after_motion = simulate(replan(out_plan, edited), linkage.samples or DEFAULT_SAMPLES)
            result = EditResult(original=linkage, edited=edited if k else linkage, operations=reports,
                                before=before_motion, after=after_motion,
                                warnings=_warnings(after_motion, script.singularity_epsilon))
            if k == len(accepted) - 1:
                return result
            for report in reports[k:]:
                report.discarded = True
            kept = f"kept the linkage as it was after operation {reports[k - 1].name!r}" if k else \
                "kept the original linkage unchanged"
            raise EditFailed(f"the result of operation {reports[-1].name!r} does not work at {fine} samples "
                             f"({failure_why}); {kept}", result)
        failure_why = failure_why or why
    raise AssertionError("the original linkage always passes its own check")  # pragma: no cover
