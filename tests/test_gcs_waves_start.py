"""Where the closed form predicts the steps (linkedit.gcs.closed_form), the waves start right
after the first pose (its branch read there) instead of after two solved step by step — the
spatial slider-crank spent ~40 % of its run on its second step's continuation (issue 22:
1.15× SolveSpace) — with the step-by-step poses and velocities; where the first step is too
coarse for the acceptance test the continuation takes it as before."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.gcs.tolerances import Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES


def _runs(name: str, steps: int):
    system = compile_mechanism(load_model(MechanismSpec, EXAMPLES / "3d" / f"{name}.yaml"))[0]
    t = np.arange(steps) / (steps - 1)
    on, off = solve_run(system, t), solve_run(system, t, Options(waves=False))
    assert (on.status == 0).all() and (off.status == 0).all()
    assert np.abs(on.position - off.position).max() <= 1e-9 * system.length_scale
    assert np.abs(on.velocity - off.velocity).max() <= 1e-8 * np.abs(off.velocity).max()
    return on


@pytest.mark.parametrize("name", ["spatial-slider-crank", "rssr", "crank-rocker"])
def test_closed_form_waves_start_after_the_first_pose(name):
    on = _runs(name, 361)
    assert not on.batched[0] and on.batched[1:].all()


def test_waves_without_a_closed_form_start_after_two_poses():
    on = _runs("bennett", 361)  # skew axes: no closed form
    assert not on.batched[:2].any() and on.batched.sum() >= 350


def test_a_first_step_too_coarse_for_a_wave_goes_step_by_step():
    on = _runs("spatial-slider-crank", 13)  # 30° steps: the acceptance test fails
    assert not on.batched.any()
