"""The progress lines of a long `solve3d`: the time left is estimated from the recent rate, not from
an average that includes the slow first steps (it promised 5,213,715 s for a 27 s run, issue 26 §7)."""

from __future__ import annotations

import re

import pytest


def _lines(capsys, monkeypatch, schedule: list[tuple[float, int]], total: int) -> list[str]:
    """Progress lines for steps done at the given (time s, step index) moments, read on a fake clock."""
    import time

    from linkedit.commands.solve3d import Progress

    now = [0.0]
    monkeypatch.setattr(time, "perf_counter", lambda: now[0])
    progress = Progress("six-bar")
    for t, k in schedule:
        now[0] = t
        progress(k, total)
    return capsys.readouterr().err.splitlines()


def _left(line: str) -> float | None:
    m = re.search(r"about ([\d.]+) (s|min|h) left", line)
    return None if m is None else float(m[1]) * {"s": 1, "min": 60, "h": 3600}[m[2]]


def test_a_slow_start_does_not_make_the_estimate_absurd(capsys, monkeypatch):
    """Three steps take 5 s (assembly, building the solver), then 20,000 steps run at 1,000 steps/s."""
    total = 20_000
    schedule = [(1.0, 0), (2.5, 1), (5.0, 2)] + [(5.0 + (k - 2) / 1000, k) for k in range(3, total, 50)]
    lines = _lines(capsys, monkeypatch, schedule, total)
    assert lines and all(_left(ln) is None for ln in lines if int(ln.split()[2].split("/")[0].replace(",", "")) < 1000)
    estimates = [(int(ln.split()[2].split("/")[0].replace(",", "")), _left(ln)) for ln in lines if _left(ln)]
    assert estimates, lines
    for done, left in estimates:
        truth = (total - done) / 1000
        assert 0.5 * truth <= left <= 2 * truth + 1, (done, left, truth, lines)


def test_a_steady_run_is_estimated_from_its_rate(capsys, monkeypatch):
    total = 1000
    lines = _lines(capsys, monkeypatch, [(0.01 * (k + 1), k) for k in range(total)], total)  # 100 steps/s from the start
    assert lines[0] == "six-bar: step 200/1,000 (100.0 steps/s, about 8 s left)"
    assert lines[-1] == "six-bar: step 1,000/1,000 (100.0 steps/s)"


@pytest.mark.parametrize("seconds, text", [(12.4, "12 s"), (600, "10 min"), (9000, "2.5 h")])
def test_time_left_reads_in_a_unit_a_person_takes_in(seconds, text):
    from linkedit.commands.solve3d import _duration

    assert _duration(seconds) == text
