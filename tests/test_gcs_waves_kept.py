"""The waves' kept compilation (``StructureCache.waves``: parts, quiet parts,
skipped groups): cases where a run with waves differs from the step-by-step run or fails.
Each test states the step-by-step (``Options(waves=False)``) run as the reference.

The four dwell tests (StopIteration) and the work test failed at 052f16c (fixed by 69b57f5
and 345c00d); the copy and threads tests failed from f38609d until the system's copy started
without the kept compilation and a run changed a copy of its own; the RSSR test states the
documented limit along a free direction."""

from __future__ import annotations

import numpy as np

from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.gcs.structure import StructureCache
from linkedit.gcs.tolerances import Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests.test_gcs_waves import _assert_same


def _solved_as_step_by_step(system, t: np.ndarray) -> None:
    """Waves give the step-by-step run's poses, every step converged."""
    off = solve_run(system, t, Options(waves=False))
    assert (off.status == 0).all()
    _assert_same(solve_run(system, t), off, system.length_scale)


def _four_bar_at_origin(angles_deg: list[float]):
    """A planar four-bar whose members all have their frames at the world origin, unturned (as
    when parts are drawn in world coordinates): at rest every residual is exactly zero. The
    crank turns by ``angles_deg`` (keyframes spread over [0, 1]): ``[0, 0, 60]`` dwells over
    the first half."""
    data = {
        "name": "four-bar-at-origin", "units": "m",
        "shapes": {"crank": {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}},
                   "coupler": {"points": {"a": [1, 0, 0], "b": [1, 3, 0]}},
                   "rocker": {"points": {"pivot": [4, 0, 0], "tip": [1, 3, 0]}}},
        "members": {"crank": {"shape": "crank"}, "coupler": {"shape": "coupler"}, "rocker": {"shape": "rocker"}},
        "constraints": {
            "crank_pivot": {"type": "pin", "member": "crank", "point": "pivot", "world": [0, 0, 0]},
            "crank_coupler": {"type": "pin", "member": "crank", "point": "tip", "other": "coupler",
                              "other_point": "a"},
            "coupler_rocker": {"type": "pin", "member": "coupler", "point": "b", "other": "rocker",
                               "other_point": "tip"},
            "rocker_pivot": {"type": "pin", "member": "rocker", "point": "pivot", "world": [4, 0, 0]}},
        "inputs": {"drive": {"type": "orientation", "member": "crank",
                             "rotation": {"axis": [0, 0, 1], "angles_deg": angles_deg}}},
    }
    return compile_mechanism(validate(MechanismSpec, data, file="test"))[0]


def test_a_dwell_at_an_exact_rest_then_motion_in_the_same_run():
    """The crank dwells over [0, 0.5] (keyframes 0, 0, 60°): the first big batch of waves has
    every residual and time derivative exactly zero, so every part is taken as quiet and every
    group skipped; the first wave after the keyframe then evaluates no group at all.
    Observed: StopIteration from Waves.jacobian (next(J for J in jacs if J is not None))."""
    _solved_as_step_by_step(_four_bar_at_origin([0, 0, 60]), np.linspace(0.0, 1.0, 361))


def test_a_run_inside_a_dwell_then_a_run_through_it_on_the_same_system():
    """A first run over the dwell only (t in [0, 0.45]) is right, but leaves every part
    "quiet" on the system; the next run on the same system over [0, 1] then fails as above
    (StopIteration) though a fresh system solves it."""
    system = _four_bar_at_origin([0, 0, 60])
    first = solve_run(system, np.linspace(0.0, 0.45, 181))
    assert (first.status == 0).all()
    t = np.linspace(0.0, 1.0, 361)
    off = solve_run(system, t, Options(waves=False))
    on = solve_run(system, t)
    _assert_same(on, off, system.length_scale)


DRAWN = """
name: drawn-crank-rocker
units: m
shapes:
  crank: {points: {pivot: [-3, 3, 0], tip: [-2, 3, 0]}}
  coupler: {points: {a: [-2, 3, 0], b: [2, 2.75, 0]}}
  rocker: {points: {pivot: [2, -3, 0], tip: [2, 2.75, 0]}}
members:
  crank: {shape: crank}
  coupler: {shape: coupler}
  rocker: {shape: rocker}
joints:
  crank_pivot: {type: revolute, members: [crank, world], at: [-3, 3, 0], axis: [0, 0, 1]}
  crank_coupler: {type: revolute, members: [crank, coupler], at: [-2, 3, 0], axis: [0, 0, 1]}
  coupler_rocker: {type: revolute, members: [coupler, rocker], at: [2, 2.75, 0], axis: [0, 0, 1]}
  rocker_pivot: {type: revolute, members: [rocker, world], at: [2, -3, 0], axis: [0, 0, 1]}
inputs:
  drive: {type: orientation, member: crank, rotation: {axis: [0, 0, 1], angles_deg: [0, 0, 360]}}
outputs:
  steps: 361
"""


def test_a_drawn_mechanism_that_dwells_first_solves_as_step_by_step(tmp_path):
    """A crank-rocker written as a drawing (joints placed in the world, members at their
    default pose: the rest satisfies every constraint exactly) whose crank dwells over the first
    half: ``linkedit solve3d`` on it fails with StopIteration (solve_spec → solve_run → waves);
    before 7006916 (and at 4612409) it solved (361 converged)."""
    from linkedit.gcs.mechanism import solve_spec

    path = tmp_path / "drawn.yaml"
    path.write_text(DRAWN)
    spec = validate(MechanismSpec, load_yaml(path)[0], file=str(path))
    res = solve_spec(spec, rank=False)
    assert (res.diagnostics.status == 0).all()
    system = compile_mechanism(spec)[0]
    off = solve_run(system, res.t, Options(waves=False))
    assert np.abs(res.position - off.position).max() < 1e-9 * system.length_scale


def test_the_spherical_four_bar_example_with_a_dwell_first_solves_as_step_by_step():
    """The shipped spherical four-bar (every member frame at the world's at rest: residuals
    exactly zero there) with its crank dwelling over the first half (angles 0, 0, 360°), one
    run on a fresh system: StopIteration from Waves.jacobian. The same with a window and a
    rocking input (window [0.1, 1], angles 0, 0, 120, 0)."""
    from tests.conftest import EXAMPLES

    for window, angles in ((None, [0, 0, 360]), ([0.1, 1.0], [0, 0, 120, 0])):
        data = load_yaml(EXAMPLES / "3d" / "spherical-four-bar.yaml")[0]
        data["inputs"]["drive"]["rotation"]["angles_deg"] = angles
        if window:
            data["inputs"]["drive"]["window"] = window
        _solved_as_step_by_step(compile_mechanism(validate(MechanismSpec, data, file="test"))[0],
                                np.linspace(0.0, 1.0, 361))


def test_a_sub_mechanism_that_dwells_at_an_exact_rest_does_not_make_waves_dearer_than_step_by_step():
    """Not a wrong answer — work: the shipped crank-rocker plus a second, drawn four-bar (frames
    at the world's, residuals exactly zero at rest) whose crank dwells over the first half then
    turns 60°. Its in-plane part is taken as quiet from the dwell; after the keyframe its rough
    poses are not corrected and their velocities are zero, so the block solves start from poses
    that are far off (moves up to ~1e33 in Waves.solve) and most are rejected. Measured: 2566
    linear solves with waves (915 before 7006916) against 690 step by step; 0.38 s against
    0.087 s per run (lim − 0.01° variant, medians of 3)."""
    from tests.conftest import EXAMPLES

    data = load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0]
    dx = 20.0
    data["shapes"].update({
        "bcrank": {"points": {"p": [dx, 0, 0], "a": [dx + 2, 0, 0]}},
        "bcoupler": {"points": {"a": [dx + 2, 0, 0], "c": [dx + 3.2, 2.8, 0]}},
        "brocker": {"points": {"p": [dx + 5, 0, 0], "c": [dx + 3.2, 2.8, 0]}}})
    data["members"].update({"bcrank": {"shape": "bcrank"}, "bcoupler": {"shape": "bcoupler"},
                            "brocker": {"shape": "brocker"}})
    data["constraints"].update({
        "b1": {"type": "pin", "member": "bcrank", "point": "p", "world": [dx, 0, 0]},
        "b2": {"type": "pin", "member": "bcrank", "point": "a", "other": "bcoupler", "other_point": "a"},
        "b3": {"type": "pin", "member": "bcoupler", "point": "c", "other": "brocker", "other_point": "c"},
        "b4": {"type": "pin", "member": "brocker", "point": "p", "world": [dx + 5, 0, 0]}})
    data["inputs"]["bdrive"] = {"type": "orientation", "member": "bcrank",
                                "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 0, 60]}}
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    t = np.linspace(0.0, 1.0, 721)
    on = solve_run(system, t)
    off = solve_run(system, t, Options(waves=False))
    _assert_same(on, off, system.length_scale)  # holds
    assert on.batched.sum() > 700
    assert on.iterations.sum() <= 1.5 * off.iterations.sum()


def test_a_copy_of_a_system_does_not_change_what_the_original_solves():
    """``dataclasses.replace(system, …)`` copies the ``batched`` dict by reference, so a copy
    and its original share the kept compilation (``Compiled.places`` holds each Jacobian
    entry's scale, from the solver's length scale). A copy with another length scale (the same
    mechanism, scaled unknowns) solved first leaves its scales for the original: the original's
    poses are right but its velocities are off by 1 % (measured 0.0099 of their max), every
    step converged and solved in waves. The copy, solved after a warm original, likewise
    (0.0100). Before f38609d (the compilation kept per run) it held."""
    import dataclasses

    from tests.test_gcs_waves import _system

    t = np.arange(360) / 360
    system = _system("crank-rocker")
    copy = dataclasses.replace(system, length_scale=1.01 * system.length_scale,
                               row_scale=np.where(system.row_scale == 1.0, 1.0, system.row_scale / 1.01))
    solve_run(copy, t)
    on = solve_run(system, t)
    off = solve_run(system, t, Options(waves=False))
    assert (on.status == 0).all() and on.batched.sum() >= 350
    _assert_same(on, off, system.length_scale)


def test_one_system_solved_from_several_threads_at_once():
    """One structure cache shared by runs of one system in four threads. Each run used to keep
    its own batched state; then the parts, places and layouts lived on the System and a run
    rewrote them (``_decouple`` sets ``parts`` then drops ``places``), so
    runs of one System in several threads see each other's halfway state. Measured: 19 of 172
    runs of a fresh Jansen system, four grids at a time, raise (IndexError "index 21 is out of
    bounds for axis 1 with size 21", ValueError "operands could not be broadcast together with
    shapes (31,) (63,)", TypeError "'NoneType' object is not iterable"); none at 4612409 (15 s).
    Stops at the first failure, else after ~5 s."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from tests.test_gcs_waves import _system

    grids = [np.linspace(0.1, 0.9, 500), np.linspace(0.0, 1.0, 1000), np.arange(360) / 360, np.linspace(1.0, 0.0, 400)]
    errors: list[BaseException] = []
    start = time.monotonic()
    while not errors and time.monotonic() - start < 5.0:
        system = _system("jansen")
        barrier = threading.Barrier(len(grids))
        cache = StructureCache(system)  # one cache shared by the threads

        def run(t: np.ndarray, system=system, barrier=barrier, cache=cache):
            barrier.wait()
            return solve_run(system, t, cache=cache)

        with ThreadPoolExecutor(len(grids)) as pool:
            for future in [pool.submit(run, t) for t in grids]:
                if future.exception() is not None:
                    errors.append(future.exception())
    assert not errors, repr(errors[0])


def test_the_rssr_coupler_spin_in_waves_over_a_descending_part_of_the_cycle():
    """The RSSR over t from 0.356 down to 0.289 (130 steps), cold system: waves and step by
    step give the same poses, the coupler's spin included (once kept still from step to step,
    it drifted apart by up to N × still_tol; now both take the canonical spin)."""
    from tests.test_gcs_waves import _system

    system = _system("rssr")
    t = np.linspace(0.356, 0.289, 130)
    on = solve_run(system, t)
    off = solve_run(system, t, Options(waves=False))
    assert (off.status == 0).all() and on.batched.sum() > 120
    assert (on.status == off.status).all()
    assert np.abs(on.position - off.position).max() < 1e-9 * system.length_scale
    q = np.minimum(np.abs(on.orientation - off.orientation), np.abs(on.orientation + off.orientation))
    assert q.max() < 1e-9


def test_what_a_system_keeps_for_later_runs_is_bounded():
    """Runs of many sizes on one system (the review measured 194 MB kept after runs of 2k to
    50k steps): the layouts kept are of at most KEPT_LAYOUTS batch sizes of at most
    KEPT_POSES poses each."""
    from linkedit.gcs.evaluate import KEPT_LAYOUTS, KEPT_POSES
    from tests.test_gcs_waves import _system

    system = _system("six-bar")
    cache = StructureCache(system)
    for steps in (100, 2000, 360, 1500, 50):
        solve_run(system, np.arange(steps) / steps, cache=cache)
    assert cache.waves is not None
    layouts = cache.waves.layouts
    assert 0 < len(layouts) <= KEPT_LAYOUTS and max(layouts) <= KEPT_POSES


def test_the_3d_system_of_a_planar_linkage_with_an_oscillating_input_is_refused_clearly():
    """planar_model on a linkage with a slider motor raised StopIteration (review); sliders and
    linear inputs are modelled now, an oscillating input is refused with a ValueError naming it."""
    import pytest

    from linkedit.gcs.planar_bridge import planar_model
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model
    from tests.conftest import EXAMPLES

    assert planar_model(load_model(LinkageSpec, EXAMPLES / "lifting-arm.yaml")).system is not None
    spec = load_model(LinkageSpec, EXAMPLES / "crank-rocker.yaml")
    rocking = spec.model_copy(update={"motor": spec.motor.model_copy(update={"oscillate_deg": (0.0, 30.0)})})
    with pytest.raises(ValueError, match="oscillating"):
        planar_model(rocking)
