"""Hostile and careless input: every case is one line on stderr and exit 2 (or a clean exit),
never a hang, a traceback, a clobbered input or a replaced device node."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES, report_of

CRANK_ROCKER = EXAMPLES / "crank-rocker.yaml"


def _one_line(r, code: int) -> str:
    assert r.exit_code == code, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln]
    assert len(lines) == 1 and "Traceback" not in r.output, r.output
    return lines[0]


@pytest.fixture
def spec(tmp_path):
    path = tmp_path / "spec.yaml"
    shutil.copy(CRANK_ROCKER, path)
    return path


def _bomb(levels: int = 9) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text, words", [
    (_bomb(), "more than 1,000,000 values"),
    ("name: &a [*a]\n", "refers to itself"),
    ("name: " + "[" * 5000 + "]" * 5000 + "\n", "nested more than"),
    ("name: x\nsamples: " + "9" * 5000 + "\n", "4300 digits"),
    ("name: cr\u0000\n", "not a UTF-8 text file"),
])
def test_hostile_yaml_is_one_line_exit_2(run_cli, tmp_path, text, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    line = _one_line(run_cli("simulate", path, "-o", tmp_path / "o.h5"), 2)
    assert words in line and str(path) in line
    assert not (tmp_path / "o.h5").exists()


def test_a_fifo_and_a_device_as_spec_are_refused_not_read(run_cli, tmp_path):
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    assert "not a regular file" in _one_line(run_cli("simulate", fifo, "-o", tmp_path / "o.h5"), 2)
    assert "not a regular file" in _one_line(run_cli("simulate", "/dev/zero", "-o", tmp_path / "o.h5"), 2)
    assert "not a regular file" in _one_line(run_cli("solve3d", "/dev/zero", "-o", tmp_path / "o.h5"), 2)


def test_a_binary_3d_spec_is_one_line(run_cli, tmp_path):
    path = tmp_path / "m.yaml"
    path.write_bytes(bytes(range(256)))
    assert "not a UTF-8 text file" in _one_line(run_cli("solve3d", path, "-o", tmp_path / "o.h5"), 2)


def test_a_spec_larger_than_the_limit_is_refused(run_cli, tmp_path):
    from linkedit.spec.yamlload import MAX_BYTES

    path = tmp_path / "big.yaml"
    with open(path, "wb") as fh:
        fh.truncate(MAX_BYTES + 1)
    assert "file too large" in _one_line(run_cli("simulate", path, "-o", tmp_path / "o.h5"), 2)


def test_a_byte_order_mark_is_accepted_in_specs_and_csv(run_cli, tmp_path, spec):
    bom = tmp_path / "bom.yaml"
    bom.write_bytes(b"\xef\xbb\xbf" + spec.read_bytes())
    assert run_cli("simulate", bom, "-o", tmp_path / "o.h5").exit_code == 0
    csv = tmp_path / "excel.csv"
    csv.write_bytes(b"\xef\xbb\xbfx,y\r\n0,0\r\n1,0\r\n1,1\r\n0,1\r\n")
    r = run_cli("features", csv, "--json")
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("old, new, field", [
    ("  O: [0, 0]", "  O: [true, 0]", "joints.O[0]"),
    ("name: crank-rocker", "name: crank-rocker\nsamples: true", "samples"),
    ("name: crank-rocker", "name: crank-rocker\nsamples: 100000000000000000000000000000", "samples"),
])
def test_booleans_are_not_numbers_and_huge_sample_counts_are_refused(run_cli, tmp_path, spec, old, new, field):
    spec.write_text(spec.read_text().replace(old, new))
    line = _one_line(run_cli("simulate", spec, "-o", tmp_path / "o.h5"), 2)
    assert field in line


def test_exponent_without_a_dot_reads_as_a_number(run_cli, tmp_path, spec):
    spec.write_text(spec.read_text().replace("  D: [75, 0]", "  D: [7.5e1, 0e0]"))
    r = run_cli("simulate", spec, "-o", tmp_path / "o.h5")
    assert r.exit_code == 0, r.output


def test_a_huge_sample_option_names_the_memory_it_needs(run_cli, spec):
    for command in ("simulate", "validate"):
        line = _one_line(run_cli(command, spec, "--samples", 10**9), 2)
        assert "--samples" in line and "GiB" in line


@pytest.mark.parametrize("args, expected", [
    (["simulate", "{spec}", "--samples", "0"], "--samples: must be ≥ 1"),
    (["simulate", "{spec}", "--samples", "abc"], "--samples: "),
    (["features", "{spec}", "--samples", "7"], "--samples: must be ≥ 8"),
    (["features", "{spec}", "--harmonics", "0"], "--harmonics: must be ≥ 1"),
    (["compare-curves", "a", "b", "--top", "0"], "--top: must be ≥ 1"),
    (["frobnicate"], "No such command"),
    (["simulate", "--bogus", "{spec}"], "No such option: --bogus"),
])
def test_usage_errors_are_one_line_exit_2(run_cli, spec, args, expected):
    line = _one_line(run_cli(*[a.format(spec=spec) for a in args]), 2)
    assert line.startswith("linkedit: error: ") and expected in line


# --- outputs ---------------------------------------------------------------------------------

def _untouched(path, before: bytes) -> None:
    assert path.read_bytes() == before


def test_simulate_never_writes_its_picture_over_its_input(run_cli, tmp_path, spec):
    odd = tmp_path / "spec.svg"  # a spec under a name the SVG writer would accept
    shutil.copy(spec, odd)
    before = odd.read_bytes()
    assert "would overwrite" in _one_line(run_cli("simulate", odd, "-o", tmp_path / "o.h5", "--svg", odd), 2)
    _untouched(odd, before)
    assert not (tmp_path / "o.h5").exists()


def test_an_output_that_is_the_spec_itself_is_refused(run_cli, tmp_path, spec):
    odd = tmp_path / "spec.csv"  # a spec under a name the CSV writer would accept
    shutil.copy(spec, odd)
    before = odd.read_bytes()
    assert "would overwrite" in _one_line(run_cli("simulate", odd, "-o", odd), 2)
    _untouched(odd, before)


def test_a_batch_with_two_specs_of_the_same_name_writes_nothing(run_cli, tmp_path, spec):
    (tmp_path / "b").mkdir()
    other = tmp_path / "b" / "spec.yaml"
    shutil.copy(spec, other)
    line = _one_line(run_cli("simulate", spec, other, "-o", tmp_path / "out"), 2)
    assert "spec.h5" in line
    assert not (tmp_path / "out").exists()


def test_features_and_compare_curves_never_write_over_an_input(run_cli, tmp_path):
    csv = tmp_path / "c.csv"
    csv.write_text("x,y\n0,0\n1,0\n1,1\n0,1\n")
    before = csv.read_bytes()
    assert "would overwrite" in _one_line(run_cli("features", csv, "-o", csv), 2)
    other = tmp_path / "d.csv"
    other.write_text("x,y\n0,0\n2,0\n2,1\n0,1\n")
    assert "would overwrite" in _one_line(run_cli("compare-curves", csv, other, "--svg", other), 2)
    _untouched(csv, before)
    shutil.copytree(EXAMPLES / "curves", tmp_path / "curves")
    copy = tmp_path / "curves" / "pairs.yaml"
    before = copy.read_bytes()
    assert "would overwrite" in _one_line(run_cli("compare-curves", "--learn-weights", copy, "-o", copy), 2)
    _untouched(copy, before)


def test_solve3d_never_writes_over_its_spec(run_cli, tmp_path):
    spec = tmp_path / "m.yaml"
    shutil.copy(EXAMPLES / "3d" / "compound-crank-rocker.yaml", spec)
    before = spec.read_bytes()
    assert "would overwrite" in _one_line(run_cli("solve3d", spec, "-o", spec, "--steps", "3"), 2)
    assert "would overwrite" in _one_line(run_cli("solve3d", spec, "-o", tmp_path / "o.h5", "--svg", spec,
                                                  "--steps", "3"), 2)
    _untouched(spec, before)


@pytest.mark.skipif(os.geteuid() != 0, reason="making a device node needs root")
def test_a_device_node_is_never_replaced(run_cli, tmp_path, spec):
    node = tmp_path / "null.h5"
    os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    assert "not a regular file" in _one_line(run_cli("simulate", spec, "-o", node), 2)
    assert stat.S_ISCHR(node.stat().st_mode)


def test_outputs_are_written_together_or_not_at_all(run_cli, tmp_path, spec):
    afile = tmp_path / "afile"
    afile.write_text("keep")
    line = _one_line(run_cli("simulate", spec, "-o", tmp_path / "o.h5", "--svg", afile / "x.svg"), 2)
    assert "afile is not a folder" in line and "part" not in line
    assert not (tmp_path / "o.h5").exists() and afile.read_text() == "keep"
    assert _one_line(run_cli("simulate", spec, "-o", afile / "o.h5"), 2).endswith("afile is not a folder")


def test_atomic_writes_commit_together_and_leave_no_part_file(tmp_path):
    from linkedit.io.atomic import together, write_text

    (tmp_path / "a.txt").write_text("old")
    with pytest.raises(RuntimeError), together():
        write_text(tmp_path / "a.txt", "new")
        write_text(tmp_path / "b.txt", "new")
        raise RuntimeError
    assert (tmp_path / "a.txt").read_text() == "old" and sorted(os.listdir(tmp_path)) == ["a.txt"]
    with together():
        write_text(tmp_path / "a.txt", "new")
        write_text(tmp_path / "b.txt", "new")
    assert sorted(os.listdir(tmp_path)) == ["a.txt", "b.txt"] and (tmp_path / "a.txt").read_text() == "new"


def test_a_stale_part_file_of_a_dead_process_is_removed(tmp_path):
    from linkedit.io.atomic import write_text

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    stale = tmp_path / f".r.h5.{dead}.abc123.part"
    stale.write_text("half")
    write_text(tmp_path / "r.h5", "x")
    assert sorted(os.listdir(tmp_path)) == ["r.h5"]


def test_a_closed_pipe_is_a_quiet_exit(tmp_path):
    curves = EXAMPLES / "curves" / "foot-paths.yaml"
    p = subprocess.run(f"{sys.executable} -c 'from linkedit.cli import main; main()' compare-curves {curves} | head -1",
                       shell=True, capture_output=True, text=True, timeout=120)
    assert p.stderr == "" and len(p.stdout.splitlines()) == 1


# --- features on odd HDF5 -----------------------------------------------------------------------

@pytest.mark.parametrize("data", [np.array([(1.0, 2.0)] * 5, dtype=[("a", "f8"), ("b", "f8")]).reshape(5, 1),
                                  np.full((5, 2), 1 + 1j), np.array([["a", "b"]] * 5, dtype="S1")])
def test_features_on_a_position_that_is_not_real_numbers(run_cli, tmp_path, data):
    path = tmp_path / "odd.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("tracks/foot/position", data=data)
    _one_line(run_cli("features", f"{path}:foot"), 2)


# --- 3D specs ------------------------------------------------------------------------------------

def test_3d_huge_quaternion_and_axis_are_normalized_without_overflow():
    from linkedit.spec.geometry3d import _nonzero_quaternion, _nonzero_vector

    q = _nonzero_quaternion((1e300, 1e300, 0.0, 0.0))
    assert np.allclose(q, (2**-0.5, 2**-0.5, 0, 0))
    assert _nonzero_vector((0.0, 0.0, 1e308)) == (0.0, 0.0, 1.0)


def test_a_weight_of_1e308_is_refused(run_cli, tmp_path):
    curves = EXAMPLES / "curves" / "foot-paths.yaml"
    assert "--weight" in _one_line(run_cli("compare-curves", curves, "--weight", "points=1e308"), 2)


@pytest.fixture(scope="module")
def gcs_result(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    path = tmp_path_factory.mktemp("gcs") / "g.h5"
    r = CliRunner().invoke(app, ["solve3d", str(EXAMPLES / "3d" / "crank-rocker.yaml"), "-o", str(path),
                                 "--steps", "5"])
    assert r.exit_code == 0, r.output
    return path


@pytest.mark.parametrize("name", ["=coupler:1,0,0", ".=coupler:1,0,0", "..=coupler:1,0,0", "a\0b=coupler:1,0,0"])
def test_track_names_that_cannot_be_hdf5_groups_are_refused(run_cli, tmp_path, gcs_result, name):
    assert "--track" in _one_line(run_cli("solve3d", "--from", gcs_result, "-o", tmp_path / "o.h5",
                                          "--track", name), 2)
    assert not (tmp_path / "o.h5").exists()


def _damaged(src, dst, change):
    shutil.copy(src, dst)
    with h5py.File(dst, "a") as f:
        change(f)
    return dst


def _truncate_rows(f):
    rows = f["members/position"][()]
    del f["members/position"]
    f["members/position"] = rows[:2]


def _first_shape(f):
    return f["members/shapes"][next(iter(f["members/shapes"]))]


@pytest.mark.parametrize("change, words", [
    (lambda f: f.attrs.__setitem__("options", "{not json"), "not a readable gcs result"),
    (lambda f: f.attrs.__setitem__("options", "[1, 2]"), "options"),
    (_truncate_rows, "members/position"),
    (lambda f: _first_shape(f).attrs.__setitem__("lines", '[["no-such-point"]]'), "lines"),
    (lambda f: _first_shape(f).attrs.__setitem__("lines", '{"a": 1}'), "lines"),
])
def test_from_a_damaged_result_is_one_line(run_cli, tmp_path, gcs_result, change, words):
    bad = _damaged(gcs_result, tmp_path / "bad.h5", change)
    assert words in _one_line(run_cli("solve3d", "--from", bad, "-o", tmp_path / "o.h5"), 2)


def test_a_planar_result_labelled_edit_is_one_line(run_cli, tmp_path, spec):
    out = tmp_path / "p.h5"
    assert run_cli("simulate", spec, "-o", out).exit_code == 0
    with h5py.File(out, "a") as f:
        f.attrs["kind"] = "edit"
    _one_line(run_cli("features", out), 2)


def test_a_curve_set_whose_source_is_itself_is_one_line(run_cli, tmp_path):
    path = tmp_path / "loop.yaml"
    path.write_text("curves:\n  - name: me\n    source: loop.yaml:me\n")
    assert "loop" in _one_line(run_cli("features", path), 2)


def test_learning_no_terms_is_one_line(run_cli, tmp_path):
    shutil.copytree(EXAMPLES / "curves", tmp_path / "curves")
    pairs = tmp_path / "curves" / "pairs.yaml"
    pairs.write_text(pairs.read_text() + "terms: []\n")
    assert "terms" in _one_line(run_cli("compare-curves", "--learn-weights", pairs, "-o", tmp_path / "w.json"), 2)


def test_one_weight_option_leaves_the_other_weights_at_1(run_cli):
    import json

    curves = EXAMPLES / "curves" / "foot-paths.yaml"
    r = run_cli("compare-curves", curves, "--weight", "points=2", "--json")
    weights = report_of(r)["weights"]
    assert weights.pop("points") == 2 and set(weights.values()) == {1.0}


def test_a_null_character_in_a_joint_name_is_refused(run_cli, tmp_path, spec):
    spec.write_text(spec.read_text().replace("rocker_tip: {joint: B}", '"rock\\0er": {joint: B}'))
    assert "tracks" in _one_line(run_cli("simulate", spec, "-o", tmp_path / "o.h5"), 2)


# --- edits ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("operation, field", [
    ("displace: {joint: B, to: [1e300, 60]}", "displace.to"),
    ("retarget: {track: coupler_point, translate: [1e300, 0]}", "retarget.translate"),
    ("retarget: {track: coupler_point, scale: [1e300, 1]}", "retarget.scale"),
    ("drag: {track: coupler_point, at: 0.2, by: [0, 1e299]}", "drag.by"),
    ("envelope: {xmax: 1e300}", "envelope"),
    ("transform: {scale: 1e300}", "transform.scale"),
    ("transform: {translate: [1e300, 0]}", "transform.translate"),
    ("displace: {joint: B, to: [60, 60]}\n    terms: {displace: 1e308}", "terms.displace"),
])
def test_edit_targets_and_weights_out_of_reach_are_one_line(run_cli, tmp_path, spec, operation, field):
    script = tmp_path / "s.yaml"
    script.write_text(f"operations:\n  - {operation}\n")
    line = _one_line(run_cli("edit", spec, script, "-o", tmp_path / "out"), 2)
    assert f"operations[0].{field}" in line
    assert not (tmp_path / "out").exists()


def test_editing_a_linkage_that_locks_up_is_one_line_exit_1(run_cli, tmp_path, spec):
    # coupler and rocker of 32 cannot span the 100 between pivot D and the crank pin at 180°
    spec.write_text(spec.read_text().replace("  B: [63, 58.787753826796276]", "  B: [50, 20]")
                    .replace("at: [20.48489846928149, 44.59387691339814]", "at: [40, 15]"))
    script = tmp_path / "s.yaml"
    script.write_text("operations:\n  - displace: {joint: B, to: [50, 25]}\n")
    line = _one_line(run_cli("edit", spec, script, "-o", tmp_path / "out"), 1)
    assert "joint B" in line and "works" in line
    assert not (tmp_path / "out").exists()


def test_a_3d_shape_point_at_1e308_is_one_line(run_cli, tmp_path):
    # found by the fuzz test: the SVG of such a spec held NaN
    spec = tmp_path / "m.yaml"
    spec.write_text((EXAMPLES / "3d" / "spherical-four-bar.yaml").read_text()
                    .replace("a: [0, 0, 1]", "a: [1.0e+308, 0, 1]", 1))
    line = _one_line(run_cli("solve3d", spec, "-o", tmp_path / "o.h5", "--svg", tmp_path / "o.svg"), 2)
    assert "shapes.crank.points.a[0]" in line
    assert not (tmp_path / "o.h5").exists()


def test_a_rotation_axis_of_1e308_turns_the_crank_like_the_unit_axis(run_cli, tmp_path):
    text = (EXAMPLES / "3d" / "crank-rocker.yaml").read_text()
    huge = tmp_path / "huge.yaml"
    huge.write_text(text.replace("rotation: {axis: [0, 0, 1]", "rotation: {axis: [0, 0, 1.0e+308]"))
    unit = tmp_path / "unit.yaml"
    unit.write_text(text)
    for spec in (huge, unit):
        r = run_cli("solve3d", spec, "-o", tmp_path / f"{spec.stem}.h5", "--steps", "9")
        assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "huge.h5") as a, h5py.File(tmp_path / "unit.h5") as b:
        p, q = a["tracks/P/position"][()], b["tracks/P/position"][()]
    assert np.ptp(p, axis=0).max() > 0.1  # the crank turns
    assert np.allclose(p, q, rtol=0, atol=1e-9)


@pytest.mark.parametrize("old, new", [
    ("orientation: {axis: [0, 0, 1], angle_deg: 90}", "orientation: [1.0e-300, 0, 0, 1.0e-300]"),
    ("orientation: {axis: [0, 0, 1], angle_deg: 90}", "orientation: [5.0e-324, 0, 0, 5.0e-324]"),  # subnormal
    ("rotation: {axis: [0, 0, 1]", "rotation: {axis: [0, 0, 1.0e-300]"),
])
def test_a_tiny_quaternion_or_axis_is_normalized_not_called_zero(run_cli, tmp_path, old, new):
    """specs/limits.md: any finite nonzero size is normalized (it was refused below 1e-9 as 'zero')."""
    text = (EXAMPLES / "3d" / "crank-rocker.yaml").read_text()
    tiny, unit = tmp_path / "tiny.yaml", tmp_path / "unit.yaml"
    assert old in text
    tiny.write_text(text.replace(old, new))
    unit.write_text(text.replace(old, old.replace("{axis: [0, 0, 1], angle_deg: 90}", "[1, 0, 0, 1]")))
    for spec in (tiny, unit):
        r = run_cli("solve3d", spec, "-o", tmp_path / f"{spec.stem}.h5", "--steps", "9")
        assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "tiny.h5") as a, h5py.File(tmp_path / "unit.h5") as b:
        assert np.ptp(a["tracks/P/position"][()], axis=0).max() > 0.1  # the crank turns
        assert np.array_equal(a["members/orientation"][()], b["members/orientation"][()])
        assert np.array_equal(a["tracks/P/position"][()], b["tracks/P/position"][()])


def test_an_all_zero_quaternion_is_still_refused(run_cli, tmp_path):
    spec = tmp_path / "zero.yaml"
    spec.write_text((EXAMPLES / "3d" / "crank-rocker.yaml").read_text()
                    .replace("orientation: {axis: [0, 0, 1], angle_deg: 90}", "orientation: [0, 0, 0.0, -0.0]"))
    assert "rocker.orientation: zero quaternion" in _one_line(run_cli("solve3d", spec, "-o", tmp_path / "o.h5"), 2)


def test_a_mechanism_with_nothing_to_solve_is_one_line(run_cli, tmp_path):
    """No constraint, joint or input: refused (exit 2), not ``ValueError: need at least one array``."""
    spec = tmp_path / "free.yaml"
    spec.write_text("name: free\nunits: mm\nmembers:\n  a: {shape: {points: {p: [1, 0, 0]}}}\n"
                    "outputs: {tracks: {tip: {member: a, point: p}}}\n")
    r = run_cli("solve3d", spec, "-o", tmp_path / "o.h5", "--json")
    assert r.exit_code == 2 and report_of(r) is None
    line = _one_line(run_cli("solve3d", spec, "-o", tmp_path / "o.h5"), 2)
    assert line.endswith("free.yaml:1: constraints: nothing holds or drives the members: give at least one "
                         "constraint, joint or input")
    assert sorted(os.listdir(tmp_path)) == ["free.yaml"]


def test_an_edit_whose_picture_path_is_a_folder_writes_nothing(run_cli, tmp_path, spec):
    out = tmp_path / "out"
    (out / "spec-edit.svg").mkdir(parents=True)
    script = tmp_path / "s.yaml"
    script.write_text("operations:\n  - displace: {joint: B, to: [62, 60]}\n")
    line = _one_line(run_cli("edit", spec, script, "-o", out), 2)
    assert "spec-edit.svg: is a folder" in line and ".part" not in line
    assert sorted(p.name for p in out.iterdir()) == ["spec-edit.svg"]


def test_a_track_point_beyond_1e150_is_one_line(run_cli, tmp_path, gcs_result):
    assert "--track" in _one_line(run_cli("solve3d", "--from", gcs_result, "-o", tmp_path / "o.h5",
                                          "--track", "far=coupler:1e308,0,0"), 2)


def test_runtime_warnings_of_a_command_do_not_reach_the_user():
    body = ("import numpy as np\nfrom linkedit.commands.common import guard\n"
            "print(guard(lambda: float(np.float64(1.0) / np.float64(0.0)))())")  # numpy warns "divide by zero"
    p = subprocess.run([sys.executable, "-W", "default", "-c", body], capture_output=True, text=True, timeout=120)
    assert p.stdout.strip() == "inf" and p.stderr == "", p.stderr


def test_a_stroke_far_beyond_the_linkage_is_one_line_not_a_hang(run_cli, tmp_path):
    text = (EXAMPLES / "lifting-arm.yaml").read_text()
    import re

    spec = tmp_path / "lift.yaml"
    spec.write_text(re.sub(r"stroke: \[[^]]*\]", "stroke: [1e9, 25]", text))
    r = run_cli("simulate", spec, "-o", tmp_path / "lift.h5")
    assert r.exit_code == 2 and "motor.stroke" in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "lift.h5").exists()


@pytest.mark.slow  # about 17 s: 1000 members, 6000 unknowns
def test_a_chain_of_a_thousand_welded_members_is_solved(run_cli, tmp_path):
    n = 1000
    lines = ["name: chain", "units: m", "shapes:", "  bar:", "    points: {a: [0, 0, 0], b: [1, 0, 0]}", "members:"]
    lines += [f"  m{k}: {{position: [{k}, 0, 0], shape: bar}}" for k in range(n)]
    lines += ["constraints:", "  root: {type: pin, member: m0, point: a, world: [0, 0, 0]}"]
    lines += [f"  w{k}: {{type: weld, member: m{k - 1}, point: b, other: m{k}, other_point: a}}" for k in range(1, n)]
    lines += ["inputs:", "  drive:", "    type: orientation", "    member: m0",
              "    rotation: {axis: [0, 0, 1], angles_deg: [0, 90]}", "outputs:", "  steps: 5", "  tracks:",
              f"    tip: {{member: m{n - 1}, point: b}}"]
    spec = tmp_path / "chain.yaml"
    spec.write_text("\n".join(lines) + "\n")
    r = run_cli("solve3d", spec, "-o", tmp_path / "chain.h5")
    assert r.exit_code == 0, r.output
    import h5py

    with h5py.File(tmp_path / "chain.h5") as f:
        tip = f["tracks/tip/position"][()]
    np.testing.assert_allclose(tip[0], [n, 0, 0], atol=1e-9 * n)
    np.testing.assert_allclose(tip[-1], [0, n, 0], atol=1e-9 * n)  # the whole chain turned a quarter


@pytest.mark.skipif(os.geteuid() != 0 or shutil.which("setpriv") is None,
                    reason="needs root to run linkedit as an unprivileged user (setpriv)")
def test_an_unreadable_spec_is_one_line_for_a_user_without_override():
    import tempfile

    import linkedit

    nobody = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", sys.executable]
    probe = subprocess.run([*nobody, "-c", "import linkedit; print(linkedit.__file__)"],
                           capture_output=True, text=True, timeout=60)
    if probe.returncode != 0 or probe.stdout.strip() != linkedit.__file__:  # a clone in a private folder (mktemp -d)
        pytest.skip(f"the unprivileged user cannot import this linkedit ({linkedit.__file__}): "
                    f"{(probe.stderr.strip().splitlines() or [probe.stdout.strip()])[-1]}")
    with tempfile.TemporaryDirectory(dir="/tmp") as folder:  # reachable by the unprivileged user
        os.chmod(folder, 0o777)
        spec = Path(folder) / "j.yaml"
        spec.write_text((EXAMPLES / "jansen.yaml").read_text())
        spec.chmod(0)
        r = subprocess.run([*nobody, "-m", "linkedit", "simulate", str(spec), "-o", f"{folder}/o.h5"],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2, r.stderr
        assert "not readable" in r.stderr and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
        assert not (Path(folder) / "o.h5").exists()


@pytest.mark.parametrize("command, example, old, new, where", [
    ("validate", "jansen.yaml", "joints:", "jionts:", "jionts: unknown field (not part of this format); did you mean 'joints'?"),
    ("validate", "invalid/locking-slider-crank.yaml", "{joint: A, pivot: O}", "{joint: A, pviot: O}",
     "motor.pviot: unknown field (not part of this format); did you mean 'pivot'?"),
    ("validate", "invalid/locking-slider-crank.yaml", "piston: {joint: B}", "piston: {jiont: B}",  # a union member's field
     "tracks.piston.jiont: unknown field (not part of this format); did you mean 'joint'?"),
    ("validate", "lengths/jansen.yaml", "length: 15}", "lenght: 15}",
     "links.crank.lenght: unknown field (not part of this format); did you mean 'length'?"),
    ("edit", "edits/jansen-move-knee.yaml", "displace: {joint: C,", "displace: {jont: C,",
     "operations[0].displace.jont: unknown field (not part of this format); did you mean 'joint'?"),
    ("solve3d", "3d/crank-rocker.yaml", "other_point: a}", "othr_point: a}",  # tagged by its type: pin
     "constraints.crank_coupler.othr_point: unknown field (not part of this format); did you mean 'other_point'?"),
    ("solve3d", "3d/crank-rocker.yaml", "angles_deg: [0, 360]", "angle_deg: [0, 360]",
     "inputs.drive.rotation.angle_deg: unknown field (not part of this format); did you mean 'angles_deg'?"),
    ("validate", "jansen.yaml", "units: mm", "units: mm\ncolour: red",  # nothing close: no guess
     "colour: unknown field (not part of this format)"),
    ("validate", "jansen.yaml", "tracks:", "tracks:\n  ankle: {joint: F, jiont: G}",  # 'joint' is given already
     "tracks.ankle.jiont: unknown field (not part of this format)"),
])
def test_a_misspelt_key_gets_a_did_you_mean(run_cli, tmp_path, command, example, old, new, where):
    text = (EXAMPLES / example).read_text()
    assert old in text
    path = tmp_path / Path(example).name
    path.write_text(text.replace(old, new, 1))
    if example.startswith("edits/"):
        shutil.copy(EXAMPLES / "jansen.yaml", tmp_path / "jansen.yaml")
        path.write_text(path.read_text().replace("../jansen.yaml", "jansen.yaml"))
    line = 1 + path.read_text().splitlines().index(next(ln for ln in path.read_text().splitlines()
                                                        if new.splitlines()[-1] in ln))
    assert _one_line(run_cli(command, path, "-o", tmp_path / "out") if command != "validate"
                     else run_cli(command, path), 2) == f"linkedit: error: {path}:{line}: {where}"


def _square(path) -> None:
    path.write_text("x,y\n0,0\n1,0\n1,1\n0,1\n")


def _listing(folder) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_an_output_that_a_run_reads_through_a_folder_or_a_curve_set_is_refused(run_cli, tmp_path):
    """Outputs matched by an input folder, named as a curve set's source, or given as a --query are inputs
    too: exit 2 before anything is written (they were overwritten, or read back by the next run)."""
    d = tmp_path / "d"
    d.mkdir()
    _square(d / "a.csv")
    _square(d / "c.csv")
    (tmp_path / "s.yaml").write_text("curves:\n  - name: c\n    source: d/c.csv\n  - name: a\n    source: d/a.csv\n")
    before = _listing(tmp_path)
    for args in [("features", d, "-o", d / "c.csv"),                    # inside the input folder, read from it
                 ("features", d, "-o", d / "new.csv"),                  # would be read by the next run
                 ("features", tmp_path / "s.yaml", "-o", d / "c.csv"),  # a source the set names
                 ("compare-curves", "--query", d / "a.csv", "--library", d / "c.csv", "-o", d / "a.csv"),
                 ("compare-curves", "--query", tmp_path / "s.yaml:c", "--library", d, "-o", d / "x.csv")]:
        line = _one_line(run_cli(*args), 2)
        assert "would overwrite" in line or "input folder" in line, (args, line)
        assert _listing(tmp_path) == before, args


def test_synthesize_never_writes_into_its_atlas_folder(run_cli, tmp_path):
    atlases = tmp_path / "atlases"
    atlases.mkdir()
    (atlases / "a.h5").write_bytes(b"an atlas")
    _square(tmp_path / "target.csv")
    line = _one_line(run_cli("synthesize", tmp_path / "target.csv", "--atlas", atlases, "-o", atlases), 2)
    assert "input folder" in line and str(atlases) in line
    assert _listing(atlases) == {Path("a.h5"): b"an atlas"}


# --- sizes: refused before the work when they cannot fit ------------------------------------------

def _linkedit(*args, limit: tuple[int, int] | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    """The CLI in a subprocess; ``limit``: (resource, bytes), e.g. the address space (``ulimit -v``)."""
    import resource

    def preexec() -> None:
        if limit is not None:
            resource.setrlimit(limit[0], (limit[1], limit[1]))

    # -B: under a file size limit CPython writes a .pyc cut short (and every later import fails)
    return subprocess.run([sys.executable, "-B", "-c", "from linkedit.cli import main; main()", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, preexec_fn=preexec)


def _refused_line(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    return lines[0]


def test_samples_beyond_a_memory_limit_are_refused_naming_the_memory(tmp_path):
    """Under `ulimit -v` (or a container's cgroup limit) MemAvailable still showed the whole machine:
    `--samples 2000000` passed the check and ended in an ArrayMemoryError traceback."""
    import resource

    r = _linkedit("simulate", EXAMPLES / "jansen.yaml", "--samples", 2_000_000, "-o", tmp_path / "o.h5",
                  limit=(resource.RLIMIT_AS, 2 << 30))
    line = _refused_line(r)
    assert line.startswith("linkedit: error: --samples: 2,000,000 samples of 8 joints would need about 5.7 GiB")
    assert list(tmp_path.iterdir()) == []


def test_features_beyond_the_memory_are_refused_naming_the_memory(tmp_path):
    """`features -n 4096` on many curves was a 16 GiB allocation traceback (crossings are counted for 128
    curves at once over all pairs of points)."""
    import resource

    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    for k in range(20):
        np.savetxt(tmp_path / f"c{k}.csv", np.column_stack([np.cos(t), (1 + k / 10) * np.sin(t)]), delimiter=",",
                   header="x,y", comments="")
    r = _linkedit("features", tmp_path, "-n", 4096, limit=(resource.RLIMIT_AS, 3 << 30))
    need = 20 * 4096 * 4097 * 13 / 2**30
    assert _refused_line(r).startswith(f"linkedit: error: --samples: 20 curves of 4,096 points would need about "
                                       f"{need:.1f} GiB of memory")


def test_a_long_csv_is_written_in_pieces(tmp_path, monkeypatch):
    """`simulate -o o.csv --samples 3000000` hung: the whole table was formatted as text at once (27 GB
    for 3 million rows). Rows are formatted a chunk at a time: writing takes little more memory than the
    table of numbers itself (a third of the text's size here; the text at once was 6 times its size),
    and the file is the same as the text made at once."""
    import tracemalloc

    from linkedit.io import csv_table
    from linkedit.io.planar_csv import columns, motion_csv
    from linkedit.io.planar_out import write_result
    from linkedit.planar import compile_plan, simulate
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model

    motion = simulate(compile_plan(load_model(LinkageSpec, EXAMPLES / "jansen.yaml")), 5000)
    monkeypatch.setattr(csv_table, "CHUNK_ROWS", 100)
    peaks = []
    for write in (lambda: columns(motion), lambda: write_result(tmp_path / "o.csv", motion, spec_text="", options={})):
        tracemalloc.start()
        write()
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    text = (tmp_path / "o.csv").read_text()
    assert peaks[1] < peaks[0] + len(text) / 3, (peaks, len(text))
    assert text == "".join(motion_csv(motion)) and len(text.splitlines()) == 2 + 5000


# --- `linkedit examples DIR`: nothing followed, all or nothing ---------------------------------------

def _planted(tmp_path, kind: str) -> Path:
    """A DIR for `linkedit examples` with something hostile in it (or as it); returns DIR."""
    folder = tmp_path / "ex"
    if kind == "fifo":
        os.mkfifo(folder)
        return folder
    if kind == "dangling":
        folder.symlink_to(tmp_path / "nowhere")
        return folder
    folder.mkdir()
    if kind == "fifo inside":
        os.mkfifo(folder / "jansen.yaml")
    elif kind == "device inside":
        (folder / "jansen.yaml").symlink_to("/dev/zero")
    elif kind == "planted link":
        (folder / "jansen.yaml").symlink_to(tmp_path / "planted.yaml")
    elif kind == "linked folder":
        (folder / "3d").symlink_to(tmp_path / "elsewhere")
    return folder


@pytest.mark.parametrize("kind, words", [
    ("fifo", "ex exists and is not a folder"), ("dangling", "ex is a symbolic link: not followed"),
    ("fifo inside", "jansen.yaml exists and is not a regular file"),
    ("device inside", "jansen.yaml is a symbolic link: not followed"),
    ("planted link", "jansen.yaml is a symbolic link: not followed"),
    ("linked folder", "3d is a symbolic link: not followed"),
])
def test_examples_into_a_hostile_folder_is_one_line_and_follows_nothing(tmp_path, kind, words):
    """A FIFO hung (read to compare), /dev/zero was a MemoryError, links were followed (creating their
    target anywhere)."""
    folder = _planted(tmp_path, kind)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    line = _refused_line(_linkedit("examples", folder, timeout=30))
    assert line.startswith("linkedit: error: ") and words in line
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_examples_are_copied_all_or_nothing(tmp_path):
    """A copy that fails half-way (here the file size limit, as a full disk) leaves no file and no
    folder it made (it left a partial copy)."""
    import resource

    from linkedit.examples import examples_dir

    source = examples_dir()
    first_big = min(p.relative_to(source) for p in source.rglob("*.yaml") if p.stat().st_size > 4096)
    r = _linkedit("examples", tmp_path / "new" / "ex", limit=(resource.RLIMIT_FSIZE, 4096))
    assert r.returncode == 1, r.stderr  # named: the copy that failed, not its example
    assert r.stderr == f"linkedit: error: file size limit reached writing {tmp_path / 'new' / 'ex' / first_big}\n"
    assert list(tmp_path.iterdir()) == []
    assert _linkedit("examples", tmp_path / "ex").returncode == 0
    assert _linkedit("examples", tmp_path / "ex").returncode == 0  # the same files again: nothing differs


def test_a_result_updated_in_place_by_another_process_is_refused(run_cli, tmp_path, gcs_result, monkeypatch):
    """Two `solve3d --from R.h5` updating R.h5 at once lost one update: the second waits for the lock
    (here 0.2 s), then is refused naming the holder; R.h5 is untouched, and the lock is free afterwards."""
    from linkedit.io import atomic

    path = tmp_path / "g.h5"
    shutil.copy(gcs_result, path)
    before = path.read_bytes()
    monkeypatch.setattr(atomic, "LOCK_WAIT", 0.2)
    with atomic.locked(path):
        line = _one_line(run_cli("solve3d", "--from", path, "--track", "p=coupler:1,0,0"), 2)
    assert line == f"linkedit: error: {path}: another linkedit process (pid {os.getpid()}) is updating it; " \
                   "try again when it has finished"
    assert path.read_bytes() == before
    assert run_cli("solve3d", "--from", path, "--track", "p=coupler:1,0,0").exit_code == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.h5"]


def test_a_result_updated_in_place_through_a_link_updates_its_target(run_cli, tmp_path, gcs_result):
    """`solve3d --from LINK` without -o replaced the symbolic link by a new file and left the result it
    pointed to as it was (issue 26 §4): the result is updated, and the link stays a link to it."""
    shutil.copy(gcs_result, tmp_path / "g.h5")
    (tmp_path / "link.h5").symlink_to("g.h5")
    r = run_cli("solve3d", "--from", tmp_path / "link.h5", "--track", "p=coupler:1,0,0")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "link.h5").is_symlink() and os.readlink(tmp_path / "link.h5") == "g.h5"
    with h5py.File(tmp_path / "g.h5") as f:
        assert "p" in f["tracks"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.h5", "link.h5"]


@pytest.mark.parametrize("samples", [10**11])
def test_the_library_simulate_refuses_samples_beyond_memory(monkeypatch, samples):
    """The CLI refused `--samples` beyond memory; the library's (and the notebook's) simulate went on to
    allocate them (10**11: a MemoryError traceback from numpy; fewer: until the machine swapped). Now the
    same InputError, naming the memory, before anything is allocated."""
    from linkedit import notebook, resources
    from linkedit.errors import InputError

    monkeypatch.setattr(resources, "available_memory", lambda: 2 << 30)
    with pytest.raises(InputError, match=f"samples: {samples:,} samples of 8 joints would need about .* of memory"):
        notebook.simulate(EXAMPLES / "jansen.yaml", samples)
