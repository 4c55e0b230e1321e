"""The bench's scaling figures (``linkedit bench -s synthesis``): the wall-clock parallel efficiency, and the
CPU-time efficiency and busy fraction that still mean something on a machine other processes share."""

from __future__ import annotations

import re

import pytest

from linkedit.synthesis import bench_cluster


def test_the_scaling_figures_parse_and_add_up(cluster):
    """On the pre-started 2-worker cluster: every printed efficiency lies in (0, 1.2]; the tasks' CPU seconds, measured inside each task, are
    within the worker processes' CPU over the build and at least 60 % of it (the rest: Dask's own work there),
    and near the same build's CPU in-process; the tasks ran within the workers × wall seconds; the printed
    CPU-time efficiency is the in-process CPU over the workers' and the client's."""
    lines: list[str] = []
    figures = bench_cluster.shard_scaling(lines.append, cluster.scheduler_address, 2, 1, 0.0)
    text = "\n".join(lines)
    printed = {name: float(re.search(pattern, text).group(1)) / scale for name, pattern, scale in [
        ("wall", r"parallel efficiency (\d+)%", 100), ("cpu", r"CPU-time efficiency (\d+)%", 100),
        ("busy", r"busy fraction ([\d.]+) ", 1)]}
    assert all(0 < value <= 1.2 for value in printed.values()), printed
    assert figures["threads"] == 2
    assert 0.6 * figures["workers"] <= figures["tasks_cpu"] <= figures["workers"], figures
    assert 0.5 * figures["cpu"] <= figures["tasks_cpu"] <= 1.5 * figures["cpu"], figures
    assert figures["tasks_wall"] <= 2 * figures["dask_wall"], figures
    assert printed["cpu"] == pytest.approx(figures["cpu"] / (figures["workers"] + figures["client"]), abs=0.006)
    assert printed["busy"] == pytest.approx(figures["tasks_wall"] / (2 * figures["dask_wall"]), abs=0.006)
