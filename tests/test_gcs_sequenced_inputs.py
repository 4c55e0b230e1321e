"""Inputs that act one after another (a robot arm's joints moved in turn): a joint whose input
window has closed holds where its input left it while the next joint moves
(specs/mechanism3d.md, Inputs; checked against the arm's forward kinematics)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from linkedit.io.gcs_hdf5 import read_result

L1, L2 = 0.3, 0.2  # m


def _arm(tmp_path, steps: int):
    """Link l1 turns about world z (joint q1, 0° → 90° over t ∈ [0, 0.5]), then link l2 pitches
    about l1's y axis at l1's tip (joint q2, 0° → −60° → −30° over [0.5, 1])."""
    data = {
        "name": "arm", "units": "m",
        "shapes": {"l1": {"points": {"o": [0, 0, 0], "e": [L1, 0, 0]}},
                   "l2": {"points": {"o": [0, 0, 0], "e": [L2, 0, 0]}}},
        "members": {"l1": {"shape": "l1"}, "l2": {"shape": "l2", "position": [L1, 0, 0]}},
        "joints": {"j1": {"type": "revolute", "members": ["l1", "world"], "at": [0, 0, 0], "axis": [0, 0, 1]},
                   "j2": {"type": "revolute", "members": ["l2", "l1"], "at": [L1, 0, 0], "axis": [0, 1, 0]}},
        "inputs": {"q1": {"type": "orientation", "member": "l1",
                          "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 90]}, "window": [0, 0.5]},
                   "q2": {"type": "orientation", "member": "l2", "other": "l1",
                          "rotation": {"axis": [0, 1, 0], "angles_deg": [0, -60, -30]}, "window": [0.5, 1]}},
        "outputs": {"steps": steps, "tracks": {"E": {"member": "l2", "point": "e"}}},
    }
    path = tmp_path / "arm.yaml"
    path.write_text(yaml.safe_dump(data, default_flow_style=None, sort_keys=False))
    return path


def _forward(t: np.ndarray) -> np.ndarray:
    """The tip of l2 (T, 3) from the joint angles' schedules (each held outside its window)."""
    q1 = np.radians(np.interp(t, [0, 0.5], [0, 90]))
    q2 = np.radians(np.interp(t, [0.5, 0.75, 1], [0, -60, -30]))
    reach = L1 + L2 * np.cos(q2)  # in l1's frame: x along l1, z up; a pitch of q2 about y lifts by −sin
    return np.stack([reach * np.cos(q1), reach * np.sin(q1), -L2 * np.sin(q2)], axis=1)


@pytest.mark.parametrize("steps", [5, 21])
def test_a_joint_whose_window_closed_holds_while_the_next_one_moves(run_cli, tmp_path, steps):
    """The first joint kept turning at its last rate after its window closed (to 186° instead
    of holding 90°: the tip 0.53 m off at t = 1, exit 0): whether J had a free direction for
    the inputs active after the window was decided once, at the first unconverged iterate, where
    the residual hides it; so the minimum change that holds it was never applied."""
    spec = _arm(tmp_path, steps)
    out = tmp_path / "arm.h5"
    res = run_cli("solve3d", spec, "-o", out, "--quiet")
    assert res.exit_code == 0, res.output
    run = read_result(out)
    assert np.abs(run.tracks["E"].position - _forward(run.t)).max() < 1e-9 * (L1 + L2)


def _arm3(tmp_path, steps: int):
    """A three-joint arm whose joints move in turn, each locked by an input of one keyframe
    while it is not moving (specs/mechanism3d.md, Inputs): yaw q1 0° → 120° → 60° over
    [0, 0.4], pitch q2 0° → −45° over [0.3, 0.7], pitch q3 0° → 90° → 30° over [0.6, 1]."""
    rot = lambda member, other, axis, angles, window: {  # noqa: E731
        "type": "orientation", "member": member, **({"other": other} if other else {}),
        "rotation": {"axis": axis, "angles_deg": angles}, "window": window}
    z, y = [0, 0, 1], [0, 1, 0]
    data = {
        "name": "arm3", "units": "m",
        "shapes": {"l1": {"points": {"e": [0.3, 0, 0]}}, "l2": {"points": {"e": [0.2, 0, 0]}},
                   "l3": {"points": {"e": [0.1, 0, 0]}}},
        "members": {"l1": {"shape": "l1"}, "l2": {"shape": "l2", "position": [0.3, 0, 0]},
                    "l3": {"shape": "l3", "position": [0.5, 0, 0]}},
        "joints": {"j1": {"type": "revolute", "members": ["l1", "world"], "at": [0, 0, 0], "axis": z},
                   "j2": {"type": "revolute", "members": ["l2", "l1"], "at": [0.3, 0, 0], "axis": y},
                   "j3": {"type": "revolute", "members": ["l3", "l2"], "at": [0.5, 0, 0], "axis": y}},
        "inputs": {"q1": rot("l1", None, z, [0, 120, 60], [0, 0.4]), "h1": rot("l1", None, z, [60], [0.4, 1]),
                   "q2": rot("l2", "l1", y, [0, -45], [0.3, 0.7]), "h2a": rot("l2", "l1", y, [0], [0, 0.3]),
                   "h2b": rot("l2", "l1", y, [-45], [0.7, 1]),
                   "q3": rot("l3", "l2", y, [0, 90, 30], [0.6, 1]), "h3": rot("l3", "l2", y, [0], [0, 0.6])},
        "outputs": {"steps": steps, "tracks": {"E": {"member": "l3", "point": "e"}}},
    }
    path = tmp_path / "arm3.yaml"
    path.write_text(yaml.safe_dump(data, default_flow_style=None, sort_keys=False))
    return path


@pytest.mark.parametrize("steps", [6, 21])
def test_joints_locked_by_one_keyframe_inputs_follow_the_forward_kinematics(run_cli, tmp_path, steps):
    """The recipe the spec page gives for a joint held between its moves: its angle is exact at
    any --steps (minimum change alone would let a held joint turn as the next one moves)."""
    out = tmp_path / "arm3.h5"
    res = run_cli("solve3d", _arm3(tmp_path, steps), "-o", out, "--quiet")
    assert res.exit_code == 0, res.output
    run = read_result(out)
    t = run.t
    q1 = np.radians(np.interp(t, [0, 0.2, 0.4], [0, 120, 60]))
    q2 = np.radians(np.interp(t, [0.3, 0.7], [0, -45]))
    q3 = np.radians(np.interp(t, [0.6, 0.8, 1], [0, 90, 30]))
    reach = 0.3 + 0.2 * np.cos(q2) + 0.1 * np.cos(q2 + q3)
    tip = np.stack([reach * np.cos(q1), reach * np.sin(q1), -0.2 * np.sin(q2) - 0.1 * np.sin(q2 + q3)], axis=1)
    assert np.abs(run.tracks["E"].position - tip).max() < 1e-9 * 0.6
