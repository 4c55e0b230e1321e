"""`linkedit features` / `compare-curves` end to end: inputs, outputs, ranking, learning, errors."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
import yaml

from linkedit.spec.curveset import CurveSet, CurveWeights
from linkedit.spec.schema import schema_text
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES, ROOT, report_of

CURVES = EXAMPLES / "curves"


def write_result(path, tracks: dict[str, np.ndarray]) -> None:
    """A result file in the layout of `simulate` / `solve3d`: /t and /tracks/<name>/position."""
    with h5py.File(path, "w") as f:
        f.attrs["format_version"] = "1"
        f.attrs["units"] = "mm"
        length = len(next(iter(tracks.values())))
        f["t"] = np.arange(length) / length
        for name, pos in tracks.items():
            f[f"tracks/{name}/position"] = pos


def ellipse(a, b, m=120, phase=0.0):
    t = np.linspace(0, 2 * np.pi, m, endpoint=False) + phase
    return np.stack([a * np.cos(t), b * np.sin(t)], axis=1)


def one_error_line(r, *patterns: str) -> str:
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.output, r.output
    for p in patterns:
        assert re.search(p, lines[0]), (p, lines[0])
    return lines[0]


@pytest.fixture
def result(tmp_path):
    path = tmp_path / "r.h5"
    egg = ellipse(30, 12) + np.stack([np.zeros(120), 3 * np.cos(np.linspace(0, 2 * np.pi, 120))], 1) ** 2 / 10
    write_result(path, {"foot": egg, "knee": ellipse(10, 6)})
    return path


def test_features_of_result_tracks_printed_and_written(run_cli, result, tmp_path):
    r = run_cli("features", f"{result}:foot", f"{result}:knee")
    assert r.exit_code == 0, r.output
    header, *rows = r.output.strip().splitlines()
    assert header.split() == ["name", "closed", "points", "length", "area", "ellipticity", "self_intersections"]
    assert rows[1].split()[:3] == ["r:knee", "True", "120"]
    assert float(rows[1].split()[5]) == pytest.approx(0.6)

    for suffix in (".csv", ".json", ".h5"):
        out = tmp_path / f"f{suffix}"
        r = run_cli("features", result, "-o", out, "--samples", "32")
        assert r.exit_code == 0, r.output
    table = json.loads((tmp_path / "f.json").read_text())
    assert [row["name"] for row in table] == ["r:foot", "r:knee"]
    assert (tmp_path / "f.csv").read_text().splitlines()[0].startswith("name,origin,closed,points,length")
    with h5py.File(tmp_path / "f.h5") as f:
        assert f.attrs["format_version"] == "1" and f.attrs["kind"] == "curve-features"
        assert json.loads(f["features"].attrs["columns"])[:2] == ["length", "area"]
        assert f["features"].shape == (2, 4) and f["normalized"].shape == (2, 32, 2)
        assert f["efd"].shape == (2, 10, 4) and f["frame"].shape == (2, 2, 2)
        np.testing.assert_allclose(f["features"][1], [row[k] for k in ("length", "area", "ellipticity",
                                                                       "self_intersections") for row in table[1:]])


def test_features_of_3d_tracks_and_anchor(run_cli, tmp_path):
    path = tmp_path / "g.h5"
    helix = np.concatenate([ellipse(5, 2, 90), np.sin(np.linspace(0, 2 * np.pi, 90, endpoint=False))[:, None]], 1)
    write_result(path, {"tip": helix})
    r = run_cli("features", f"{path}:tip", "--anchor", "0,1,-3", "--json")
    assert r.exit_code == 0, r.output
    row = report_of(r)[0]
    assert {"area_xy", "area_yz", "area_xz", "ellipticity_yz", "anchor_distance", "anchor_angle"} <= set(row)
    assert row["anchor_distance"] == pytest.approx(np.sqrt(10) / 10, rel=1e-6)  # |(0, 1, -3)| / major extent 10


def test_compare_matrix_nearest_and_svg(run_cli, tmp_path):
    svg = tmp_path / "o.svg"
    r = run_cli("compare-curves", CURVES / "foot-paths.yaml", "--json", "--svg", svg)
    assert r.exit_code == 0, r.output
    out = report_of(r)
    dist = np.array(out["distance"])
    assert dist.shape == (9, 9) and np.allclose(dist, dist.T) and np.allclose(np.diag(dist), 0, atol=1e-6)
    nearest = {row["curve"]: row["nearest"] for row in out["nearest"]}
    assert nearest["ellipse"] == "ellipse-moved" and nearest["figure-eight"] == "figure-eight-wide"
    assert nearest["d-shape"] == "d-shape-variant"
    root = ET.parse(svg).getroot()
    assert root.tag.endswith("svg") and len(root.findall("{http://www.w3.org/2000/svg}polygon")) == 8
    text = run_cli("compare-curves", CURVES / "foot-paths.yaml").output
    assert "ellipse → ellipse-moved" in text


def test_the_overlay_does_not_depend_on_the_order_of_the_curves(run_cli, tmp_path):
    """Each curve is drawn aligned to the medoid (the curve nearest all the others), whatever the
    order they are given in: with a circle first, a D-shape and its near copy were drawn 90° apart."""
    import yaml

    curves = {c["name"]: c for c in yaml.safe_load((CURVES / "foot-paths.yaml").read_text())["curves"]}
    d = np.array(curves["d-shape"]["points"])
    turn = np.exp(1j * 0.7) * (d[:, 0] + 1j * d[:, 1]) * 1.5 + (40 + 3j)
    copy = np.column_stack([turn.real, turn.imag]) + 0.02 * np.sin(np.arange(len(d)))[:, None]
    sets = {"circle-first": ["circle", "d-shape", "near-copy"], "circle-last": ["near-copy", "d-shape", "circle"]}
    curves["near-copy"] = {"name": "near-copy", "points": copy.round(4).tolist()}
    drawn = {}
    for label, order in sets.items():
        path = tmp_path / f"{label}.yaml"
        path.write_text(yaml.safe_dump({"name": label, "units": "mm", "curves": [curves[n] for n in order]}))
        svg = tmp_path / f"{label}.svg"
        assert run_cli("compare-curves", path, "--svg", svg).exit_code == 0
        root = ET.parse(svg).getroot()
        drawn[label] = {e.get("data-name"): e.get("points") for e in root.iter() if "curve" in (e.get("class") or "")}
        assert "aligned to d-shape" in svg.read_text() or "aligned to near-copy" in svg.read_text()
    assert drawn["circle-first"].keys() == set(sets["circle-first"])
    for name in ("d-shape", "near-copy"):
        assert drawn["circle-first"][name] == drawn["circle-last"][name], name


def test_ranking_a_library_against_a_query(run_cli, tmp_path):
    """The library holds the query's shape (moved, resampled, reversed) among others: it ranks first."""
    lib = tmp_path / "lib"
    lib.mkdir()
    shapes = {"egg": lambda t: np.stack([np.cos(t) + 0.3 * np.cos(2 * t), 0.6 * np.sin(t)], 1),
              "bean": lambda t: np.stack([np.cos(t), 0.5 * np.sin(t) + 0.25 * np.cos(2 * t)], 1),
              "oval": lambda t: np.stack([np.cos(t), 0.55 * np.sin(t)], 1),
              "kite": lambda t: np.stack([np.cos(t) + 0.2 * np.cos(3 * t), 0.7 * np.sin(t)], 1)}
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    for name, f in shapes.items():
        np.savetxt(lib / f"{name}.csv", f(t)[::-1] * 40 + 7, delimiter=",", header="x,y", comments="")
    query = tmp_path / "q.h5"
    write_result(query, {"foot": np.roll(shapes["bean"](np.linspace(0, 2 * np.pi, 333, endpoint=False)), 50, 0)
                         @ np.array([[0.0, -1.0], [1.0, 0.0]])})
    r = run_cli("compare-curves", "--query", f"{query}:foot", "--library", lib, "--json", "--svg", tmp_path / "r.svg")
    assert r.exit_code == 0, r.output
    ranking = report_of(r)["queries"][0]["ranking"]
    assert ranking[0]["curve"] == "bean" and ranking[0]["distance"] < 0.2 * ranking[1]["distance"]
    assert [x["rank"] for x in ranking] == [1, 2, 3, 4]
    assert (tmp_path / "r.svg").is_file()


def test_learned_weights_separate_the_labelled_set(run_cli, tmp_path):
    out = tmp_path / "w.yaml"
    r = run_cli("compare-curves", "--learn-weights", CURVES / "pairs.yaml", "-o", out, "--json")
    assert r.exit_code == 0, r.output
    fit = report_of(r)
    assert fit["separated"] and min(fit["dissimilar"]) >= 1 - 1e-9 and max(fit["similar"]) < 1
    weights = load_model(CurveWeights, out)
    assert all(w >= 0 for w in weights.weights.values())
    # the learned metric, used for the matrix, keeps each labelled pair on its side of 1
    dist = report_of(run_cli("compare-curves", CURVES / "foot-paths.yaml", "--weights", out, "--json"))
    names = dist["curves"]
    d = np.array(dist["distance"])
    pairs = yaml.safe_load((CURVES / "pairs.yaml").read_text())
    for a, b in pairs["similar"]:
        assert d[names.index(a), names.index(b)] < 1
    for a, b in pairs["dissimilar"]:
        assert d[names.index(a), names.index(b)] >= 1 - 1e-6


def test_example_weights_file_is_valid_and_schema_in_sync():
    load_model(CurveWeights, CURVES / "weights.yaml")
    load_model(CurveSet, CURVES / "foot-paths.yaml")
    assert (ROOT / "specs" / "curve-set.schema.json").read_text() == schema_text(CurveSet)


def test_weight_overrides_and_unknown_terms(run_cli, tmp_path):
    r = run_cli("compare-curves", CURVES / "foot-paths.yaml", "--weight", "points=1", "--weights",
                CURVES / "weights.yaml", "--json")
    assert report_of(r)["weights"]["points"] == 1.0
    bad = tmp_path / "w.yaml"
    bad.write_text("weights:\n  points: 1\n  wiggle: 2\n")
    one_error_line(run_cli("compare-curves", CURVES / "foot-paths.yaml", "--weights", bad),
                   r"w\.yaml:3: weights\.wiggle: unknown term")
    three_d = tmp_path / "w3.yaml"
    three_d.write_text("weights:\n  area_xy: 1\n")
    one_error_line(run_cli("compare-curves", CURVES / "foot-paths.yaml", "--weights", three_d),
                   r"area_xy.*does not apply")


def test_unknown_track_lists_the_available_ones(run_cli, result):
    line = one_error_line(run_cli("features", f"{result}:hand"), r"r\.h5: tracks\.hand: unknown track 'hand'")
    assert "foot, knee" in line


def test_csv_errors(run_cli, tmp_path):
    few = tmp_path / "few.csv"
    few.write_text("x,y\n0,0\n1,1\n0,0\n1,1\n")
    one_error_line(run_cli("features", few), r"few\.csv: .*at least 3 distinct points.*has 2")
    nan = tmp_path / "nan.csv"
    nan.write_text("x,y\n0,0\n1,0\n1,nan\n0,1\n")
    one_error_line(run_cli("features", nan), r"nan\.csv:4: y: not a finite number")
    text = tmp_path / "text.csv"
    text.write_text("x,y\n0,0\n1,zero\n")
    one_error_line(run_cli("features", text), r"text\.csv:3: y: not a number: 'zero'")
    same = tmp_path / "same.csv"
    same.write_text("x,y,t\n2,3,0\n2,3,1\n2,3,2\n")
    one_error_line(run_cli("features", same), r"same\.csv: .*zero length")


def test_nan_in_a_track_and_mixed_dimensions(run_cli, tmp_path):
    path = tmp_path / "p.h5"
    foot = ellipse(3, 1)
    foot[40:50] = np.nan
    write_result(path, {"foot": foot})
    one_error_line(run_cli("features", f"{path}:foot"), r"p\.h5: tracks\.foot\.position: 10 samples are not finite")
    mixed = tmp_path / "m.h5"
    write_result(mixed, {"a": ellipse(3, 1)})
    with h5py.File(mixed, "a") as f:
        f["tracks/b/position"] = np.concatenate([ellipse(3, 1), np.zeros((120, 1))], 1)
    one_error_line(run_cli("compare-curves", mixed), r"2D and 3D curves")


def test_curve_set_errors_name_the_line(run_cli, tmp_path):
    bad = tmp_path / "set.yaml"
    bad.write_text("curves:\n  - name: a\n    points: [[0, 0], [1, 0], [1, 1]]\n"
                   "  - name: b\n    points: [[0, 0], [1, 0, 2], [1, 1]]\n")
    one_error_line(run_cli("features", bad), r"set\.yaml:5: curves\[1\]\.points\[1\]: .*same 2 or 3 coordinates")
    flat = tmp_path / "flat.yaml"
    flat.write_text("curves:\n  - name: a\n    points: [[0, 0], [0, 0], [0, 0]]\n")
    one_error_line(run_cli("features", flat), r"flat\.yaml:3: curves\[0\]\.points: degenerate curve")
    nan = tmp_path / "nan.yaml"
    nan.write_text("curves:\n  - name: a\n    points: [[0, 0], [1, .nan], [0, 1]]\n")
    one_error_line(run_cli("features", nan), r"nan\.yaml:3: curves\[0\]\.points")
    missing = tmp_path / "src.yaml"
    missing.write_text("curves:\n  - name: a\n    source: nowhere.csv\n")
    one_error_line(run_cli("features", missing), r"nowhere\.csv: no such file")
    one_error_line(run_cli("features", f"{CURVES / 'foot-paths.yaml'}:hexagon"), r"unknown curve 'hexagon'")


def test_closedness_is_detected_or_declared(run_cli, tmp_path):
    arc = tmp_path / "arc.csv"
    t = np.linspace(0, 1.5, 30)
    np.savetxt(arc, np.stack([np.cos(t), np.sin(t)], 1), delimiter=",")
    loop = tmp_path / "loop.csv"
    np.savetxt(loop, ellipse(2, 1, 30), delimiter=",")
    rows = report_of(run_cli("features", arc, loop, "--json"))
    assert [row["closed"] for row in rows] == [False, True]
    rows = report_of(run_cli("features", arc, loop, "--json", "--closed"))
    assert [row["closed"] for row in rows] == [True, True]


def test_bench_quick_runs(run_cli):
    r = run_cli("bench", "--section", "curves", "--quick")
    assert r.exit_code == 0, r.output
    assert "curves/s" in r.output and "distance matrix" in r.output


def egg(m=150):
    t = np.linspace(0, 2 * np.pi, m, endpoint=False)
    return np.stack([3 * np.cos(t) + 0.5 * np.cos(2 * t), np.sin(t)], axis=1)


@pytest.mark.parametrize("size", [1e-170, 1e170])
def test_tiny_and_huge_curves_in_every_output(run_cli, tmp_path, size):
    """Squared steps of such curves under/overflowed: NaN features, a crash writing JSON."""
    np.savetxt(tmp_path / "unit.csv", egg(), delimiter=",", header="x,y", comments="")
    np.savetxt(tmp_path / "scaled.csv", np.roll(egg() + 7, 40, axis=0) * size, delimiter=",", header="x,y", comments="")
    np.savetxt(tmp_path / "other.csv", ellipse(2, 1, 100) * size, delimiter=",", header="x,y", comments="")
    t = np.linspace(0, 1.5, 30)
    np.savetxt(tmp_path / "arc.csv", np.stack([np.cos(t), np.sin(t)], 1) * size, delimiter=",")
    inputs = [tmp_path / f"{n}.csv" for n in ("unit", "scaled", "other", "arc")]
    r = run_cli("features", *inputs, "--json")
    assert r.exit_code == 0, r.output
    rows = report_of(r)
    assert [row["closed"] for row in rows] == [True, True, True, False]
    for key in ("length", "area", "ellipticity"):
        assert rows[1][key] == pytest.approx(rows[0][key], abs=1e-9)  # the same egg, moved and scaled
    assert rows[2]["ellipticity"] == pytest.approx(0.5, abs=1e-12)
    for suffix in (".json", ".csv"):
        assert run_cli("features", *inputs, "-o", tmp_path / f"f{suffix}").exit_code == 0
    assert json.loads((tmp_path / "f.json").read_text()) == rows
    assert "nan" not in (tmp_path / "f.csv").read_text().lower()
    out = report_of(run_cli("compare-curves", *inputs[:3], "--json"))
    assert np.isfinite(np.array(out["distance"], dtype=float)).all()
    assert [row["nearest"] for row in out["nearest"]][:2] == ["scaled", "unit"]


def test_curves_beyond_the_float_range_are_one_error_line(run_cli, tmp_path):
    wide = tmp_path / "wide.csv"
    wide.write_text("x,y\n-1.5e308,0\n1.5e308,0\n0,1e308\n")
    r = run_cli("features", wide, "--json")
    one_error_line(run_cli("features", wide), r"wide\.csv: curve wide: its descriptors are not finite")
    assert r.exit_code == 2 and re.search(r"curve wide: its descriptors are not finite", r.stderr)  # and in the JSON:
    assert report_of(r) is None and json.loads(r.stdout)["errors"][0]["file"] == str(wide)
    np.savetxt(tmp_path / "e.csv", ellipse(3, 1), delimiter=",")
    one_error_line(run_cli("compare-curves", wide, tmp_path / "e.csv"), r"curve wide: .*not finite")


def write_edit_result(path, before: dict[str, np.ndarray], after: dict[str, np.ndarray]) -> None:
    """An edit result in the layout of specs/edit-hdf5.md: /before/tracks/<name>, /after/tracks/<name>."""
    with h5py.File(path, "w") as f:
        f.attrs.update(format_version="1", kind="edit", units="mm")
        for stage, tracks in (("before", before), ("after", after)):
            for name, pos in tracks.items():
                f[f"{stage}/tracks/{name}/position"] = pos


def test_edit_results_before_and_after(run_cli, tmp_path):
    path = tmp_path / "e.h5"
    write_edit_result(path, {"foot": ellipse(3, 1), "knee": ellipse(4, 1)}, {"foot": ellipse(3, 2), "knee": ellipse(4, 2)})
    r = run_cli("features", f"{path}:foot", f"{path}:before/foot", f"{path}:after/knee", "--json")
    assert r.exit_code == 0, r.output
    rows = report_of(r)
    assert [row["name"] for row in rows] == ["e:after/foot", "e:before/foot", "e:after/knee"]
    assert [row["ellipticity"] for row in rows] == pytest.approx([2 / 3, 1 / 3, 1 / 2], abs=1e-12)
    rows = report_of(run_cli("features", path, "--json"))
    assert [row["name"] for row in rows] == ["e:before/foot", "e:before/knee", "e:after/foot", "e:after/knee"]
    one_error_line(run_cli("features", f"{path}:hand"), r"e\.h5: after\.tracks\.hand: unknown track 'hand'.*foot, knee")
    one_error_line(run_cli("features", f"{path}:middle/foot"), r"e\.h5: .*unknown stage 'middle'")
    plain = tmp_path / "p.h5"
    write_result(plain, {"foot": ellipse(3, 1)})
    one_error_line(run_cli("features", f"{plain}:before/foot"), r"p\.h5: .*not one")


def test_tracks_of_a_linkedit_edit_run(run_cli, tmp_path):
    r = run_cli("edit", EXAMPLES / "edits" / "jansen-move-knee.yaml", "-o", tmp_path)
    assert r.exit_code == 0, r.output
    (path,) = tmp_path.glob("*.h5")
    r = run_cli("compare-curves", f"{path}:before/foot", f"{path}:foot", f"{path}:after/foot", "--json")
    assert r.exit_code == 0, r.output
    out = report_of(r)
    assert out["curves"] == [f"{path.stem}:before/foot", f"{path}:after/foot", f"{path}:after/foot#2"]
    dist = np.array(out["distance"])
    # identical curves: d = sqrt(|a|² + |b|² − 2·corr) cancels to rounding, so d ~ sqrt(1e-16)
    assert dist[1, 2] == pytest.approx(0.0, abs=1e-7) and dist[0, 1] > 1e-3  # the edit moved the foot path
    with h5py.File(path) as f:
        assert len(f["before/tracks/foot/position"]) == report_of(run_cli("features", f"{path}:before/foot",
                                                                           "--json"))[0]["points"]
