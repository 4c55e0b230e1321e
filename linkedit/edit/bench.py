"""Benchmark of editing: gradient cost ratio and wall time to convergence.

* (energy + gradient) / energy on the 3- and 10-pair Strandbeests at 120 samples, both with
  every objective kind active (target ≤ 4);
* the Jansen function-preserving edit (``examples/edits/jansen-move-knee.yaml``, target ≤ 0.15 s)
  and the Strandbeest scaling edit (``examples/edits/strandbeest-scale.yaml``, target ≤ 1.5 s).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from linkedit.edit.objectives import build_problem
from linkedit.edit.runner import pair_lengths, run_script
from linkedit.planar import catalog
from linkedit.planar.plan import compile_plan
from linkedit.spec.edit_script import EditScript
from linkedit.timing import best_time

JANSEN_KNEE = {"samples": 120, "lock": ["O"], "operations": [
    {"name": "move knee, keep gait", "preserve": ["foot"], "displace": {"joint": "C", "to": [-20, 36]}}]}


def strandbeest_scale(pairs: int) -> dict:
    """Scale the whole mechanism to 80 % about the crank axle while every foot keeps its gait."""
    spec = catalog.strandbeest(pairs)
    return {"samples": 120, "lock": ["O"], "operations": [
        {"name": "smaller, same gait", "preserve": list(spec.tracks),
         "transform": {"joints": "all", "scale": 0.8, "about": [0, 0]},
         "terms": {"preserve": 1000, "transform": 0.3}}]}


def gradient_ratio(spec, budget: float) -> tuple[float, float, float]:
    """(energy µs, energy+gradient µs, ratio) with preserve + displace + envelope + barrier active."""
    plan = compile_plan(spec)
    names = plan.joint_names
    script = EditScript.model_validate({"samples": 120, "singularity_epsilon": 0.2, "operations": [{
        "preserve": list(spec.tracks), "displace": {"joint": names[-1], "to": [0, 0]},
        "envelope": {"xmin": -60, "xmax": 60}}]})
    x = plan.graph.rest.copy()
    problem = build_problem(plan, script, script.operations[0], x, plan.geometry().rest_angle, pair_lengths(plan, x))
    v = x[problem.free]
    e_only = best_time(lambda: problem.energy(v, with_gradient=False), budget_s=budget)
    e_grad = best_time(lambda: problem.energy(v), budget_s=budget)
    return e_only * 1e6, e_grad * 1e6, e_grad / e_only


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    budget = 0.02 if quick else 0.5
    echo(f"{'energy + gradient / energy (120 samples)':<44}{'E µs':>9}{'E+∇E µs':>10}{'ratio':>8}  target")
    for pairs in (3, 10):
        e, eg, ratio = gradient_ratio(catalog.strandbeest(pairs), budget)
        echo(f"{f'Strandbeest {pairs} pairs':<44}{e:>9.0f}{eg:>10.0f}{ratio:>8.2f}  ≤ 4")
    cases = [("Jansen function-preserving edit", catalog.jansen_leg(), JANSEN_KNEE, 0.15),
             ("Strandbeest 3 pairs scaling edit", catalog.strandbeest(3), strandbeest_scale(3), 1.5)]
    echo(f"{'edit to convergence':<44}{'iterations':>11}{'seconds':>9}  target")
    for name, spec, script, target in cases:
        parsed = EditScript.model_validate(script)
        if quick:
            parsed = EditScript.model_validate(script | {"operations": [script["operations"][0] | {"max_iterations": 3}]})
        times = []
        for _ in range(1 if quick else 3):
            t0 = time.perf_counter()
            result = run_script(spec, parsed)
            times.append(time.perf_counter() - t0)
        its = sum(op.iterations for op in result.operations)
        echo(f"{name:<44}{its:>11}{min(times):>9.3f}  ≤ {target}")
