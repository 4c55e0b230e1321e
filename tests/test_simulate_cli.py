"""`linkedit simulate` / `validate` end to end: result layout, batches, exit codes, bad specs."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest

from tests.conftest import report_of

from tests.planar_specs import FOURBAR, LOCKING, TRIAD


@pytest.fixture
def four_bar(tmp_path):
    path = tmp_path / "four-bar.yaml"
    path.write_text(FOURBAR)
    return path


def test_result_file_layout(run_cli, four_bar, tmp_path):
    out = tmp_path / "r.h5"
    r = run_cli("simulate", four_bar, "-o", out, "--samples", "90")
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f.attrs["format_version"] == "3" and f.attrs["kind"] == "planar"
        assert f.attrs["units"] == "mm" and f.attrs["generator"].startswith("linkedit ")
        assert f.attrs["spec"] == FOURBAR
        assert f["t"].shape == (90,) and f["motor_angle"].shape == (90,)
        assert [s.decode() for s in f["joint"][()]] == ["O", "A", "B", "D"]
        for name in ("position", "velocity", "acceleration"):
            assert f[f"joints/{name}"].shape == (90, 4, 2)
        assert f["links/pairs"].shape == (3, 2)
        assert f["tracks/coupler_point/position"].shape == (90, 2)
        assert f["tracks/tip/velocity"].shape == (90, 2)
        assert f["rules/joints"].shape == (1, 3) and f["rules/level"].shape == (1,)
        assert f["diagnostics/singularity"].shape == (90, 1)
        assert f["diagnostics/assembled"][()].all()
        assert np.isfinite(f["joints/position"][()]).all()


def test_batch_writes_one_result_each_and_fails_if_any_failed(run_cli, four_bar, tmp_path):
    bad = tmp_path / "locks.yaml"
    bad.write_text(LOCKING)
    out = tmp_path / "out"
    r = run_cli("simulate", four_bar, bad, "-o", out)
    assert r.exit_code == 1
    assert (out / "four-bar.h5").is_file() and not (out / "locks.h5").exists()
    assert "1 of 2 specs simulated, 1 failed" in r.output
    assert not list(out.glob(".*part"))  # no temporary left behind


def test_lockup_exit_1_names_joint_and_angle_and_writes_nothing(run_cli, tmp_path):
    bad = tmp_path / "locks.yaml"
    bad.write_text(LOCKING)
    out = tmp_path / "x.h5"
    r = run_cli("simulate", bad, "-o", out)
    assert r.exit_code == 1
    assert re.search(r"motor angles [\d.]+°…[\d.]+°: joint B", r.output)
    assert not out.exists()
    r = run_cli("simulate", bad, "-o", out, "--partial")
    assert r.exit_code == 0 and out.exists()
    with h5py.File(out) as f:
        ok = f["diagnostics/assembled"][()]
        assert not ok.all() and np.isnan(f["joints/position"][()][~ok]).all()
        assert "joint B" in f["diagnostics"].attrs["lockups"]


def test_complex_loop_that_locks_up_exits_1_naming_the_group_and_angles(run_cli, tmp_path):
    path = tmp_path / "triad.yaml"
    path.write_text(TRIAD)
    out = tmp_path / "t.h5"
    r = run_cli("simulate", path, "-o", out)
    assert r.exit_code == 1 and "Traceback" not in r.output, r.output
    assert re.search(r"motor angles within [\d.]+°…[\d.]+° \(the assembled samples either side; more samples "
                     r"narrow it\): the numeric group T1, T2, T3 cannot be assembled", r.output), r.output
    assert not out.exists()


def test_validate_prints_levels_and_mobility(run_cli, four_bar):
    r = run_cli("validate", four_bar)
    assert r.exit_code == 0
    assert "mobility 1" in r.output and "level 1: B ← (A, D) dyad" in r.output


def test_validate_names_the_spec_of_a_linkage_that_cannot_move(run_cli, four_bar, tmp_path):
    """An over-constrained linkage in a batch: validate's error line names its file, as simulate's does
    (it printed 'linkedit: error: the linkage cannot move: …' with no file)."""
    braced = tmp_path / "braced.yaml"
    braced.write_text(FOURBAR.replace("  rocker: [D, B]", "  rocker: [D, B]\n  brace: [O, B]"))
    r = run_cli("validate", four_bar, braced)
    assert r.exit_code == 1, r.output
    assert f"linkedit: error: {braced}: the linkage cannot move: it is over-constrained" in r.output, r.output
    simulated = run_cli("simulate", braced, "-o", tmp_path / "b.h5")
    assert f"linkedit: error: {braced}: the linkage cannot move: it is over-constrained" in simulated.output


def test_json_summary(run_cli, four_bar, tmp_path):
    import json

    r = run_cli("simulate", four_bar, "-o", tmp_path / "a.h5", "--json")
    data = report_of(r)
    assert data[0]["samples"] == 360 and data[0]["assembled"] is True


BAD = [
    ("malformed YAML", lambda s: s.replace("  A: [1, 0]", "  A: [1, 0"), r"^x\.yaml:\d+: malformed YAML"),
    ("unknown joint", lambda s: s.replace("rocker: [D, B]", "rocker: [D, Q]"), r"^x\.yaml:12: links\.rocker\[1\]: unknown joint 'Q'"),
    ("duplicate joint", lambda s: s.replace("  D: [3, 0]", "  D: [3, 0]\n  A: [5, 5]"), r"^x\.yaml:8: joints\.A: duplicate key 'A'"),
    ("link with one joint", lambda s: s.replace("crank: [O, A]", "crank: [O]"), r"^x\.yaml:10: links\.crank: a link needs at least 2 joints"),
    ("coincident joints", lambda s: s.replace("D: [3, 0]", "D: [1, 0]"), r"^x\.yaml:7: joints\.D: joint 'D' coincides with joint 'A'"),
    ("NaN coordinate", lambda s: s.replace("B: [2.2, 2.1]", "B: [.nan, 2.1]"), r"^x\.yaml:6: joints\.B\[0\]: .*finite"),
    ("motor pivot not on ground", lambda s: s.replace("pivot: O}", "pivot: B}"), r"^x\.yaml:13: motor\.pivot: the motor pivot 'B' is not a ground joint"),
    ("unknown track link", lambda s: s.replace("link: coupler", "link: nope"), r"^x\.yaml:16: tracks\.coupler_point\.link: unknown link 'nope'"),
    ("extra key", lambda s: s + "colour: red\n", r"^x\.yaml:17: colour: unknown field"),
    ("missing field", lambda s: s.replace("units: mm\n", ""), r"^x\.yaml:1: units: required field is missing"),
]


@pytest.mark.parametrize("case,mutate,pattern", BAD, ids=[b[0] for b in BAD])
def test_bad_spec_one_line_exit_2(run_cli, tmp_path, monkeypatch, case, mutate, pattern):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x.yaml").write_text(mutate(FOURBAR))
    r = run_cli("simulate", "x.yaml", "-o", "r.h5")
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.output
    message = lines[0].removeprefix("linkedit: error: ")
    assert re.search(pattern, message), message
    assert not (tmp_path / "r.h5").exists()


def test_missing_file_exit_2(run_cli, tmp_path):
    r = run_cli("simulate", tmp_path / "nope.yaml", "-o", tmp_path / "r.h5")
    assert r.exit_code == 2 and "cannot read file" in r.output


def test_result_file_given_as_spec_is_one_line_exit_2(run_cli, four_bar, tmp_path):
    out = tmp_path / "r.h5"
    assert run_cli("simulate", four_bar, "-o", out).exit_code == 0
    for command in (("simulate", out, "-o", tmp_path / "again.h5"), ("validate", out), ("edit", four_bar, out)):
        r = run_cli(*command)
        assert r.exit_code == 2, r.output
        assert "not a UTF-8 text file" in r.output and "Traceback" not in r.output


def test_json_output_has_no_nan():
    import io
    import json
    from contextlib import redirect_stdout

    from linkedit.commands.common import print_json

    buf = io.StringIO()
    with redirect_stdout(buf):
        print_json({"a": float("nan"), "b": [np.inf, 1.5], "c": np.float64(2.0)})
    assert json.loads(buf.getvalue()) == {"a": None, "b": [None, 1.5], "c": 2.0}


@pytest.mark.parametrize("engine", ["symbolic", "numeric"])
def test_rigid_rules_read_90_degrees_of_transmission(run_cli, tmp_path, engine):
    """A welded triangle (the Watt six-bar's bell crank) has no transmission angle: result.h5 gives 90° there
    (its d_s is 1), and each dyad's angle at its rebuilt joint k between k→i and k→j, measured here."""
    out = tmp_path / "w.h5"
    r = run_cli("simulate", "examples/watt-six-bar.yaml", "-n", "72", "--engine", engine, "-o", out)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        rigid, rules = f["rules/rigid"][()], f["rules/joints"][()]
        mu, ds = f["diagnostics/transmission_angle"][()], f["diagnostics/singularity"][()]
        z = f["joints/position"][()] @ np.array([1.0, 1j])
    assert rigid.any() and (~rigid).any()
    assert np.all(mu[:, rigid] == np.pi / 2) and np.all(ds[:, rigid] == 1.0)
    i, j, k = (z[:, rules[~rigid, c]] for c in range(3))
    assert np.allclose(mu[:, ~rigid], np.abs(np.angle((i - k) / (j - k))), rtol=0, atol=1e-9)
