"""An atlas on a Dask cluster: a build streams (a few tasks ahead of the client, never all of them)."""

from __future__ import annotations

import time

import numpy as np

from linkedit.synthesis import chunks
from linkedit.synthesis import cluster as runner


def test_a_dask_build_streams(cluster):
    """When the first chunk comes back, the scheduler knows only the tasks submitted ahead (IN_FLIGHT per
    worker thread), not all 20 of the build (the old runner submitted every task at once: a 100-million
    build's chunks piled up on the workers); the chunks are the in-process ones, in order."""
    jobs = [(k, 10) for k in range(40)]
    with runner.chunk_runner(cluster.scheduler_address) as run:
        built = run("four-bar", 3, jobs)
        first = next(built)
        time.sleep(0.5)  # whatever the client submitted has reached the scheduler
        known = len(cluster.scheduler.tasks)
        rest = list(built)
    assert len(runner.dask_tasks(jobs, 2)) == 20 and known <= 6 == runner.IN_FLIGHT * 2
    assert [index for index, _ in [first, *rest]] == list(range(40))
    for index, chunk in [first, *rest][::13]:
        np.testing.assert_array_equal(chunk.index, chunks.build_chunk("four-bar", 3, index, 10).index)
