"""solve3d you can trust: the same answer at any scale, free motion left still, coarse steps on
the fine run's branch, exact velocities, inputs that hold, restarts on the same branch, and
closed-form oracles (tests/gcs_oracles.py)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from linkedit.gcs import quaternions as quat
from linkedit.gcs.mechanism import solve_spec
from linkedit.io.gcs_hdf5 import read_result
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests import gcs_oracles as oracle
from tests.conftest import EXAMPLES

EXAMPLES_3D = {p.stem: p for p in sorted((EXAMPLES / "3d").glob("*.yaml"))}


def _data(name: str) -> dict:
    return load_yaml(EXAMPLES_3D[name])[0]


def _spec(data: dict) -> MechanismSpec:
    return validate(MechanismSpec, data, file="test")


def _size(res) -> float:
    pts = np.concatenate([tr.position for tr in res.tracks.values()])
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def _world_points(res) -> np.ndarray:
    """Every shape point of every member at every step, (T, P, 3)."""
    out = []
    for m, name in enumerate(res.member_names):
        for p in res.points[name].values():
            out.append(res.position[:, m] + quat.to_matrix(res.orientation[:, m]) @ p)
    return np.stack(out, axis=1)


@pytest.mark.parametrize("name", sorted(EXAMPLES_3D))
def test_same_trajectories_relative_to_size_at_any_scale(name):
    data = _data(name)
    base = solve_spec(_spec(data), steps=73, rank=False)
    assert (base.diagnostics.status == 0).all()
    ref = _world_points(base)
    size = float(np.ptp(ref.reshape(-1, 3), axis=0).max())
    for s in (1e3, 1e-3):
        res = solve_spec(_spec(oracle.scaled_spec(data, s)), steps=73, rank=False)
        assert (res.diagnostics.status == 0).all(), (s, res.diagnostics.unsatisfied)
        assert np.abs(_world_points(res) / s - ref).max() < 1e-9 * size, s
        for tr, tr0 in zip(res.tracks.values(), base.tracks.values()):
            assert np.abs(tr.velocity / s - tr0.velocity).max() < 1e-9 * np.abs(tr0.velocity).max()


def test_crank_rocker_in_mm_solves_through_the_cli(run_cli, tmp_path):
    """Defect 1: ×1000 exited 1 ("inconsistent / did not converge")."""
    spec = tmp_path / "mm.yaml"
    spec.write_text(yaml.safe_dump(oracle.scaled_spec(_data("crank-rocker"), 1000.0) | {"units": "mm"}))
    r = run_cli("solve3d", spec, "-o", tmp_path / "mm.h5")
    assert r.exit_code == 0, r.output
    mm = read_result(tmp_path / "mm.h5")
    theta = 2 * np.pi * mm.t
    assert np.abs(mm.tracks["P"].position / 1000.0 - oracle.crank_rocker(theta)).max() < 1e-9 * 10


def test_jansen_leg_in_3d_scales_and_coarse_steps_stay_on_the_branch():
    """Defects 1 and 3: the Jansen leg ×100 failed 360 of 361 steps; with 19 steps the foot
    was up to 144 mm off on the last 5, all "converged"."""
    from linkedit.gcs.planar_bridge import planar_model, point_positions
    from linkedit.gcs.solve import solve_run
    from linkedit.spec.linkage import LinkageSpec

    data = load_yaml(EXAMPLES / "jansen.yaml")[0]

    def run(scale: float, steps: int) -> np.ndarray:
        d = dict(data, joints={k: [scale * c for c in v] for k, v in data["joints"].items()})
        model = planar_model(validate(LinkageSpec, d, file="test"))
        t = np.linspace(0.0, 1.0, steps)
        out = solve_run(model.system, t)
        assert (out.status == 0).all(), (scale, steps, np.flatnonzero(out.status))
        return point_positions(model.joint_member, model.joint_point, out.position, out.orientation) / scale

    fine = run(1.0, 361)
    size = float(np.ptp(fine.reshape(-1, 3), axis=0).max())
    assert np.abs(run(1.0, 19) - fine[::20]).max() < 1e-9 * size
    for scale in (100.0, 1e-3):
        assert np.abs(run(scale, 19) - fine[::20]).max() < 1e-9 * size, scale


@pytest.mark.parametrize("name", ["crank-rocker", "six-bar", "spherical-four-bar", "spatial-slider-crank"])
def test_coarse_steps_give_the_fine_run_poses(name):
    spec = _spec(_data(name))
    fine = solve_spec(spec, steps=361, rank=False)
    coarse = solve_spec(spec, steps=19, rank=False)
    assert (coarse.diagnostics.status == 0).all()
    size = _size(fine)
    for n, tr in coarse.tracks.items():
        assert np.abs(tr.position - fine.tracks[n].position[::20]).max() < 1e-9 * size


def _spin_between_steps(res, member: str, a: str, b: str) -> np.ndarray:
    """The rotation between consecutive steps about the member's own a → b axis (radians)."""
    m = res.member_names.index(member)
    R = quat.to_matrix(res.orientation[:, m])
    axis = R @ (res.points[member][b] - res.points[member][a])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    phi = quat.log(quat.multiply(res.orientation[1:, m], quat.conjugate(res.orientation[:-1, m])))
    return np.sum(phi * axis[1:], axis=1)


def _canonical_spin(res, spec: MechanismSpec, member: str, a: str, b: str) -> np.ndarray:
    """The derivative of the member's scaled squared distance from its rest pose along its
    spin about its a → b axis, at every step (:func:`oracle.spin_gradient`)."""
    from linkedit.gcs.members import compile_mechanism

    system = compile_mechanism(spec)[0]
    m = res.member_names.index(member)
    return oracle.spin_gradient(res.position[:, m], res.orientation[:, m], res.points[member][a],
                                res.points[member][b], system.rest.position[m], system.rest.orientation[m],
                                system.length_scale)


@pytest.mark.parametrize("steps", [361, 37])
def test_rssr_coupler_takes_the_spin_nearest_its_rest_pose(steps):
    """Defect 2: the idle spin jumped ~70° (up to 152°) per 1° of crank. Issue 22: kept still
    from step to step instead, it depended on the steps; now it is the spin nearest the rest
    pose at every step (tests/test_gcs_passive.py: against its closed form)."""
    spec = _spec(_data("rssr"))
    res = solve_spec(spec, steps=steps, rank=False)
    assert (res.diagnostics.status == 0).all()
    assert np.abs(_canonical_spin(res, spec, "coupler", "a", "b")).max() < 1e-9
    assert np.abs(_spin_between_steps(res, "coupler", "a", "b")).max() > 1e-3  # it does turn
    # the rocker follows the closed form
    theta = 2 * np.pi * res.t
    assert np.abs(res.tracks["rocker_tip"].position - oracle.rssr(theta)).max() < 1e-9 * 6


def test_spatial_slider_crank_rod_takes_its_canonical_spin_and_slider_follows_the_closed_form():
    spec = _spec(_data("spatial-slider-crank"))
    res = solve_spec(spec, steps=361, rank=False)
    assert (res.diagnostics.status == 0).all()
    assert np.abs(_canonical_spin(res, spec, "rod", "a", "b")).max() < 1e-9
    theta = 2 * np.pi * res.t
    assert np.abs(res.tracks["slider"].position - oracle.spatial_slider_crank(theta)).max() < 1e-9 * 4


def test_closed_input_window_holds_its_last_value():
    """Defect 2: after the window closed the crank kept turning and then jumped."""
    data = _data("crank-rocker")
    data["inputs"]["drive"]["window"] = [0.0, 0.5]
    data["inputs"]["drive"]["rotation"]["angles_deg"] = [0, 180]
    res = solve_spec(_spec(data), steps=101, rank=False)
    assert (res.diagnostics.status == 0).all()
    late = res.t >= 0.5
    held = res.position[late] - res.position[np.argmax(late)]
    assert np.abs(held).max() < 1e-12 * 10
    q = res.orientation[late]
    assert np.abs(np.abs(np.sum(q * q[:1], axis=-1)) - 1.0).max() < 1e-15 + 1e-12
    assert np.abs(res.tracks["P"].velocity[res.t > 0.5]).max() == 0.0


def test_crank_rocker_and_spherical_four_bar_match_their_closed_forms():
    res = solve_spec(_spec(_data("crank-rocker")), steps=361, rank=False)
    theta = 2 * np.pi * res.t
    assert np.abs(res.tracks["P"].position - oracle.crank_rocker(theta)).max() < 1e-9 * 10
    sph = solve_spec(_spec(_data("spherical-four-bar")), steps=361, rank=False)
    assert np.abs(sph.tracks["c"].position - oracle.spherical_four_bar(2 * np.pi * sph.t)).max() < 1e-9


@pytest.mark.parametrize("name,track", [("crank-rocker", "P"), ("rssr", "fin"), ("spherical-four-bar", "P")])
def test_exact_velocities_match_central_differences_of_fine_positions(name, track):
    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.solve import solve_run

    spec = _spec(_data(name))
    res = solve_spec(spec, steps=361, rank=False)
    tr = res.tracks[track]
    member = res.member_names.index(tr.member)
    k = np.arange(36, 361, 36)[:-1]
    h = 1e-5
    grid = np.unique(np.concatenate([res.t, res.t[k] - h, res.t[k] + h]))
    run = solve_run(compile_mechanism(spec)[0], grid)  # the same continuation, with the ±h samples
    idx = np.searchsorted(grid, np.concatenate([res.t[k] - h, res.t[k] + h]))
    p = run.position[idx, member] + quat.to_matrix(run.orientation[idx, member]) @ tr.point
    fd = (p[len(k):] - p[:len(k)]) / (2 * h)
    assert np.abs(tr.velocity[k] - fd).max() < 1e-6 * np.abs(tr.velocity).max()


def test_rocking_input_end_velocities_are_the_analytic_ones():
    """Defect 6: "ends meet ⇒ cyclic" gave v(0) = v(1) = 0 for angles_deg [0, 90, 0]."""
    data = _data("crank-rocker")
    data["inputs"]["drive"]["rotation"]["angles_deg"] = [0, 90, 0]
    res = solve_spec(_spec(data), steps=181, rank=False)
    tr = res.tracks["P"]
    assert not tr.cyclic
    rate = np.pi / 2 / 0.5  # crank radians per unit t on each half
    h = 1e-7
    dP = (oracle.crank_rocker(np.array([h])) - oracle.crank_rocker(np.array([-h])))[0] / (2 * h)
    assert np.abs(tr.velocity[0] - rate * dP).max() < 1e-7 * np.abs(rate * dP).max()
    assert np.abs(tr.velocity[-1] + rate * dP).max() < 1e-7 * np.abs(rate * dP).max()
    assert np.linalg.norm(tr.velocity[0]) > 1.0
    # at the keyframe between (t = 0.5, crank at 90°, where the rate jumps) the outgoing one
    # (specs/gcs-hdf5.md)
    dP = (oracle.crank_rocker(np.array([np.pi / 2 + h])) - oracle.crank_rocker(np.array([np.pi / 2 - h])))[0] / (2 * h)
    assert res.t[90] == 0.5 and np.abs(tr.velocity[90] + rate * dP).max() < 1e-7 * np.abs(rate * dP).max()


def test_full_turn_input_is_cyclic_and_parabola_rule_is_an_option():
    data = _data("crank-rocker")
    exact = solve_spec(_spec(data), steps=361, rank=False)
    para = solve_spec(_spec(data), steps=361, rank=False, velocity="parabola")
    assert exact.tracks["P"].cyclic and para.tracks["P"].cyclic
    err = np.abs(para.tracks["P"].velocity - exact.tracks["P"].velocity).max() / np.abs(exact.tracks["P"].velocity).max()
    assert 1e-7 < err < 1e-2  # the paper's O(h²) rule, not the exact one


@pytest.mark.parametrize("keyframes,kind", [([[0, 0, 1], [0, 0, -1]], "axis"),
                                            ([[1, 0, 0, 0], [0, 0, 0, 1]], "orientation"),
                                            ([[1, 0, 0, 0], [0, 0, 0, -1]], "orientation")])
def test_half_turn_keyframes_are_refused_with_the_line(run_cli, tmp_path, keyframes, kind):
    """Defect 4: antipodal axis keyframes never moved; ±q half-turns turned different ways."""
    data = _data("crank-rocker")
    if kind == "axis":
        data["inputs"]["drive"] = {"type": "axis", "member": "crank", "axis": [0, 0, 1], "keyframes": keyframes}
    else:
        data["inputs"]["drive"] = {"type": "orientation", "member": "crank", "keyframes": keyframes}
    spec = tmp_path / "half.yaml"
    spec.write_text(yaml.safe_dump(data, default_flow_style=None, sort_keys=False))
    r = run_cli("solve3d", spec, "-o", tmp_path / "half.h5")
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert "\n" not in line and "half a turn" in line and "inputs.drive.keyframes" in line.replace("/", ".")
    # issue 22, 5: the only exit-2 message without file:line; the line of the second keyframe
    text = spec.read_text().splitlines()
    at = 1 + next(i for i, row in enumerate(text) if row.strip() == "keyframes:") + 2
    assert text[at - 1].strip() == f"- {keyframes[1]}".replace("'", ""), text[at - 1]
    assert f"{spec}:{at}: inputs.drive.keyframes[1]: " in line, line
    assert not (tmp_path / "half.h5").exists()


def test_partial_restarts_from_the_last_good_pose_on_the_same_branch(run_cli, tmp_path):
    """Defect 5: after a locked interval the solver came back on the other branch and reported
    feasible steps as inconsistent. The rocker is driven past its reach and back."""
    data = _data("crank-rocker")
    data["inputs"]["drive"] = {"type": "orientation", "member": "rocker",
                               "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 120, 0]}}
    spec = tmp_path / "lock.yaml"
    spec.write_text(yaml.safe_dump(data, default_flow_style=None, sort_keys=False))
    out = tmp_path / "lock.h5"
    r = run_cli("solve3d", spec, "-o", out, "--steps", "61")
    assert r.exit_code == 1 and "step" in r.output
    r = run_cli("solve3d", spec, "-o", out, "--steps", "61", "--partial")
    assert r.exit_code == 0, r.output
    res = read_result(out)
    status = res.diagnostics.status
    bad = np.flatnonzero(status != 0)
    assert bad.size and (status[: bad[0]] == 0).all() and (status[bad[-1] + 1:] == 0).all()
    # symmetric input: the steps after the lock mirror the ones before it, on the same branch
    ok = np.flatnonzero(status == 0)
    mirror = 60 - ok
    both = status[mirror] == 0
    P = res.tracks["P"].position
    assert np.abs(P[ok[both]] - P[mirror[both]]).max() < 1e-9 * 10


@pytest.mark.parametrize("waves", [True, False])
def test_a_failed_step_reports_its_own_times_pose_and_gap(waves):
    """A 3-pair Strandbeest whose crank (22 mm instead of 15) locks a leg: the step that fails
    keeps a pose of its own time — the least-squares one there, not a sub-step's at an earlier
    time just before the lock — so its residual is the constraints' at that pose, and the
    message gives the real gap (~0.09 mm, not the 3e-10 of a sub-step's pose)."""
    from linkedit.errors import MechanismError
    from linkedit.gcs.planar_bridge import planar_model, simulate_numeric
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.tolerances import Options
    from linkedit.gcs.system import State
    from linkedit.planar import catalog
    from linkedit.planar.simulate import motor_angles

    spec = catalog.strandbeest(3)
    joints = {n: (22.0 * np.cos(np.arctan2(y, x)), 22.0 * np.sin(np.arctan2(y, x))) if n.startswith("A_") else (x, y)
              for n, (x, y) in spec.joints.items()}
    spec = spec.model_copy(update={"joints": joints})
    t = motor_angles(spec, 360)[0][:37]  # 0 … 36°: the lock at 29°
    system = planar_model(spec).system
    table = system.step_table(t)
    run = solve_run(system, t, Options(waves=waves), table=table)
    bad = np.flatnonzero(run.status != 0)
    assert bad.size
    for k in bad[:5]:
        again = system.evaluate(State(run.position[k], run.orientation[k]), table, k).r
        assert np.abs(again - run.residual[k]).max() <= 1e-12 * system.length_scale
    with pytest.raises(MechanismError, match="off by 0.09"):
        simulate_numeric(spec, t, Options(waves=waves))


def test_time_run_backwards_is_continued_step_by_step_to_the_forward_poses():
    """The crank-rocker over a descending cycle, step by step: the continuation goes backwards
    as it goes forwards (it used to stop at once — its step's sign was lost — and every other
    step was found by a direct solve instead, which a lock-up between steps would have sent to
    another branch); the poses are the ascending run's."""
    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.continuation import Solver
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.tolerances import Options

    system = compile_mechanism(validate(MechanismSpec, load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0], file="t"))[0]
    t = np.linspace(0.0, 1.0, 121)
    up = solve_run(system, t, Options(waves=False))
    calls = []
    advance = Solver.advance

    def counted(self, good, table, step):
        out = advance(self, good, table, step)
        calls.append(out[3] is not None)
        return out

    Solver.advance = counted
    try:
        down = solve_run(system, t[::-1], Options(waves=False))
    finally:
        Solver.advance = advance
    assert (down.status == 0).all() and len(calls) == len(t) - 1 and all(calls)
    assert np.abs(down.position[::-1] - up.position).max() < 1e-9 * system.length_scale
