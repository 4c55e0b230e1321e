"""Solve a 3D mechanism spec over its time steps: the library entry point of ``solve3d``."""

from __future__ import annotations

import time

import numpy as np

from linkedit.errors import MechanismError
from linkedit.gcs.diagnostics import run_diagnostics
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.result import GcsResult
from linkedit.gcs.solver import CONVERGED, STATUS_NAMES, Options, solve_run
from linkedit.spec.mechanism3d import MechanismSpec


def solve_spec(spec: MechanismSpec, *, steps: int | None = None, solver: str = "lm",
               allow_python: bool = False, spec_text: str = "", rank: bool = True) -> GcsResult:
    """Solve every step t = linspace(0, 1, steps) (default: the spec's ``outputs.steps``)."""
    system, tracks = compile_mechanism(spec, allow_python=allow_python)
    steps = steps or spec.outputs.steps
    t = np.linspace(0.0, 1.0, steps)
    table = system.step_table(t)
    start = time.perf_counter()
    run = solve_run(system, t, Options(solver=solver), table=table)
    seconds = time.perf_counter() - start
    diag = run_diagnostics(system, run, table, rank=rank)
    res = GcsResult(
        name=spec.name, units=spec.units, t=t, member_names=system.member_names, position=run.position,
        orientation=run.orientation, constraint_names=system.constraint_names,
        constraint_inputs=system.constraint_inputs, diagnostics=diag, iterations=run.iterations,
        points=system.points, lines=system.lines, spec_text=spec_text,
        options={"steps": steps, "solver": solver, "seconds": round(seconds, 6)})
    for tr in tracks:
        res.add_track(tr.name, system.member_names[tr.member], tr.point)
    return res


def check_solved(res: GcsResult) -> None:
    """Raise :class:`MechanismError` at the first step that did not converge, naming the
    unsatisfied constraints and the time."""
    d = res.diagnostics
    bad = np.flatnonzero(d.status != CONVERGED)
    if not bad.size:
        return
    k = int(bad[0])
    names = d.unsatisfied[k] or [res.constraint_names[int(np.argmax(d.costs[k]))]]
    more = f" (and {bad.size - 1} more steps)" if bad.size > 1 else ""
    raise MechanismError(
        f"{res.name}: {STATUS_NAMES[d.status[k]]} at step {k} (t = {res.t[k]:.4f}){more}: "
        f"constraints not satisfied: {', '.join(names)}; residual {d.residual[k]:.3g}")
