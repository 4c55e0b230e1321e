"""The atlas build on a Dask cluster, for ``linkedit bench -s synthesis``: per core against in-process builds side by
side (:func:`dask_comparison`), and a sharded build's parallel efficiency, CPU-time efficiency and busy fraction
(:func:`shard_scaling`)."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import shutil
import statistics
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from linkedit.io.atomic import commit
from linkedit.synthesis import atlas
from linkedit.synthesis.cluster import connected, local_cluster, task_times, usable_cores


def _build_seconds(path: Path, count: int, scheduler: str | None = None) -> float:
    """Wall seconds of ``atlas build`` of ``count`` four-bars into a new HDF5 file ``path``."""
    path.unlink(missing_ok=True)
    t0 = time.perf_counter()
    atlas.build(path, ["four-bar"], count, seed=1, scheduler=scheduler)
    commit()  # the command's outputs are renamed together at its end; this file lives in a folder about to go
    return time.perf_counter() - t0


def dask_comparison(echo: Callable[[str], None], chunks: int, repeats: int, workers: int) -> None:
    """``atlas build`` of ``chunks`` chunks, writing the HDF5 atlas, per core: in-process; as
    ``workers`` in-process builds side by side (separate processes, each a share of the
    linkages); on a local Dask cluster of as many single-threaded workers (started once, before
    the timing), whose sharded build :func:`shard_scaling` then times. Runs interleaved, medians
    of ``repeats``.

    Per core: the in-process rate divided by the threads it keeps busy (over a tenth of the wall
    time; its numpy code is single-threaded); the side-by-side and Dask rates divided by their
    processes, one per core (Dask's client, writing the file, and scheduler share those cores).
    Other processes on the machine slow the runs that need every core most: the side-by-side
    builds show what the machine gives that many processes meanwhile, and the CPU seconds used
    (in-process: its threads; Dask: every process of the run, client, scheduler, nannies and
    workers) give the ratio on cores of its own.
    """
    try:
        import psutil
        from dask.distributed import Client  # noqa: F401 (the extra is installed)
    except ImportError:
        echo("atlas build on Dask: not timed (pip install 'linkedit[cluster]')")
        return
    count = chunks * atlas.CHUNK
    me = psutil.Process()
    own = {t.id for t in me.threads()}  # before the cluster starts: this program's threads, numpy's included

    def own_threads() -> dict[int, float]:
        """CPU seconds of each of this program's own threads so far (not the cluster's)."""
        return {t.id: t.user_time + t.system_time for t in me.threads() if t.id in own}

    def ours() -> float:
        """CPU seconds of this process and its children (the cluster) so far."""
        total = 0.0
        for proc in [me, *me.children(recursive=True)]:
            with contextlib.suppress(psutil.NoSuchProcess):
                times = proc.cpu_times()
                total += times.user + times.system
        return total

    def machine() -> float:
        """CPU seconds the machine's cores were busy so far (or taken by the hypervisor: steal)."""
        times = psutil.cpu_times()
        return sum(getattr(times, field, 0.0) for field in ("user", "nice", "system", "irq", "softirq", "steal"))

    spawn = multiprocessing.get_context("spawn")  # no fork of a process running the cluster's threads
    runs: dict[str, list[tuple[float, float, float, int]]] = {"in-process": [], "side by side": [], "dask": []}
    t0 = time.perf_counter()
    with (local_cluster(workers) as cluster, tempfile.TemporaryDirectory() as tmp,
          ProcessPoolExecutor(workers, mp_context=spawn) as pool):
        start = time.perf_counter() - t0
        paths = [Path(tmp) / f"bench-{k}.h5" for k in range(workers)]
        share = [count // workers] * workers

        def side_by_side() -> float:
            t0 = time.perf_counter()
            list(pool.map(_build_seconds, paths, share))
            return time.perf_counter() - t0

        _build_seconds(paths[0], 2 * atlas.CHUNK, cluster.scheduler_address)  # workers import linkedit
        _build_seconds(paths[0], atlas.CHUNK)
        side_by_side()  # the pool's processes start and import linkedit
        load = os.getloadavg()[0]
        for _ in range(repeats):
            for kind in runs:
                threads, total, every = own_threads(), ours(), machine()
                if kind == "side by side":
                    seconds = side_by_side()
                else:
                    seconds = _build_seconds(paths[0], count, cluster.scheduler_address if kind == "dask" else None)
                total = ours() - total
                every = machine() - every - total
                if kind == "in-process":
                    used = [cpu - threads.get(tid, 0.0) for tid, cpu in own_threads().items()]
                    runs[kind].append((seconds, sum(used), every, sum(cpu > 0.1 * seconds for cpu in used)))
                else:
                    runs[kind].append((seconds, total, every, workers))
        shard_scaling(echo, cluster.scheduler_address, chunks, repeats, start)
    wall, cpu, others, cores = ({k: statistics.median(r[i] for r in v) for k, v in runs.items()} for i in range(4))
    per_core = {k: count / wall[k] / cores[k] for k in runs}
    echo(f"atlas build -n {count:,} (HDF5 written) with {workers} workers (--workers; {usable_cores()} cores usable "
         f"of the machine's {os.cpu_count()}, load average {load:.2f} before), per core = linkages/s / busy threads "
         f"or processes; runs interleaved, medians of {repeats}:")
    echo(f"  in-process, {cores['in-process']:g} busy thread(s): {per_core['in-process']:,.0f} linkages/s per core "
         f"(other processes kept {others['in-process'] / wall['in-process']:.2f} of the {os.cpu_count()} cores busy)")
    echo(f"  {workers} in-process builds side by side: {per_core['side by side']:,.0f} linkages/s per core "
         f"= ×{per_core['side by side'] / per_core['in-process']:.2f} (what the machine gives {workers} "
         f"processes; others kept {others['side by side'] / wall['side by side']:.2f} cores busy)")
    echo(f"  local Dask cluster, {workers} single-threaded workers (started in {start:.1f} s, before the "
         f"timing): {per_core['dask']:,.0f} linkages/s per core = ×{per_core['dask'] / per_core['in-process']:.2f} "
         f"of in-process, ×{per_core['dask'] / per_core['side by side']:.2f} of side by side; per CPU-second of "
         f"every process of the run ×{cpu['in-process'] / cpu['dask']:.2f} of in-process (the ratio on cores of "
         f"its own)")


def _store_a_shard() -> None:
    """A chunk of ten four-bars built and stored as a shard in a temporary folder: what a task of a sharded build
    imports and sets up first."""
    from linkedit.synthesis import shards

    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / shards.folder_of("four-bar")).mkdir()
        quantizer = shards.write_quantizer(Path(tmp), "four-bar", 1, 10)
        shards.store_chunks(tmp, {"four-bar": quantizer}, "four-bar", 1, [(0, 10)])


def shard_scaling(echo: Callable[[str], None], scheduler: str, chunks: int, repeats: int,
                  start: float) -> dict[str, float]:
    """A sharded ``atlas build`` of ``chunks`` chunks of four-bars (each task stores its shard; the client writes
    only the manifest): in-process and on the pre-started Dask cluster at ``scheduler`` (started in ``start``
    seconds, apart), interleaved, medians of ``repeats``. The parallel efficiency is the Dask rate over the
    worker threads times the in-process rate: a ratio of speeds, which means what it says only on an idle
    machine. Two figures that hold on a shared one: the CPU-time efficiency, in-process CPU seconds over the
    Dask run's (the worker processes' and this process's: the client, and a local cluster's scheduler), and the
    busy fraction, the tasks' wall seconds (measured inside each, :func:`~linkedit.synthesis.cluster.task_times`)
    over the worker threads times the run's wall seconds. Returns the medians (seconds: ``wall``, ``cpu`` of
    in-process and ``dask_wall``, ``client``, ``workers``, ``tasks_cpu``, ``tasks_wall`` of Dask) and the
    ``threads``."""
    from linkedit.synthesis import shards

    count = chunks * atlas.CHUNK
    runs: dict[str, list[dict[str, float]]] = {"in-process": [], "dask": []}
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp, connected(scheduler) as (client, nthreads, _):
        client.run(_store_a_shard)  # on every worker before the timing
        for _ in range(repeats):
            for kind in runs:
                folder = Path(tmp) / kind
                before: dict[str, float] = client.run(time.process_time) if kind == "dask" else {}
                # in-process: this thread's CPU (the build runs in it; a local cluster's scheduler and the client's
                # event loop, threads of this process, are not the build's); Dask: this process's (client, scheduler)
                clock = time.process_time if kind == "dask" else time.thread_time
                with task_times() as tasks:
                    wall, cpu = time.perf_counter(), clock()
                    shards.build(folder, ["four-bar"], count, seed=1, scheduler=scheduler if kind == "dask" else None)
                    wall, cpu = time.perf_counter() - wall, clock() - cpu
                after: dict[str, float] = client.run(time.process_time) if kind == "dask" else {}
                runs[kind].append({"wall": wall, "cpu": cpu, "workers": sum(after[w] - before[w] for w in before),
                                   "tasks_cpu": sum(t.cpu for t in tasks), "tasks_wall": sum(t.wall for t in tasks)})
                shutil.rmtree(folder)
    threads = sum(nthreads.values())
    here, dask = ({k: statistics.median(r[k] for r in v) for k in v[0]} for v in runs.values())
    rate = {"in-process": count / here["wall"], "dask": count / dask["wall"]}
    efficiency = here["cpu"] / (dask["workers"] + dask["cpu"])
    busy = dask["tasks_wall"] / (threads * dask["wall"])
    echo(f"sharded atlas build -n {count:,} (workers write their shards, the client the manifest; {usable_cores()} "
         f"cores usable of the machine's {os.cpu_count()}, load average {load:.2f} before, {os.getloadavg()[0]:.2f} "
         f"after; medians of {repeats}): in-process {rate['in-process']:,.0f} linkages/s; {threads} local Dask workers (started once in {start:.1f} s, not "
         f"timed) {rate['dask']:,.0f} linkages/s: parallel efficiency "
         f"{rate['dask'] / (threads * rate['in-process']):.0%} (target ≥ 85 % at 2 workers on 2 cores; a ratio of "
         "speeds, meaningful on an idle machine)")
    echo(f"  per CPU-second: in-process {here['cpu']:.2f} s (on {here['cpu'] / here['wall']:.2f} of a core); Dask workers {dask['workers']:.2f} s (their tasks "
         f"{dask['tasks_cpu']:.2f} s) + client and scheduler {dask['cpu']:.2f} s: CPU-time efficiency "
         f"{efficiency:.0%}; busy fraction {busy:.2f} (tasks' wall {dask['tasks_wall']:.2f} s over {threads} workers "
         f"× {dask['wall']:.2f} s), the tasks ran on {dask['tasks_cpu'] / dask['tasks_wall']:.2f} of a core each "
         "(the rest waiting for cores other processes held)")
    return {"wall": here["wall"], "cpu": here["cpu"], "dask_wall": dask["wall"], "client": dask["cpu"],
            "workers": dask["workers"], "tasks_cpu": dask["tasks_cpu"], "tasks_wall": dask["tasks_wall"],
            "threads": threads}
