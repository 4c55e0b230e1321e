"""The waves' kept compilation, its blocks and copies (``StructureCache.waves``: ``_survey``,
``_stir``, ``_merge``, copies per run). Every run here gives the step-by-step poses
(``Options(waves=False)``); what fails is what the system keeps for its later runs.

Each test states what it measured at 7174002, before: entries of J at most TIED off the kept
blocks (rounding) tie nothing, and a system copied or changed since keeps what it compiled
unused (its digest differs). The complex-loop crash it found is tested in
tests/test_planar_sliders.py."""

from __future__ import annotations

import numpy as np

from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.gcs.structure import StructureCache
from linkedit.gcs.tolerances import Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests.conftest import EXAMPLES
from tests.test_gcs_waves import _assert_same, _system


def test_an_input_window_does_not_merge_a_planar_linkage_for_its_later_runs():
    """The shipped 3D crank-rocker with its input active over [0.2, 0.8] only, solved over
    [0, 1]: the steps outside the window go step by step with the crank free and leave the
    poses out of the plane by rounding (|z| up to 9e-29 of the size before the window, 6e-52
    inside it). Those poses' J has entries (~1e-29) off the kept in-plane/out-of-plane blocks,
    so ``_merge`` joins the two blocks into J whole — on the system, for every later run: the
    later runs keep nothing still out of their rough steps (``skip`` empty). Measured: a later
    run over the window, 36.1 ms (merged) against 28.5 ms on a system that never saw the
    wider run (blocks [9, 9]), 648 linear solves each, best of 7. The poses are right."""
    data = load_yaml(EXAMPLES / "3d" / "crank-rocker.yaml")[0]
    data["inputs"]["drive"]["window"] = [0.2, 0.8]
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    cache = StructureCache(system)
    solve_run(system, np.arange(360) / 360, cache=cache)
    t = np.linspace(0.2, 0.8, 361)
    again = solve_run(system, t, cache=cache)
    _assert_same(again, solve_run(system, t, Options(waves=False)), system.length_scale)  # holds
    kept = cache.waves
    assert kept is not None
    assert [len(p.cols) for p in kept.parts] == [9, 9] and kept.skip  # [18], ()


def test_a_run_past_the_input_window_does_not_slow_every_later_run_of_a_planar_linkage():
    """Klann's linkage (planar_model) solved once over t in [-0.5, 1.5] (the motor active over
    [0, 1]): as above, the steps outside go step by step and leave |z| ~3e-32, and the blocks
    are merged for good ([15, 15] → [30]). Measured after it, the usual run (360 steps over
    [0, 1]): 75.1 ms against 44.6 ms on a system warmed by that usual run (743 and 744 linear
    solves); Jansen 83.0 against 53.1 ms, the six-bar 29.3 against 19.7 ms, the crank-rocker
    21.4 against 16.8 ms — every later run, for the life of the system."""
    system = _system("klann")
    cache = StructureCache(system)
    solve_run(system, np.linspace(-0.5, 1.5, 400), cache=cache)
    t = np.arange(360) / 360
    again = solve_run(system, t, cache=cache)
    _assert_same(again, solve_run(system, t, Options(waves=False)), system.length_scale)  # holds
    kept = cache.waves
    assert kept is not None
    assert [len(p.cols) for p in kept.parts] == [15, 15] and kept.skip  # [30], ()


def test_a_shallow_copy_of_a_system_does_not_change_what_the_original_solves():
    """As the first review's copy test (``dataclasses.replace``, fixed by 400613d: a replaced
    system starts with ``batched`` empty), but the copy made by ``copy.copy`` — System is a
    plain (not frozen) dataclass, so the copy keeps the very same ``batched`` dict. A copy with
    another length scale (and row scales to match) solved first leaves its Jacobian scales
    (``Compiled.places``) for the original: the original's poses are right, every step
    converged and solved in waves, but its velocities are off by 0.0099 of their max (1075
    linear solves against 645). The copy solved after a warm original: 0.0100; the same with
    ``copy.deepcopy`` of a warm system (its own dict, but the original's compilation)."""
    import copy

    t = np.arange(360) / 360
    system = _system("crank-rocker")
    other = copy.copy(system)
    other.length_scale = 1.01 * system.length_scale
    other.row_scale = np.where(system.row_scale == 1.0, 1.0, system.row_scale / 1.01)
    solve_run(other, t)
    on = solve_run(system, t)
    off = solve_run(system, t, Options(waves=False))
    assert (on.status == 0).all() and on.batched.sum() >= 350
    _assert_same(on, off, system.length_scale)
