"""The bench's mechanism variants (examples/3d/bench/, issue 22's Speed section) solve right:
each against a closed form derived in its spec, at 73 steps, to 1e-9 of its size."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES
from tests.gcs_oracles import crank_rocker

BENCH = EXAMPLES / "3d" / "bench"
STEPS = 73


def _track(run_cli, tmp_path, stem: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    out = tmp_path / f"{stem}.h5"
    r = run_cli("solve3d", BENCH / f"{stem}.yaml", "-o", out, "--steps", str(STEPS))
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        return f["t"][()], f[f"tracks/{name}/position"][()]


def _cylinder_rocker(t: np.ndarray) -> np.ndarray:
    d = 1.5 + 1.3 * (1 - np.abs(2 * t - 1))  # the stroke's keyframes 1.5, 2.8, 1.5, evenly spread
    phi = np.arccos((6 - d**2) / (2 * np.sqrt(5))) - np.arctan2(1, 2)
    return 3 * np.column_stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)])


def _offset_slider_crank(t: np.ndarray) -> np.ndarray:
    theta, r, rod, e = 2 * np.pi * t, 1.0, 3.0, 0.5
    x = r * np.cos(theta) + np.sqrt(rod**2 - (r * np.sin(theta) - e) ** 2)
    return np.column_stack([x, np.full_like(x, e), np.zeros_like(x)])


@pytest.mark.parametrize("stem, track, closed_form, size", [
    ("cylinder-rocker", "tip", _cylinder_rocker, 3.0),
    ("welded-crank-rocker", "P", lambda t: crank_rocker(2 * np.pi * t), 10.0),
    ("offset-slider-crank", "slider", _offset_slider_crank, 4.0),
])
def test_a_bench_variant_follows_its_closed_form(run_cli, tmp_path, stem, track, closed_form, size):
    t, p = _track(run_cli, tmp_path, stem, track)
    assert np.allclose(t, np.arange(STEPS) / (STEPS - 1))
    assert np.abs(p - closed_form(t)).max() < 1e-9 * size
