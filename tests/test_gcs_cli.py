"""``linkedit solve3d``: outputs, --from/--track, custom Python constraints and bad input (exit 2)."""

from __future__ import annotations

import json
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
    # an input named as a constraint: the result's /constraint scale and the diagnostics would name two
    "input named as a constraint": (("  drive:", "  rocker_pivot: {type: location, member: rocker, point: pivot, "
                                                 "keyframes: [[2, -3, 0], [2, -3, 0]]}\n  drive:"),
                                    "inputs.rocker_pivot", "'rocker_pivot' is also a constraint's name"),
    "coordinate beyond 1e150": (("position: [-3, 3, 0]", "position: [3e200, 3, 0]"),
                                "members.crank.position[0]", "less than or equal to 1e+150"),
    # an absurd angle was a lock-up ("the step could not be cut small enough") or a run of hours
    "rotation beyond 1000 turns": (("angles_deg: [0, 360]", "angles_deg: [0, 1e300]"),
                                   "inputs.drive.rotation.angles_deg[1]", "less than or equal to 360000"),
    "rotation below -1000 turns": (("angles_deg: [0, 360]", "angles_deg: [-1e300, 360]"),
                                   "inputs.drive.rotation.angles_deg[0]", "greater than or equal to -360000"),
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
        names = [n.decode() for n in f["constraint"][()]]
        cost = f["constraints/cost"][()][:, names.index("circle")]
        assert cost.max() < 1e-18


def test_from_result_adds_tracks_without_solving(run_cli, tmp_path):
    src = _write(tmp_path, CRANK_ROCKER)
    out = tmp_path / "cr.h5"
    assert run_cli("solve3d", src, "-o", out, "--steps", "73").exit_code == 0
    r = run_cli("solve3d", "--from", out, "--track", "coupler:2.5,2.5,0", "--track", "tip=rocker:tip",
                "-o", tmp_path / "more.h5", "--svg", tmp_path / "more.svg", "--view", "xy", "--arrows", "--json")
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "more.h5") as f:
        assert np.allclose(f["tracks/coupler:2.5,2.5,0/position"][()], f["tracks/P/position"][()], atol=1e-12)
        assert np.allclose(f["tracks/tip/position"][()], f["tracks/rocker_tip/position"][()], atol=1e-12)
    svg = (tmp_path / "more.svg").read_text()
    assert "<svg" in svg and 'class="track"' in svg and 'class="velocity"' in svg
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


def _one_line(r, code):
    assert r.exit_code == code, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln]
    assert len(lines) == 1 and "Traceback" not in r.output, r.output
    return lines[0]


BAD_PLUGINS = {
    "raises": ("raise RuntimeError('no luck\\nsecond line')", "RuntimeError: no luck"),
    "nan": ("return np.array([np.nan])", "non-finite"),
    "inf": ("return np.array([np.inf])", "non-finite"),
    "wrong size": ("return np.zeros(2)", "returned 2 values, expected 1"),
}


@pytest.mark.parametrize("case", sorted(BAD_PLUGINS))
def test_misbehaving_python_constraint_is_one_line_exit_1(run_cli, tmp_path, monkeypatch, case):
    body, message = BAD_PLUGINS[case]
    module = f"gcs_bad_plugin_{case.replace(' ', '_')}"
    (tmp_path / f"{module}.py").write_text(f"import numpy as np\n\ndef on_circle(P, Q, t):\n    {body}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    path = _write(tmp_path, CUSTOM.replace("gcs_plugin_for_tests", module))
    r = run_cli("solve3d", path, "-o", tmp_path / "o.h5", "--allow-python", "--steps", "5", "--partial")
    sys.modules.pop(module, None)
    line = _one_line(r, 1)
    assert "custom constraint 'circle' at t = 0.0000" in line and message in line, line
    assert not (tmp_path / "o.h5").exists()


def test_slsqp_fd_solves_the_six_bar(run_cli, tmp_path):
    out = tmp_path / "six.h5"
    r = run_cli("solve3d", EXAMPLES / "3d" / "six-bar.yaml", "--solver", "slsqp-fd", "--steps", "9", "-o", out)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert (f["diagnostics/status"][()] == 0).all()
        import json

        options = json.loads(f.attrs["options"])
        assert options["solver"] == "slsqp-fd" and options["tolerance"] == 1e-6
        assert f["diagnostics/residual"][()].max() < 1e-5  # SLSQP's accuracy: well short of lm's 1e-12


def test_too_many_steps_is_exit_2(run_cli, tmp_path):
    path = _write(tmp_path, CRANK_ROCKER)
    line = _one_line(run_cli("solve3d", path, "--steps", str(10**12), "-o", tmp_path / "o.h5"), 2)
    assert "--steps" in line and "1,000,000" in line
    big = _write(tmp_path, CRANK_ROCKER.replace("steps: 361", "steps: 100000000"), "big.yaml")
    _one_line_error(run_cli("solve3d", big, "-o", tmp_path / "o.h5"), big, "outputs.steps")
    assert not (tmp_path / "o.h5").exists()


@pytest.fixture
def solved_h5(run_cli, tmp_path):
    out = tmp_path / "cr.h5"
    assert run_cli("solve3d", _write(tmp_path, CRANK_ROCKER), "-o", out, "--steps", "9").exit_code == 0
    return out


@pytest.mark.parametrize("option", [("--steps", "20"), ("--solver", "lm"), ("--solver", "slsqp-fd"),
                                    ("--allow-python",), ("--partial",)])
def test_from_rejects_options_that_only_affect_solving(run_cli, solved_h5, option):
    before = solved_h5.read_bytes()
    line = _one_line(run_cli("solve3d", "--from", solved_h5, *option, "--track", "x=coupler:1,0,0"), 2)
    assert "--from" in line and option[0] in line
    assert solved_h5.read_bytes() == before


def test_track_name_collision_is_exit_2(run_cli, solved_h5, tmp_path):
    line = _one_line(run_cli("solve3d", "--from", solved_h5, "--track", "P=coupler:1,0,0", "-o", tmp_path / "n.h5"), 2)
    assert "--track" in line and "'P'" in line
    r = run_cli("solve3d", "--from", solved_h5, "--track", "n=coupler:1,0,0", "--track", "n=rocker:tip",
                "-o", tmp_path / "n.h5")
    assert "'n'" in _one_line(r, 2)
    assert not (tmp_path / "n.h5").exists()
    with h5py.File(solved_h5) as f:  # the file's own track is untouched
        assert np.allclose(f["tracks/P/position"][0], [0.6622, 5.3265, 0.0], atol=1e-4)


def test_overflowing_solve_with_partial_json_is_one_line_exit_1(run_cli, tmp_path):
    text = CRANK_ROCKER.replace(
        "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}",
        "  rocker_pivot: {type: pin, member: rocker, point: pivot, world: [2, -3, 0]}\n"
        "  far: {type: location, member: rocker, point: tip, world: [1e200, 2.75, 0]}")
    path = _write(tmp_path, text)
    r = run_cli("solve3d", path, "-o", tmp_path / "x.h5", "--steps", "5", "--partial", "--json")
    assert r.exit_code == 1 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output
    error = json.loads(r.stdout)["errors"][0]  # with --json, the error is in the report too
    assert error["exit_code"] == 1 and error["text"] in r.stderr
    line = error["message"]
    assert "far" in line and "t = 0.0000" in line and "not finite" in line
    assert not (tmp_path / "x.h5").exists()
