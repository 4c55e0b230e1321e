"""The designer's vocabulary of solve3d: point-on-line, distance, angle, parallel and
perpendicular constraints, a linear (distance) input, and joint presets placed in the world —
each against a closed form, and every preset against the same mechanism written with
elementary constraints."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from linkedit.gcs import quaternions as quat
from linkedit.gcs.mechanism import solve_spec
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import validate
from tests import gcs_oracles as oracle

Z = [0.0, 0.0, 1.0]


def _solve(data: dict, steps: int = 61):
    res = solve_spec(validate(MechanismSpec, data, file="test"), steps=steps, rank=False)
    assert (res.diagnostics.status == 0).all(), res.diagnostics.unsatisfied
    return res


def _turn(deg: float) -> dict:
    return {"axis": Z, "angle_deg": float(deg)}


def _four_bar(presets: bool, balls: bool = False) -> dict:
    """examples/3d/crank-rocker.yaml's linkage, assembled at rest: revolute joints, or the
    location + axis constraints they stand for; with ``balls``, the coupler hangs between two
    spherical joints (locations), its idle spin about the line of the balls left still."""
    A0, B0 = np.array([-3.0, 3.0]), np.array([2.0, -3.0])
    A = A0 + [1.0, 0.0]
    B = oracle._circles(A[None], 5.0, B0, 5.75, +1)[0]
    deg = lambda v: float(np.degrees(np.arctan2(v[1], v[0])))  # noqa: E731
    data = {
        "name": "four-bar", "units": "m",
        "members": {
            "crank": {"position": [*A0, 0.0], "shape": {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}}},
            "coupler": {"position": [*A, 0.0], "orientation": _turn(deg(B - A)),
                        "shape": {"points": {"a": [0, 0, 0], "b": [5, 0, 0], "P": [2.5, 2.5, 0]}}},
            "rocker": {"position": [*B0, 0.0], "orientation": _turn(deg(B - B0)),
                       "shape": {"points": {"pivot": [0, 0, 0], "tip": [5.75, 0, 0]}}}},
        "inputs": {"drive": {"type": "orientation", "member": "crank", "rotation": {"axis": Z, "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"P": {"member": "coupler", "point": "P"}}},
    }
    joints = [("crank_pivot", "crank", "pivot", "world", None, A0), ("crank_coupler", "coupler", "a", "crank", "tip", A),
              ("coupler_rocker", "coupler", "b", "rocker", "tip", B), ("rocker_pivot", "rocker", "pivot", "world", None, B0)]
    ball = lambda m: balls and m == "coupler"  # noqa: E731
    if presets:
        data["joints"] = {n: {"type": "spherical", "members": [m, o], "at": [*at, 0.0]} if ball(m) else
                          {"type": "revolute", "members": [m, o], "at": [*at, 0.0], "axis": Z}
                          for n, m, _, o, _, at in joints}
    else:
        data["constraints"] = {}
        for n, m, p, o, op, at in joints:
            loc = {"world": [*at, 0.0]} if o == "world" else {"other": o, "other_point": op}
            ax = {"world": Z} if o == "world" else {"other": o, "other_axis": Z}
            data["constraints"][f"{n}_point"] = {"type": "location", "member": m, "point": p, **loc}
            if not ball(m):
                data["constraints"][f"{n}_axis"] = {"type": "axis", "member": m, "axis": Z, **ax}
    return data


def _slider_crank(presets: bool) -> dict:
    """Crank 1 about z, rod 3, slider on the line y = 0.5 along x: revolute and prismatic
    joints, or the slider held by on_line + orientation."""
    e, L = 0.5, 3.0
    x0 = float(1.0 + np.sqrt(L**2 - e**2))
    data = {
        "name": "slider-crank", "units": "m",
        "members": {
            "crank": {"shape": {"points": {"tip": [1, 0, 0]}}},
            "rod": {"position": [1, 0, 0], "orientation": _turn(np.degrees(np.arctan2(e, x0 - 1.0))),
                    "shape": {"points": {"a": [0, 0, 0], "b": [L, 0, 0]}}},
            "slider": {"position": [x0, e, 0]}},
        "joints": {"crank_pivot": {"type": "revolute", "members": ["crank", "world"], "at": [0, 0, 0], "axis": Z},
                   "crank_rod": {"type": "revolute", "members": ["rod", "crank"], "at": [1, 0, 0], "axis": Z},
                   "rod_slider": {"type": "revolute", "members": ["slider", "rod"], "at": [x0, e, 0], "axis": Z}},
        "inputs": {"drive": {"type": "orientation", "member": "crank", "rotation": {"axis": Z, "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"slider": {"member": "slider", "point": [0, 0, 0]}}},
    }
    if presets:
        data["joints"]["slide"] = {"type": "prismatic", "members": ["world", "slider"], "at": [x0, e, 0], "axis": [1, 0, 0]}
    else:
        data["constraints"] = {
            "slide_line": {"type": "on_line", "member": "slider", "point": [0, 0, 0],
                           "line": {"point": [0, e, 0], "direction": [-1, 0, 0]}},
            "slide_orientation": {"type": "orientation", "member": "slider", "world": [1, 0, 0, 0]}}
    return data


def _sleeve(presets: bool) -> dict:
    """A sleeve on a cylindrical joint along z, pushed by a linear actuator from (0, 0, −1) and
    turned by an orientation input."""
    data = {
        "name": "sleeve", "units": "m",
        "members": {"sleeve": {"shape": {"points": {"o": [0, 0, 0], "fin": [0.5, 0, 0]}}}},
        "inputs": {"push": {"type": "distance", "member": "sleeve", "point": "o", "world": [0, 0, -1],
                            "keyframes": [1.0, 2.5, 1.5]},
                   "spin": {"type": "orientation", "member": "sleeve", "rotation": {"axis": Z, "angles_deg": [0, 90]}}},
        "outputs": {"tracks": {"fin": {"member": "sleeve", "point": "fin"}}},
    }
    if presets:
        data["joints"] = {"guide": {"type": "cylindrical", "members": ["sleeve", "world"], "at": [0, 0, 0], "axis": Z}}
    else:
        data["constraints"] = {
            "guide_line": {"type": "on_line", "member": "sleeve", "point": "o", "line": {"point": [0, 0, 3], "direction": Z}},
            "guide_axis": {"type": "axis", "member": "sleeve", "axis": Z, "world": Z}}
    return data


def _puck(presets: bool) -> dict:
    """A puck on a planar joint (the plane z = 1), tilted in the spec (so the joint's normal is
    the puck's axis that is world z at rest), moved and turned by inputs."""
    tilt = {"axis": [1, 0, 0], "angle_deg": 20.0}
    local_z = quat.rotate(quat.conjugate(quat.from_axis_angle(np.array([1.0, 0, 0]), np.radians(20.0))),
                          np.array(Z)).tolist()
    data = {
        "name": "puck", "units": "m",
        "members": {"puck": {"position": [0, 0, 1], "orientation": tilt, "shape": {"points": {"o": [0, 0, 0], "rim": [0.3, 0, 0]}}}},
        "inputs": {"move": {"type": "location", "member": "puck", "point": "o", "keyframes": [[0, 0, 1], [1, 2, 1]]},
                   "turn": {"type": "orientation", "member": "puck", "rotation": {"axis": Z, "angles_deg": [0, 120]}}},
        "outputs": {"tracks": {"rim": {"member": "puck", "point": "rim"}}},
    }
    if presets:
        data["joints"] = {"table": {"type": "planar", "members": ["puck", "world"], "at": [0, 0, 1], "normal": Z}}
    else:
        data["constraints"] = {
            "table_plane": {"type": "on_plane", "member": "puck", "point": "o", "plane": {"point": [5, 5, 1], "normal": Z}},
            "table_axis": {"type": "axis", "member": "puck", "axis": local_z, "world": Z}}
    return data


def _cardan(presets: bool) -> dict:
    """Two shafts 30° apart joined by a universal joint (cross): revolute bearings and a
    universal joint, or location + axis + perpendicular constraints."""
    b = np.radians(30.0)
    axis2 = [float(np.cos(b)), float(np.sin(b)), 0.0]
    data = {
        "name": "cardan", "units": "m",
        "members": {"in": {"shape": {"points": {"o": [0, 0, 0], "fork": [0, 0.3, 0]}}},
                    "out": {"orientation": _turn(30.0), "shape": {"points": {"o": [0, 0, 0], "fork": [0, 0, 0.3]}}}},
        "inputs": {"drive": {"type": "orientation", "member": "in", "rotation": {"axis": [1, 0, 0], "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"fork": {"member": "out", "point": "fork"}}},
    }
    if presets:
        data["joints"] = {
            "in_bearing": {"type": "revolute", "members": ["in", "world"], "at": [0, 0, 0], "axis": [1, 0, 0]},
            "out_bearing": {"type": "revolute", "members": ["world", "out"], "at": [0, 0, 0], "axis": axis2},
            "cross": {"type": "universal", "members": ["in", "out"], "at": [0, 0, 0], "axes": [[0, 1, 0], Z]}}
    else:
        data["constraints"] = {
            "in_point": {"type": "location", "member": "in", "point": "o", "world": [0, 0, 0]},
            "in_axis": {"type": "axis", "member": "in", "axis": [1, 0, 0], "world": [1, 0, 0]},
            "out_point": {"type": "location", "member": "out", "point": "o", "world": [0, 0, 0]},
            "out_axis": {"type": "axis", "member": "out", "axis": [1, 0, 0], "world": axis2},
            "cross": {"type": "perpendicular", "member": "in", "axis": [0, 1, 0], "other": "out", "other_axis": Z}}
    return data


def _slider_x(theta):
    return np.cos(theta) + np.sqrt(9.0 - (np.sin(theta) - 0.5) ** 2)


def _closed_form(name: str, res) -> None:
    """Each mechanism's own closed form, to 1e-9 of its size."""
    t = res.t
    tr = next(iter(res.tracks.values())).position
    if name.startswith("four-bar"):
        assert np.abs(tr - oracle.crank_rocker(2 * np.pi * t)).max() < 1e-9 * 10
    elif name == "slider-crank":
        theta = 2 * np.pi * t
        assert np.abs(tr[:, 0] - _slider_x(theta)).max() < 1e-9 * 4 and np.abs(tr[:, 1:] - [0.5, 0]).max() < 1e-9 * 4
    elif name == "sleeve":
        d = np.interp(t, [0, 0.5, 1], [1.0, 2.5, 1.5])
        a = np.radians(90 * t)
        want = np.column_stack([0.5 * np.cos(a), 0.5 * np.sin(a), d - 1.0])
        assert np.abs(tr - want).max() < 1e-9 * 2
    elif name == "puck":
        a = np.radians(120 * t)
        want = np.column_stack([t + 0.3 * np.cos(a), 2 * t + 0.3 * np.sin(a), np.ones_like(t)])
        assert np.abs(tr - want).max() < 1e-9 * 3
    else:  # Cardan: tan φ2 = tan φ1 / cos β, i.e. sin φ1 cos φ2 = cos β cos φ1 sin φ2
        b = np.radians(30.0)
        fork = tr / 0.3
        phi2 = np.arctan2(fork @ np.cross([np.cos(b), np.sin(b), 0], Z), fork[:, 2])
        phi1 = 2 * np.pi * t
        assert np.abs(np.sin(phi1) * np.cos(phi2) - np.cos(b) * np.cos(phi1) * np.sin(phi2)).max() < 1e-9
        assert np.abs(fork @ [np.cos(b), np.sin(b), 0]).max() < 1e-9


MECHANISMS = {"four-bar": _four_bar, "four-bar-balls": lambda presets: _four_bar(presets, balls=True),
              "slider-crank": _slider_crank, "sleeve": _sleeve, "puck": _puck, "cardan": _cardan}


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_presets_solve_like_elementary_constraints_and_their_closed_form(name):
    build = MECHANISMS[name]
    preset, plain = _solve(build(True)), _solve(build(False))
    _closed_form(name, preset)
    for a, b in zip(preset.tracks.values(), plain.tracks.values()):
        size = float(np.ptp(b.position, axis=0).max())
        assert np.abs(a.position - b.position).max() < 1e-9 * size
        assert np.abs(a.velocity - b.velocity).max() < 1e-9 * np.abs(b.velocity).max()


@pytest.mark.parametrize("s", [1e3, 1e-3])
@pytest.mark.parametrize("name", ["slider-crank", "sleeve"])
def test_presets_and_the_linear_input_are_scale_free(name, s):
    data = MECHANISMS[name](True)
    base, big = _solve(data, 31), _solve(oracle.scaled_spec(data, s), 31)
    for a, b in zip(big.tracks.values(), base.tracks.values()):
        assert np.abs(a.position / s - b.position).max() < 1e-9 * float(np.ptp(b.position, axis=0).max())


def test_distance_constraint_replaces_a_ball_jointed_coupler():
    """The RSSR with its coupler written as a distance of 5.5 between the crank and rocker tips:
    the rocker tip follows the closed form (tests/gcs_oracles.rssr), at ×1 and ×1000."""
    data = {
        "name": "rss-r", "units": "m",
        "members": {"crank": {"shape": {"points": {"tip": [1, 0, 0]}}},
                    "rocker": {"position": [4, 0, 2], "orientation": {"axis": [1, 0, 0], "angle_deg": 43},
                               "shape": {"points": {"tip": [0, 3, 0]}}}},
        "joints": {"crank_pivot": {"type": "revolute", "members": ["crank", "world"], "at": [0, 0, 0], "axis": Z},
                   "rocker_pivot": {"type": "revolute", "members": ["rocker", "world"], "at": [4, 0, 2], "axis": [1, 0, 0]}},
        "constraints": {"coupler": {"type": "distance", "member": "crank", "point": "tip", "other": "rocker",
                                    "other_point": "tip", "value": 5.5}},
        "inputs": {"drive": {"type": "orientation", "member": "crank", "rotation": {"axis": Z, "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"tip": {"member": "rocker", "point": "tip"}}},
    }
    for s in (1.0, 1e3):
        res = _solve(oracle.scaled_spec(data, s), 73)
        assert np.abs(res.tracks["tip"].position / s - oracle.rssr(2 * np.pi * res.t)).max() < 1e-9 * 8


def _luffing_arm() -> dict:
    """An arm hinged at the origin about z, its lug (1, 0, 0) pushed by a cylinder from (2, −1, 0)."""
    return {
        "name": "luffing-arm", "units": "m",
        "members": {"arm": {"shape": {"points": {"lug": [1, 0, 0], "tip": [3, 0, 0]}}}},
        "joints": {"pivot": {"type": "revolute", "members": ["arm", "world"], "at": [0, 0, 0], "axis": Z}},
        "inputs": {"cylinder": {"type": "distance", "member": "arm", "point": "lug", "world": [2, -1, 0],
                                "keyframes": [1.5, 2.8]}},
        "outputs": {"tracks": {"tip": {"member": "arm", "point": "tip"}}},
    }


def test_linear_actuator_lifts_an_arm_with_its_closed_form_position_and_velocity():
    """A luffing arm turned by a hydraulic cylinder from (2, −1, 0) to the arm's lug at 1 from
    the pivot, its length 1.5 → 2.8: cos(θ + β) = (6 − d²) / (2√5), β = atan2(1, 2)."""
    res = _solve(_luffing_arm(), 41)
    d, rate = 1.5 + 1.3 * res.t, 1.3
    c = (6.0 - d**2) / (2 * np.sqrt(5.0))
    theta = np.arccos(c) - np.arctan2(1.0, 2.0)
    omega = d * rate / (np.sqrt(5.0) * np.sqrt(1 - c**2))
    tip = res.tracks["tip"]
    assert np.abs(tip.position - 3 * np.column_stack([np.cos(theta), np.sin(theta), 0 * theta])).max() < 3e-9
    want_v = 3 * omega[:, None] * np.column_stack([-np.sin(theta), np.cos(theta), 0 * theta])
    assert np.abs(tip.velocity - want_v).max() < 1e-9 * np.abs(want_v).max()


def test_angle_constraint_turns_an_arm_to_its_value():
    """An arm turning about x whose y axis must make 60° with world z settles at 30° about x
    (from 20° at rest); 0° and 180° are aligned and opposite axes."""
    for deg, want in ((60.0, 30.0), (0.0, 90.0), (180.0, -90.0)):
        data = {"name": "arm", "units": "m",
                "members": {"arm": {"orientation": {"axis": [1, 0, 0], "angle_deg": 20 if deg else 80}}},
                "joints": {"hinge": {"type": "revolute", "members": ["arm", "world"], "at": [0, 0, 0], "axis": [1, 0, 0]}},
                "constraints": {"tilt": {"type": "angle", "member": "arm", "axis": [0, 1, 0], "world": Z, "angle_deg": deg}}}
        if deg == 180.0:
            data["members"]["arm"]["orientation"]["angle_deg"] = -80
        res = _solve(data, 2)
        q = quat.from_axis_angle(np.array([1.0, 0, 0]), np.radians(want))
        assert abs(abs(float(res.orientation[0, 0] @ q)) - 1.0) < 1e-12, deg


def test_parallel_holds_either_way_and_perpendicular_is_ninety_degrees():
    """parallel is satisfied by opposite axes too (no flip from a rest pose at 170°)."""
    data = {"name": "flag", "units": "m",
            "members": {"flag": {"orientation": {"axis": [1, 0, 0], "angle_deg": 170}}},
            "joints": {"hinge": {"type": "revolute", "members": ["flag", "world"], "at": [0, 0, 0], "axis": [1, 0, 0]}},
            "constraints": {"up": {"type": "parallel", "member": "flag", "axis": Z, "world": Z}}}
    res = _solve(data, 2)
    up = quat.rotate(res.orientation[0, 0], np.array(Z))
    assert np.abs(up - [0, 0, -1]).max() < 1e-12
    data["constraints"]["up"]["type"] = "perpendicular"
    res = _solve(data, 2)
    up = quat.rotate(res.orientation[0, 0], np.array(Z))
    assert abs(up[2]) < 1e-12 and up[1] < -0.99  # 170° → 90° about x, the nearer one


CARDAN_YAML = """\
name: cardan
units: m
members:
  in: {shape: {points: {o: [0, 0, 0]}}}
  out: {orientation: {axis: [0, 0, 1], angle_deg: 30}}
joints:
  in_bearing: {type: revolute, members: [in, world], at: [0, 0, 0], axis: [1, 0, 0]}
  out_bearing: {type: revolute, members: [out, world], at: [0, 0, 0], axis: [0.8660254037844387, 0.5, 0]}
  cross: {type: universal, members: [in, out], at: [0, 0, 0], axes: [[0, 1, 0], [0, 0, 1]]}
constraints:
  stroke: {type: distance, member: in, point: o, world: [1, 0, 0], value: 1}
inputs:
  drive: {type: orientation, member: in, rotation: {axis: [1, 0, 0], angles_deg: [0, 360]}}
"""


@pytest.mark.parametrize("old, new, where", [
    ("axis: [1, 0, 0]}\n  out_bearing", "}\n  out_bearing", ":7: joints.in_bearing.axis: required field is missing"),
    ("members: [in, out]", "members: [in, outt]", ":9: joints.cross.members[1]: unknown member 'outt'"),
    ("members: [in, out]", "members: [in, in]", ":9: joints.cross.members: a joint needs two different members"),
    ("[0, 0, 1]]}", "[0, 1, 1]]}", ":9: joints.cross.axes: the two axes of a universal joint must be perpendicular"),
    ("type: universal", "type: hinge", ":9: joints.cross: Input tag 'hinge'"),
    ("type: universal, members: [in, out], at: [0, 0, 0], axes: [[0, 1, 0], [0, 0, 1]]",
     "type: spherical, members: [in, out], at: [0, 0, 0], axis: [1, 0, 0]", ":9: joints.cross.axis: unknown field"),
    ("value: 1}", "value: -1}", ":11: constraints.stroke.value:"),
    ("  stroke:", "  cross.point:", ":9: joints.cross: its constraint cross.point has the name of a constraint"),
    ("out: {orientation", "world: {orientation", ":7: joints.in_bearing.members[1]: 'world' in a joint is the fixed frame"),
])
def test_bad_joint_specs_are_one_line_naming_file_line_and_field(run_cli, tmp_path, old, new, where):
    assert old in CARDAN_YAML
    path = tmp_path / "bad.yaml"
    path.write_text(CARDAN_YAML.replace(old, new, 1))
    r = run_cli("solve3d", path, "-o", tmp_path / "out.h5")
    assert r.exit_code == 2, r.output
    assert len(r.output.strip().splitlines()) == 1 and f"bad.yaml{where}" in r.output, r.output
    assert not (tmp_path / "out.h5").exists()


def test_bad_distance_input_keyframe_is_one_line(run_cli, tmp_path):
    data = copy.deepcopy(_sleeve(True))
    data["inputs"]["push"]["keyframes"] = [1.0, 0.0]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    r = run_cli("solve3d", path)
    assert r.exit_code == 2 and "inputs.push.keyframes[1]:" in r.output and len(r.output.strip().splitlines()) == 1


def test_conflicting_joints_name_the_constraint_that_fails(run_cli, tmp_path):
    """An input that tilts a hinged arm out of its hinge's plane: exit 1 naming the joint's
    axis part (joint.part) and the input, not the satisfied point part."""
    data = {"name": "conflict", "units": "m", "members": {"arm": {"shape": {"points": {"tip": [1, 0, 0]}}}},
            "joints": {"hinge": {"type": "revolute", "members": ["arm", "world"], "at": [0, 0, 0], "axis": Z}},
            "inputs": {"drive": {"type": "orientation", "member": "arm",
                                 "rotation": {"axis": [1, 0, 0], "angles_deg": [30, 90]}}}}
    path = tmp_path / "conflict.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    r = run_cli("solve3d", path, "-o", tmp_path / "out.h5")
    assert r.exit_code == 1, r.output
    assert "step 0" in r.output and "hinge.axis" in r.output and "hinge.point" not in r.output, r.output


def test_luffing_arm_example_follows_its_closed_form(run_cli, tmp_path):
    """examples/3d/luffing-arm.yaml (barrel, rod and arm joined by presets, a distance input
    from the barrel's base to the rod's eye): the arm's angle, the tip's exact velocity and the
    arm's exact angular acceleration against the closed form, from the result file."""
    from linkedit.io.gcs_hdf5 import read_result
    from tests.conftest import EXAMPLES

    r = run_cli("solve3d", EXAMPLES / "3d" / "luffing-arm.yaml", "-o", tmp_path / "arm.h5", "--accelerations")
    assert r.exit_code == 0, r.output
    res = read_result(tmp_path / "arm.h5")
    d, rate = 1.5 + 1.3 * res.t, 1.3
    c = (6.0 - d**2) / (2 * np.sqrt(5.0))
    dc, ddc = -d * rate / np.sqrt(5.0), -rate**2 / np.sqrt(5.0)
    theta = np.arccos(c) - np.arctan2(1.0, 2.0)
    omega = -dc / np.sqrt(1 - c**2)
    alpha = -ddc / np.sqrt(1 - c**2) - dc**2 * c / (1 - c**2) ** 1.5
    tip = res.tracks["tip"]
    zero = np.zeros_like(theta)
    assert np.abs(tip.position - 3 * np.column_stack([np.cos(theta), np.sin(theta), zero])).max() < 3e-9
    want_v = 3 * omega[:, None] * np.column_stack([-np.sin(theta), np.cos(theta), zero])
    assert np.abs(tip.velocity - want_v).max() < 1e-9 * np.abs(want_v).max()
    arm = res.member_names.index("arm")
    assert np.abs(res.acceleration[:, arm, 5] - alpha).max() < 1e-9 * np.abs(alpha).max()
