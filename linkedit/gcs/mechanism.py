"""Solve a 3D mechanism spec over its time steps: the library entry point of ``solve3d``."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from linkedit.errors import MechanismError
from linkedit.gcs.diagnostics import run_diagnostics
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.result import GcsResult
from linkedit.gcs.solve import Run, solve_run
from linkedit.gcs.tolerances import CONVERGED, STATUS_NAMES, Options
from linkedit.gcs.system import System
from linkedit.spec.common import require_count
from linkedit.spec.mechanism3d import MAX_STEPS, MechanismSpec


def solve_spec(spec: MechanismSpec, *, steps: int | None = None, solver: str = "lm",
               allow_python: bool = False, spec_text: str = "", rank: bool = True,
               velocity: str = "exact", accelerations: bool = False, stop_at_failure: bool = False,
               progress: Callable[[int, int], None] | None = None) -> GcsResult:
    """Solve every step t = linspace(0, 1, steps) (default: the spec's ``outputs.steps``).
    ``velocity``: "exact" (from J v = −∂r/∂t at each pose) or "parabola" (the paper's
    three-point rule on the positions); ``accelerations``: also the exact member accelerations
    (:mod:`linkedit.gcs.acceleration`); ``stop_at_failure``: end at the first step that fails
    (the result holds the steps up to it, for :func:`check_solved`; one at an input window's
    edge between two steps is held at its own time); ``progress(k, T)`` is
    called after each step.

    Raises :class:`MechanismError` when a step's state or residual is not finite (overflow):
    a result never holds NaN or inf."""
    steps = spec.outputs.steps if steps is None else require_count(steps, "steps", 2, MAX_STEPS)
    system, tracks = compile_mechanism(spec, allow_python=allow_python)
    t = np.linspace(0.0, 1.0, steps)
    table = system.step_table(t)
    options = Options(solver=solver, accelerations=accelerations, stop_at_failure=stop_at_failure)
    with np.errstate(all="ignore"):  # overflow is checked (check_run_finite), not warned about
        start = time.perf_counter()
        run = solve_run(system, t, options, table=table, progress=progress)
        seconds = time.perf_counter() - start
        if not np.array_equal(run.t, t):  # stopped at a failed step (or input window's edge: solve_run)
            t, table = run.t, system.step_table(run.t)
        check_run_finite(spec.name, system, run)
        diag = run_diagnostics(system, run, table, rank=rank, unsatisfied_tol=options.satisfied_tol)
    res = GcsResult(
        name=spec.name, units=spec.units, t=t, member_names=system.member_names, position=run.position,
        orientation=run.orientation, velocity=run.velocity, acceleration=run.acceleration,
        velocity_rule=velocity,
        periodic=periodic_inputs(system), constraint_names=system.constraint_names,
        constraint_inputs=system.constraint_inputs, diagnostics=diag, iterations=run.iterations,
        points=system.points, lines=system.lines, spec_text=spec_text,
        options={"steps": steps, "solver": solver, "tolerance": options.satisfied_tol, "velocity": velocity,
                 "accelerations": accelerations, "seconds": round(seconds, 6)})
    for tr in tracks:
        res.add_track(tr.name, system.member_names[tr.member], tr.point)
    return res


def periodic_inputs(system: System) -> bool:
    """True when the run is one period of its inputs: there is an input, and every input acts
    over the whole of [0, 1] and ends where and how fast it started (a full turn, a closed
    keyframe loop); a rocking input (0° → 90° → 0°) ends where it started but not at the
    same rate, so it is not periodic."""
    schedules = [s for blk in system.blocks for s in blk.schedules]
    if not schedules:
        return False
    ends = np.array([0.0, 1.0])
    for s in schedules:
        if tuple(s.window) != (0.0, 1.0):
            return False
        v, rate = s.evaluate(ends), s.rate(ends)
        same = abs(abs(float(v[0] @ v[1])) - 1.0) < 1e-12 if v.shape[1] == 4 else \
            np.allclose(v[0], v[1], rtol=0.0, atol=1e-12 * max(1.0, float(np.abs(v).max())))
        if not same or not np.allclose(rate[0], rate[1], rtol=1e-12, atol=1e-300):
            return False
    return True


def check_run_finite(name: str, system: System, run: Run) -> None:
    """Raise :class:`MechanismError` at the first step whose member states or constraint costs
    are not finite (the solver overflowed), naming those constraints and the time."""
    T = run.t.size
    costs = system.costs(run.residual)
    finite = np.isfinite(costs).all(axis=1) & np.isfinite(run.position.reshape(T, -1)).all(axis=1) \
        & np.isfinite(run.orientation.reshape(T, -1)).all(axis=1)
    if finite.all():
        return
    k = int(np.flatnonzero(~finite)[0])
    off = np.flatnonzero(~np.isfinite(costs[k]))
    names = ", ".join(system.constraint_names[c] for c in off) if off.size else "the member states"
    raise MechanismError(f"{name}: the solution overflowed at step {k} (t = {run.t[k]:.4f}): {names} not finite "
                         "(coordinates too large?); a result never holds NaN or inf, nothing written")


def check_solved(res: GcsResult) -> None:
    """Raise :class:`MechanismError` at the first step that did not converge, naming the
    unsatisfied constraints (worst first) and the time."""
    d = res.diagnostics
    bad = np.flatnonzero(d.status != CONVERGED)
    if not bad.size:
        return
    k = int(bad[0])
    more = f" (and {bad.size - 1} more steps)" if bad.size > 1 else ""
    grid = np.linspace(0.0, 1.0, int(res.options.get("steps", res.t.size)))
    where = f"step {k} (t = {res.t[k]:.4f})" if k >= grid.size or res.t[k] == grid[k] else \
        f"t = {res.t[k]:.4f}, an input window's edge between steps {k - 1} and {k}"
    head = f"{res.name}: {STATUS_NAMES[d.status[k]]} at {where}{more}: "
    if not d.unsatisfied[k]:  # a pose was found, but not on the branch of the step before
        raise MechanismError(head + "no pose on the previous step's assembly branch (the step could not be cut "
                             "small enough: a lock-up or a singular pose before this time)")
    off = d.offsets[k] if len(d.offsets) > k else []
    named = ", ".join(f"{n} off by {_offset(o, res.units)}" for n, o in zip(d.unsatisfied[k], off)) \
        or ", ".join(d.unsatisfied[k])
    if k == 0:  # no pose to continue from: the constraints themselves contradict each other
        raise MechanismError(head + "over-constrained: the constraints contradict each other at the start (no pose "
                             f"satisfies them all); least squares leaves {named}")
    raise MechanismError(head + f"constraints not satisfied: {named}; residual {d.residual[k]:.3g}")


def _offset(off: tuple[float, float], units: str) -> str:
    """How far a constraint is off, (length, angle in radians): "2e-09 m", "0.5°" or both."""
    length, angle = off
    parts = ([f"{length:.3g} {units}"] if length or not angle else []) + ([f"{math.degrees(angle):.3g}°"] if angle else [])
    return " and ".join(parts)
