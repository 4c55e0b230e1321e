"""Benchmark of the closed-form engine: µs per time step at 360 samples and at 1 sample.

"positions" is the reconstruction alone (:func:`linkedit.planar.kinematics.positions`);
"+derivatives" adds analytic velocities and accelerations and the singularity distances
(:func:`linkedit.planar.kinematics.evaluate`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from linkedit.planar import catalog
from linkedit.planar.kinematics import Workspace, evaluate, positions
from linkedit.planar.plan import compile_plan
from linkedit.planar.simulate import motor_angles
from linkedit.timing import best_time

TARGETS_360 = {"Jansen leg": 0.3, "Strandbeest 3 pairs": 0.7, "Strandbeest 10 pairs": 1.5}


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    budget = 0.02 if quick else 0.5
    mechanisms = {"Jansen leg": catalog.jansen_leg(), "Strandbeest 3 pairs": catalog.strandbeest(3),
                  "Strandbeest 10 pairs": catalog.strandbeest(10)}
    echo(f"{'mechanism':<22}{'joints':>7}{'levels':>7}  {'samples':>7}  {'positions µs/step':>18}  {'+derivatives µs/step':>21}  target")
    for name, spec in mechanisms.items():
        plan = compile_plan(spec)
        geom = plan.geometry()
        for samples in (360, 1):
            angle = motor_angles(spec, samples)[1]
            work = Workspace(plan, samples)
            pos = best_time(lambda: positions(plan, geom, angle, work), budget_s=budget) / samples * 1e6
            full = best_time(lambda: evaluate(plan, geom, angle, order=2), budget_s=budget) / samples * 1e6
            target = f"≤ {TARGETS_360[name]}" if samples == 360 else ""
            echo(f"{name:<22}{plan.n_joints:>7}{int(plan.level.max()):>7}  {samples:>7}  {pos:>18.3f}  {full:>21.3f}  {target}")
