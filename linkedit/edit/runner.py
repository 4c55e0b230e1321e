"""Run an edit script: operations in order, each solved to convergence, then a final check.

The final linkage is re-simulated at 4× the samples; it must assemble everywhere with every
triangle's orientation unchanged. Otherwise the last accepted iterate that passes the check is
kept and :class:`EditFailed` is raised with it, so the caller can write it and exit 1.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from linkedit.edit.bfgs import minimize
from linkedit.edit.objectives import Problem, build_problem
from linkedit.errors import MechanismError
from linkedit.planar.plan import Plan, compile_plan
from linkedit.planar.simulate import Motion, simulate
from linkedit.spec.edit_script import EditScript
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
    targets: dict[str, np.ndarray] = field(default_factory=dict)  # track label → (T, 2) target curve


@dataclass
class EditResult:
    original: LinkageSpec
    edited: LinkageSpec
    operations: list[OperationReport]
    before: Motion  # at 4× samples, absolute motor angles of the original
    after: Motion


class EditFailed(MechanismError):
    """The edit could not finish with a working linkage; ``result`` holds the last valid one."""

    def __init__(self, message: str, result: EditResult) -> None:
        super().__init__(message)
        self.result = result


def pair_lengths(plan: Plan, x: np.ndarray) -> np.ndarray:
    """(P,) distances of the joint pairs held on links, for rest pose ``x`` (J, 2)."""
    return np.linalg.norm(x[plan.pairs[:, 1]] - x[plan.pairs[:, 0]], axis=1)


def errors(problem: Problem, v: np.ndarray) -> dict[str, float]:
    """Readable objective errors: tracking RMS per curve, displacement distance, envelope excess,
    min d_s, and the weighted energy terms."""
    f = problem.forward(v)
    assert f is not None
    T = problem.samples
    out: dict[str, float] = {}
    for tr in problem.tracking:
        out[f"{tr.label} RMS"] = float(np.sqrt(np.mean(np.abs(f.z[tr.row, :T] - tr.target) ** 2)))
    for d in problem.displacements:
        z = f.rest[d.joint] if d.column is None else f.z[problem.plan.row_of[d.joint], d.column]
        out[f"{d.label} error"] = float(abs(z - d.target))
    if problem.envelope is not None:
        env = problem.envelope
        z = f.z[env.rows, :T]
        outside = np.maximum.reduce([env.lo.real - z.real, z.real - env.hi.real, env.lo.imag - z.imag,
                                     z.imag - env.hi.imag, np.zeros(z.shape)])
        out["envelope max excess"] = float(outside.max())
    ds = [d[:, :T] for d in f.ds if d is not None]
    out["min d_s"] = float(min(d.min() for d in ds)) if ds else 1.0
    out |= {f"energy {k}": float(v_) for k, v_ in problem.terms(f).items()}
    return out


def with_rest_pose(spec: LinkageSpec, plan: Plan, x: np.ndarray, note: str) -> LinkageSpec:
    """A copy of ``spec`` with joints at ``x`` (J, 2); link tracks move with their link."""
    points = plan.points_for(x)
    joints = {n: (float(p[0]), float(p[1])) for n, p in zip(plan.joint_names, x)}
    tracks = {}
    for name, point in zip(plan.track_names, plan.track_points):
        track = spec.tracks[name]
        if isinstance(track, LinkTrack):
            track = LinkTrack(link=track.link, at=(float(points[point, 0]), float(points[point, 1])))
        tracks[name] = track
    description = f"{spec.description.strip()}\n{note}" if spec.description else note
    return spec.model_copy(update={"joints": joints, "tracks": tracks, "description": description})


def _check(plan: Plan, spec: LinkageSpec, samples: int, base_angle: float) -> tuple[Motion | None, str]:
    """Re-simulate at ``samples`` absolute angles; (motion, "") if it works, else (None, why)."""
    try:
        edited = compile_plan(spec)
    except MechanismError as exc:
        return None, str(exc)
    if not np.array_equal(edited.orientation, plan.orientation) or not np.array_equal(edited.rules, plan.rules):
        return None, "a triangle of the rest pose changed orientation"
    motion = sample_motion(edited, samples, base_angle, partial=True)
    if not motion.assembled.all():
        return None, "; ".join(lk.describe() for lk in motion.lockups)
    flips = motion.orientation != plan.orientation[None, :]
    if flips.any():
        t, r = np.argwhere(flips)[0]
        return None, (f"joint {plan.joint_names[plan.rules[r, 2]]} changes branch at motor angle "
                      f"{np.degrees(motion.motor_angle[t]):.1f}°")
    return motion, ""


def sample_motion(plan: Plan, samples: int, base_angle: float, partial: bool = False) -> Motion:
    """Simulate at absolute motor angles base_angle + dir·2π·n/T (so before/after compare)."""
    rest_angle = plan.geometry().rest_angle
    offset = np.degrees(plan.direction * (base_angle - rest_angle))
    motor = plan.spec.motor.model_copy(update={"range_deg": (offset, offset + 360.0 * (1 - 1 / samples))})
    shifted = compile_plan(plan.spec.model_copy(update={"motor": motor}))
    return simulate(shifted, samples, partial=partial)


def run_script(linkage: LinkageSpec, script: EditScript,
               progress: Callable[[str, int, float], None] | None = None) -> EditResult:
    """Apply ``script`` to ``linkage``; raises :class:`EditFailed` if the result does not work."""
    plan = compile_plan(linkage)
    base_angle = plan.geometry().rest_angle
    x = plan.graph.rest.copy()
    size = float(np.ptp(x, axis=0).max())
    ref = pair_lengths(plan, x)
    reports: list[OperationReport] = []
    accepted = [x.copy()]
    for n, op in enumerate(script.operations):
        name = op.name or f"operation {n + 1}"
        problem = build_problem(plan, script, op, x, base_angle, ref)
        v0 = x[problem.free]
        before = errors(problem, v0)
        start = time.perf_counter()

        def energy(v: np.ndarray, p: Problem = problem) -> tuple:
            return p.energy(v)

        def tick(it: int, e: float, label: str = name) -> None:
            if progress is not None:
                progress(label, it, e)

        result = minimize(energy, v0, max_iterations=op.max_iterations, max_step=0.1 * size, callback=tick)
        seconds = time.perf_counter() - start
        x = problem.full(result.x)
        accepted.append(x.copy())
        after = errors(problem, result.x)
        targets = {tr.label: np.column_stack([tr.target.real, tr.target.imag]) for tr in problem.tracking
                   if not tr.label.startswith("preserve")}
        reports.append(OperationReport(name=name, iterations=result.iterations, evaluations=result.evaluations,
                                       rejected_steps=result.rejected, seconds=seconds, converged=result.converged,
                                       energy=result.history, before=before, after=after, targets=targets))
        ref = pair_lengths(plan, x)

    fine = 4 * script.samples
    before_motion = sample_motion(plan, fine, base_angle)
    for k in range(len(accepted) - 1, -1, -1):
        edited = with_rest_pose(linkage, plan, accepted[k], f"edited by linkedit ({len(script.operations)} operations)")
        motion, why = _check(plan, edited, fine, base_angle)
        if motion is not None:
            result = EditResult(original=linkage, edited=edited, operations=reports, before=before_motion, after=motion)
            if k == len(accepted) - 1:
                return result
            raise EditFailed(f"the edited linkage does not work at {fine} samples ({failure}); "
                             f"kept the result of operation {k} instead", result)
        if k == len(accepted) - 1:
            failure = why
    raise AssertionError("the original linkage always passes its own check")  # pragma: no cover
