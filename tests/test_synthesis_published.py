"""Published precision-point problems: their data as the sources print it, the exact polish, a CLI round trip."""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

from linkedit.synthesis import atlas, fourbar
from linkedit.synthesis import points as precision
from linkedit.synthesis.published import PROBLEMS

#: The sources' lines, as printed (PHCpack fourbar.rst; HomotopyContinuation.jl 9point.md; FourBarLinkages.jl
#: examples.jl example2–4).
MORGAN_WAMPLER_7 = """
    pt0 = Matrix([[ 0.50], [ 1.06]])
    pt1 = Matrix([[-0.83], [-0.27]])
    pt2 = Matrix([[-0.34], [ 0.22]])
    pt3 = Matrix([[-0.13], [ 0.43]])
    pt4 = Matrix([[ 0.22], [ 0.78]])
"""
NINE_POINT = """
coupler_points = [complex(0.8961867,-0.09802917),
        complex(1.2156535, -1.18749100),
        complex(1.5151435, -0.85449808),
        complex(1.6754775,  -0.48768058),
        complex(1.7138690,-0.30099232),
        complex(1.7215236,0.03269953),
        complex(1.6642029, 0.33241088),
        complex(1.4984171, 0.74435576),
        complex(1.3011834,  0.92153806)]
"""
EXAMPLES = [
    "P=[Point2f0(0.0,0.0), Point2f0(0.30,-0.1), Point2f0(0.70,0.0), Point2f0(0.82,0.2), Point2f0(0.90,0.4), "
    "Point2f0(0.90,0.7), Point2f0(0.60,0.7), Point2f0(0.10,0.5), Point2f0(0.00,0.3)].*10;",
    "P=[Point2f0(0.25,0.00), Point2f0(0.52,0.10), Point2f0(0.80,0.70), Point2f0(1.20,1.00), Point2f0(1.40,1.30), "
    "Point2f0(1.10,1.48), Point2f0(0.70,1.40), Point2f0(0.20,1.00), Point2f0(0.02,0.40)].*10;",
    "P=[Point2f0(1.000,0.875), Point2f0(0.750,0.625), Point2f0(0.500,0.375), Point2f0(0.250,0.125), "
    "Point2f0(0.000,0.000), Point2f0(0.96824583,1.32287565), Point2f0(1.56124949,1.73205080), "
    "Point2f0(1.85404962,1.93649167), Point2f0(1.98431348,2.00000000)].*5;",
]
NUMBER = r"\s*(-?[0-9.]+)\s*"


def test_the_problems_hold_the_sources_numbers():
    mw = [(float(x), float(y)) for x, y in re.findall(rf"\[\[{NUMBER}\], \[{NUMBER}\]\]", MORGAN_WAMPLER_7)]
    nine = [(float(x), float(y)) for x, y in re.findall(rf"complex\({NUMBER},{NUMBER}\)", NINE_POINT)]
    examples = [[(float(x), float(y)) for x, y in re.findall(rf"Point2f0\({NUMBER},{NUMBER}\)", text)]
                for text in EXAMPLES]
    expected = [mw, nine, *examples]
    assert [len(e) for e in expected] == [5, 9, 9, 9, 9]
    assert [list(p.points) for p in PROBLEMS] == expected


def test_newton_reaches_the_linkage_through_nine_of_its_points():
    """Nine points of a crank-rocker's curve, the linkage moved off by 1e-3 in every parameter and its placement:
    the polish meets every point to rounding and the linkage still works with the margin."""
    row = np.array([0.06463566742102209, 0.2660799336834831, 0.8805589003435231, 2.016235087700304,
                    -0.886957629285714, 1.0])
    z = 3 - 2j + 40 * np.exp(0.3j) * fourbar.curves(row[None], 9, 0.05)[0]
    radius = precision.rms_radius(z)
    start = row + np.array([1e-3, -1e-3, 1e-3, 1e-3, -1e-3, 0.0])
    factor, shift = 40 * np.exp(0.3j) * (1 + 1e-3j), 3 - 2j + 0.03
    before = precision.family_closest(fourbar, start[None], np.array([factor]), np.array([shift]), False, z)[0]
    assert before.max() > 1e-4 * radius
    found = precision.newton(fourbar, start, factor, shift, False, z, fourbar.margin())
    assert found is not None
    params, factor, shift = found
    after = precision.family_closest(fourbar, params[None], np.array([factor]), np.array([shift]), False, z)[0]
    assert after.max() <= 1e-12 * radius
    assert fourbar.min_singularity(params[None])[0] >= fourbar.margin()


@pytest.fixture(scope="module")
def small_atlas(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 2 * atlas.CHUNK, seed=1)
    return path


def test_morgan_wampler_problem_7_round_trip(run_cli, small_atlas, tmp_path):
    """`synthesize --points` on the five points of Morgan & Wampler's problem 7: the result passes through every
    point to rounding (the published linkages' error, 0); `linkedit simulate result.yaml` draws a curve whose
    distances to the points are the reported ones."""
    z = PROBLEMS[0].array()
    (tmp_path / "mw7.csv").write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in PROBLEMS[0].points))
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "mw7.csv", "--points", "--atlas", small_atlas, "-o", out,
                     "--top", "3")
    assert result.exit_code == 0, result.output
    found = json.loads((out / "report.json").read_text())["precision_points"]
    radius = precision.rms_radius(z)
    assert found["mode"] == "given (--points)" and max(found["distances"]) <= 1e-12 * radius
    fine = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "20000")
    assert fine.exit_code == 0, fine.output
    with h5py.File(tmp_path / "fine.h5") as f:
        p = f["tracks/target/position"][()]
    curve = p[:, 0] + 1j * p[:, 1]
    a, e = curve, np.roll(curve, -1) - curve  # each point's distance to the closed polyline, brute force
    rel = z[:, None] - a[None]
    t = np.clip((rel.real * e.real + rel.imag * e.imag) / np.abs(e) ** 2, 0.0, 1.0)
    drawn = np.abs(rel - t * e).min(axis=1)
    np.testing.assert_allclose(found["distances"], drawn, rtol=0, atol=1e-6 * radius)
