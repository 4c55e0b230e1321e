"""An input window's edge between two steps is solved too (specs/mechanism3d.md, Inputs); a
failure there is reported like any step's, never dropped with the edge."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from linkedit.io.gcs_hdf5 import read_result

REACH = 3.0  # the rod (length 1, pinned at the origin) keeps its tip 2 to 4 from (3, 0, 0)


def _spec(tmp_path, steps: int, end: float, last: float):
    """A rod turned by a linear actuator from its tip to (3, 0, 0), 2.9 long at t = 0 and
    ``last`` (< 2: out of reach) at its window's end ``end``, between two of ``steps`` steps."""
    data = {
        "name": "edge", "units": "m",
        "shapes": {"rod": {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}, "lines": [["pivot", "tip"]]}},
        "members": {"rod": {"position": [0, 0, 0], "orientation": {"axis": [0, 0, 1], "angle_deg": 90},
                            "shape": "rod"}},
        "constraints": {"hinge": {"type": "pin", "member": "rod", "point": "pivot", "world": [0, 0, 0]}},
        "inputs": {"pull": {"type": "distance", "member": "rod", "point": "tip", "world": [REACH, 0, 0],
                            "keyframes": [2.9, last], "window": [0, end]}},
        "outputs": {"steps": steps, "tracks": {"tip": {"member": "rod", "point": "tip"}}},
    }
    path = tmp_path / "edge.yaml"
    path.write_text(yaml.safe_dump(data, default_flow_style=None, sort_keys=False))
    return path


# (steps, window end, actuator length there): the reach (2) is lost after the last step before
# the edge (t = 0.5 of 3 steps, 7/12 of 13) and before the edge, which is no step
CASES = [(3, 0.7, 1.9), (13, 0.65, 1.95)]


@pytest.mark.parametrize("steps,end,last", CASES)
def test_a_failure_at_a_window_edge_is_reported(run_cli, tmp_path, steps, end, last):
    """It was dropped with the edge: exit 0, "2 steps … 2 converged" written for 3 asked."""
    out = tmp_path / "edge.h5"
    r = run_cli("solve3d", _spec(tmp_path, steps, end, last), "-o", out)
    assert r.exit_code == 1, r.output
    line = r.output.strip()
    before = int(np.floor(end * (steps - 1)))
    assert "\n" not in line and "Traceback" not in line
    assert f"inconsistent at t = {end:.4f}, an input window's edge between steps {before} and {before + 1}" \
        in line and "pull off by" in line, line
    assert not out.exists()


@pytest.mark.parametrize("steps,end,last", CASES)
def test_partial_marks_the_step_after_a_failed_window_edge(run_cli, tmp_path, steps, end, last):
    """With --partial the steps written are the ones asked; the first after the failed edge
    did not converge (its pose is a restart's, not the edge's held one); the steps before it
    are the closed form's: tip x = (10 − d²)/6 on the unit circle, d the actuator's length."""
    out = tmp_path / "edge.h5"
    r = run_cli("solve3d", _spec(tmp_path, steps, end, last), "-o", out, "--partial")
    assert r.exit_code == 0, r.output
    assert f"{steps - 1} converged, 0 inconsistent, 1 did not converge" in r.output, r.output
    res = read_result(out)
    assert np.array_equal(res.t, np.linspace(0.0, 1.0, steps))
    before = int(np.floor(end * (steps - 1)))
    status = res.diagnostics.status
    assert (status[:before + 1] == 0).all() and status[before + 1] == 2, status
    t = res.t[:before + 1]
    d = 2.9 + (last - 2.9) * t / end
    x = (1 + REACH**2 - d**2) / (2 * REACH)
    tip = np.stack([x, np.sqrt(1 - x**2), 0 * x], axis=1)
    assert np.abs(res.tracks["tip"].position[:before + 1] - tip).max() < 1e-9
