"""A four-bar through its change points (all links collinear, where the parallelogram and the
anti-parallelogram branches cross): solve3d keeps the branch whose tangent continues the
motion, whatever the number of steps."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from linkedit.io.gcs_hdf5 import read_result
from tests.gcs_oracles import pinned_four_bar

#: crank = rocker = 1 m, coupler = ground = 4 m, crank at 90° at rest: a parallelogram whose
#: change points (crank at 180° and 360°) are at t = 0.25 and 0.75
PARALLELOGRAM = pinned_four_bar("parallelogram", {"a": [0, 0, 0], "b": [4, 0, 0], "P": [2, 1, 0]},
                                {"P": {"member": "coupler", "point": "P"},
                                 "rocker_tip": {"member": "rocker", "point": "tip"}})
SIZE = float(np.hypot(4.0, 2.0))  # the rest pose's bounding box: (0, 0) to (4, 2)


def _points(run_cli, tmp_path, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Times (T,) and the coupler point P and rocker tip (T, 2, 3) of a solve3d run."""
    spec = tmp_path / "parallelogram.yaml"
    spec.write_text(yaml.safe_dump(PARALLELOGRAM))
    out = tmp_path / f"p{steps}.h5"
    r = run_cli("solve3d", spec, "--steps", str(steps), "-o", out, "--quiet")
    assert r.exit_code == 0, r.output
    res = read_result(out)
    assert (res.diagnostics.status == 0).all()
    return res.t, np.stack([res.tracks["P"].position, res.tracks["rocker_tip"].position], axis=1)


def test_parallelogram_keeps_its_branch_through_change_points_at_any_steps(run_cli, tmp_path):
    """Issue 22, 1: with 361 steps (a step exactly on the change point) 269 steps went over to
    the anti-parallelogram, all "converged"; 37, 19 and 5 steps stayed on the parallelogram."""
    runs = {n: _points(run_cli, tmp_path, n) for n in (361, 37, 19, 5)}
    for n, (t, p) in runs.items():
        theta = np.radians(90.0 + 360.0 * t)
        tip = np.stack([np.cos(theta), np.sin(theta), 0 * theta], axis=1)  # the crank tip
        closed = np.stack([tip + [2.0, 1.0, 0.0], tip + [4.0, 0.0, 0.0]], axis=1)  # rocker angle = crank angle
        assert np.abs(p - closed).max() <= 1e-9 * SIZE, n
    t0, p0 = runs[361]
    for n in (37, 19, 5):
        t, p = runs[n]
        shared = np.flatnonzero(np.isclose(t0[:, None], t[None, :], rtol=0, atol=1e-12).any(axis=1))
        mine = np.searchsorted(t, t0[shared] - 1e-12)
        assert np.abs(p[mine] - p0[shared]).max() <= 1e-9 * SIZE, n
