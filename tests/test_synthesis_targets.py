"""`linkedit synthesize` and its target: units, empty files, magnitudes, closure, smoothing, the pictures.

Each run's written result.yaml is simulated again and its error measured independently (both curves
sampled evenly along their length, brute-force nearest points, both ways): it is the reported one.
"""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

from linkedit.curves.efd import polyline_efd
from linkedit.curves.sources import is_closed
from linkedit.synthesis import atlas, fourbar

from tests.conftest import svg_legend, svg_texts


@pytest.fixture(scope="module")
def coupler_curve() -> np.ndarray:
    """A held-out four-bar's coupler curve (another seed than the atlas), densely sampled (20000,) complex."""
    row = atlas.build_chunk("four-bar", 12345, 0, 3).params[2]
    return -20 + 55j + 80 * np.exp(-0.6j) * fourbar.curves(row[None], 20000)[0]


def write_csv(path, z: np.ndarray, header: str = "x,y") -> None:
    path.write_text(header + "\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")


def even(z: np.ndarray, count: int, closed: bool = True) -> np.ndarray:
    """``count`` points evenly spaced along the polyline z (M,) complex (closed: back to the start)."""
    ring = np.concatenate([z, z[:1]]) if closed else z
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(ring)))])
    at = np.linspace(0.0, s[-1], count, endpoint=not closed)
    return np.interp(at, s, ring.real) + 1j * np.interp(at, s, ring.imag)


def to_polyline(a: np.ndarray, b: np.ndarray, closed: bool) -> np.ndarray:
    """Distance of each point of a (N,) to the polyline through b (M,), all complex: brute force over segments."""
    start, end = (b, np.roll(b, -1)) if closed else (b[:-1], b[1:])
    edge = (end - start)[None, :]
    rel = a[:, None] - start[None, :]
    t = np.clip((rel * np.conj(edge)).real / np.abs(edge) ** 2, 0.0, 1.0)
    return np.abs(rel - t * edge).min(axis=1)


def resimulated_error(run_cli, out, target: np.ndarray, closed: bool, tmp_path) -> float:
    """`linkedit simulate result.yaml` at the result's 360 samples; the RMS distance, over the reported size,
    from the target to the drawn curve and (closed) back, both sampled evenly along their length."""
    again = tmp_path / f"{out.name}-again.h5"
    sim = run_cli("simulate", out / "result.yaml", "-o", again, "-n", "360")
    assert sim.exit_code == 0, sim.output
    with h5py.File(again) as f:
        p = f["tracks/target/position"][()]
    drawn = p[:, 0] + 1j * p[:, 1]
    report = json.loads((out / "report.json").read_text())
    gaps = [to_polyline(even(target, 1000, closed), drawn, True)]
    if closed:
        gaps.append(to_polyline(even(drawn, 1000), target, closed))
    gap = np.concatenate(gaps) / report["target"]["size"]
    return float(np.sqrt(np.mean(gap ** 2)))


def one_line_exit_2(result, *words: str) -> str:
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert all(w in lines[0] for w in words), lines[0]
    return lines[0]


# --- units --------------------------------------------------------------------------------------------------------


def test_units_from_the_csv_header_reach_every_result_file(run_cli, four_bar_atlas, coupler_curve, tmp_path):
    """`x (m),y (m)`: result.yaml, result.h5 and report.json say m (the numbers are not rescaled)."""
    target = coupler_curve[::160] / 1000
    write_csv(tmp_path / "m.csv", target, "x (m),y (m)")
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "m.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    assert re.search(r"^units: m$", (out / "result.yaml").read_text(), re.M)
    with h5py.File(out / "result.h5") as f:
        assert f.attrs["units"] == "m"
    report = json.loads((out / "report.json").read_text())
    diagonal = np.hypot(np.ptp(target.real), np.ptp(target.imag))  # the size (major extent) is at most that
    assert report["target"]["units"] == "m" and 0.5 * diagonal < report["target"]["size"] <= diagonal
    assert resimulated_error(run_cli, out, target, True, tmp_path) == pytest.approx(report["error"]["after"]["rms"],
                                                                                     rel=0.02)


def test_units_option(run_cli, four_bar_atlas, coupler_curve, tmp_path):
    """--units names the units of a bare header; one that contradicts the file's is exit 2."""
    write_csv(tmp_path / "bare.csv", coupler_curve[::160])
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "bare.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "1",
                     "--units", "in")
    assert result.exit_code == 0, result.output
    assert re.search(r"^units: in$", (out / "result.yaml").read_text(), re.M)
    assert json.loads((out / "report.json").read_text())["target"]["units"] == "in"
    write_csv(tmp_path / "m.csv", coupler_curve[::160], "x (m),y (m)")
    clash = run_cli("synthesize", tmp_path / "m.csv", "--atlas", four_bar_atlas, "-o", tmp_path / "o2", "--units", "mm")
    one_line_exit_2(clash, "--units", "mm", "m.csv")
    assert not (tmp_path / "o2").exists()


@pytest.mark.parametrize("header, words", [("x (m),y (mm)", ["units", "m", "mm"]), ("x (m/s),y (m/s)", ["m/s"])])
def test_unusable_units_in_the_header_are_exit_2(run_cli, four_bar_atlas, coupler_curve, tmp_path, header, words):
    write_csv(tmp_path / "u.csv", coupler_curve[::160], header)
    result = run_cli("synthesize", tmp_path / "u.csv", "--atlas", four_bar_atlas, "-o", tmp_path / "out")
    assert "u.csv:1" in one_line_exit_2(result, *words)
    assert not (tmp_path / "out").exists()


# --- no data, magnitudes ------------------------------------------------------------------------------------------


def test_a_header_without_rows_is_no_data(run_cli, four_bar_atlas, tmp_path):
    (tmp_path / "h.csv").write_text("x,y\n")
    result = run_cli("synthesize", tmp_path / "h.csv", "--atlas", four_bar_atlas, "-o", tmp_path / "out")
    one_line_exit_2(result, "h.csv", "no data")
    assert not (tmp_path / "out").exists()


def test_the_fit_is_scale_free(run_cli, four_bar_atlas, coupler_curve, tmp_path):
    """The same target in units 1e30 apart (and 1e-100, where the polish failed) gives the same normalized
    error, and a result.yaml in the target's frame that draws it with that error."""
    base = coupler_curve[::160]
    errors, sizes = {}, {}
    for scale in (1e-100, 1e-30, 1.0, 1e30):
        target = base * scale
        write_csv(tmp_path / "t.csv", target)
        out = tmp_path / f"out{scale:g}"
        result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "1")
        assert result.exit_code == 0, result.output
        report = json.loads((out / "report.json").read_text())
        errors[scale] = report["error"]["after"]["rms"]
        sizes[scale] = report["target"]["size"] / scale
        assert resimulated_error(run_cli, out, target, True, tmp_path) == pytest.approx(errors[scale], rel=0.02)
    assert errors[1.0] < 0.01
    for scale, error in errors.items():  # to 1e-6 of the size: the scaled input's rounding (1e-16) moves the
        assert error == pytest.approx(errors[1.0], rel=0, abs=1e-6), scale  # least-squares path by ~1e-8
        assert sizes[scale] == pytest.approx(sizes[1.0], rel=1e-12)


def test_the_index_descriptor_is_scale_free(coupler_curve):
    """The float32 index descriptor of a curve in any units is that of the curve in mm (it was NaN from 1e60 on:
    the float32 product saw the unnormalized slopes)."""
    z = coupler_curve[::50]
    want = polyline_efd(z[None], 8)
    for scale in (1e-300, 1e-30, 1e60, 1e150, 1e300):
        np.testing.assert_allclose(polyline_efd(z[None] * scale, 8), want, atol=1e-6)


@pytest.mark.parametrize("scale, words", [(1e300, ["e+30", "≤ 1e+150"]), (1e-200, ["e-19", "1e-150 across"])])
def test_a_target_beyond_the_float_range_is_one_line_exit_2(run_cli, four_bar_atlas, coupler_curve, tmp_path, scale,
                                                            words):
    write_csv(tmp_path / "big.csv", coupler_curve[::160] * scale)
    result = run_cli("synthesize", tmp_path / "big.csv", "--atlas", four_bar_atlas, "-o", tmp_path / "out")
    one_line_exit_2(result, "big.csv", *words)
    assert not (tmp_path / "out").exists()


# --- closure --------------------------------------------------------------------------------------------------------


def uneven(curve: np.ndarray, sparse: int, dense: int, fraction: float = 1.0) -> np.ndarray:
    """The first ``fraction`` of the closed ``curve`` (M,) by arc length: ``dense`` points evenly over its middle
    half, ``sparse`` over each quarter at its ends (a part: its last point is the fraction's end)."""
    f = np.concatenate([np.linspace(0.0, 0.25, sparse, endpoint=False), np.linspace(0.25, 0.75, dense, endpoint=False),
                        np.linspace(0.75, 1.0, sparse, endpoint=fraction < 1.0)])
    return even(curve, 20000)[np.round(f * fraction * 20000).astype(int) % 20000]


def test_closure_is_told_from_the_geometry_not_from_even_sampling(coupler_curve):
    """A closed curve sampled sparsely where it starts and ends is closed (the gap between its ends is one of
    its steps there, though 9 median steps and 10 % of its diagonal); open parts of it stay open."""
    def pts(z):
        return np.stack([z.real, z.imag], axis=1)

    assert is_closed(pts(uneven(coupler_curve, 5, 90))) and is_closed(pts(uneven(coupler_curve, 8, 140)))
    for fraction in (0.5, 0.8, 0.9):
        assert not is_closed(pts(uneven(coupler_curve, 5, 90, fraction))), fraction
    assert is_closed(pts(coupler_curve[::400]))  # evenly sampled, 50 points


def test_an_unevenly_sampled_closed_target_is_synthesized_as_closed(run_cli, four_bar_atlas, coupler_curve, tmp_path):
    target = uneven(coupler_curve, 5, 90)
    write_csv(tmp_path / "w.csv", target)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "w.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["target"]["closed"] and report["error"]["after"]["rms"] < 0.01
    assert resimulated_error(run_cli, out, target, True, tmp_path) == pytest.approx(report["error"]["after"]["rms"],
                                                                                     rel=0.02)


# --- the pictures -------------------------------------------------------------------------------------------------


def test_smoothed_target_the_overlay_draws_what_its_error_is_measured_against(run_cli, four_bar_atlas, coupler_curve,
                                                                              tmp_path):
    """--smooth: the overlay draws the smoothed target (the error's reference) and its title says so; the report's
    error is against the smoothed target (given in the report), which result.yaml reproduces."""
    rng = np.random.default_rng(3)
    raw = coupler_curve[::100] + 0.8 * (rng.normal(size=200) + 1j * rng.normal(size=200))
    write_csv(tmp_path / "noisy.csv", raw)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "noisy.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "1",
                     "--smooth", "0.01")
    assert result.exit_code == 0, result.output
    svg = (out / "overlay.svg").read_text()
    title = re.search(r"<title>([^<]*)</title>", svg).group(1)
    assert "smoothed" in title and "σ = 0.01" in title, title
    assert re.findall(r'class="target" data-name="([^"]*)"', svg) == ["smoothed target"]
    names = svg_legend(svg)
    assert len(names) == len(set(names)) and names.count("target") == 1, names
    report = json.loads((out / "report.json").read_text())
    assert report["target"]["smoothed"] is True
    smoothed = np.array(report["target"]["curve"])
    smoothed = smoothed[:, 0] + 1j * smoothed[:, 1]
    assert len(smoothed) == 200 and np.abs(smoothed - raw).max() > 0.1
    error = report["error"]["after"]["rms"]
    assert resimulated_error(run_cli, out, smoothed, True, tmp_path) == pytest.approx(error, rel=0.02)
    assert resimulated_error(run_cli, out, raw, True, tmp_path) > 1.2 * error  # the raw target is farther


def test_history_and_overlay_name_their_axes_and_each_thing_once(run_cli, four_bar_atlas, coupler_curve, tmp_path):
    write_csv(tmp_path / "t.csv", coupler_curve[::160], "x (mm),y (mm)")
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bar_atlas, "-o", out, "--top", "2")
    assert result.exit_code == 0, result.output
    overlay = svg_legend((out / "overlay.svg").read_text())
    assert len(overlay) == len(set(overlay)) and overlay.count("target") == 1, overlay
    history = (out / "history.svg").read_text()
    words = svg_texts(history)
    assert "evaluations" in words and not {"x", "y"} & set(words)
    assert any("RMS error" in w and "% of the target's size" in w and "log" in w for w in words), words
    assert not any("1 unit =" in w for w in words)
    names = svg_legend(history)
    assert len(names) == 2 and len(set(names)) == 2 and sum("(kept)" in n for n in names) == 1, names
