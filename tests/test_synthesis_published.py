"""Published precision-point problems: their data as the sources print it, the exact polish, a CLI round trip."""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

from linkedit.curves.polyline import distances_to
from linkedit.planar import compile_plan, simulate
from linkedit.synthesis import fourbar
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
    assert [list(p.points) for p in PROBLEMS if not p.linkages] == expected


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


def _drawn_distances(curve: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Each point's (N,) complex distance to the closed polyline ``curve`` (M,) complex, brute force."""
    a, e = curve, np.roll(curve, -1) - curve
    rel = z[:, None] - a[None]
    t = np.clip((rel.real * e.real + rel.imag * e.imag) / np.abs(e) ** 2, 0.0, 1.0)
    return np.abs(rel - t * e).min(axis=1)


@pytest.mark.slow  # 7 s; the six points on a line run the same round trip, and `bench -s synthesis --quick` solves problem 7
def test_morgan_wampler_problem_7_round_trip(run_cli, four_bar_atlas, tmp_path):
    """`synthesize --points` on the five points of Morgan & Wampler's problem 7: the result passes through every
    point to rounding (the published linkages' error, 0); `linkedit simulate result.yaml` draws a curve whose
    distances to the points are the reported ones."""
    z = PROBLEMS[0].array()
    (tmp_path / "mw7.csv").write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in PROBLEMS[0].points))
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "mw7.csv", "--points", "--atlas", four_bar_atlas, "-o", out,
                     "--top", "3")
    assert result.exit_code == 0, result.output
    found = json.loads((out / "report.json").read_text())["precision_points"]
    radius = precision.rms_radius(z)
    assert found["mode"] == "given (--points)" and max(found["distances"]) <= 1e-12 * radius
    fine = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "20000")
    assert fine.exit_code == 0, fine.output
    with h5py.File(tmp_path / "fine.h5") as f:
        p = f["tracks/target/position"][()]
    np.testing.assert_allclose(found["distances"], _drawn_distances(p[:, 0] + 1j * p[:, 1], z), rtol=0,
                               atol=1e-6 * radius)


def test_six_points_on_a_line_reach_the_published_error(run_cli, four_bar_atlas, tmp_path):
    """`synthesize --points` on GA case 1's six points on a vertical line (free timing; the best published four-bar,
    HCDJ's, meets them to 3.8e-8 of their RMS radius with its transmission angle falling to 19°, Lin & Hsiao's to
    7.9e-8 at 46°): the result, inside the 20° band, meets them at least as well (the atlas ranking blew its
    curves up until a near-straight stretch met the points, a valley whose error only falls as the linkage grows:
    1e-5 after refinement); `linkedit simulate result.yaml` draws a curve whose distances to the points are the
    reported ones."""
    problem = next(p for p in PROBLEMS if p.name.startswith("GA case 1"))
    z = problem.array()
    radius = precision.rms_radius(z)
    best = problem.best()
    assert best is not None
    (tmp_path / "line.csv").write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in problem.points))
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "line.csv", "--points", "--atlas", four_bar_atlas, "-o", out,
                     "--top", "3")
    assert result.exit_code == 0, result.output
    found = json.loads((out / "report.json").read_text())["precision_points"]
    assert np.mean(found["distances"]) / radius <= best[1].mean()
    fine = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "20000")
    assert fine.exit_code == 0, fine.output
    with h5py.File(tmp_path / "fine.h5") as f:
        p = f["tracks/target/position"][()]
        ds = f["diagnostics/singularity"][()]
    assert np.nanmin(ds) >= fourbar.margin()  # inside the 20° transmission band
    np.testing.assert_allclose(found["distances"], _drawn_distances(p[:, 0] + 1j * p[:, 1], z), rtol=0,
                               atol=1e-6 * radius)


#: The metaheuristic problems' points as the source prints them (sy-nguyen-van/DE_Jaya_Synthesis_Four_Bar_Mechanisms,
#: Case1/Objf1.m, Case2/Objf2.m, Case3/Objf3.m, Case4/Objf4.m, Case5/Objf5.m).
GA_POINTS = [
    "Cdx=[20 20 20 20 20 20];\nCdy=[20 25 30 35 40 45];",
    "Cdx=[3, 2.759, 2.372, 1.890, 1.355];\nCdy=[3, 3.363, 3.663, 3.862, 3.943];",
    "CD=[0.5, 1.1;    0.4, 1.1;    0.3, 1.1;    0.2, 1.0;    0.1, 0.9;    0.05, 0.75;    0.02, 0.6;    "
    "0.0, 0.5;    0.0, 0.4;    0.03, 0.3;    0.1, 0.25;    0.15, 0.2;    0.2, 0.3;    0.3, 0.4;    0.4, 0.5;    "
    "0.5, 0.7;    0.6, 0.9;    0.6, 1.0];",
    "C1=[0;0];\nC2=[1.9098 ;5.8779];\nC3=[6.9098; 9.5106];\nC4=[13.09; 9.5106];\nC5=[18.09 ;5.8779];\nC6=[20 ;0.0];",
    "C1=[20;10];\nC2=[17.66;15.142];\nC3=[11.736;17.878];\nC4=[5;16.928];\nC5=[0.60307;12.736];\n"
    "C6=[0.60307;7.2638];\nC7=[5;3.0718];\nC8=[11.736;2.1215];\nC9=[17.66;4.8577];\nC10=[20;10];",
]


def _printed_points(text: str) -> list[tuple[float, float]]:
    """The (x, y) of one source text: Cdx/Cdy rows, a CD matrix of x, y rows, or C1..Cn columns."""
    if text.startswith("Cdx"):
        xs, ys = ([float(v) for v in re.split(r"[ ,]+", row)] for row in re.findall(r"=\[([^\]]*)\]", text))
        return list(zip(xs, ys))
    pairs = re.findall(r"(-?[0-9.]+)\s*[;,]\s*(-?[0-9.]+)", text)
    return [(float(x), float(y)) for x, y in pairs]


def _sources_coupler(x: tuple[float, ...], theta2: np.ndarray) -> np.ndarray:
    """The sources' closed form of the coupler point (N,) complex at crank angles ``theta2`` (N,) rad (their
    Freudenstein half-angle solution for the coupler angle θ3, then C = r2·e^{iθ2} + (rcx + i·rcy)·e^{iθ3},
    rotated by θ0 and moved to (x0, y0)): an independent reference for linkedit's four-bar."""
    r1, r2, r3, r4, rcx, rcy = x[:6]
    x0, y0, theta0 = x[6:9] if len(x) > 6 else (0.0, 0.0, 0.0)
    k1, k4, k5 = r1 / r2, r1 / r3, (r4 ** 2 - r1 ** 2 - r2 ** 2 - r3 ** 2) / (2 * r3 * r2)
    d = np.cos(theta2) - k1 + k4 * np.cos(theta2) + k5
    e = -2 * np.sin(theta2)
    f = k1 + (k4 - 1) * np.cos(theta2) + k5
    theta3 = 2 * np.arctan((-e - np.sqrt(e * e - 4 * d * f)) / (2 * d))
    c = r2 * np.exp(1j * theta2) + complex(rcx, rcy) * np.exp(1j * theta3)
    return complex(x0, y0) + np.exp(1j * theta0) * c


def _significant(value: float) -> int:
    """Significant digits of a number as written (4.27e-6: 3)."""
    mantissa = repr(value).split("e")[0].replace(".", "").lstrip("0")
    return len(mantissa)


def test_the_ga_problems_hold_the_sources_points():
    ga = [p for p in PROBLEMS if p.linkages]
    assert [list(p.points) for p in ga] == [_printed_points(text) for text in GA_POINTS]
    assert [len(p.points) for p in ga] == [6, 5, 18, 6, 10]


def test_the_published_linkages_reproduce_the_stated_errors():
    """The sources' own error (sum of squared distances at the sources' crank angles, by their closed form) of each
    linkage marked ``stated`` is the stated number to its last digit: the linkages were copied right; and linkedit's four-bar
    of every published linkage puts its coupler point where the sources' closed form does at those angles."""
    stated = 0
    for problem in (p for p in PROBLEMS if p.linkages):
        z = problem.array()
        for linkage in problem.linkages:
            theta = problem.angles(linkage)
            theirs = _sources_coupler(linkage.x, theta)
            row, factor, shift = linkage.placed()
            ours = shift + factor * fourbar.curves(np.repeat(row[None], len(theta), axis=0), 1,
                                                   theta / (2 * np.pi))[:, 0]
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * abs(factor))
            if linkage.stated is not None:
                error = float(np.sum(np.abs(theirs - z) ** 2))
                last = 10.0 ** (np.floor(np.log10(linkage.stated)) - _significant(linkage.stated) + 1)
                assert abs(error - linkage.stated) <= last, (problem.name, error)  # rounded or cut at its last digit
                stated += 1
    assert stated == 5


def test_a_published_linkage_scores_no_worse_free_than_timed():
    """Each point's distance to the whole curve (the bench's measure) is at most its distance to the curve point at
    the sources' crank angle, and the best published linkage of the six points on a line meets them to 1e-6 of
    their RMS radius (the sources' 4.07e-12 sum of squares)."""
    for problem in (p for p in PROBLEMS if p.linkages):
        z = problem.array()
        for linkage in problem.linkages:
            timed = np.abs(_sources_coupler(linkage.x, problem.angles(linkage)) - z)
            assert np.all(linkage.distances(z) <= timed + 1e-12 * precision.rms_radius(z)), linkage.label
    best = next(p for p in PROBLEMS if p.name.startswith("GA case 1")).best()
    assert best is not None and best[1].max() < 1e-6


def test_the_published_spec_draws_the_scored_curve():
    """The published linkage written as a linkedit spec and simulated passes where it is scored: the points'
    distances to the simulated (polyline) curve are the exact ones the bench reports."""
    for problem in (p for p in PROBLEMS if p.linkages):
        best = problem.best()
        assert best is not None
        linkage, scored = best
        z = problem.array()
        radius = precision.rms_radius(z)
        p = simulate(compile_plan(linkage.to_spec()), 20000).tracks["target"].position
        drawn = distances_to(z, p[:, 0] + 1j * p[:, 1], True) / radius
        np.testing.assert_allclose(drawn, scored, rtol=0, atol=1e-6)
