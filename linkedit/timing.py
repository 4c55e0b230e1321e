"""Wall-time measurement for the benchmarks (``linkedit bench``): best or median of repeated calls."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def best_time(fn: Callable[[], object], repeats: int = 1, budget_s: float = 0.0) -> float:
    """Best wall time of one call to ``fn``, in seconds, after one warm-up call.

    Calls at least ``repeats`` times and keeps calling until ``budget_s`` seconds have passed.
    """
    fn()
    best = float("inf")
    end = time.perf_counter() + budget_s
    n = 0
    while n < repeats or time.perf_counter() < end:
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
        n += 1
    return best


def alternating(fns: list[Callable[[], object]], rounds: int, budget_s: float) -> list[list[float]]:
    """Best wall times (rounds, len(fns)) in seconds of ``fns`` measured in turn, ``rounds`` times, each a
    :func:`best_time` of ``budget_s`` / rounds (``budget_s``: each one's time over all rounds): a burst of another process's load falls on one round of all of
    them, so that medians of their ratios per round hold where ratios of separate bests do not."""
    return [[best_time(fn, budget_s=budget_s / rounds) for fn in fns] for _ in range(rounds)]


def median_time(fn: Callable[[], object], repeats: int) -> float:
    """Median wall time of ``repeats`` calls to ``fn``, in seconds (no warm-up call)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)
