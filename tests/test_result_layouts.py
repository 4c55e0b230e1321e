"""The gcs (`solve3d`) and edit result files, like the planar format 2: every axis a named
dimension (xarray shows `t`, `member`, `xyz`, `joint`, … — never `phony_dim_*`), a `description`
on every dataset, unit strings pint parses with the right dimensionality; and the readers of
those files (`solve3d --from`, `compare-curves FILE:after/foot`) still read them."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from linkedit.cli import app
    from typer.testing import CliRunner

    folder = tmp_path_factory.mktemp("layouts")
    run = CliRunner().invoke
    r = run(app, ["solve3d", str(EXAMPLES / "3d" / "compound-crank-rocker.yaml"), "-o", str(folder / "g.h5"),
                  "--steps", "31"])
    assert r.exit_code == 0, r.output
    r = run(app, ["edit", str(EXAMPLES / "edits" / "klann-curve.yaml"), "-o", str(folder / "edit")])
    assert r.exit_code == 0, r.output
    return {"gcs": folder / "g.h5", "edit": next((folder / "edit").glob("*.h5"))}


def _datasets(path):
    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.__setitem__(name, dict(obj.attrs)) if isinstance(obj, h5py.Dataset) else None)
    return out


@pytest.mark.parametrize("kind", ["gcs", "edit"])
def test_every_dataset_described_every_unit_parses(files, kind):
    pint = pytest.importorskip("pint")
    reg = pint.UnitRegistry()
    sets = _datasets(files[kind])
    assert [n for n, a in sets.items() if "description" not in a] == []
    units = {n: a["units"] for n, a in sets.items() if "units" in a}
    for name, u in units.items():
        reg.parse_units(u)  # raises on a string pint cannot read
    length = reg.parse_units("m" if kind == "gcs" else "mm").dimensionality
    if kind == "gcs":  # t is dimensionless: a velocity per unit t has the unit of its quantity
        assert reg.parse_units(units["t"]).dimensionless
        for name in ("members/velocity", "tracks/P/velocity", "members/position"):
            assert reg.parse_units(units[name]).dimensionality == length, name
        assert reg.parse_units(units["members/angular_velocity"]) == reg.parse_units("rad")
    else:
        assert reg.parse_units(units["after/tracks/foot/velocity"]).dimensionality == length / reg.radian.dimensionality
        assert reg.parse_units(units["after/tracks/foot/position"]).dimensionality == length


@pytest.mark.parametrize("kind, dims", [
    ("gcs", {"members/position": ("t", "member", "xyz"), "members/orientation": ("t", "member", "wxyz"),
             "constraints/cost": ("t", "constraint"), "tracks/P/velocity": ("t", "xyz"),
             "members/shapes/crank/points": ("point", "xyz"), "diagnostics/status": ("t",)}),
    ("edit", {"after/joints/position": ("t", "joint", "xy"), "before/tracks/foot/position": ("t", "xy"),
              "after/diagnostics/singularity": ("t", "rule"), "operations/000/energy": ("iteration",),
              "operations/000/targets/retarget foot": ("sample", "xy")}),
])
def test_xarray_names_every_dimension(files, kind, dims):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    tree = xr.open_datatree(files[kind], engine="h5netcdf", phony_dims="sort")
    assert not [str(d) for node in tree.subtree for d in node.dims if str(d).startswith("phony")]
    for path, want in dims.items():
        group, _, name = path.rpartition("/")
        assert tree[group][name].dims == want, path
    with h5py.File(files[kind]) as f:  # the coordinates are the names and the data the file's
        if kind == "gcs":
            members = tree["members"]
            assert list(members["member"].values) == [s.decode() for s in f["member"][()]]
            crank = members["position"].sel(member="crank", xyz="y").values
            assert (crank == f["members/position"][:, 0, 1]).all()
        else:
            foot = tree["after/tracks/foot"]["position"].to_pandas()
            assert list(foot.columns) == ["x", "y"] and (foot.values == f["after/tracks/foot/position"][()]).all()


def test_gcs_readers_still_read_it(files, run_cli, tmp_path):
    out = tmp_path / "more.h5"
    r = run_cli("solve3d", "--from", files["gcs"], "-o", out, "--track", "tip=rocker:tip")
    assert r.exit_code == 0, r.output
    with h5py.File(files["gcs"]) as a, h5py.File(out) as b:
        for name in ("members/position", "members/orientation", "members/velocity", "tracks/P/position",
                     "tracks/P/velocity", "constraints/cost", "diagnostics/unsatisfied"):
            assert (a[name][()] == b[name][()]).all(), name
        assert np.allclose(b["tracks/tip/position"][()], a["tracks/rocker_tip/position"][()], rtol=0, atol=1e-12)


def test_edit_result_still_read_by_compare_curves(files, run_cli):
    r = run_cli("compare-curves", f"{files['edit']}:before/foot", f"{files['edit']}:after/foot", "--json")
    assert r.exit_code == 0, r.output
