"""Spatial synthesis: the spherical four-bar and RSSR families' closed forms against solve3d's solver,
their atlases, and ``linkedit synthesize target3d.csv`` on held-out linkages, checked by ``solve3d``."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from linkedit.curves import partial
from linkedit.curves.polyline import arc_resample
from linkedit.gcs import check_solved, solve_spec
from linkedit.io.gcs_hdf5 import read_result
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.synthesis import atlas, rssr, spherical
from linkedit.synthesis.refine import curve_error

from tests.conftest import svg_legend, svg_texts

FAMILIES = {"spherical-four-bar": spherical, "rssr": rssr}


def _working(fam, seed: int, count: int) -> np.ndarray:
    params = fam.sample(np.random.default_rng(seed), 400)
    return params[fam.min_singularity(params) >= fam.margin()][:count]


@pytest.mark.parametrize("name", FAMILIES)
def test_closed_form_matches_solve3d(name):
    """The family's coupler curve, placed by a random rotation or reflection, is the track solve3d's solver
    finds on the spec the family writes (the solver knows nothing of the closed form)."""
    fam = FAMILIES[name]
    rng = np.random.default_rng(3)
    for k, row in enumerate(_working(fam, 11, 1)):
        matrix = -Rotation.random(random_state=k).as_matrix()  # a reflection: the crank turns the other way
        shift, phase = np.array([1.0, -2.0, 3.0]), float(rng.uniform())
        spec = fam.to_spec(row, phase=phase, scale=2.5, matrix=matrix, shift=shift, name="x", units="mm",
                           description="")
        spec["outputs"]["steps"] = 37
        res = solve_spec(MechanismSpec.model_validate(spec))
        check_solved(res)
        expected = shift + 2.5 * fam.curves(row[None], 36, phase)[0] @ matrix.T
        assert np.abs(res.tracks["target"].position[:-1] - expected).max() < 1e-8 * 2.5


def test_spherical_transmission_is_exact():
    """The closed-form lowest d_s = sin²μ of the spherical four-bar is the minimum over a dense cycle of the
    angle at c between the great circles c→b and c→d (measured from the joint axes themselves)."""
    params = _working(spherical, 5, 20)
    ax = spherical.axes(params, np.linspace(0, 2 * np.pi, 7200, endpoint=False)[None])
    b, c, d = ax["b"], ax["c"], ax["d"]
    tb = b - np.sum(b * c, axis=-1, keepdims=True) * c
    td = d - np.sum(d * c, axis=-1, keepdims=True) * c
    cos_mu = np.sum(tb * td, axis=-1) / (np.linalg.norm(tb, axis=-1) * np.linalg.norm(td, axis=-1))
    np.testing.assert_allclose(spherical.min_singularity(params), (1 - cos_mu ** 2).min(axis=1), atol=1e-6)
    # and the joints keep their arcs
    np.testing.assert_allclose(np.sum(b * c, axis=-1), np.cos(params[:, 1:2]) * np.ones((1, 7200)), atol=1e-12)
    np.testing.assert_allclose(np.sum(c * d, axis=-1), np.cos(params[:, 2:3]) * np.ones((1, 7200)), atol=1e-12)


def test_rssr_transmission_is_the_coupler_along_the_rocker_path():
    """RSSR d_s from K₁, K₂, K₃ equals ((A − B)·t / L)², t the rocker tip's path direction, and the coupler
    keeps its length."""
    params = _working(rssr, 6, 20)
    angle = np.linspace(0, 2 * np.pi, 90, endpoint=False)[None]
    j = rssr.joints(params, angle)
    a, b, q = j["A"], j["B"], j["Q"]
    n = j["n"]
    tangent = np.cross(n, b - q)
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    length = params[:, 5:6]
    np.testing.assert_allclose(j["ds"], (np.sum((a - b) * tangent, axis=-1) / length) ** 2, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(a - b, axis=-1), length * np.ones((1, 90)), rtol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(b - q, axis=-1), params[:, 4:5] * np.ones((1, 90)), rtol=1e-10)


@pytest.fixture(scope="module")
def spatial_atlas(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "spatial.h5"
    atlas.build(path, ["spherical-four-bar", "rssr"], 6000, seed=1)
    return path


def _target(tmp_path, name: str, seed: int, row: int, rotation: int):
    """A held-out linkage's curve (another seed than the atlas's), turned, scaled, moved, as x, y, z CSV."""
    fam = FAMILIES[name]
    params = atlas.build_chunk(name, seed, 0, row + 1).params[row]
    matrix = Rotation.random(random_state=rotation).as_matrix()
    points = np.array([40.0, -12.0, 7.0]) + 25.0 * fam.curves(params[None], 240, 0.3)[0] @ matrix.T
    path = tmp_path / f"{name}.csv"
    np.savetxt(path, points, delimiter=",", header="x,y,z", comments="")
    return path, points


def _check_round_trip(run_cli, tmp_path, out, points) -> dict:
    """result.yaml solved by `linkedit solve3d` draws the target with the error report.json gives."""
    report = json.loads((out / "report.json").read_text())
    solved = run_cli("solve3d", out / "result.yaml", "-o", tmp_path / "again.h5")
    assert solved.exit_code == 0, solved.output
    track = read_result(tmp_path / "again.h5").tracks["target"].position[:-1]
    again = curve_error(points, report["target"]["closed"], track, report["target"]["size"])
    assert again[0] == pytest.approx(report["error"]["after"]["rms"], rel=1e-6)
    assert again[1] == pytest.approx(report["error"]["after"]["max"], rel=1e-6)
    return report


def _small_spherical(tmp_path, samples: int, count: int):
    """A 1,500-linkage spherical atlas and a target drawn by one of its linkages with every length changed by
    ~2 % (not in the atlas), turned, scaled and moved, in metres: its first ``count`` of ``samples`` points."""
    path = tmp_path / "a.h5"
    atlas.build(path, ["spherical-four-bar"], 1500, seed=1)
    row = atlas.load(path).families["spherical-four-bar"]["params"][7].copy()
    row[:4] *= np.array([1.02, 0.98, 1.01, 0.985])
    points = np.array([3.0, 1.0, -2.0]) + 0.4 * spherical.curves(row[None], samples, 0.1)[0][:count] @ \
        Rotation.random(random_state=5).as_matrix().T
    target = tmp_path / "t.csv"
    np.savetxt(target, points, delimiter=",", header="x (m),y (m),z (m)", comments="")
    return path, target, points


def test_spatial_round_trip(run_cli, tmp_path):
    """A closed target near a small atlas's linkage: found to ≤ 1 %, and solve3d reproduces the reported error;
    overlay.svg draws the target, the atlas candidate and the result face-on to the curves' plane, with named
    axes in the target's units and one legend entry per thing; history.svg as for planar targets."""
    path, target, points = _small_spherical(tmp_path, 200, 200)
    out = tmp_path / "out"
    result = run_cli("synthesize", target, "--atlas", path, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    report = _check_round_trip(run_cli, tmp_path, out, points)
    assert report["error"]["after"]["rms"] <= 0.01 and report["target"]["units"] == "m"
    assert report["target"]["closed"] is True
    overlay = (out / "overlay.svg").read_text()
    names = svg_legend(overlay)
    assert len(names) == len(set(names)), names
    assert {"target", "atlas candidate as placed", "drawn by the linkage"} <= set(names), names
    assert {"u (m)", "v (m)"} <= set(svg_texts(overlay))
    assert re.findall(r'class="curve" data-name="([^"]*)"', overlay) == ["target", "atlas candidate as placed"]
    history = (out / "history.svg").read_text()
    words = svg_texts(history)
    assert "evaluations" in words and not {"x", "y"} & set(words)
    assert any("RMS error" in w and "% of the target's size" in w and "log" in w for w in words), words
    assert svg_legend(history) == ["candidate 1 (kept)"]


def test_open_spatial_arc(run_cli, tmp_path):
    """Half the cycle of the curve of test_spatial_round_trip (its ends far apart against its spacing): taken
    as an open arc, matched against a stretch of each candidate's cycle, found to ≤ 1 % RMS of its size, reported
    open, and solve3d reproduces the reported (one-sided) error."""
    path, target, points = _small_spherical(tmp_path, 400, 200)
    out = tmp_path / "out"
    result = run_cli("synthesize", target, "--atlas", path, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    report = _check_round_trip(run_cli, tmp_path, out, points)
    assert report["target"]["closed"] is False and report["error"]["after"]["rms"] <= 0.01
    assert "target→result distances (an open arc" in report["error"]["normalized_by"]
    assert "target (open arc)" in svg_legend((out / "overlay.svg").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("name, row", [("spherical-four-bar", 0), ("rssr", 3)])
def test_held_out_spatial_curve(run_cli, tmp_path, spatial_atlas, name, row):
    """A held-out spherical four-bar / RSSR curve is synthesized to ≤ 1 % RMS of its size, and result.yaml
    solved by `linkedit solve3d` draws it with the error the report gives."""
    target, points = _target(tmp_path, name, 99, row, row)
    out = tmp_path / "out"
    result = run_cli("synthesize", target, "--atlas", spatial_atlas, "-o", out, "--top", "2")
    assert result.exit_code == 0, result.output
    assert _check_round_trip(run_cli, tmp_path, out, points)["error"]["after"]["rms"] <= 0.01


@pytest.mark.slow
@pytest.mark.parametrize("row, fraction, start", [(0, 0.5, 0.3), (2, 0.6, 0.5)])
def test_held_out_spherical_arc(run_cli, tmp_path, spatial_atlas, row, fraction, start):
    """An open arc (a fraction of the cycle from a start phase) of a held-out spherical four-bar curve, turned,
    scaled and moved: recovered to ≤ 1 % RMS of its size, and result.yaml solved by `linkedit solve3d` draws it
    with the error the report gives."""
    params = atlas.build_chunk("spherical-four-bar", 99, 0, row + 1).params[row]
    points = np.array([40.0, -12.0, 7.0]) + 25.0 * spherical.curves(params[None], 480, start)[0][
        :int(480 * fraction)] @ Rotation.random(random_state=row).as_matrix().T
    target = tmp_path / "arc.csv"
    np.savetxt(target, points, delimiter=",", header="x,y,z", comments="")
    out = tmp_path / "out"
    result = run_cli("synthesize", target, "--atlas", spatial_atlas, "-o", out, "--top", "2")
    assert result.exit_code == 0, result.output
    report = _check_round_trip(run_cli, tmp_path, out, points)
    assert report["target"]["closed"] is False and report["error"]["after"]["rms"] <= 0.01


def test_atlas_of_spatial_families(run_cli, tmp_path):
    """`atlas build --family spherical-four-bar,rssr` stores 3D curves; the same chunks as built directly."""
    path = tmp_path / "a.h5"
    result = run_cli("atlas", "build", "--family", "spherical-four-bar,rssr", "-n", "200", "-o", path)
    assert result.exit_code == 0, result.output
    found = atlas.load(path)
    for name in FAMILIES:
        part = found.families[name]
        assert part["curves"].shape == (200, atlas.SAMPLES // atlas.COARSE_STEP, 3)
        chunk = atlas.build_chunk(name, 1, 0, 200)
        np.testing.assert_array_equal(part["params"], chunk.params)
        np.testing.assert_array_equal(part["index"], chunk.index)


def test_dimension_mismatch_is_an_input_error(run_cli, tmp_path):
    """A planar target against a spatial-only atlas, or a 3D target with a planar-only option: exit 2."""
    path = tmp_path / "a.h5"
    assert run_cli("atlas", "build", "--family", "spherical-four-bar", "-n", "100", "-o", path).exit_code == 0
    planar = tmp_path / "p.csv"
    t = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    np.savetxt(planar, np.stack([np.cos(t), 0.5 * np.sin(t)], axis=1), delimiter=",", header="x,y", comments="")
    result = run_cli("synthesize", planar, "--atlas", path, "-o", tmp_path / "o")
    assert result.exit_code == 2 and "no planar family" in result.output
    spatial = tmp_path / "s.csv"
    np.savetxt(spatial, np.stack([np.cos(t), np.sin(t), 0.3 * np.sin(2 * t)], axis=1), delimiter=",",
               header="x,y,z", comments="")
    result = run_cli("synthesize", spatial, "--atlas", path, "-o", tmp_path / "o", "--smooth", "0.1")
    assert result.exit_code == 2 and "--smooth applies to a planar target" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("mirrored", [False, True])
def test_a_3d_stretch_is_placed_by_the_similarity_that_made_it(mirrored):
    """An open 3D curve made from a stretch of a closed one (one window of the partial grid: offset 0, the
    fifth-largest fraction) by a known scale, rotation (or reflection) and shift: partial_rms finds it at ~0
    (a reflection only with mirror), partial_placement3 gives back that similarity."""
    t = np.linspace(0, 2 * np.pi, 500, endpoint=False)
    closed = np.stack([np.cos(t) + 0.3 * np.cos(2 * t) + 0.2 * np.sin(2 * t), np.sin(t) + 0.1 * np.cos(3 * t),
                       0.4 * np.sin(3 * t) + 0.2 * np.cos(t)], axis=1)  # no symmetry: one stretch fits
    ring = arc_resample(closed, partial.PARTIAL_OUTLINE, True)
    k = np.arange(partial.PARTIAL_POINTS) / (partial.PARTIAL_POINTS - 1)
    stretch = ring[np.round(partial.FINE[1][-5] * k * partial.PARTIAL_OUTLINE).astype(int)]
    matrix = Rotation.random(random_state=4).as_matrix() @ np.diag([1.0, 1.0, -1.0 if mirrored else 1.0])
    shift = np.array([2.0, -1.0, 0.5])
    arc = shift + 3.0 * stretch @ matrix.T
    rms, scale, found, moved = partial.partial_placement3(arc, closed, mirror=True)
    assert rms < 1e-9 and scale == pytest.approx(3.0, rel=1e-9)
    np.testing.assert_allclose(found, matrix, atol=1e-9)
    np.testing.assert_allclose(moved, shift, atol=1e-9)
    assert partial.partial_rms(arc[None], closed[None], mirror=True)[0, 0] < 1e-6 * 3.0
    proper = partial.partial_rms(arc[None], closed[None], mirror=False)[0, 0]
    assert (proper > 1e-2) if mirrored else (proper < 1e-6 * 3.0)
