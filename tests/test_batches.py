"""Batches keep going past a bad file and name it: validate, features, a library folder."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import EXAMPLES, report_of


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
    import json

    data = json.loads(r.stdout)
    assert data["exit_code"] == r.exit_code == 2 and not data["ok"]
    assert [x["spec"] for x in data["result"]] == [str(EXAMPLES / "crank-rocker.yaml")]
    assert [(e["input"], e["file"], e["exit_code"]) for e in data["errors"]] == [(str(bad), str(bad), 2)]


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
    ranking = report_of(r)["queries"][0]["ranking"]
    assert [x["curve"] for x in ranking][0] == "e0" and len(ranking) == 3


def test_csv_curves_as_spreadsheets_export_them(run_cli, tmp_path):
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    x, y = 3 * np.cos(t), np.sin(t)
    plain = tmp_path / "plain.csv"
    plain.write_text("x,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, y)))
    sheet = tmp_path / "sheet.csv"  # European spreadsheet: ';' separators, decimal commas, an index, units
    sheet.write_text("// exported from a spreadsheet\nPoint;X (mm);Y [mm]\n" + "".join(
        f"{n};{float(a)!r};{float(b)!r}\n".replace(".", ",") for n, (a, b) in enumerate(zip(x, y))))
    tabbed = tmp_path / "tabbed.csv"
    tabbed.write_text("# PMKS+ path\nindex\tTime\tX (mm)\tY (mm)\n" + "".join(
        f"{n}\t{n}\t{float(a)!r}\t{float(b)!r}\n" for n, (a, b) in enumerate(zip(x, y))))
    r = run_cli("features", plain, sheet, tabbed, "--json")
    assert r.exit_code == 0, r.output
    rows = report_of(r)
    for other in rows[1:]:
        for key in ("length", "area"):
            assert other[key] == pytest.approx(rows[0][key], rel=1e-12)
    bad = tmp_path / "bad.csv"
    bad.write_text("Point;X (mm);Speed\n1;2;3\n")
    r = run_cli("features", bad)
    assert r.exit_code == 2 and "unknown column 'speed'" in r.output


def test_compare_curves_writes_matrices_and_rankings_to_files(run_cli, tmp_path):
    import csv

    import h5py

    sets = EXAMPLES / "curves" / "foot-paths.yaml"
    ref = report_of(run_cli("compare-curves", sets, "--json"))
    out = tmp_path / "m.csv"
    r = run_cli("compare-curves", sets, "-o", out)
    assert r.exit_code == 0, r.output
    rows = list(csv.reader(out.read_text().splitlines()))
    assert rows[0] == ["curve", *ref["curves"]] and [x[0] for x in rows[1:]] == ref["curves"]
    assert np.array([[float(v) for v in x[1:]] for x in rows[1:]]).tolist() == ref["distance"]  # full precision
    h5 = tmp_path / "m.h5"
    assert run_cli("compare-curves", sets, "-o", h5).exit_code == 0
    with h5py.File(h5) as f:
        assert f["values"].shape == (9, 9) and list(f["curve"].asstr()[()]) == ref["curves"]
    r = run_cli("compare-curves", sets, "-o", "-")
    assert r.exit_code == 0 and r.stdout.splitlines()[0].startswith("curve,")
    r = run_cli("compare-curves", sets, "-o", tmp_path / "m.txt")
    assert r.exit_code == 2 and "unknown output format" in r.output
    lib = tmp_path / "lib"
    lib.mkdir()
    for n, (a, b) in enumerate([(3, 1), (2, 1), (1, 1)]):
        _ellipse_csv(lib / f"e{n}.csv", a, b)
    q1, q2 = tmp_path / "q1.csv", tmp_path / "q2.csv"
    _ellipse_csv(q1, 3, 1.05)
    _ellipse_csv(q2, 1.02, 1)
    rank = tmp_path / "rank.csv"
    r = run_cli("compare-curves", "--query", q1, "--query", q2, "--library", lib, "-o", rank)
    assert r.exit_code == 0, r.output
    table = list(csv.reader(rank.read_text().splitlines()))
    assert table[0] == ["curve", "q1", "q2"] and len(table) == 4
    d = {row[0]: (float(row[1]), float(row[2])) for row in table[1:]}
    assert min(d, key=lambda k: d[k][0]) == "e0" and min(d, key=lambda k: d[k][1]) == "e2"
    both = report_of(run_cli("compare-curves", "--query", q1, "--query", q2, "--library", lib, "--json"))
    assert [x["ranking"][0]["curve"] for x in both["queries"]] == ["e0", "e2"]


def test_outputs_follow_the_suffix_for_features_and_solve3d(run_cli, tmp_path):
    good = tmp_path / "good.csv"
    _ellipse_csv(good, 3, 1)
    r = run_cli("features", good, "-o", "-")
    assert r.exit_code == 0 and r.stdout.startswith("name,") and len(r.stdout.splitlines()) == 2
    r = run_cli("features", good, "-o", tmp_path / "f.xlsx")
    assert r.exit_code == 2 and "unknown output format '.xlsx'" in r.output
    r = run_cli("solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "-o", tmp_path / "s.csv")
    assert r.exit_code == 2 and "unknown output format '.csv'" in r.output and not (tmp_path / "s.csv").exists()


def test_quiet_prints_only_errors(run_cli, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: broken\n")
    r = run_cli("validate", "-q", EXAMPLES / "jansen.yaml")
    assert r.exit_code == 0 and r.output == ""
    r = run_cli("simulate", "--quiet", EXAMPLES / "jansen.yaml", bad, "-o", tmp_path)
    assert r.exit_code == 2 and r.stdout == "" and "bad.yaml" in r.stderr
    assert (tmp_path / "jansen.h5").exists()
