"""`simulate -o` follows the suffix: HDF5 (named dimensions, descriptions, pint units), CSV, DXF, stdout."""

from __future__ import annotations

import io

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES
from tests.planar_specs import FOURBAR, LOCKING

JANSEN = EXAMPLES / "jansen.yaml"


def _read_csv(text: str) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    header = lines[0].split(",")
    rows = [[float(v) if v else np.nan for v in ln.split(",")] for ln in lines[1:]]
    return header, np.array(rows)


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
    assert upper.closed and np.allclose(pts, rest[[2, 3, 5]] - origin, atol=1e-12)  # B, C, E
    holes = on("CIRCLE", "LINK-lower")
    assert len(holes) == 3
    frame = np.array([(c.dxf.center.x, c.dxf.center.y) for c in on("CIRCLE", "FRAME")])
    assert np.allclose(frame, [[0, 0], rest[2] - origin])
    curve = on("LWPOLYLINE", "TRACK-foot")[0]
    assert curve.closed and np.allclose([p[:2] for p in curve.get_points()], foot - origin, atol=1e-12)


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
