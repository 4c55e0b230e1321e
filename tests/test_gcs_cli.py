"""``linkedit solve3d``: outputs, --from/--track, custom Python constraints and bad input (exit 2)."""

from __future__ import annotations

import sys
import textwrap

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES

CRANK_ROCKER = (EXAMPLES / "3d" / "crank-rocker.yaml").read_text()


def _write(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _one_line_error(r, path, field, code=2):
    assert r.exit_code == code, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln]
    assert len(lines) == 1, r.output
    assert "Traceback" not in r.output
    assert f"{path}:" in lines[0] and field in lines[0], lines[0]
    return lines[0]


BAD = {
    "zero quaternion": (("orientation: {axis: [0, 0, 1], angle_deg: 90}", "orientation: [0, 0, 0, 0]"),
                        "members.rocker.orientation", "zero quaternion"),
    "unknown member": (("other: coupler, other_point: a}", "other: coupling, other_point: a}"),
                       "constraints.crank_coupler.other", "unknown member 'coupling'"),
    "unknown point": (("point: tip, other: coupler", "point: toe, other: coupler"),
                      "constraints.crank_coupler.point", "unknown point 'toe'"),
    "window outside [0, 1]": (("    member: crank\n    rotation:", "    member: crank\n    window: [0.5, 1.5]\n    rotation:"),
                              "inputs.drive.window", "window"),
    "steps < 2": (("steps: 361", "steps: 1"), "outputs.steps", "greater than or equal to 2"),
    "unknown field": (("units: m", "units: m\ncolour: red"), "colour", "unknown field"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_spec_is_one_line_exit_2(run_cli, tmp_path, case):
    (old, new), field, message = BAD[case]
    assert old in CRANK_ROCKER
    path = _write(tmp_path, CRANK_ROCKER.replace(old, new, 1))
    line = _one_line_error(run_cli("solve3d", path, "-o", tmp_path / "out.h5"), path, field)
    assert message in line
    assert not (tmp_path / "out.h5").exists()


def test_line_number_points_at_the_field(run_cli, tmp_path):
    text = CRANK_ROCKER.replace("orientation: {axis: [0, 0, 1], angle_deg: 90}", "orientation: [0, 0, 0, 0]")
    path = _write(tmp_path, text)
    line_no = next(i for i, ln in enumerate(text.splitlines(), 1) if "[0, 0, 0, 0]" in ln)
    line = _one_line_error(run_cli("solve3d", path), path, "members.rocker.orientation")
    assert line.split(": ")[1].startswith(f"{path}:{line_no}") or f"{path}:{line_no}:" in line


PLUGIN = """
import numpy as np

def on_circle(P, Q, t):
    '''Keep member 0's origin at distance 5.75 from (2, -3, 0) (the rocker length).'''
    return np.array([np.linalg.norm(P[0] - [2.0, -3.0, 0.0]) - 5.75])
"""

CUSTOM = CRANK_ROCKER.replace(
    "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}",
    "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}\n"
    "  circle: {type: custom, python: 'gcs_plugin_for_tests:on_circle', members: [spinner], size: 1}\n"
    "  spinner_on_rocker: {type: location, member: spinner, point: [0, 0, 0], other: rocker, other_point: tip}"
).replace("members:\n", "members:\n  spinner: {position: [2, 2.75, 0]}\n", 1)


def test_python_constraint_needs_allow_python(run_cli, tmp_path):
    path = _write(tmp_path, CUSTOM)
    line = _one_line_error(run_cli("solve3d", path, "-o", tmp_path / "o.h5"), path, "constraints.circle.python")
    assert "--allow-python" in line


def test_python_constraint_runs_with_allow_python(run_cli, tmp_path, monkeypatch):
    (tmp_path / "gcs_plugin_for_tests.py").write_text(textwrap.dedent(PLUGIN))
    monkeypatch.syspath_prepend(str(tmp_path))
    path = _write(tmp_path, CUSTOM)
    out = tmp_path / "o.h5"
    r = run_cli("solve3d", path, "-o", out, "--allow-python", "--steps", "13")
    sys.modules.pop("gcs_plugin_for_tests", None)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert (f["diagnostics/status"][()] == 0).all()
        names = [n.decode() for n in f["constraints/names"][()]]
        cost = f["constraints/cost"][()][:, names.index("circle")]
        assert cost.max() < 1e-18


def test_from_result_adds_tracks_without_solving(run_cli, tmp_path):
    src = _write(tmp_path, CRANK_ROCKER)
    out = tmp_path / "cr.h5"
    assert run_cli("solve3d", src, "-o", out, "--steps", "73").exit_code == 0
    r = run_cli("solve3d", "--from", out, "--track", "coupler:2.5,2.5,0", "--track", "tip=rocker:tip",
                "-o", tmp_path / "more.h5", "--svg", tmp_path / "more.svg", "--view", "xy", "--velocity", "--json")
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "more.h5") as f:
        assert np.allclose(f["tracks/coupler:2.5,2.5,0/position"][()], f["tracks/P/position"][()], atol=1e-12)
        assert np.allclose(f["tracks/tip/position"][()], f["tracks/rocker_tip/position"][()], atol=1e-12)
    svg = (tmp_path / "more.svg").read_text()
    assert svg.startswith("<svg") and "polyline" in svg and "marker-end" in svg
    bad = run_cli("solve3d", "--from", out, "--track", "nobody:1,2,3")
    assert bad.exit_code == 2 and "unknown member 'nobody'" in bad.output and "Traceback" not in bad.output
    bad = run_cli("solve3d", "--from", out, "--track", "coupler:1,2")
    assert bad.exit_code == 2 and "--track" in bad.output


def test_inconsistent_spec_exit_1_names_the_constraint(run_cli, tmp_path):
    text = CRANK_ROCKER.replace(
        "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}",
        "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}\n"
        "  stuck: {type: location, member: rocker, point: tip, world: [2, 2.75, 0]}")
    path = _write(tmp_path, text)
    r = run_cli("solve3d", path, "-o", tmp_path / "x.h5", "--steps", "9")
    assert r.exit_code == 1 and "stuck" in r.output and "inconsistent" in r.output and "t = " in r.output
    assert not (tmp_path / "x.h5").exists()
    r = run_cli("solve3d", path, "-o", tmp_path / "x.h5", "--steps", "9", "--partial")
    assert r.exit_code == 0 and "inconsistent" in r.output
    with h5py.File(tmp_path / "x.h5") as f:
        assert (f["diagnostics/status"][()] == 1).any()


@pytest.mark.parametrize("option", [("--steps", "1"), ("--solver", "magic"), ("--view", "top")])
def test_bad_options_exit_2(run_cli, tmp_path, option):
    r = run_cli("solve3d", _write(tmp_path, CRANK_ROCKER), *option)
    assert r.exit_code == 2 and option[0] in r.output and "Traceback" not in r.output
