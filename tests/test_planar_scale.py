"""Scale-free planar numerics, lock-ups between samples, toggles exactly at a sample (issue 13)."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
import yaml

from linkedit.planar import catalog, simulate
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage
from tests.planar_specs import FOURBAR

SCALES = [1e-10, 1e-100, 1e-300, 1e100, 1e150, 1e160, 1e200, 1e250, 1e300]


def scaled(text: str, k: float) -> LinkageSpec:
    data = yaml.safe_load(text)
    data["joints"] = {n: [x * k, y * k] for n, (x, y) in data["joints"].items()}
    for track in data.get("tracks", {}).values():
        if "at" in track:
            track["at"] = [c * k for c in track["at"]]
    return LinkageSpec.model_validate(data)


@pytest.fixture(scope="module")
def reference():
    return simulate(LinkageSpec.model_validate(yaml.safe_load(FOURBAR)), 90)


@pytest.mark.parametrize("k", SCALES)
def test_four_bar_at_any_scale_is_the_same_motion_scaled(reference, k):
    m = simulate(scaled(FOURBAR, k), 90)
    for got, want in ((m.positions, reference.positions), (m.velocity, reference.velocity),
                      (m.acceleration, reference.acceleration),
                      (m.tracks["coupler_point"].position, reference.tracks["coupler_point"].position)):
        assert np.isfinite(got).all()
        assert np.abs(got / k - want).max() <= 1e-12
    assert np.abs(m.singularity - reference.singularity).max() <= 1e-12


@pytest.mark.parametrize("k", [1e-300, 1e300])
def test_scaled_result_file_and_picture_hold_no_inf_or_nan(run_cli, tmp_path, k):
    path = tmp_path / "tiny.yaml"
    path.write_text(dump_linkage(scaled(FOURBAR, k)))
    out = tmp_path / "r.h5"
    r = run_cli("simulate", path, "-o", out, "--samples", "36", "--svg", tmp_path / "r.svg")
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        for name in ("joints/position", "joints/velocity", "joints/acceleration", "diagnostics/singularity"):
            assert np.isfinite(f[name][()]).all(), name
    svg = (tmp_path / "r.svg").read_text()
    assert "nan" not in svg.lower() and "inf" not in re.sub(r"[a-z-]*inf[a-z]+", "", svg.lower())


@pytest.mark.parametrize("k", [1e-200, 1e200])
def test_slider_and_numeric_group_at_any_scale(k):
    for build in (catalog.slider_crank, catalog.complex_loop):
        spec = build()
        text = dump_linkage(spec)
        ref = simulate(spec, 36)
        m = simulate(scaled(text, k), 36)
        assert np.isfinite(m.positions).all()
        assert np.abs(m.positions / k - ref.positions).max() <= 1e-9 * np.abs(ref.positions).max()


# A four-bar whose crank locks between 166.7° and 193.3° only: |AD| = sqrt(10 − 6 cos θ) exceeds
# coupler + rocker = 3.98 there; 7 samples (0°, 51.4°, …, 154.3°, 205.7°, …) all miss it.
NARROW = """\
name: narrow-lock
units: mm
joints: {O: [0, 0], A: [1, 0], B: [2, 1.7204941150727602], D: [3, 0]}
ground: [O, D]
links: {crank: [O, A], coupler: [A, B], rocker: [D, B]}
motor: {joint: A, pivot: O}
"""


def test_lockup_between_samples_is_not_silent(run_cli, tmp_path):
    path = tmp_path / "narrow.yaml"
    path.write_text(NARROW)
    out = tmp_path / "n.h5"
    r = run_cli("simulate", path, "--samples", "7", "-o", out)
    assert r.exit_code == 1, r.output
    found = re.search(r"motor angles ([\d.]+)°…([\d.]+)°.*joint B", r.output)
    assert found and "between" in r.output, r.output
    edge = np.degrees(np.arccos((10 - 3.98**2) / 6))
    assert abs(float(found.group(1)) - edge) <= 0.5 and abs(float(found.group(2)) - (360 - edge)) <= 0.5
    assert not out.exists()
    r = run_cli("validate", path, "--samples", "7")
    assert r.exit_code == 1 and "LOCK-UP" in r.output


@pytest.mark.parametrize("deg", [0, 42, 91, 133, 222, 301])
def test_toggle_exactly_at_a_sample_is_named_a_toggle_never_too_close(run_cli, tmp_path, deg):
    """Coupler = rocker = 50, crank 20, ground 80: fully stretched at a crank angle of 180°."""
    turn = np.exp(1j * np.radians(deg))
    joints = {n: turn * z for n, z in {"O": 0j, "A": 20 + 0j, "B": 50 + 40j, "D": 80 + 0j}.items()}
    text = ("name: toggle\nunits: mm\njoints: {" + ", ".join(f"{n}: [{float(z.real)!r}, {float(z.imag)!r}]" for n, z in joints.items())
            + "}\nground: [O, D]\nlinks: {crank: [O, A], coupler: [A, B], rocker: [D, B]}\nmotor: {joint: A, pivot: O}\n")
    path = tmp_path / "toggle.yaml"
    path.write_text(text)
    out = tmp_path / "t.h5"
    r = run_cli("simulate", path, "--samples", "4", "-o", out)
    assert "too close together" not in r.output
    assert r.exit_code == 1 and "toggle" in r.output and "joint B" in r.output, r.output
    assert re.search(r"motor angles (\d+\.\d)°…\1°", r.output)
    assert not out.exists()
    r = run_cli("simulate", path, "--samples", "4", "--partial", "-o", out)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        ok = f["diagnostics/assembled"][()]
        assert ok.tolist() == [True, True, False, True]
        assert np.isfinite(f["joints/velocity"][()][ok]).all()


def _moved(dx: float) -> str:
    """The crank-rocker example (75 mm) moved by ``dx`` along x."""
    from tests.conftest import EXAMPLES

    data = yaml.safe_load((EXAMPLES / "crank-rocker.yaml").read_text())
    data["joints"] = {n: [x + dx, y] for n, (x, y) in data["joints"].items()}
    return yaml.safe_dump(data, sort_keys=False)


def test_a_linkage_beyond_double_precision_from_the_origin_is_named_so_not_coinciding(run_cli, tmp_path):
    far, near = tmp_path / "far.yaml", tmp_path / "near.yaml"
    far.write_text(_moved(1e12))  # joints 75 mm apart at 1e12: 1e-9 of the offset is 1000 mm
    r = run_cli("simulate", far, "-o", tmp_path / "far.h5")
    assert r.exit_code == 2 and "coincides" not in r.output, r.output
    assert "lies 1e+12 from the origin: beyond double precision for its size" in r.output
    assert "move it nearer the origin" in r.output
    near.write_text(_moved(1e9))  # 1e-9 of the offset is 1 mm: still simulated
    assert run_cli("simulate", near, "-o", tmp_path / "near.h5", "-n", "12").exit_code == 0
    # joints that are one point for the linkage's own size still coincide, at any offset
    same = tmp_path / "same.yaml"
    same.write_text(_moved(1e12).replace("1000000000075.0", "1000000000000.0"))
    r = run_cli("simulate", same, "-o", tmp_path / "same.h5")
    assert r.exit_code == 2 and "joint 'D' coincides with joint 'O'" in r.output, r.output
