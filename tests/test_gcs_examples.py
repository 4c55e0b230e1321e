"""Every 3D example solves through the CLI, with residuals < 1e-9 at every step and known poses."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.io.gcs_hdf5 import read_result
from tests.conftest import EXAMPLES

EXAMPLES_3D = sorted((EXAMPLES / "3d").glob("*.yaml"))


def _point(res, member, point, step):
    m = res.member_names.index(member)
    p = res.points[member][point] if isinstance(point, str) else np.asarray(point, dtype=float)
    return res.position[step, m] + quat.to_matrix(res.orientation[step, m]) @ p


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = {}
    folder = tmp_path_factory.mktemp("gcs")
    for path in EXAMPLES_3D:
        h5 = folder / f"{path.stem}.h5"
        r = CliRunner().invoke(app, ["solve3d", str(path), "-o", str(h5), "--svg", str(folder / f"{path.stem}.svg")])
        assert r.exit_code == 0, r.output
        out[path.stem] = (read_result(h5), h5)
    return out


def test_there_are_four_examples():
    assert {p.stem for p in EXAMPLES_3D} >= {"crank-rocker", "compound-crank-rocker", "six-bar", "spherical-four-bar"}


@pytest.mark.parametrize("name", [p.stem for p in EXAMPLES_3D])
def test_every_step_satisfies_every_constraint(solved, name):
    res, h5 = solved[name]
    assert (res.diagnostics.status == 0).all()
    assert np.sqrt(res.diagnostics.costs).max() < 1e-9
    # the ball-jointed coupler / rod of these two spins freely about its own axis
    assert (res.diagnostics.dof == (1 if name in ("rssr", "spatial-slider-crank") else 0)).all()
    with h5py.File(h5) as f:  # the file holds what the result says
        assert f.attrs["kind"] == "gcs" and f.attrs["format_version"] == "2"
        T = f["t"].shape[0]
        assert f["members/position"].shape == (T, len(res.member_names), 3)
        assert f["members/orientation"].shape == (T, len(res.member_names), 4)
        for name in res.tracks:
            assert f[f"tracks/{name}/position"].shape == (T, 3) and f[f"tracks/{name}/velocity"].shape == (T, 3)
        for key in ("status", "residual", "dof"):
            assert f[f"diagnostics/{key}"].shape == (T,)
        assert np.isfinite(f["members/position"][()]).all()
    q = res.orientation
    assert np.allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)


def test_crank_rocker_known_pose(solved):
    res, _ = solved["crank-rocker"]
    assert np.allclose(_point(res, "rocker", "tip", 0)[:2], [2.9887, 2.6644], atol=5e-5)
    assert np.allclose(res.tracks["P"].position[0, :2], [0.6622, 5.3265], atol=5e-5)
    # the crank turns once about z: its tip angle goes 0 → 360° with t
    tip = np.array([_point(res, "crank", "tip", k) for k in range(res.t.size)]) - [-3, 3, 0]
    angle = np.unwrap(np.arctan2(tip[:, 1], tip[:, 0]))
    assert np.allclose(angle, 2 * np.pi * res.t, atol=1e-9)
    assert res.tracks["P"].cyclic and np.abs(res.tracks["P"].position[:, 2]).max() < 1e-12


def test_compound_crank_rocker_leaves_the_plane(solved):
    plain, _ = solved["crank-rocker"]
    res, _ = solved["compound-crank-rocker"]
    P = res.tracks["P"].position
    assert np.allclose(P[0], plain.tracks["P"].position[0], atol=1e-9)  # same start
    assert np.ptp(P[:, 2]) > 4.9  # the point spins about the coupler axis through ±2.5
    # the spinner's P stays 2.5·√2 from the crank tip and at distance 2.5 from the coupler axis
    a = np.array([_point(res, "coupler", "a", k) for k in range(res.t.size)])
    b = np.array([_point(res, "coupler", "b", k) for k in range(res.t.size)])
    u = (b - a) / 5.0
    rel = P - a
    along = np.sum(rel * u, axis=1)
    assert np.allclose(along, 2.5, atol=1e-9)
    assert np.allclose(np.linalg.norm(rel - along[:, None] * u, axis=1), 2.5, atol=1e-9)


def test_six_bar_known_pose(solved):
    res, _ = solved["six-bar"]
    assert np.allclose(_point(res, "coupler", "C", 0)[:2], [0.5153, -2.9882], atol=5e-5)
    assert np.allclose(_point(res, "coupler", "E", 0)[:2], [-0.0077, -2.9889], atol=5e-5)
    assert np.allclose(_point(res, "GFH", "F", 0)[:2], [-2.2025, -3.4842], atol=5e-5)
    assert np.allclose(res.tracks["H"].position[0, :2], [-3.7026, -2.6734], atol=5e-5)


def test_spherical_four_bar_moves_on_spheres(solved):
    res, _ = solved["spherical-four-bar"]
    P = res.tracks["P"].position
    assert np.allclose(np.linalg.norm(P, axis=1), np.linalg.norm(res.points["coupler"]["P"]), atol=1e-9)
    assert np.ptp(P, axis=0).min() > 0.1  # a truly spatial curve
    # joint axes keep their arcs: the crank's b and the rocker's c stay 70° apart, c and d 50°
    b = np.array([_point(res, "crank", "b", k) for k in range(res.t.size)])
    c = np.array([_point(res, "rocker", "c", k) for k in range(res.t.size)])
    d = np.array([_point(res, "rocker", "d", k) for k in range(res.t.size)])
    assert np.allclose(np.degrees(np.arccos(np.sum(b * c, axis=1))), 70.0, atol=1e-6)
    assert np.allclose(d, d[0], atol=1e-9)  # the rocker turns about its fixed axis d
    assert np.allclose(np.degrees(np.arccos(np.sum(c * d, axis=1))), 50.0, atol=1e-6)
