"""Precision points in `linkedit synthesize`: exact point-to-curve distances, detection, a held-out four-bar reached."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from linkedit.synthesis import atlas, fourbar
from linkedit.synthesis import points as precision


#: A crank-rocker the atlas does not hold (family parameters a, b, c, u, v, branch), written out so that the test does
#: not depend on the family's sampler.
HELD_OUT = np.array([0.06463566742102209, 0.2660799336834831, 0.8805589003435231, 2.016235087700304,
                     -0.886957629285714, 1.0])


def held_out() -> tuple[np.ndarray, np.ndarray]:
    """The held-out four-bar (family parameters) and its curve, moved (3600 samples)."""
    row = HELD_OUT
    return row, -20 + 55j + 80 * np.exp(-0.6j) * fourbar.curves(row[None], 3600)[0]


def uneven(curve: np.ndarray, count: int, seed: int) -> np.ndarray:
    return curve[np.sort(np.random.default_rng(seed).choice(len(curve), count, replace=False))]


def segment_distances(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Distance of each point (N,) to the closed polyline curve (M,): brute force over every segment."""
    a, e = curve, np.roll(curve, -1) - curve
    rel = points[:, None] - a[None]
    t = np.clip((rel.real * e.real + rel.imag * e.imag) / np.abs(e) ** 2, 0.0, 1.0)
    return np.abs(rel - t * e).min(axis=1)


def test_closest_distances_are_exact():
    """Against a bounded scalar minimization of the distance over the crank phase (to 1e-13)."""
    row = np.array([[0.4, 1.2, 1.1, 0.3, 0.6, 1.0]])
    rng = np.random.default_rng(0)
    pts = fourbar.curves(row, 720)[0][rng.choice(720, 10, replace=False)] + 0.05 * (rng.normal(size=10)
                                                                                     + 1j * rng.normal(size=10))
    got = precision.family_closest(fourbar, row, np.array([1 + 0j]), np.array([0j]), False, pts)[0]
    dense = fourbar.curves(row, 20000)[0]
    want = []
    for q in pts:
        j = np.argmin(np.abs(dense - q)) / 20000
        fit = minimize_scalar(lambda ph: abs(fourbar.curves(row, 1, np.array([ph]))[0, 0] - q),
                              bounds=(j - 1e-4, j + 1e-4), method="bounded", options={"xatol": 1e-13})
        want.append(fit.fun)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # from samples only (the written result's check): the parabola through the closest three
    sampled = precision.closest(pts, fourbar.curves(row, 7200))[0][0]
    np.testing.assert_allclose(sampled, want, rtol=0, atol=1e-7)


def test_precision_points_are_told_from_a_sampled_curve():
    _, curve = held_out()
    assert precision.detect(uneven(curve, 12, 3), closed=True).startswith("detected: 12 points")
    assert precision.detect(curve[::24], closed=True) is None  # 150 samples: a curve
    assert precision.detect(uneven(curve, 12, 3), closed=False) is None  # open: a part of a curve
    ring = np.concatenate([curve, curve[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(ring)))])
    at = np.arange(12) * s[-1] / 12
    even = np.interp(at, s, ring.real) + 1j * np.interp(at, s, ring.imag)
    assert precision.detect(even, closed=True) is None  # 12 points evenly spaced along the curve: a sampled curve


@pytest.fixture(scope="module")
def points_atlas(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 2 * atlas.CHUNK, seed=1)
    return path


def write_csv(path, z: np.ndarray) -> None:
    path.write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")


def test_precision_points_of_a_held_out_four_bar_are_reached(run_cli, points_atlas, tmp_path):
    """8 unevenly spaced points of a held-out four-bar's curve, taken for precision points (detected): every
    point within 1e-4 of their RMS radius of the result's curve; `linkedit simulate result.yaml` reproduces
    the reported per-point distances (segment distances to its dense curve)."""
    _, curve = held_out()
    target = uneven(curve, 8, 4)
    write_csv(tmp_path / "points.csv", target)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "points.csv", "--atlas", points_atlas, "-o", out, "--top", "3",
                     "--closed")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    found = report["precision_points"]
    assert found["mode"].startswith("detected: 8 points") and found["count"] == 8
    radius = np.sqrt(np.mean(np.abs(target - target.mean()) ** 2))
    assert found["radius"] == pytest.approx(radius, rel=1e-12)
    assert report["error"]["after"]["max"] <= 1e-4 and report["polish"]["kept"] is False
    fine = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "20000")
    assert fine.exit_code == 0, fine.output
    with h5py.File(tmp_path / "fine.h5") as f:
        p = f["tracks/target/position"][()]
    drawn = segment_distances(target, p[:, 0] + 1j * p[:, 1])
    np.testing.assert_allclose(found["distances"], drawn, rtol=0, atol=1e-6 * radius)
    assert max(drawn) / radius <= 1e-4


def test_points_take_neither_timing_nor_smoothing(run_cli, points_atlas, tmp_path):
    _, curve = held_out()
    write_csv(tmp_path / "points.csv", uneven(curve, 8, 4))
    result = run_cli("synthesize", tmp_path / "points.csv", "--atlas", points_atlas, "-o", tmp_path / "out",
                     "--points", "--smooth", "0.1")
    assert result.exit_code == 2 and "--points" in result.output and "Traceback" not in result.output
    assert not (tmp_path / "out").exists()
