"""Exact member accelerations of solve3d (J a = −γ at each solved pose): against central
differences of the exact velocities at fine steps, and against closed forms (an offset
slider-crank's slider, a luffing arm driven by a linear actuator) read back from the file."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import yaml

from linkedit.gcs import quaternions as quat
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.gcs.tolerances import Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests.conftest import EXAMPLES
from tests.test_gcs_vocabulary import _luffing_arm, _slider_crank

DELTA = 1e-5  #: half-gap of the velocity differences (unit t)
TIMES = (0.13, 0.41, 0.77)


def _differences(data: dict) -> tuple[np.ndarray, np.ndarray, float]:
    """Exact accelerations (n, M, 6) at TIMES, central differences (n, M, 6) of the exact
    velocities solved at TIMES ± DELTA, and the mechanism's size."""
    system, _ = compile_mechanism(validate(MechanismSpec, data, file="test"))
    t = np.concatenate([[0.0], np.ravel([[s - DELTA, s, s + DELTA] for s in TIMES])])
    run = solve_run(system, t, Options(accelerations=True))
    assert (run.status == 0).all()
    v = run.velocity[1:].reshape(len(TIMES), 3, -1, 6)
    a = run.acceleration[1:].reshape(len(TIMES), 3, -1, 6)[:, 1]
    return a, (v[:, 2] - v[:, 0]) / (2 * DELTA), system.length_scale


def _rssr_offset() -> dict:
    """examples/3d/rssr.yaml with the coupler's member origin off the line of its balls (the same
    world geometry): the free spin's null direction then moves the origin too, and turns as the
    coupler moves, so the acceleration has a part along it (P a = −Ṗ v)."""
    data = load_yaml(EXAMPLES / "3d" / "rssr.yaml")[0]
    o = np.array([0.0, 1.5, 0.7])
    shape = data["shapes"]["coupler"]
    shape["points"] = {k: (np.array(v) + o).tolist() for k, v in shape["points"].items()}
    c = data["members"]["coupler"]
    axis = np.array(c["orientation"]["axis"], dtype=float)
    q = quat.from_axis_angle(axis / np.linalg.norm(axis), np.radians(c["orientation"]["angle_deg"]))
    c["position"] = (np.array(c["position"]) - quat.rotate(q, o)).tolist()
    return data


@pytest.mark.parametrize("name", ["crank-rocker", "rssr", "rssr-offset", "spatial-slider-crank", "bennett",
                                  "six-bar", "luffing-arm"])
def test_accelerations_are_the_derivatives_of_the_exact_velocities(name):
    """To 1e-6 of the mechanism's acceleration (they agree to ~1e-8; the differences' own error
    is ~δ²); the RSSR's coupler spin is free, and the luffing arm is driven by a linear
    (distance) input."""
    builders = {"luffing-arm": _luffing_arm, "rssr-offset": _rssr_offset}
    data = builders[name]() if name in builders else load_yaml(EXAMPLES / "3d" / f"{name}.yaml")[0]
    a, fd, L = _differences(data)
    # relative to the mechanism's acceleration: linear, and angular times its size L
    scale = max(np.abs(fd[..., :3]).max(), L * np.abs(fd[..., 3:]).max())
    assert np.abs(a[..., :3] - fd[..., :3]).max() < 1e-6 * scale
    assert L * np.abs(a[..., 3:] - fd[..., 3:]).max() < 1e-6 * scale


def _solve_file(run_cli, tmp_path, data: dict, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """t and the member accelerations (T, M, 6) of a CLI solve, read from the result file."""
    spec = tmp_path / "m.yaml"
    spec.write_text(yaml.safe_dump(data, sort_keys=False))
    r = run_cli("solve3d", spec, "-o", tmp_path / "m.h5", "--steps", steps, "--accelerations")
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "m.h5") as f:
        assert f["members/acceleration"].attrs["units"] == "m"  # per unit t², the quantity's own unit (specs/gcs-hdf5.md)
        return f["t"][()], np.concatenate([f["members/acceleration"][()], f["members/angular_acceleration"][()]], -1)


def test_slider_crank_acceleration_matches_its_closed_form(run_cli, tmp_path):
    """x = cos θ + S, S = √(L² − (sin θ − e)²), θ = 2πt: ẍ = (2π)² [−cos θ − (cos²θ − g sin θ)/S
    − g² cos²θ / S³], g = sin θ − e."""
    t, acc = _solve_file(run_cli, tmp_path, _slider_crank(True), 37)
    theta, e, L = 2 * np.pi * t, 0.5, 3.0
    g = np.sin(theta) - e
    S = np.sqrt(L**2 - g**2)
    want = (2 * np.pi) ** 2 * (-np.cos(theta) - (np.cos(theta) ** 2 - g * np.sin(theta)) / S
                               - g**2 * np.cos(theta) ** 2 / S**3)
    slider = acc[:, 2]
    assert np.abs(slider[:, 0] - want).max() < 1e-9 * np.abs(want).max()
    assert np.abs(slider[:, 1:]).max() < 1e-9 * np.abs(want).max()  # on its line, never turning
    assert np.abs(acc[:, 0, 3:]).max() < 1e-9  # the crank turns at a constant rate


def test_linear_actuator_angular_acceleration_matches_its_closed_form(run_cli, tmp_path):
    """θ = arccos c − β, c = (6 − d²)/(2√5), d = 1.5 + 1.3 t: θ̈ = −c̈/√(1−c²) − ċ² c/(1−c²)^{3/2}."""
    t, acc = _solve_file(run_cli, tmp_path, _luffing_arm(), 41)
    d, rate = 1.5 + 1.3 * t, 1.3
    c = (6.0 - d**2) / (2 * np.sqrt(5.0))
    dc, ddc = -d * rate / np.sqrt(5.0), -rate**2 / np.sqrt(5.0)
    want = -ddc / np.sqrt(1 - c**2) - dc**2 * c / (1 - c**2) ** 1.5
    assert np.abs(acc[:, 0, 5] - want).max() < 1e-9 * np.abs(want).max()
    assert np.abs(acc[:, 0, :5]).max() < 1e-9 * np.abs(want).max()  # the pivot holds, the axis stays z


def test_accelerations_are_written_only_when_asked_and_kept_by_from(run_cli, tmp_path):
    """Without --accelerations the file has none (nothing is made up); --from keeps them; they
    are refused with --from (nothing is solved)."""
    spec = EXAMPLES / "3d" / "crank-rocker.yaml"
    assert run_cli("solve3d", spec, "-o", tmp_path / "plain.h5", "--steps", 9).exit_code == 0
    with h5py.File(tmp_path / "plain.h5") as f:
        assert "acceleration" not in f["members"] and "angular_acceleration" not in f["members"]
    assert run_cli("solve3d", spec, "-o", tmp_path / "acc.h5", "--steps", 9, "--accelerations").exit_code == 0
    r = run_cli("solve3d", "--from", tmp_path / "acc.h5", "-o", tmp_path / "again.h5", "--track", "new=coupler:1,0,0")
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "acc.h5") as f, h5py.File(tmp_path / "again.h5") as g:
        for key in ("members/acceleration", "members/angular_acceleration"):
            assert np.array_equal(f[key][()], g[key][()]) and np.abs(f[key][()]).max() > 1.0
    r = run_cli("solve3d", "--from", tmp_path / "acc.h5", "--accelerations")
    assert r.exit_code == 2 and "--accelerations" in r.output
