"""The structure cache belongs to the caller, not the model (issue 22): ``solve_run`` leaves
the system as it was, and runs of one system in threads give what a run alone gives.

Before: the first run kept its compilation on the system (``System.batched``, checked by a
digest of the system's arrays and copied per thread), so a system pickled before and after a
run differed."""

from __future__ import annotations

import pickle
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from linkedit.gcs.solve import solve_run
from linkedit.gcs.structure import StructureCache
from tests.test_gcs_waves import _system


@pytest.mark.parametrize("name", ["six-bar", "rssr"])
def test_a_run_leaves_the_system_as_it_was(name):
    system = _system(name)
    before = pickle.dumps(system)
    attributes = set(vars(system))
    run = solve_run(system, np.arange(240) / 240)
    assert run.batched.sum() > 200  # solved in waves: what they compile went elsewhere
    assert set(vars(system)) == attributes and pickle.dumps(system) == before


def test_two_runs_in_threads_on_one_system_give_a_lone_run_bit_for_bit():
    system = _system("six-bar")
    t = np.arange(240) / 240
    alone = solve_run(_system("six-bar"), t)
    with ThreadPoolExecutor(2) as pool:
        runs = list(pool.map(lambda _: solve_run(system, t), range(2)))
    for run in runs:
        for a, b in ((run.position, alone.position), (run.orientation, alone.orientation),
                     (run.velocity, alone.velocity), (run.batched, alone.batched)):
            assert np.array_equal(a, b)


def test_a_cache_kept_by_the_caller_serves_later_runs_and_only_its_system():
    system = _system("six-bar")
    t = np.arange(240) / 240
    cache = StructureCache(system)
    first = solve_run(system, t, cache=cache)
    assert cache.waves is not None and cache.waves.decided
    again = solve_run(system, t, cache=cache)
    assert np.array_equal(first.position, again.position) and np.array_equal(first.velocity, again.velocity)
    with pytest.raises(ValueError, match="another system"):
        solve_run(_system("six-bar"), t, cache=cache)
