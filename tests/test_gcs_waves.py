"""Waves (many steps solved at once) give the step-by-step continuation's poses and exact
velocities, fall back to it where its acceptance test fails, and leave it alone where they do
not apply (linkedit.gcs.waves)."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.planar_bridge import planar_model
from linkedit.gcs.solve import solve_run
from linkedit.gcs.structure import SPLIT_FROM, StructureCache
from linkedit.gcs.tolerances import Options
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests import gcs_oracles as oracle
from tests.conftest import EXAMPLES


def _system(name: str, scale: float = 1.0):
    if name in ("jansen", "klann"):
        data = load_yaml(EXAMPLES / f"{name}.yaml")[0]
        data = dict(data, joints={k: [scale * c for c in v] for k, v in data["joints"].items()})
        return planar_model(validate(LinkageSpec, data, file="test")).system
    data = load_yaml(EXAMPLES / "3d" / f"{name}.yaml")[0]
    return compile_mechanism(validate(MechanismSpec, oracle.scaled_spec(data, scale), file="test"))[0]


@pytest.fixture
def own_predictions(monkeypatch):
    """Waves predicting from the poses they solved, as for a mechanism without a closed form
    (linkedit.gcs.closed_form: the revolute chains here have one)."""
    monkeypatch.setattr(ClosedForm, "compile", classmethod(lambda cls, system: None))


@pytest.fixture(params=["closed form", "own"])
def predictions(request):
    """Either way waves predict (:func:`own_predictions`)."""
    if request.param == "own":
        request.getfixturevalue("own_predictions")
    return request.param


def _both(system, t):
    on = solve_run(system, t, Options(waves=True))
    off = solve_run(system, t, Options(waves=False))
    return on, off


def _assert_same(on, off, size):
    assert (on.status == off.status).all()
    assert np.abs(on.position - off.position).max() < 1e-9 * size
    q = np.minimum(np.abs(on.orientation - off.orientation), np.abs(on.orientation + off.orientation))
    assert q.max() < 1e-9  # either sign: the same rotation
    scale = np.abs(off.velocity).max()
    assert np.abs(on.velocity - off.velocity).max() <= 1e-8 * scale


@pytest.mark.parametrize("name,scale", [("crank-rocker", 1.0), ("crank-rocker", 1e3), ("six-bar", 1e-3),
                                        ("spherical-four-bar", 1.0), ("jansen", 1.0), ("klann", 100.0),
                                        ("luffing-arm", 1.0), ("bennett", 1e-3), ("compound-crank-rocker", 1.0)])
def test_waves_give_the_step_by_step_poses_and_velocities(name, scale, predictions):
    system = _system(name, scale)
    t = np.arange(360) / 360
    on, off = _both(system, t)
    assert (off.status == 0).all()
    assert on.batched.sum() >= 350  # solved in waves, but for the first steps
    assert not off.batched.any()
    _assert_same(on, off, system.length_scale)


def test_waves_match_the_closed_form_crank_rocker():
    """An oracle independent of both solvers: the crank-rocker's coupler point P."""
    from linkedit.gcs.mechanism import solve_spec

    spec = validate(MechanismSpec, load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0], file="test")
    res = solve_spec(spec, steps=721, rank=False)
    assert (res.diagnostics.status == 0).all()
    assert solve_run(compile_mechanism(spec)[0], res.t).batched.sum() > 700
    assert np.abs(res.tracks["P"].position - oracle.crank_rocker(2 * np.pi * res.t)).max() < 1e-9 * 10


def test_coarse_steps_fall_back_step_by_step_and_stay_on_the_branch(predictions):
    """19 steps of the Jansen leg: the acceptance test rejects the wide steps (the continuation
    sub-steps them), and the result is the fine run's."""
    system = _system("jansen")
    fine = solve_run(system, np.linspace(0.0, 1.0, 361))
    on, off = _both(system, np.linspace(0.0, 1.0, 19))
    _assert_same(on, off, system.length_scale)
    assert np.abs(on.position - fine.position[::20]).max() < 1e-9 * system.length_scale


def test_a_closed_input_window_goes_step_by_step_and_holds():
    data = load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0]
    data["inputs"]["drive"]["window"] = [0.0, 0.5]
    data["inputs"]["drive"]["rotation"]["angles_deg"] = [0, 180]
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    on, off = _both(system, np.linspace(0.0, 1.0, 201))
    _assert_same(on, off, system.length_scale)
    late = on.t > 0.5
    assert not on.batched[late].any() and on.batched[~late].sum() > 90
    assert np.abs(on.position[late] - on.position[np.argmax(late)]).max() < 1e-12 * system.length_scale


@pytest.mark.parametrize("scale", [1.0, 1e3, 1e-3])
def test_a_free_direction_takes_its_canonical_pose_in_waves_as_step_by_step(scale):
    """The RSSR's coupler spin (a null space of J): waves move it to the canonical pose (the
    spin nearest the rest pose) as the continuation does — the same poses, velocities and
    rank, the spin's distance from rest stationary, the rocker on its closed form."""
    system = _system("rssr", scale)
    t = np.arange(360) / 360
    on, off = _both(system, t)
    assert (off.status == 0).all() and on.batched.sum() >= 350
    _assert_same(on, off, system.length_scale)
    assert (on.rank == system.n_unknowns - 1).all()
    c = system.member_names.index("coupler")
    spin = oracle.spin_gradient(on.position[:, c], on.orientation[:, c], system.points["coupler"]["a"],
                                system.points["coupler"]["b"], system.rest.position[c], system.rest.orientation[c],
                                system.length_scale)
    assert np.abs(spin).max() < 1e-9
    rocker = system.member_names.index("rocker")
    tip = on.position[:, rocker] + quat.to_matrix(on.orientation[:, rocker]) @ system.points["rocker"]["tip"]
    assert np.abs(tip - scale * oracle.rssr(2 * np.pi * t)).max() < 1e-9 * 6 * scale


def test_a_window_opening_after_the_start_lets_waves_in_once_every_input_is_active():
    """A partial first pose (an input outside its window) does not decide what waves keep
    still: they start once every input is active, the free spin of the RSSR included."""
    for name in ("crank-rocker", "rssr"):
        data = load_yaml(EXAMPLES / "3d" / f"{name}.yaml")[0]
        data["inputs"][next(iter(data["inputs"]))]["window"] = [0.1, 1.0]
        system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
        on, off = _both(system, np.linspace(0.0, 1.0, 361))
        _assert_same(on, off, system.length_scale)
        assert on.batched.sum() > 250 and not on.batched[on.t < 0.1].any()


@pytest.mark.parametrize("name", ["crank-rocker", "rssr"])
def test_a_rocking_input_is_solved_in_waves_between_its_keyframes(name):
    """The input's rate jumps at each keyframe (linear angles between them): waves stop there
    and start again after it — the step-by-step poses, nearly all of them in waves."""
    data = load_yaml(EXAMPLES / "3d" / f"{name}.yaml")[0]
    data["inputs"][next(iter(data["inputs"]))]["rotation"]["angles_deg"] = [0, 90, 0, 90, 0]
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    on, off = _both(system, np.linspace(0.0, 1.0, 361))
    _assert_same(on, off, system.length_scale)
    assert on.batched.sum() > 340


def test_a_repeated_time_repeats_its_pose_and_does_not_hang():
    """A time given twice (through the Python API) is the same pose twice, with or without
    waves; it used to halve the continuation's step forever."""
    t = np.insert(np.linspace(0.0, 1.0, 181), 90, 0.5)
    for name in ("crank-rocker", "rssr"):
        on, off = _both(_system(name), t)
        assert (on.status == 0).all() and (off.status == 0).all()
        for run in (on, off):
            assert (run.position[90] == run.position[91]).all() and (run.velocity[90] == run.velocity[91]).all()


@pytest.mark.parametrize("name, tol", [("crank-rocker", 1e-9), ("bennett", 1e-9), ("rssr", 1e-6)])
def test_accelerations_keep_the_waves(name, tol):
    """--accelerations used to switch the waves off (the run step by step: 8-31x its time at 361 steps):
    the run is solved in waves all the same, the poses and velocities unchanged, and the
    accelerations, batched after it, are the pose-by-pose ones at those poses: to 1e-9 (γ's
    central difference rounds to ~1e-11), and along the RSSR's free spin to the ~1e-7 that the
    central difference of its canonical velocity rounds to."""
    from linkedit.gcs.acceleration import acceleration
    from linkedit.gcs.continuation import Solver

    system = _system(name)
    t = np.linspace(0.0, 1.0, 181)
    run = solve_run(system, t, Options(accelerations=True))
    plain = solve_run(system, t, Options())
    assert (run.status == 0).all() and run.batched.sum() >= 170
    assert np.array_equal(run.position, plain.position) and np.array_equal(run.velocity, plain.velocity)
    solver, table = Solver(system), system.step_table(t)
    steps = np.arange(0, t.size, 12)
    want = np.empty((steps.size,) + run.acceleration.shape[1:])
    for i, k in enumerate(steps):
        x = run.state(k)
        a = acceleration(solver, x, table, k, solver.linearize(x, table, k), run.velocity[k].ravel() / solver.col)
        want[i] = (a * solver.col).reshape(-1, 6)
    got, L = run.acceleration[steps], system.length_scale
    scale = max(np.abs(want[..., :3]).max(), L * np.abs(want[..., 3:]).max())
    assert np.abs(got[..., :3] - want[..., :3]).max() < tol * scale
    assert L * np.abs(got[..., 3:] - want[..., 3:]).max() < tol * scale


def test_blas_runs_on_one_thread_inside_and_is_restored_after():
    from linkedit.blas import _controls, single_threaded

    controls = _controls()
    before = [get() for _, get in controls]
    with single_threaded():
        assert all(get() == 1 for _, get in controls)
    assert [get() for _, get in controls] == before


def test_a_planar_linkage_solves_its_in_plane_and_out_of_plane_unknowns_apart():
    from linkedit.gcs.continuation import Solver
    from linkedit.gcs.waves import Waves

    system = _system("crank-rocker")
    t = np.arange(2 * SPLIT_FROM) / (2 * SPLIT_FROM)
    cache = StructureCache(system)
    run = solve_run(system, t, cache=cache)
    waves = Waves(Solver(system), system.step_table(t), cache)
    steps = np.arange(len(t))
    r, jacs = waves.evaluate(run.position.copy(), run.orientation.copy(), steps, True)
    J = waves.jacobian(jacs)
    assert [len(p.cols) for p in waves.parts] == [9, 9] and sum(len(p.rows) for p in waves.parts) == system.n_rows
    assert not J.leaves.any()  # J is zero off its diagonal blocks
    # a pose out of the plane ties them: its factorization is not sound (it goes step by step)
    P, Q = run.position[:SPLIT_FROM].copy(), run.orientation[:SPLIT_FROM].copy()
    P[0, :, 2] += 1e-3 * system.length_scale
    Q[0] = quat.turned(Q[0], np.tile([0.01, 0.0, 0.0], (len(Q[0]), 1)))
    _, jacs = waves.evaluate(P, Q, steps[:SPLIT_FROM], True)
    apart = waves._apart(waves.jacobian(jacs), np.arange(SPLIT_FROM))
    assert not apart[0] and apart[1:].all()


def test_a_second_run_reuses_what_the_first_compiled_and_gives_its_poses():
    """The batched evaluation's parts (J's diagonal blocks, where its entries go, the layouts
    per batch size) are built at the first run and kept in the caller's cache."""
    system = _system("jansen")
    cache = StructureCache(system)
    t = np.arange(360) / 360
    first = solve_run(system, t, cache=cache)
    compiled = cache.waves
    assert compiled.decided and [len(p.cols) for p in compiled.parts] == [21, 21]
    layouts = dict(compiled.layouts)
    again = solve_run(system, t, cache=cache)
    kept = cache.waves  # a copy of the run's own, after each block
    assert kept.layouts is compiled.layouts and all(kept.layouts[B] is lay for B, lay in layouts.items())
    assert [list(p.cols) for p in kept.parts] == [list(p.cols) for p in compiled.parts]
    assert again.batched.sum() >= 350
    _assert_same(again, first, system.length_scale)


@pytest.mark.parametrize("name", ["crank-rocker", "six-bar", "spherical-four-bar", "klann"])
def test_a_warm_system_leaves_what_stays_still_out_of_its_rough_steps_and_gives_the_step_by_step_poses(name, own_predictions):
    """The rough steps leave out the parts that stay still (a planar linkage's out-of-plane
    unknowns, the spherical four-bar's positions) and the groups that are theirs alone, found at
    the first run and kept; the block's solve still checks every row and pivot."""
    system = _system(name)
    cache = StructureCache(system)
    t = np.arange(360) / 360
    solve_run(system, t, cache=cache)
    compiled = cache.waves
    assert compiled.quiet.any() and not compiled.quiet.all() and compiled.skip
    on = solve_run(system, t, cache=cache)
    off = solve_run(system, t, Options(waves=False))
    assert on.batched.sum() >= 350
    _assert_same(on, off, system.length_scale)


def test_a_run_started_off_the_plane_is_solved_as_step_by_step(own_predictions):
    """A warm planar linkage started out of its plane: the continuation brings the first pose
    back into it to the tolerance; the rough steps then hold what stays still where it is, and
    the poses keep J zero off its blocks (to TIED): all in waves, the blocks kept."""
    system = _system("crank-rocker")
    cache = StructureCache(system)
    t = np.arange(360) / 360
    solve_run(system, t, cache=cache)
    start = system.rest.copy()
    start.orientation[:] = quat.turned(start.orientation, np.tile([0.02, -0.01, 0.0], (system.n_members, 1)))
    start.position[:, 2] += 0.01 * system.length_scale
    on = solve_run(system, t, start=start, cache=cache)
    off = solve_run(system, t, Options(waves=False), start=start)
    assert (off.status == 0).all() and on.batched.sum() >= 350
    kept = cache.waves
    assert len(kept.parts) == 2 and kept.skip
    _assert_same(on, off, system.length_scale)


def test_an_input_held_then_moving_merges_the_blocks_it_ties_and_stirs_what_was_still(own_predictions):
    """Two cranks on one pivot, the second held for half the run then turned: the blocks and
    still parts found while it is held (its x and y turns apart, its z turn still) do not hold
    once it turns; the run finds out (merged, stirred) and solves it all in waves."""
    from linkedit.gcs.members import compile_mechanism

    crank = {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}}
    data = {"name": "two", "units": "m", "shapes": {"crank": crank},
            "members": {m: {"position": [0, 0, 0], "shape": "crank"} for m in "ab"},
            "constraints": {f"{m}_pivot": {"type": "pin", "member": m, "point": "pivot", "world": [0, 0, 0]}
                            for m in "ab"},
            "inputs": {"drive_a": {"type": "orientation", "member": "a",
                                   "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 360]}},
                       "drive_b": {"type": "orientation", "member": "b",
                                   "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 0, 90]}}},
            "outputs": {"steps": 361, "tracks": {"tip": {"member": "b", "point": "tip"}}}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    cache = StructureCache(system)
    t = np.linspace(0.0, 1.0, 361)
    off = solve_run(system, t, Options(waves=False))
    first = solve_run(system, t, cache=cache)
    compiled = cache.waves
    b_turn = [i for i, p in enumerate(compiled.parts) if 6 + 5 in p.cols]  # b's turn about z
    assert len(b_turn) == 1 and not compiled.quiet[b_turn[0]]
    assert any({9, 10} <= set(p.cols) for p in compiled.parts)  # b's x and y turns, tied once it turns
    again = solve_run(system, t, cache=cache)
    assert first.batched.sum() >= 355 and again.batched.sum() >= 355
    _assert_same(first, off, system.length_scale)
    _assert_same(again, off, system.length_scale)


def test_a_first_run_finds_the_blocks_before_its_first_wave(own_predictions):
    """Too short a run for a batch of SPLIT_FROM poses: the blocks and the still parts come
    from poses along the tangent of the last solved one, and the poses are step by step's."""

    system = _system("klann")
    cache = StructureCache(system)
    t = np.arange(SPLIT_FROM // 2) / 360
    on = solve_run(system, t, cache=cache)
    compiled = cache.waves
    assert compiled.decided and [len(p.cols) for p in compiled.parts] == [15, 15]
    assert list(compiled.quiet) == [False, True] and compiled.skip
    off = solve_run(system, t, Options(waves=False))
    assert on.batched.sum() >= len(t) - 2
    _assert_same(on, off, system.length_scale)


def test_a_mechanism_that_stays_still_is_solved_again():
    """Every part still (a crank held by its input): the rough steps keep them all."""
    from linkedit.gcs.members import compile_mechanism

    data = load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0]
    data["inputs"]["drive"]["rotation"]["angles_deg"] = [0, 0]  # at rest: every row exactly zero
    data["members"] = {"crank": {"position": [0, 0, 0], "shape": "crank"}}
    data["constraints"] = {"crank_pivot": dict(data["constraints"]["crank_pivot"], world=[0, 0, 0])}
    data["outputs"]["tracks"] = {"tip": {"member": "crank", "point": "tip"}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    cache = StructureCache(system)
    t = np.linspace(0.0, 1.0, 200)
    first = solve_run(system, t, cache=cache)
    again = solve_run(system, t, cache=cache)
    off = solve_run(system, t, Options(waves=False))
    assert cache.waves.quiet.all() and again.batched.sum() >= 190
    _assert_same(first, off, system.length_scale)
    _assert_same(again, off, system.length_scale)
