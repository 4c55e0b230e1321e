"""Batches keep going past a bad file and name it: validate, features, a library folder."""

from __future__ import annotations

import json

import numpy as np

from tests.conftest import EXAMPLES


def _ellipse_csv(path, a, b):
    t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    path.write_text("x,y\n" + "".join(f"{float(a * np.cos(s))!r},{float(b * np.sin(s))!r}\n" for s in t))


def test_validate_reports_every_spec_and_names_the_bad_one(run_cli, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: broken\n")
    r = run_cli("validate", EXAMPLES / "crank-rocker.yaml", bad, EXAMPLES / "klann.yaml")
    assert r.exit_code == 2
    assert "crank-rocker.yaml: crank-rocker" in r.output and "klann.yaml: klann-leg" in r.output
    assert f"linkedit: error: {bad}:" in r.output
    r = run_cli("validate", EXAMPLES / "crank-rocker.yaml", bad, "--json")
    reports = json.loads(r.stdout)
    assert [("error" in x) for x in reports] == [False, True] and reports[1]["exit_code"] == 2


def test_features_skip_a_bad_file_and_exit_2(run_cli, tmp_path):
    good, bad = tmp_path / "good.csv", tmp_path / "bad.csv"
    _ellipse_csv(good, 3, 1)
    bad.write_text("x,y\n1,oops\n")
    out = tmp_path / "f.csv"
    r = run_cli("features", good, bad, "-o", out)
    assert r.exit_code == 2
    assert str(bad) in r.output and "(skipped)" in r.output
    assert len(out.read_text().splitlines()) == 2  # header + the good curve


def test_a_library_folder_with_a_bad_file_warns_and_ranks_the_rest(run_cli, tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    for n, (a, b) in enumerate([(3, 1), (2, 1), (1, 1)]):
        _ellipse_csv(lib / f"e{n}.csv", a, b)
    (lib / "junk.csv").write_text("not, numbers\nat, all\n")
    query = tmp_path / "q.csv"
    _ellipse_csv(query, 3, 1.05)
    r = run_cli("compare-curves", "--query", query, "--library", lib, "--json")
    assert r.exit_code == 0, r.output
    assert "junk.csv" in r.stderr and "warning" in r.stderr
    ranking = json.loads(r.stdout)["ranking"]
    assert [x["curve"] for x in ranking][0] == "e0" and len(ranking) == 3
