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

from linkedit.curves.sources import is_closed
from linkedit.synthesis import atlas, fourbar


@pytest.fixture(scope="module")
def small_atlas(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 2 * atlas.CHUNK, seed=1)
    return path


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


@pytest.mark.parametrize("header, words", [("x (m),y (mm)", ["units", "m", "mm"]), ("x (m/s),y (m/s)", ["m/s"])])
def test_unusable_units_in_the_header_are_exit_2(run_cli, small_atlas, coupler_curve, tmp_path, header, words):
    write_csv(tmp_path / "u.csv", coupler_curve[::160], header)
    result = run_cli("synthesize", tmp_path / "u.csv", "--atlas", small_atlas, "-o", tmp_path / "out")
    assert "u.csv:1" in one_line_exit_2(result, *words)
    assert not (tmp_path / "out").exists()


# --- no data ---------------------------------------------------------------------------------------------------


def test_a_header_without_rows_is_no_data(run_cli, small_atlas, tmp_path):
    (tmp_path / "h.csv").write_text("x,y\n")
    result = run_cli("synthesize", tmp_path / "h.csv", "--atlas", small_atlas, "-o", tmp_path / "out")
    one_line_exit_2(result, "h.csv", "no data")
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


def test_an_unevenly_sampled_closed_target_is_synthesized_as_closed(run_cli, small_atlas, coupler_curve, tmp_path):
    target = uneven(coupler_curve, 5, 90)
    write_csv(tmp_path / "w.csv", target)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "w.csv", "--atlas", small_atlas, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["target"]["closed"] and report["error"]["after"]["rms"] < 0.01
    assert resimulated_error(run_cli, out, target, True, tmp_path) == pytest.approx(report["error"]["after"]["rms"],
                                                                                     rel=0.02)
