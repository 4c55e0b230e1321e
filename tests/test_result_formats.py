"""`simulate -o` follows the suffix: HDF5 (named dimensions, descriptions, pint units), CSV, DXF, stdout."""

from __future__ import annotations

import io

import h5py
import numpy as np
import pytest
import yaml

from tests.conftest import EXAMPLES
from tests.planar_specs import FOURBAR, LOCKING

JANSEN = EXAMPLES / "jansen.yaml"


def _read_csv(text: str) -> tuple[list[str], np.ndarray]:
    """Header and (T, C) numbers of a CSV result, read as a spreadsheet would (quoted cells, empty = NaN)."""
    import csv

    rows = list(csv.reader(io.StringIO(text)))
    rows = [r for r in rows if not r[0].startswith("#")]
    assert {len(r) for r in rows} == {len(rows[0])}, "every row as wide as the header"
    return rows[0], np.array([[float(v) if v else np.nan for v in r] for r in rows[1:]])


def _h5_columns(h5) -> dict[str, np.ndarray]:
    """What each CSV column must hold, read from the HDF5 result (plain joint and track names)."""
    with h5py.File(h5) as f:
        units = f.attrs["units"]
        cols = {"t": f["t"][()]}
        if f.attrs["input"] == "linear":
            cols[f"stroke_{units}"] = f["stroke"][()]
        else:
            cols["motor_angle_deg"] = np.degrees(f["motor_angle"][()])
        points = {n: (f["joints/position"][:, j], f["joints/velocity"][:, j]) for j, n in enumerate(f["joint"].asstr()[()])}
        points |= {n: (f[f"tracks/{n}/position"][()], f[f"tracks/{n}/velocity"][()]) for n in f["tracks"]}
    for name, (pos, vel) in points.items():
        cols |= {f"{name}_x": pos[:, 0], f"{name}_y": pos[:, 1]}
    for name, (pos, vel) in points.items():
        cols |= {f"{name}_vx": vel[:, 0], f"{name}_vy": vel[:, 1]}
    return cols


def test_csv_equals_hdf5_to_full_precision(run_cli, tmp_path):
    h5, csv = tmp_path / "j.h5", tmp_path / "j.csv"
    assert run_cli("simulate", JANSEN, "-o", h5, "-n", "72").exit_code == 0
    r = run_cli("simulate", JANSEN, "-o", csv, "-n", "72")
    assert r.exit_code == 0, r.output
    text = csv.read_text()
    assert text.startswith("#") and "positions in mm" in text.splitlines()[0]
    header, table = _read_csv(text)
    col = {name: table[:, i] for i, name in enumerate(header)}
    with h5py.File(h5) as f:
        names = f["joint"].asstr()[()]
        assert (col["t"] == f["t"][()]).all()
        assert (col["motor_angle_deg"] == np.degrees(f["motor_angle"][()])).all()
        for j, name in enumerate(names):
            for c, axis in enumerate("xy"):
                assert (col[f"{name}_{axis}"] == f["joints/position"][:, j, c]).all()
                assert (col[f"{name}_v{axis}"] == f["joints/velocity"][:, j, c]).all()
        for c, axis in enumerate("xy"):
            assert (col[f"foot_{axis}"] == f["tracks/foot/position"][:, c]).all()
            assert (col[f"foot_v{axis}"] == f["tracks/foot/velocity"][:, c]).all()
    assert header[:4] == ["t", "motor_angle_deg", "O_x", "O_y"]
    assert header.index("foot_x") < header.index("O_vx")


def test_csv_reads_into_pandas(run_cli, tmp_path):
    pd = pytest.importorskip("pandas")
    csv = tmp_path / "f.csv"
    (tmp_path / "f.yaml").write_text(FOURBAR)
    assert run_cli("simulate", tmp_path / "f.yaml", "-o", csv, "-n", "10").exit_code == 0
    df = pd.read_csv(csv, comment="#")
    assert df.shape == (10, 2 + 4 * 6) and list(df.columns[:3]) == ["t", "motor_angle_deg", "O_x"]


def test_partial_csv_has_empty_cells_not_nan(run_cli, tmp_path):
    spec = tmp_path / "lock.yaml"
    spec.write_text(LOCKING)
    csv = tmp_path / "lock.csv"
    assert run_cli("simulate", spec, "-o", csv, "--partial", "-n", "90").exit_code == 0
    text = csv.read_text()
    assert "nan" not in text.lower()
    _, table = _read_csv(text)
    assert np.isnan(table).any(axis=1).any() and np.isfinite(table[0]).all()


def test_stdout_csv_and_summary_on_stderr(tmp_path):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "linkedit", "simulate", str(JANSEN), "-o", "-", "-n", "8"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    header, table = _read_csv(r.stdout)
    assert table.shape == (8, len(header)) and "→ -" in r.stderr


def test_linear_input_csv_has_the_stroke_in_spec_units_and_equals_its_hdf5(run_cli, tmp_path):
    """A cylinder-driven linkage: the input column is the stroke in mm (not mm × 180/π labelled degrees)."""
    spec = EXAMPLES / "lifting-arm.yaml"
    h5, csv = tmp_path / "l.h5", tmp_path / "l.csv"
    assert run_cli("simulate", spec, "-o", h5, "-n", "11").exit_code == 0
    r = run_cli("simulate", spec, "-o", csv, "-n", "11")
    assert r.exit_code == 0, r.output
    text = csv.read_text()
    header, table = _read_csv(text)
    assert header[:2] == ["t", "stroke_mm"]
    assert np.allclose(table[:, 1], np.linspace(0, 25, 11), rtol=0, atol=1e-12)  # the spec's stroke: [0, 25]
    expected = _h5_columns(h5)
    assert header == list(expected)
    for k, name in enumerate(header):
        assert (table[:, k] == expected[name]).all(), name
    first = text.splitlines()[0]
    assert "stroke_mm in mm" in first and "velocities in mm/mm" in first and "degrees" not in first


ODD_NAMES = """\
name: odd names
units: mm
joints:
  O: [0, 0]
  "A,x": [1, 0]
  B: [2.2, 2.1]
  D: [3, 0]
  B_track: [2.6, 3.0]
  "=C": [1.5, 2.5]
ground: [O, D]
links:
  crank: [O, "A,x"]
  coupler: ["A,x", B, B_track, "=C"]
  rocker: [D, B]
motor: {joint: "A,x", pivot: O}
tracks:
  "@tip": {joint: "=C"}
  B: {joint: B_track}
"""


def test_csv_quotes_commas_neutralizes_formulas_and_keeps_names_apart(run_cli, tmp_path):
    """A joint named ``A,x`` is one quoted cell; ``=C``/``@tip`` cannot run as spreadsheet formulas
    (written ``'=C_x``); the track B, named like a joint, whose ``B_track`` is a joint too, gets its own columns."""
    spec, h5, out = tmp_path / "odd.yaml", tmp_path / "odd.h5", tmp_path / "odd.csv"
    spec.write_text(ODD_NAMES)
    assert run_cli("simulate", spec, "-o", h5, "-n", "9").exit_code == 0
    assert run_cli("simulate", spec, "-o", out, "-n", "9").exit_code == 0
    header, table = _read_csv(out.read_text())
    joints = ["O", "A,x", "B", "D", "B_track", "=C"]
    shown = joints[:5] + ["'=C", "'@tip", "B_track_track"]
    assert header == ["t", "motor_angle_deg"] + [f"{p}_{c}" for p in shown for c in ("x", "y")] \
        + [f"{p}_{c}" for p in shown for c in ("vx", "vy")]
    with h5py.File(h5) as f:
        assert list(f["joint"].asstr()[()]) == joints
        sources = [f["joints/position"][:, j] for j in range(6)] + [f["tracks/@tip/position"][()], f["tracks/B/position"][()]]
        sources += [f["joints/velocity"][:, j] for j in range(6)] + [f["tracks/@tip/velocity"][()], f["tracks/B/velocity"][()]]
        want = np.column_stack([f["t"][()], np.degrees(f["motor_angle"][()])] + sources)
    assert (table == want).all()


@pytest.mark.parametrize("option, name", [("-o", "x.png"), ("-o", "x.txt"), ("--svg", "x.png")])
def test_unknown_suffix_is_exit_2_and_writes_nothing(run_cli, tmp_path, option, name):
    r = run_cli("simulate", JANSEN, option, tmp_path / name)
    assert r.exit_code == 2
    assert "unknown output format" in r.output and name in r.output
    assert list(tmp_path.iterdir()) == []


def test_dxf_reopens_with_layers_units_origin(run_cli, tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    out, h5 = tmp_path / "j.dxf", tmp_path / "j.h5"
    assert run_cli("simulate", JANSEN, "-o", out, "-n", "90").exit_code == 0
    assert run_cli("simulate", JANSEN, "-o", h5, "-n", "90").exit_code == 0
    doc = ezdxf.readfile(out)
    assert doc.header["$INSUNITS"] == 4  # millimetres
    layers = {layer.dxf.name for layer in doc.layers}
    links = ["crank", "upper_rod", "lower_rod", "upper", "rocker", "knee", "lower"]
    assert {"FRAME", "TRACK-foot"} | {f"LINK-{n}" for n in links} <= layers
    msp = doc.modelspace()

    def on(kind: str, layer: str) -> list:
        return [e for e in msp if e.dxftype() == kind and e.dxf.layer == layer]

    with h5py.File(h5) as f:
        rest = f["joints/position"][0]
        foot = f["tracks/foot/position"][()]
    origin = rest[0]  # O, the first ground joint
    upper = on("LWPOLYLINE", "LINK-upper")[0]
    pts = np.array([p[:2] for p in upper.get_points()])
    pts = np.roll(pts, -int(np.argmin(np.hypot(*(pts - rest[2] + origin).T))), axis=0)  # from B round
    assert upper.closed and np.allclose(pts, rest[[2, 3, 5]] - origin, atol=1e-12)  # B, C, E
    holes = on("CIRCLE", "LINK-lower")
    assert len(holes) == 3
    frame = np.array([(c.dxf.center.x, c.dxf.center.y) for c in on("CIRCLE", "FRAME")])
    assert np.allclose(frame, [[0, 0], rest[2] - origin])
    curve = on("LWPOLYLINE", "TRACK-foot")[0]
    assert curve.closed and np.allclose([p[:2] for p in curve.get_points()], foot - origin, atol=1e-12)



def test_dxf_cuts_each_hole_once(run_cli, tmp_path):
    """A spec with a frame link (``base: [O, D]``): its holes were drawn twice on FRAME, once as the link's
    and once as the ground joints' (a laser cutter burns such a hole twice). Each layer's holes are distinct,
    one per joint of its parts, spaced by the link lengths."""
    ezdxf = pytest.importorskip("ezdxf")
    spec, out = tmp_path / "frame.yaml", tmp_path / "frame.dxf"
    spec.write_text(FOURBAR.replace("  crank: [O, A]\n", "  crank: [O, A]\n  base: [O, D]\n"))
    assert run_cli("simulate", spec, "-o", out, "-n", "12").exit_code == 0
    holes: dict[str, list[tuple[float, float]]] = {}
    for c in ezdxf.readfile(out).modelspace().query("CIRCLE"):
        holes.setdefault(c.dxf.layer, []).append((c.dxf.center.x, c.dxf.center.y))
    assert holes["FRAME"] == [(0, 0), (3, 0)]
    assert sorted(holes["LINK-coupler"]) == [(1, 0), (1.2, 1.6), (2.2, 2.1)]  # A, the coupler point, B
    assert {layer: len(h) for layer, h in holes.items()} == {"FRAME": 2, "LINK-crank": 2, "LINK-coupler": 3, "LINK-rocker": 2}


def test_hdf5_named_dimensions_descriptions_and_units(run_cli, tmp_path):
    out = tmp_path / "j.h5"
    assert run_cli("simulate", JANSEN, "-o", out, "-n", "36").exit_code == 0
    with h5py.File(out) as f:
        missing = []
        f.visititems(lambda name, obj: missing.append(name)
                     if isinstance(obj, h5py.Dataset) and "description" not in obj.attrs else None)
        assert missing == []
        units = set()
        f.visititems(lambda name, obj: units.add(obj.attrs["units"]) if "units" in obj.attrs else None)
    pint = pytest.importorskip("pint")
    reg = pint.UnitRegistry()
    assert {str(reg(u).units) for u in units} >= {"millimeter", "millimeter / radian", "millimeter / radian ** 2"}
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    joints = xr.open_dataset(out, engine="h5netcdf", group="joints", phony_dims="sort")
    assert joints["position"].dims == ("t", "joint", "xy")
    assert not [d for d in joints.dims if str(d).startswith("phony")]
    tree = xr.open_datatree(out, engine="h5netcdf", phony_dims="sort")
    foot = tree["tracks/foot"]["position"].to_pandas()  # the documented one-liner
    assert foot.shape == (36, 2) and list(foot.columns) == ["x", "y"] and foot.index.name == "t"
    g = tree["joints"]["position"].sel(joint="G", xy="x").values
    assert (g == foot["x"].values).all()


@pytest.mark.parametrize("module, args, pattern", [
    ("ezdxf", ["-o", "x.dxf"], r"writing DXF needs the optional package ezdxf: pip install 'linkedit\[dxf\]'"),
    ("PIL", ["-o", "x.h5", "--svg", "x.gif", "--animate"], r"writing GIF needs the optional package Pillow: pip install 'linkedit\[gif\]'"),
])
def test_missing_optional_package_is_one_clear_line(run_cli, tmp_path, monkeypatch, module, args, pattern):
    import re
    import sys

    monkeypatch.setitem(sys.modules, module, None)  # as if not installed
    r = run_cli("simulate", JANSEN, "-n", "8", *[str(tmp_path / a) if "." in a else a for a in args])
    assert r.exit_code == 2 and re.search(pattern, r.output), r.output
    assert len(r.output.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []  # found before anything was written


def _ellipse_csv(path, aspect: float) -> None:
    s = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    path.write_text("x,y\n" + "".join(f"{np.cos(a)},{aspect * np.sin(a)}\n" for a in s))


def test_curve_tables_neutralize_formulas_and_keep_columns_apart(run_cli, tmp_path):
    """``features`` and ``compare-curves`` tables: a curve named ``=cmd`` is the text ``'=cmd`` (no formula), a
    curve named ``curve`` does not take the row-name column's place."""
    import csv

    for name, aspect in (("=cmd", 0.2), ("curve", 0.5), ("plain", 0.8)):
        _ellipse_csv(tmp_path / f"{name}.csv", aspect)
    inputs = [tmp_path / f"{n}.csv" for n in ("=cmd", "curve", "plain")]
    r = run_cli("features", *inputs, "-o", tmp_path / "f.csv")
    assert r.exit_code == 0, r.output
    rows = list(csv.reader((tmp_path / "f.csv").open()))
    assert [row[0] for row in rows] == ["name", "'=cmd", "curve", "plain"]
    assert {len(row) for row in rows} == {len(rows[0])}
    r = run_cli("compare-curves", *inputs, "-o", tmp_path / "m.csv")
    assert r.exit_code == 0, r.output
    rows = list(csv.reader((tmp_path / "m.csv").open()))
    assert rows[0] == ["curve", "'=cmd", "curve#2", "plain"]
    assert [row[0] for row in rows[1:]] == ["'=cmd", "curve", "plain"]
    dist = np.array([[float(v) for v in row[1:]] for row in rows[1:]])
    assert (np.diag(dist) < 1e-6).all() and (dist + np.eye(3) > 0.1).all()  # rows and columns agree


def test_dxf_track_of_a_partial_cycle_runs_through_the_rest_pose(run_cli, tmp_path):
    """A full turn that locks between two angles away from the rest pose: each track is one polyline
    from where the linkage frees to where it locks, through the rest pose (the last sample joins the
    first). It was two, with the segment between the last sample and the rest pose left out."""
    ezdxf = pytest.importorskip("ezdxf")
    spec, out, h5 = tmp_path / "lock.yaml", tmp_path / "lock.dxf", tmp_path / "lock.h5"
    spec.write_text(LOCKING)
    assert run_cli("simulate", spec, "-o", out, "-n", "36", "--partial").exit_code == 0
    assert run_cli("simulate", spec, "-o", h5, "-n", "36", "--partial").exit_code == 0
    with h5py.File(h5) as f:
        ok = f["diagnostics/assembled"][()]
        tip = f["tracks/tip/position"][()] - f["joints/position"][0, 0]
    assert ok[0] and ok[-1] and not ok.all()
    freed = int(np.flatnonzero(~ok)[-1]) + 1  # the first sample after the locked run
    expected = np.roll(tip, -freed, axis=0)[:int(ok.sum())]
    (curve,) = [e for e in ezdxf.readfile(out).modelspace() if e.dxftype() == "LWPOLYLINE" and e.dxf.layer == "TRACK-tip"]
    assert not curve.closed and np.allclose([p[:2] for p in curve.get_points()], expected, atol=1e-12)


@pytest.mark.parametrize("spec", ["crank-rocker.yaml", "stephenson-slider.yaml"])
def test_every_axis_of_a_planar_result_is_named(run_cli, tmp_path, spec):
    """``/links/joints/<link>``, ``/steps/*``, ``/sliders/*`` and ``step_singularity``'s second axis had no
    dimension scale: h5py showed no name for the axis and xarray made up ``phony_dim_0`` (with a warning)."""
    import warnings

    out = tmp_path / "r.h5"
    assert run_cli("simulate", EXAMPLES / spec, "-o", out, "-n", "12").exit_code == 0
    unnamed: list[tuple[str, int]] = []
    with h5py.File(out) as f:
        f.visititems(lambda name, obj: unnamed.extend((name, k) for k, d in enumerate(obj.dims) if len(d) == 0)
                     if isinstance(obj, h5py.Dataset) and not obj.is_scale else None)
        assert unnamed == []
        names = f["joint"].asstr()[()]
        for link, members in yaml.safe_load((EXAMPLES / spec).read_text())["links"].items():
            indices = f[f"links/joints/{link}"]
            axis = indices.dims[0][0]  # the scale: the names of the joints on the link
            assert axis.name == f"/links/{link}.joint" and list(axis.asstr()[()]) == list(names[indices[()]])
            assert sorted(axis.asstr()[()]) == sorted(members)
        if "steps" in f:
            assert f["diagnostics/step_singularity"].dims[1][0].name == "/step"
            assert list(f["step"].asstr()[()]) == list(f["steps/name"].asstr()[()])
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the phony_dims warning among them
        tree = xr.open_datatree(out, engine="h5netcdf")
    assert not [str(d) for node in tree.subtree for d in node.dims if str(d).startswith("phony")]
    crank = tree["links/joints"]["crank"]
    assert crank.dims == ("crank.joint",) and list(crank["crank.joint"].values) == ["O", "A"]


@pytest.mark.parametrize("base, joints, coupler, outline, closed", [
    # Hoekens' coupler A-B-P is one straight bar: its outline is the bar A…P, not a closed A-B-P-A traced twice
    (EXAMPLES / "hoekens.yaml", {}, ["A", "B", "P"], [[1, 0], [2, 4.898979485566356]], False),
    # a plate listed in an order that crosses itself (A, B, E, F) is outlined around its corners A, E, B, F
    (None, {"E": [2.4, 0.6], "F": [0.9, 1.6]}, ["A", "B", "E", "F"], [[1, 0], [2.4, 0.6], [2.2, 2.1], [0.9, 1.6]], True),
])
def test_dxf_link_outlines_are_simple(run_cli, tmp_path, base, joints, coupler, outline, closed):
    """A part's outline in DXF is a bar between its outermost joints or a plate's corners in order around it
    (as the SVG draws them); the joints' spec order was used, so a collinear link was a closed line traced
    twice and a plate listed out of order a bow tie."""
    ezdxf = pytest.importorskip("ezdxf")
    doc = yaml.safe_load(base.read_text() if base else FOURBAR)
    doc["joints"] |= joints
    doc["links"]["coupler"] = coupler
    doc["tracks"] = {"tip": {"joint": "B"}}
    spec, out = tmp_path / "c.yaml", tmp_path / "c.dxf"
    spec.write_text(yaml.safe_dump(doc))
    r = run_cli("simulate", spec, "-o", out, "-n", "12")
    assert r.exit_code == 0, r.output
    msp = ezdxf.readfile(out).modelspace()
    (line,) = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "LINK-coupler"]
    pts = np.array([p[:2] for p in line.get_points()])
    assert line.closed == closed
    k = int(np.argmin(np.hypot(*(pts - outline[0]).T)))  # the same ring from the same corner, either way round
    ring = np.roll(pts, -k, axis=0)
    assert np.allclose(ring, outline, atol=1e-12) or np.allclose(np.roll(ring[::-1], 1, axis=0), outline, atol=1e-12)
    assert len(msp.query('CIRCLE[layer=="LINK-coupler"]')) == len(coupler)


def test_dxf_part_carries_its_coupler_point(run_cli, tmp_path):
    """A point tracked on a link (the crank-rocker's coupler point, given by ``at``) is a corner of that link's
    part with a hole, as the pictures draw it; the DXF's coupler was the bar A-B alone, so the part cut from it
    had no coupler point (only its curve, on TRACK-coupler_point, began there)."""
    ezdxf = pytest.importorskip("ezdxf")
    out = tmp_path / "cr.dxf"
    assert run_cli("simulate", EXAMPLES / "crank-rocker.yaml", "-o", out, "-n", "12").exit_code == 0
    msp = ezdxf.readfile(out).modelspace()
    a, b, point = (25, 0), (63, 58.787753826796276), (20.48489846928149, 44.59387691339814)  # O at the origin
    (plate,) = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "LINK-coupler"]
    assert plate.closed and np.allclose(sorted(tuple(p[:2]) for p in plate.get_points()), sorted([a, b, point]), atol=1e-12)
    holes = sorted((c.dxf.center.x, c.dxf.center.y) for c in msp.query('CIRCLE[layer=="LINK-coupler"]'))
    assert np.allclose(holes, sorted([a, b, point]), atol=1e-12)
    curve = next(e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "TRACK-coupler_point")
    assert np.allclose(curve.get_points()[0][:2], point, atol=1e-12)
