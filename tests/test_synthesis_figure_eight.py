"""Gerono's figure-eights with a six-bar family: no four-bar inside the 20° transmission band draws the 2:1 one
better than 4.15 % (README; tests/test_synthesis_band_optimum.py), the Stephenson six-bar of
`examples/figure-eight-six-bar.yaml` made a family draws both within 1 % RMS, every transmission angle in the band."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from linkedit.examples import examples_dir

SIN2_20 = np.sin(np.radians(20.0)) ** 2


def even(z: np.ndarray, count: int) -> np.ndarray:
    """``count`` points evenly spaced along the closed polyline z (M,) complex."""
    ring = np.concatenate([z, z[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(ring)))])
    at = np.linspace(0.0, s[-1], count, endpoint=False)
    return np.interp(at, s, ring.real) + 1j * np.interp(at, s, ring.imag)


def nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a[:, None] - b[None, :]).min(axis=1)


def drawn(path) -> tuple[np.ndarray, np.ndarray]:
    """A re-simulated six-bar result: its track (T,) complex and sin² of the transmission angles at B (between B→A
    and B→D) and at E (E→C, E→F), (2, T), from its joint positions."""
    with h5py.File(path) as f:
        names = [n.decode() for n in f["joint"][()]]
        pos = f["joints/position"][()]
        p = f["tracks/target/position"][()]
    j = {k: pos[:, names.index(k), 0] + 1j * pos[:, names.index(k), 1] for k in "ABCDEF"}
    angles = np.angle([(j["A"] - j["B"]) / (j["D"] - j["B"]), (j["C"] - j["E"]) / (j["F"] - j["E"])])
    return p[:, 0] + 1j * p[:, 1], np.sin(angles) ** 2


@pytest.fixture(scope="module")
def six_bars(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    path = tmp_path_factory.mktemp("atlas") / "eights.h5"
    built = CliRunner().invoke(app, ["atlas", "build", "--family", str(examples_dir() / "figure-eight-six-bar.yaml"),
                                     "-n", "500", "-o", str(path)], catch_exceptions=False)
    assert built.exit_code == 0, built.output
    return path


@pytest.mark.parametrize("height", [10.0, pytest.param(8.0, marks=pytest.mark.slow)])  # Gerono 2:1; a flatter 5:2
def test_a_six_bar_draws_the_figure_eights_within_one_percent(run_cli, six_bars, tmp_path, height):
    """`synthesize --top 1` with 500 six-bars around the example (0.11 % and 0.08 % when written): ≤ 1 % RMS of the width (40) as reported, and measured here on
    `linkedit simulate result.yaml` (4000 samples, both curves evenly spaced, distances both ways) to 2 % of the
    reported figure; every transmission angle of the re-simulated six-bar within [20°, 160°]."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    eight = 20 * np.cos(t) + 1j * height * np.sin(2 * t)
    (tmp_path / "eight.csv").write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in eight))
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "eight.csv", "--atlas", six_bars, "-o", out, "--top", "1")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["family"] == "figure-eight-six-bar" and report["note"] == ""
    assert report["error"]["after"]["rms"] <= 0.01
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "4000")
    assert sim.exit_code == 0, sim.output
    curve, sin2 = drawn(tmp_path / "fine.h5")
    gap = np.concatenate([nearest(even(eight, 1000), even(curve, 20000)),
                          nearest(even(curve, 1000), even(eight, 20000))]) / 40.0
    error = float(np.sqrt(np.mean(gap ** 2)))
    assert error <= 0.01 and error == pytest.approx(report["error"]["after"]["rms"], rel=0.02)
    assert sin2.min() >= SIN2_20 - 1e-9
