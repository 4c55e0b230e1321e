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


def median_time(fn: Callable[[], object], repeats: int) -> float:
    """Median wall time of ``repeats`` calls to ``fn``, in seconds (no warm-up call)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)
