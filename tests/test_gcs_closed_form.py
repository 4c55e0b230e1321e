"""Poses in closed form (linkedit.gcs.closed_form): members rebuilt from placed ones satisfy
every constraint to rounding, on either assembly, at any scale; the waves that take them as
predictions give the step-by-step continuation's poses, converged at once; mechanisms whose
members have no rules, or whose rules do not hold (axes not parallel), go without."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs.closed_form_rules import Driven, Dyad
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.planar_bridge import planar_model
from linkedit.gcs.solve import solve_run
from linkedit.gcs.structure import StructureCache
from linkedit.gcs.tolerances import Options
from linkedit.gcs.system import State
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests import gcs_oracles as oracle
from tests.conftest import EXAMPLES


def _data(name: str, scale: float = 1.0) -> dict:
    return oracle.scaled_spec(load_yaml(EXAMPLES / "3d" / f"{name}.yaml")[0], scale)


def _system(name: str, scale: float = 1.0):
    if name in ("jansen", "klann"):
        data = load_yaml(EXAMPLES / f"{name}.yaml")[0]
        data = dict(data, joints={k: [scale * c for c in v] for k, v in data["joints"].items()})
        return planar_model(validate(LinkageSpec, data, file="test")).system
    return compile_mechanism(validate(MechanismSpec, _data(name, scale), file="test"))[0]


def _poses(system, run, table, at: int = 0):
    """The closed form's poses of every step from the sides of the run's pose ``at``."""
    form = ClosedForm.compile(system)
    signs = form.signs(run.position[at], run.orientation[at], table, at)
    return form.poses(table, np.arange(len(table.t)), run.orientation[at], signs), signs


def _assert_same(P, Q, run, size):
    assert np.abs(P - run.position).max() < 1e-9 * size
    assert np.minimum(np.abs(Q - run.orientation), np.abs(Q + run.orientation)).max() < 1e-9


@pytest.mark.parametrize("name,rules", [
    ("crank-rocker", ["Driven", "Dyad"]), ("six-bar", ["Driven", "Dyad", "Dyad"]),
    ("compound-crank-rocker", ["Driven", "Dyad", "Driven"]), ("jansen", ["Driven", "Dyad", "Dyad", "Dyad"]),
    ("klann", ["Driven", "Dyad", "Dyad"]), ("bennett", ["Driven", "Dyad"]),
    ("rssr", ["Driven", "Swing", "Spun"]), ("spherical-four-bar", ["Driven", "Cone"]),
    ("spatial-slider-crank", ["Driven", "Reach", "Spun"]), ("luffing-arm", None)])
def test_the_rules_that_place_each_member(name, rules):
    """Revolute chains get rules (the Bennett linkage's too: its axes are not parallel, which
    only its poses tell), a spherical four-bar a spherical dyad (cone), a rocker or a slider on
    a line (or two planes) reaching a link with ball joints a swing or a reach and the link its
    canonical spin; distance inputs do not."""
    form = ClosedForm.compile(_system(name))
    assert (None if form is None else [type(r).__name__ for r in form.rules]) == rules


@pytest.mark.parametrize("name,scale", [("crank-rocker", 1e-3), ("crank-rocker", 1.0), ("crank-rocker", 1e3),
                                        ("six-bar", 1e3), ("compound-crank-rocker", 1.0), ("jansen", 1e-3),
                                        ("klann", 100.0)])
def test_rebuilt_poses_satisfy_every_constraint_and_are_the_step_by_step_ones(name, scale):
    """Over a whole cycle, at sizes from mm to km: every scaled residual row at most 1e-14 (the
    solver's tolerance is 1e-12), and the continuation's poses to 1e-9 of the size."""
    system = _system(name, scale)
    t = np.arange(360) / 360
    table = system.step_table(t)
    run = solve_run(system, t, Options(waves=False))
    (P, Q, valid), _ = _poses(system, run, table, at=0)
    assert valid.all()
    worst = max(np.abs(system.evaluate(State(P[k], Q[k]), table, k).r * system.row_scale).max() for k in range(len(t)))
    assert worst <= 1e-14
    _assert_same(P, Q, run, system.length_scale)
    # one sign from step to step, the first the run's: what the waves interpolate and write
    assert (quat.dot(Q[1:], Q[:-1]) > 0.0).all() and (quat.dot(Q[0], run.orientation[0]) > 0.0).all()


def test_the_coupler_point_is_the_independent_closed_form():
    """An oracle of its own (circle intersection in the plane): the crank-rocker's coupler point."""
    system = _system("crank-rocker")
    t = np.arange(720) / 720
    table = system.step_table(t)
    run = solve_run(system, t[:2], Options(waves=False))
    form = ClosedForm.compile(system)
    P, Q, valid = form.poses(table, np.arange(len(t)), run.orientation[0],
                             form.signs(run.position[0], run.orientation[0], table, 0))
    coupler = system.member_names.index("coupler")
    point = P[:, coupler] + quat.rotate(Q[:, coupler], np.array([2.5, 2.5, 0.0]))
    assert valid.all() and np.abs(point - oracle.crank_rocker(2 * np.pi * t)).max() < 1e-12 * 10


def _other_assembly() -> dict:
    """The crank-rocker started on its other assembly: the coupler–rocker joint mirrored across
    the line from the crank tip to the rocker pivot."""
    data = _data("crank-rocker")
    B, D = np.array([-2.0, 3.0]), np.array([2.0, -3.0])
    C = oracle._circles(B[None], 5.0, D, 5.75, -1)[0]
    for member, origin in (("coupler", B), ("rocker", D)):
        e = C - origin
        data["members"][member]["orientation"] = {"axis": [0, 0, 1], "angle_deg": float(np.degrees(np.arctan2(e[1], e[0])))}
    return data


def test_the_other_assembly_is_rebuilt_on_its_own_side_and_solved_in_waves_as_step_by_step():
    system = compile_mechanism(validate(MechanismSpec, _other_assembly(), file="test"))[0]
    t = np.arange(360) / 360
    table = system.step_table(t)
    off = solve_run(system, t, Options(waves=False))
    rocker = system.member_names.index("rocker")
    tip = off.position[:, rocker] + quat.rotate(off.orientation[:, rocker], np.array([5.75, 0.0, 0.0]))
    assert np.abs(tip[:, :2] - oracle._circles(np.column_stack([-3 + np.cos(2 * np.pi * t), 3 + np.sin(2 * np.pi * t)]),
                                               5.0, np.array([2.0, -3.0]), 5.75, -1)).max() < 1e-9 * 10
    (P, Q, valid), signs = _poses(system, off, table)
    default = _system("crank-rocker")
    run = solve_run(default, t[:1], Options(waves=False))
    assert signs == [-s for s in _poses(default, run, default.step_table(t[:1]))[1]]
    assert valid.all()
    _assert_same(P, Q, off, system.length_scale)
    on = solve_run(system, t)
    assert on.batched.sum() >= 355
    _assert_same(on.position, on.orientation, off, system.length_scale)


def test_waves_from_the_closed_form_converge_at_once_and_give_the_step_by_step_run():
    """The predictions are exact to rounding: a step costs one linear solve (its velocity)."""
    system = _system("jansen")
    t = np.arange(360) / 360
    cache = StructureCache(system)
    on, off = solve_run(system, t, cache=cache), solve_run(system, t, Options(waves=False))
    assert cache.waves is not None and cache.waves.closed is not None
    assert on.batched.sum() >= 355 and on.iterations[2:].mean() <= 1.05
    _assert_same(on.position, on.orientation, off, system.length_scale)
    assert np.abs(on.velocity - off.velocity).max() <= 1e-8 * np.abs(off.velocity).max()


def test_rules_that_do_not_hold_are_dropped_and_the_run_is_step_by_step():
    """The Bennett linkage's revolute chain has rules, but its axes are skew: the rebuilt pose
    is not the solved one, so the closed form is dropped (for later runs too)."""
    system = _system("bennett", 1e-3)
    assert ClosedForm.compile(system) is not None
    t = np.arange(360) / 360
    cache = StructureCache(system)
    on, off = solve_run(system, t, cache=cache), solve_run(system, t, Options(waves=False))
    assert cache.waves is not None and cache.waves.closed is None and on.batched.sum() >= 350
    _assert_same(on.position, on.orientation, off, system.length_scale)


@pytest.mark.slow  # ≈ 5 s
def test_a_dyad_driven_past_its_reach_stops_rebuilding_there_and_resumes_on_its_branch():
    """The rocker driven past its reach and back: the crank–coupler dyad cannot close (its
    steps fail, as step by step), and after the lock the rebuilt poses resume on the side the
    continuation comes back on."""
    data = _data("crank-rocker")
    data["inputs"]["drive"] = {"type": "orientation", "member": "rocker",
                               "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 30, 0]}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    form = ClosedForm.compile(system)
    assert [type(r) for r in form.rules] == [Driven, Dyad]
    t = np.linspace(0.0, 1.0, 241)
    on, off = solve_run(system, t), solve_run(system, t, Options(waves=False))
    ok = off.status == 0
    after = np.arange(len(t)) > np.flatnonzero(~ok)[-1]
    assert (on.status == off.status).all() and (~ok).sum() > 100 and after.sum() > 30
    assert on.batched[after].sum() >= after.sum() // 2
    assert np.abs(on.position[ok] - off.position[ok]).max() < 1e-9 * system.length_scale
    # on the rest branch again: the steps after the lock mirror the ones before it
    mirror = len(t) - 1 - np.flatnonzero(after)
    assert ok[mirror].all() and np.abs(on.position[after] - on.position[mirror]).max() < 1e-9 * system.length_scale


def test_a_redundant_link_between_placed_members_turns_about_its_axis():
    """A locomotive's coupling rod on three cranks (one driven): the third crank is pinned at
    both ends to placed members (hinged). Over-constrained, yet every constraint holds to
    rounding and waves give the step-by-step poses."""
    data = {"name": "coupling-rod", "units": "m",
            "shapes": {"crank": {"points": {"pivot": [0, 0, 0], "tip": [0, 1, 0]}},
                       "rod": {"points": {"a": [0, 0, 0], "b": [2, 0, 0], "c": [4, 0, 0]}}},
            "members": {**{f"c{i}": {"position": [2 * i, 0, 0], "shape": "crank"} for i in range(3)},
                        "rod": {"position": [0, 1, 0], "shape": "rod"}},
            "constraints": {**{f"c{i}_pivot": {"type": "pin", "member": f"c{i}", "point": "pivot",
                                               "world": [2 * i, 0, 0]} for i in range(3)},
                            **{f"c{i}_rod": {"type": "pin", "member": f"c{i}", "point": "tip", "other": "rod",
                                             "other_point": "abc"[i]} for i in range(3)}},
            "inputs": {"drive": {"type": "orientation", "member": "c0",
                                 "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 60]}}},
            "outputs": {"steps": 61, "tracks": {"tip": {"member": "rod", "point": "c"}}}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    form = ClosedForm.compile(system)
    assert [type(r).__name__ for r in form.rules] == ["Driven", "Dyad", "Hinged"]
    t = np.linspace(0.0, 1.0, 200)
    table = system.step_table(t)
    off = solve_run(system, t, Options(waves=False))
    (P, Q, valid), _ = _poses(system, off, table)
    assert valid.all()
    assert max(np.abs(system.evaluate(State(P[k], Q[k]), table, k).r * system.row_scale).max() for k in range(len(t))) <= 1e-14
    # every crank stays parallel to the driven one: the rod's points keep their ground offsets
    theta = np.radians(60 * t)
    tip = np.column_stack([-np.sin(theta), np.cos(theta), np.zeros_like(t)])
    rod = system.member_names.index("rod")
    for i, name in enumerate("abc"):
        point = P[:, rod] + quat.rotate(Q[:, rod], np.array([2.0 * i, 0.0, 0.0]))
        assert np.abs(point - (tip + [2.0 * i, 0.0, 0.0])).max() < 1e-14
    on = solve_run(system, t)
    assert on.batched.sum() >= len(t) - 2
    _assert_same(on.position, on.orientation, off, system.length_scale)


def test_a_large_linkage_is_verified_in_waves_pose_by_pose_as_step_by_step():
    """The 3-pair Strandbeest (222 unknowns: the sparse factorization, no batched one): its
    closed-form poses are evaluated together, then each factorized as the continuation does —
    the same poses, velocities, statuses and ranks, one factorization per step."""
    from linkedit.planar import catalog

    system = planar_model(catalog.strandbeest(3)).system
    t = np.arange(360) / 360
    on, off = solve_run(system, t), solve_run(system, t, Options(waves=False))
    assert system.n_unknowns > 120 and (off.status == 0).all()
    assert on.batched.sum() >= 355 and on.factorizations[2:].mean() == 1.0
    assert (on.status == off.status).all() and (on.rank == off.rank).all()
    _assert_same(on.position, on.orientation, off, system.length_scale)
    assert np.abs(on.velocity - off.velocity).max() <= 1e-8 * np.abs(off.velocity).max()


def test_a_pin_whose_axis_points_the_other_way_is_rebuilt_too():
    """The crank-rocker written with revolute joints, the rocker's ground pivot axis given as −z
    (the crank's +z): a pin's axis is a line either way, so the closed form holds (the review's
    four-bar)."""
    z = [0.0, 0.0, 1.0]
    data = {"name": "four-bar", "units": "m",
            "members": {"crank": {"position": [-2.7, 2.8, 0.1]}, "coupler": {"position": [-1.7, 2.8, 0.1]},
                        "rocker": {"position": [2.3, -3.2, 0.1]}},
            "joints": {"jA": {"type": "revolute", "members": ["crank", "world"], "at": [-3.0, 3.0, 0.0], "axis": z},
                       "jB": {"type": "revolute", "members": ["coupler", "crank"], "at": [-2.0, 3.0, 0.0], "axis": z},
                       "jC": {"type": "revolute", "members": ["rocker", "coupler"],
                              "at": [2.9887215945130663, 2.664356063008711, 0.0], "axis": z},
                       "jD": {"type": "revolute", "members": ["rocker", "world"], "at": [2.0, -3.0, 0.0],
                              "axis": [0.0, 0.0, -1.0]}},
            "inputs": {"drive": {"type": "orientation", "member": "crank", "rotation": {"axis": z, "angles_deg": [0, 360]}}},
            "outputs": {"steps": 361}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    t = np.arange(360) / 360
    cache = StructureCache(system)
    on, off = solve_run(system, t, cache=cache), solve_run(system, t, Options(waves=False))
    assert cache.waves is not None and cache.waves.closed is not None and on.iterations[2:].mean() <= 1.05
    assert (on.status == off.status).all() and (off.status == 0).all()
    _assert_same(on.position, on.orientation, off, system.length_scale)


@pytest.mark.slow  # ~25 s: pins what the waves' rebuild returns (the poses: test_a_dyad_driven_past_its_reach…)
def test_a_block_whose_first_step_cannot_be_rebuilt_is_left_to_the_continuation():
    """The crank-rocker's rocker driven past its reach: a block starting where the crank–coupler
    dyad cannot close has no pose to screen or solve (none is rebuilt); the waves say so and the
    continuation takes the step."""
    from linkedit.gcs.continuation import Solver
    from linkedit.gcs.waves import Waves

    data = _data("crank-rocker")
    data["inputs"]["drive"] = {"type": "orientation", "member": "rocker",
                               "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 30, 0]}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    t = np.linspace(0.0, 1.0, 241)
    off = solve_run(system, t, Options(waves=False))
    k = int(np.flatnonzero(off.status != 0)[0])  # the first step past the reach
    waves = Waves(Solver(system), system.step_table(t), StructureCache(system))
    vel = off.velocity.copy()
    assert waves.rebuilt(k, k + 16, off.position, off.orientation, vel) is None
