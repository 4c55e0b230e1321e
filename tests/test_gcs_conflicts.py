"""Constraints that contradict each other: solve3d says so at once (over-constrained at the
start, inconsistent), names them and how far least squares leaves each off, exit 1."""

from __future__ import annotations

import copy

import yaml

from linkedit.gcs.mechanism import solve_spec
from linkedit.io.gcs_hdf5 import read_result
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import validate
from tests.gcs_oracles import pinned_four_bar

#: a crank (1 m) and a rocker (2 m) pinned 4 m apart, their tips held 4 m apart by a distance
#: (a four-bar whose coupler is a distance constraint), the crank turned by 60°
FOUR_BAR = {
    "name": "four-bar", "units": "m",
    "shapes": {"crank": {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}},
               "rocker": {"points": {"pivot": [0, 0, 0], "tip": [2, 0, 0]}}},
    "members": {"crank": {"position": [0, 0, 0], "orientation": {"axis": [0, 0, 1], "angle_deg": 90}, "shape": "crank"},
                "rocker": {"position": [4, 0, 0], "orientation": {"axis": [0, 0, 1], "angle_deg": 90}, "shape": "rocker"}},
    "constraints": {
        "crank_pivot": {"type": "pin", "member": "crank", "point": "pivot", "world": [0, 0, 0]},
        "rocker_pivot": {"type": "pin", "member": "rocker", "point": "pivot", "world": [4, 0, 0]},
        "coupler": {"type": "distance", "member": "crank", "point": "tip", "other": "rocker", "other_point": "tip",
                    "value": 4.0}},
    "inputs": {"drive": {"type": "orientation", "member": "crank",
                         "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 60]}}},
    "outputs": {"steps": 37, "tracks": {"tip": {"member": "rocker", "point": "tip"}}},
}


def _solve3d(run_cli, tmp_path, data: dict, *args: str):
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(data))
    return run_cli("solve3d", spec, "-o", tmp_path / "out.h5", "--quiet", *args)


def test_a_tiny_conflict_is_over_constrained_at_the_start_naming_both_constraints(run_cli, tmp_path):
    """Issue 22, 3: coupler distances of 4 and 4 + 4e-9 m were "inconsistent at step 0: no pose
    on the previous step's assembly branch … lock-up" (there is no previous step), naming
    neither constraint."""
    data = copy.deepcopy(FOUR_BAR)
    data["constraints"]["coupler_twin"] = dict(data["constraints"]["coupler"], value=4.0 + 4e-9)
    r = _solve3d(run_cli, tmp_path, data)
    assert r.exit_code == 1, r.output
    line = r.output.strip().splitlines()[-1]
    assert "inconsistent at step 0 (t = 0.0000)" in line and "over-constrained" in line, line
    assert "coupler off by 2e-09 m" in line and "coupler_twin off by 2e-09 m" in line, line
    assert "lock-up" not in line and "branch" not in line and "pivot" not in line, line
    assert not (tmp_path / "out.h5").exists()
    assert _solve3d(run_cli, tmp_path, FOUR_BAR).exit_code == 0  # one of them alone is fine


#: a four-bar of pins whose coupler (10 m) is longer than the other three links together
#: (crank 1, ground 4, rocker 1): its loop closes nowhere
TOO_LONG = pinned_four_bar("too-long", {"a": [0, 0, 0], "b": [10, 0, 0]}, {"tip": {"member": "rocker", "point": "tip"}})


def test_a_loop_that_cannot_close_is_inconsistent_at_once(run_cli, tmp_path):
    """Issue 22, 4: it was "did not converge", after solving every step (8× the CPU of the
    same four-bar with a coupler that fits)."""
    r = _solve3d(run_cli, tmp_path, TOO_LONG)
    assert r.exit_code == 1, r.output
    line = r.output.strip().splitlines()[-1]
    assert "inconsistent at step 0 (t = 0.0000)" in line and "over-constrained" in line, line
    for name in ("crank_pivot", "crank_coupler", "coupler_rocker", "rocker_pivot"):
        assert f"{name} off by" in line, line  # least squares stretches the loop straight across all
    assert not (tmp_path / "out.h5").exists()
    # at once: the first step only, in fewer linear solves than the whole run of a coupler that fits
    fits = copy.deepcopy(TOO_LONG)
    fits["shapes"]["coupler"]["points"]["b"] = [4, 0, 0]
    failed = solve_spec(validate(MechanismSpec, TOO_LONG, file="test"), stop_at_failure=True, rank=False)
    working = solve_spec(validate(MechanismSpec, fits, file="test"), rank=False)
    assert failed.t.size == 1 and failed.diagnostics.status[0] == 1
    assert failed.iterations.sum() < working.iterations.sum()
    # with --partial every step is solved, and each is inconsistent (not "did not converge")
    r = _solve3d(run_cli, tmp_path, TOO_LONG, "--partial", "--steps", "5")
    assert r.exit_code == 0, r.output
    assert (read_result(tmp_path / "out.h5").diagnostics.status == 1).all()
