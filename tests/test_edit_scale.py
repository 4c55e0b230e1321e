"""Editing a large linkage: the set-up grows with the linkage as the optimization does (the Jacobian's
colouring was a dense O(sets × variables²) product: 360 s of a 982-joint Strandbeest edit, issue 26 §7)."""

from __future__ import annotations

import time

import numpy as np


def _strandbeest_like_sets(legs: int = 89, own: int = 22, per_leg: int = 76, seed: int = 5) -> np.ndarray:
    """(sets, variables) bool in the shape of a big Strandbeest's: every set holds a few variables of one
    leg and, often, the crank's two (which every leg follows)."""
    rng = np.random.default_rng(seed)
    n = 2 + legs * own
    sets = np.zeros((legs * per_leg, n), dtype=bool)
    for leg in range(legs):
        rows = sets[leg * per_leg:(leg + 1) * per_leg]
        rows[:, 2 + leg * own:2 + (leg + 1) * own] = rng.random((per_leg, own)) < 0.15
        rows[:, :2] = (rng.random(per_leg) < 0.5)[:, None]
    return sets


def _greedy(sets: np.ndarray) -> list[int]:
    """The reference: variable by variable, the lowest colour no variable sharing a set with it has."""
    members = [set(np.flatnonzero(row)) for row in sets]
    near: list[set[int]] = [set() for _ in range(sets.shape[1])]
    for m in members:
        for v in m:
            near[v] |= m
    colours: list[int] = []
    for v in range(sets.shape[1]):
        used = {colours[u] for u in near[v] if u < v}
        colours.append(next(c for c in range(len(used) + 1) if c not in used))
    return colours


def test_colouring_a_982_joint_linkage_is_quick_and_greedy():
    from linkedit.edit.variables import colour

    sets = _strandbeest_like_sets()
    start = time.perf_counter()
    colours = colour(sets)
    seconds = time.perf_counter() - start
    assert seconds < 5.0  # the dense product took minutes here
    assert colours.tolist() == _greedy(sets)
    for row in sets:  # no set repeats a colour: each colour's column of the Jacobian is one variable's per set
        used = colours[row]
        assert used.size == np.unique(used).size
