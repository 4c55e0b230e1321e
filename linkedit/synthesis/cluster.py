"""The Dask runner: where an atlas's chunks are built (in-process, on a scheduler's workers, or on a
local cluster), and the checks of a scheduler address before anything is sent there.

A task runs a pure function of (family, seed, chunks) (:func:`linkedit.synthesis.chunks.build_chunks`,
or :func:`linkedit.synthesis.shards.store_chunks`, which also stores each chunk as a shard), so the
results are the same wherever it runs; the client reads them back in chunk order, with each task's wall and
CPU seconds on its worker (:func:`task_times`). An interrupted build stops its tasks before the command returns
(:func:`_stop_tasks`): nothing of it is written after that.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import signal
import sys
import threading
import time
import uuid
from collections import Counter, deque
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple, Protocol

from linkedit.errors import InputError, LinkeditError
from linkedit.io.atomic import Interrupted
from linkedit.synthesis.chunks import build_chunks, report_kept, reporting
from linkedit.synthesis.families import SPEC_TEXTS

#: Seconds a Dask scheduler has to answer (``--connect-timeout``).
CONNECT_TIMEOUT = 10.0

#: Most chunks one Dask task builds. A task costs the scheduler, the client and the worker ~10 ms
#: of CPU whatever its size (a chunk of four-bars is ~70 ms of work), so consecutive chunks go
#: together, as long as every worker thread still gets 8 tasks (see :func:`dask_tasks`).
TASK_CHUNKS = 4


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity mask where the system has one (a container's or
    ``taskset``'s share), else the machine's count."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def dask_tasks(jobs: list[tuple[int, int]], threads: int) -> list[list[tuple[int, int]]]:
    """``jobs`` cut into runs of consecutive chunks, one per Dask task: at most :data:`TASK_CHUNKS`
    each, and at least 8 runs per worker thread while that allows more than one chunk per run (a
    worker that finishes first idles for about one task at the end)."""
    per_task = max(1, min(TASK_CHUNKS, len(jobs) // (8 * max(threads, 1))))
    return [jobs[k:k + per_task] for k in range(0, len(jobs), per_task)]


def run_chunks(name: str, seed: int, jobs: list[tuple[int, int]], *, scheduler: str | None = None,
               workers: int | None = None, connect_timeout: float = CONNECT_TIMEOUT,
               verbose: bool = False) -> Iterator[tuple[int, Any]]:
    """Chunks in order of ``jobs``: in-process, or on Dask (see :func:`chunk_runner`); results are the
    same either way."""
    with chunk_runner(scheduler, workers, connect_timeout=connect_timeout, verbose=verbose) as run:
        yield from run(name, seed, jobs)


#: one task: chunks ``jobs`` of family ``name`` from ``seed`` (``spec``: as :func:`~linkedit.synthesis.chunks.build_chunk`'s) → one result
#: per chunk (:func:`~linkedit.synthesis.chunks.build_chunks`: the chunks; :func:`linkedit.synthesis.shards.store_chunks`: their shard entries)
Task = Callable[[str, int, list[tuple[int, int]], "str | None"], list[Any]]


class Runner(Protocol):
    """Runs ``task`` over chunks ``jobs`` of family ``name`` from ``seed``: (index, result) in order of ``jobs``."""

    def __call__(self, name: str, seed: int, jobs: list[tuple[int, int]], task: Task = ...) -> Iterator[tuple[int, Any]]:
        ...


#: Tasks per worker thread submitted ahead of the one read next: the workers always have work queued,
#: and hold at most this many results per thread that the client has not read (a build streams: the
#: chunks of a 100-million atlas never sit in memory together, on the client or on the workers).
IN_FLIGHT = 3

#: Seconds between a Dask build's progress reports: a task publishes the linkages it has screened at most this
#: often (:class:`_Published`, on the Dask topic :data:`PROGRESS`), and the client, waiting for a task, reports
#: what it heard as often (a slow family's chunk takes minutes; a task is up to :data:`TASK_CHUNKS` of them).
REPORT_EVERY = 0.5
PROGRESS = "linkedit-progress"


@contextlib.contextmanager
def chunk_runner(scheduler: str | None = None, workers: int | None = None, *,
                 connect_timeout: float = CONNECT_TIMEOUT, verbose: bool = False) -> Iterator[Runner]:
    """Where chunks are built for the block: in-process, or on Dask (:func:`connected`): a build
    streams, :data:`IN_FLIGHT` tasks per worker thread submitted ahead of the one read; while it waits for a
    task, the linkages the tasks in flight have screened go to this thread's
    :func:`~linkedit.synthesis.chunks.reporting` callback every :data:`REPORT_EVERY` seconds, as an in-process
    build's chunk reports them. When the block ends with tasks still out (an interrupt, an error), they are
    cancelled and those running stopped before it returns (:func:`_stop_tasks`)."""
    if scheduler is None and not workers:
        heap_malloc()

        def here(name: str, seed: int, jobs: list[tuple[int, int]], task: Task = build_chunks) -> Iterator[tuple[int, Any]]:
            spec = SPEC_TEXTS.get(name)
            return ((index, task(name, seed, [(index, size)], spec)[0]) for index, size in jobs)

        yield here
        return
    with connected(scheduler, workers, connect_timeout=connect_timeout, verbose=verbose) as (client, nthreads, direct):
        heard: dict[str, int] = {}  # task key → linkages it has screened, as its worker published them
        build = uuid.uuid4().hex  # this block's tasks, to the workers: what an interrupt stops (:func:`_stop`)
        futures: deque[Any] = deque()  # the tasks submitted and not read yet, in order

        def hear(event: tuple[float, list[Any]]) -> None:
            key, kept = event[1]
            heard[key] = kept

        def run(name: str, seed: int, jobs: list[tuple[int, int]], task: Task = build_chunks
                ) -> Iterator[tuple[int, Any]]:
            threads = sum(nthreads.values())
            runs = dask_tasks(jobs, threads)
            spec = SPEC_TEXTS.get(name)
            ahead = IN_FLIGHT * max(threads, 1)
            later = iter(runs)
            for part in runs:
                for ahead_part in itertools.islice(later, ahead - len(futures)):
                    futures.append(client.submit(_timed, task, build, name, seed, ahead_part, spec, REPORT_EVERY,
                                                 pure=True))
                _await(futures, heard, part[0][1])
                results, took = client.gather(futures[0], direct=direct)
                heard.pop(futures.popleft().key, None)
                for record in _RECORDS:
                    record.append(took)
                yield from zip([index for index, _ in part], results)

        client.subscribe_topic(PROGRESS, hear)
        try:
            yield run
        except KeyboardInterrupt as exc:
            why = _stop_tasks(client, futures, build)
            if why is not None:
                raise Interrupted(getattr(exc, "signum", signal.SIGINT), why) from None
            raise
        finally:
            if futures:  # another error, or a caller that read no further
                _stop_tasks(client, futures, build)
            client.unsubscribe_topic(PROGRESS)


def _await(futures: deque[Any], heard: dict[str, int], first: int) -> None:
    """Wait for the first of the Dask ``futures`` in flight, reporting every :data:`REPORT_EVERY` seconds the
    linkages they have screened (``heard``: task key → count, as their workers published them), at most ``first``:
    the size of the first one's first chunk, the count its reader reports next, so that the count never goes back."""
    from distributed import wait

    while True:
        try:
            wait(futures[0], timeout=REPORT_EVERY)
            return
        except TimeoutError:
            report_kept(min(first, sum(heard.get(future.key, 0) for future in futures)))


#: Most seconds an interrupted Dask build waits for the tasks its workers are running to stop (:func:`_stop_tasks`).
STOP_WAIT = 10.0


def _stop_tasks(client: Any, futures: deque[Any], build: str) -> str | None:
    """Cancel the tasks ``futures`` of ``build`` (not started: never run) and stop those its workers are running
    (:func:`_stop`: each ends at its next progress report or before its next shard, writing nothing more), waiting
    until none runs, at most :data:`STOP_WAIT` seconds; None once none runs, else why not (for the user's message)."""
    wait = STOP_WAIT
    deadline = time.monotonic() + wait
    try:
        out = list(futures)
        futures.clear()
        client.cancel(out)
        while True:  # Client.run has no timeout of its own: its coroutine, bounded by the deadline
            running = sum(client.sync(client._run, _stop, build,
                                      callback_timeout=max(deadline - time.monotonic(), 0.1)).values())
            if not running:
                return None
            if time.monotonic() >= deadline:
                return f"{running} Dask task(s) had not stopped {wait:g} s later and may still write their shards"
            time.sleep(0.05)
    except Exception as exc:  # the scheduler or a worker gone, or no answer before the deadline
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return f"its Dask tasks could not be stopped ({reason}) and may still write their shards"


#: In a worker process: the builds whose tasks must stop (:func:`_stop`), and how many tasks of each run there.
_STOPPED: set[str] = set()
_RUNNING: Counter[str] = Counter()
_LOCK = threading.Lock()


def _stop(build: str) -> int:
    """On a worker (``Client.run``): stop the tasks of ``build`` (each raises :class:`Stopped` at its next check,
    one not started yet at its first); how many still run in this process."""
    with _LOCK:
        _STOPPED.add(build)
        return _RUNNING[build]


@contextlib.contextmanager
def _counted(build: str) -> Iterator[None]:
    """A task of ``build`` running in this worker process inside the block (what :func:`_stop` counts)."""
    with _LOCK:
        _RUNNING[build] += 1
    try:
        yield
    finally:
        with _LOCK:
            _RUNNING[build] -= 1
            if not _RUNNING[build]:
                del _RUNNING[build]


class Stopped(Exception):
    """A Dask task of an interrupted build, stopped on its worker (:func:`_stop`); nobody reads its result."""


class TaskTime(NamedTuple):
    """One Dask task's seconds, measured inside it on its worker: wall and CPU of the thread that ran it."""

    wall: float
    cpu: float


def _timed(task: Task, build: str, name: str, seed: int, jobs: list[tuple[int, int]], spec: str | None, every: float
           ) -> tuple[list[Any], TaskTime]:
    """``task``'s results, chunk by chunk, with its :class:`TaskTime` (the chunks' build and, for a shard, its
    write); the linkages it has screened are published every ``every`` seconds at most (:class:`_Published`), and
    it stops (:class:`Stopped`) there and before each chunk once ``build`` is stopped (:func:`_stop`)."""
    wall, cpu = time.perf_counter(), time.thread_time()
    published = _Published(every, build)
    results: list[Any] = []
    with _counted(build), reporting(published):
        for job in jobs:
            published(0)
            results += task(name, seed, [job], spec)
            published.done += job[1]
    return results, TaskTime(time.perf_counter() - wall, time.thread_time() - cpu)


class _Published:
    """A Dask task's progress on its worker: the linkages of its chunks built (``done``) and those the chunk
    being built has kept (:func:`~linkedit.synthesis.chunks.reporting`), logged as (task key, count) on the
    topic :data:`PROGRESS` at most every ``every`` seconds, for the client (:func:`chunk_runner`); every call
    raises :class:`Stopped` once the task's ``build`` is stopped (:func:`_stop`)."""

    def __init__(self, every: float, build: str) -> None:
        from distributed import get_worker

        self.worker = get_worker()
        self.key = self.worker.get_current_task()
        self.every, self.done, self.last, self.build = every, 0, time.monotonic(), build

    def __call__(self, kept: int) -> None:
        if self.build in _STOPPED:
            raise Stopped(self.build)
        now = time.monotonic()
        if now - self.last >= self.every:
            self.worker.log_event(PROGRESS, [self.key, self.done + kept])
            self.last = now


#: the lists :func:`task_times` is filling
_RECORDS: list[list[TaskTime]] = []


@contextlib.contextmanager
def task_times() -> Iterator[list[TaskTime]]:
    """A list that gets the :class:`TaskTime` of every Dask task whose result this process reads inside the
    block (builds in-process add nothing): what the bench's CPU-time efficiency and busy fraction are made of."""
    record: list[TaskTime] = []
    _RECORDS.append(record)
    try:
        yield record
    finally:
        _RECORDS[:] = [other for other in _RECORDS if other is not record]


@contextlib.contextmanager
def connected(scheduler: str | None = None, workers: int | None = None, *, connect_timeout: float = CONNECT_TIMEOUT,
              verbose: bool = False) -> Iterator[tuple[Any, dict[str, int], bool]]:
    """A Dask client for the block: of the scheduler at ``scheduler`` (checked by :func:`scheduler_address`
    and :func:`probe`: a ClusterError when it does not answer within ``connect_timeout`` seconds) or of a
    local cluster of ``workers`` processes, closed with the block; with its threads per worker and whether
    results can come straight from the workers. Dask's own log lines stay off the terminal unless ``verbose``."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError("the Dask path needs dask.distributed: pip install 'linkedit[cluster]'",
                         field="--scheduler" if scheduler is not None else "--workers") from None
    with dask_logs(verbose):
        address = None
        if scheduler is not None:
            address = scheduler_address(scheduler)
            probe(address, connect_timeout)
        cluster = None if address is not None else local_cluster(workers or 1, verbose=verbose)
        try:
            with Client(address or cluster, timeout=connect_timeout) as client:
                nthreads = _workers_of(client, connect_timeout)
                # results come straight from the workers when one of them can be reached (relayed by the
                # scheduler, they cost twice the CPU); each is released once read
                first = next(iter(nthreads), None)
                yield client, nthreads, cluster is not None or (first is not None and reaches(client, first))
        finally:
            if cluster is not None:
                cluster.close()


class ClusterError(LinkeditError):
    """The Dask scheduler cannot be reached, does not answer, or has no workers (exit 1)."""


#: Address schemes ``--scheduler`` takes (``inproc://`` lives inside one process; ``ucx://`` needs UCX).
SCHEMES = ("tcp", "tls")


def scheduler_address(text: str) -> str:
    """``text`` as a Dask scheduler address ``tcp://HOST:PORT`` (``HOST:PORT`` means tcp); InputError
    (exit 2) for anything else, and for ``tls://`` without Dask's TLS settings."""
    scheme, sep, rest = text.strip().partition("://")
    if not sep:
        scheme, rest = "tcp", text.strip()
    host, colon, port = rest.rpartition(":")
    if scheme not in SCHEMES:
        raise InputError(f"{text!r}: {scheme}:// is not a scheduler address linkedit can reach "
                         "(tcp://HOST:PORT or tls://HOST:PORT)", field="--scheduler")
    if not colon or not host.strip("[]") or not port.isdigit() or not 0 < int(port) < 65536 or \
            any(c.isspace() or c in "/?#@" for c in host):
        raise InputError(f"{text!r}: expected tcp://HOST:PORT (a port 1..65535), e.g. tcp://10.0.0.5:8786",
                         field="--scheduler")
    if scheme == "tls":
        from distributed.security import Security

        if Security().get_connection_args("client").get("ssl_context") is None:
            raise InputError(f"{text!r}: tls:// needs Dask's TLS settings (distributed.comm.tls.ca-file, "
                             "distributed.comm.tls.client.cert and .key in the Dask config or environment)",
                             field="--scheduler")
    return f"{scheme}://{host}:{int(port)}"


def probe(address: str, timeout: float) -> None:
    """ClusterError unless a Dask scheduler answers at ``address`` within ``timeout`` seconds in all
    (Dask's own connect waits forever for a server that accepts and never answers)."""
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.core import send_recv
    from distributed.security import Security

    async def ask() -> object:
        comm = await connect(address, timeout=timeout, **Security().get_connection_args("client"))
        try:
            return await send_recv(comm, op="identity")
        finally:
            comm.abort()

    outcome: dict[str, object] = {}

    def run() -> None:  # a thread of its own: the caller may run an event loop (a notebook)
        try:
            outcome["reply"] = asyncio.run(asyncio.wait_for(ask(), timeout))
        except BaseException as exc:  # noqa: BLE001 - whatever answered there, reported below
            outcome["error"] = exc

    thread = threading.Thread(target=run, name="linkedit-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + 5.0)
    error, reply = outcome.get("error"), outcome.get("reply")
    if "reply" not in outcome and (error is None or isinstance(error, (asyncio.TimeoutError, TimeoutError))):
        raise ClusterError(f"--scheduler {address}: no answer within {timeout:g} s (--connect-timeout)")
    if isinstance(error, OSError):  # refused, unreachable, a TLS handshake that failed
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ClusterError(f"--scheduler {address}: cannot connect ({reason})")
    # else an answer in another protocol (its first bytes read as a frame length of exabytes), or a worker
    if error is not None or not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        what = reply.get("type") if isinstance(reply, dict) else None
        raise ClusterError(f"--scheduler {address}: {f'a Dask {what}' if what else 'what answers'} is not a Dask "
                           "scheduler")


def _workers_of(client, timeout: float) -> dict[str, int]:
    """Threads per worker of ``client``'s cluster, once there is one (ClusterError after ``timeout`` s)."""
    nthreads = client.nthreads()
    if not nthreads:
        try:
            client.wait_for_workers(1, timeout=timeout)
        except Exception:  # a timeout (or the scheduler going away meanwhile)
            raise ClusterError(f"--scheduler {client.scheduler.address}: no worker joined within {timeout:g} s "
                               "(start workers with `dask worker ADDRESS`)") from None
        nthreads = client.nthreads()
    return nthreads


#: loggers whose lines Dask, tornado and asyncio print while a cluster starts, works and stops
DASK_LOGGERS = ("distributed", "tornado", "asyncio")


@contextlib.contextmanager
def dask_logs(verbose: bool) -> Iterator[None]:
    """Dask's log lines (worker warnings, "Task exception was never retrieved" at an interrupt) off the
    terminal inside the block unless ``verbose``: linkedit reports what went wrong in one line."""
    if verbose:
        yield
        return
    loggers = [logging.getLogger(name) for name in DASK_LOGGERS]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def reaches(client, address: str, timeout: float = 2.0) -> bool:
    """Whether ``client`` connects to the Dask server at ``address`` within ``timeout`` seconds
    (workers behind a gateway are reachable only through their scheduler)."""
    from distributed.comm import connect

    async def probe() -> None:
        comm = await connect(address, timeout=timeout, **client.connection_args)
        await comm.close()

    try:
        client.sync(probe)
    except Exception:  # refused, timed out, or something else answering there: relay through the scheduler
        return False
    return True


#: glibc malloc settings for Dask workers. Dask's nannies set MALLOC_TRIM_THRESHOLD_=65536,
#: which also switches off glibc's adaptive mmap threshold: every temporary array above 128 KiB
#: is then mmapped and page-faulted afresh, and a chunk builds ~2.5× slower than in-process.
#: Fixed thresholds of 1 GiB keep the temporaries in the heap. Start remote workers with them too
#: (``MALLOC_TRIM_THRESHOLD_=1073741824 MALLOC_MMAP_THRESHOLD_=1073741824 dask worker …``).
WORKER_MALLOC = {"MALLOC_TRIM_THRESHOLD_": 1 << 30, "MALLOC_MMAP_THRESHOLD_": 1 << 30}
#: mallopt(3) parameter numbers of :data:`WORKER_MALLOC`'s settings (glibc's malloc.h)
MALLOPT = {"MALLOC_TRIM_THRESHOLD_": -1, "MALLOC_MMAP_THRESHOLD_": -3}


def heap_malloc() -> bool:
    """:data:`WORKER_MALLOC` set in this process (mallopt) for an in-process build, whose speed otherwise
    depends on what the process allocated before (glibc's adaptive thresholds); whether it was set
    (glibc on Linux only; elsewhere nothing changes). Chunks are the same bytes either way."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except AttributeError:  # another C library (musl has no mallopt)
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return all(mallopt(MALLOPT[k], v) == 1 for k, v in WORKER_MALLOC.items())
#: Dask settings of the local cluster: no statistical profile of the workers (a stack sample every
#: 10 ms) and the event-loop latency check every second instead of every 20 ms in every server.
#: Both feed a dashboard nobody watches here; they cost an idle 2-worker cluster ~90 ms of CPU per second
#: (40 without them), taken from the cores the chunks are built on. Remote workers: the environment
#: ``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL=1s``.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s"}


def local_cluster(workers: int, verbose: bool = True):
    """A local Dask cluster of ``workers`` single-threaded processes, with :data:`WORKER_MALLOC`
    in their environment and :data:`LOCAL_CLUSTER_CONFIG`; its processes print nothing unless ``verbose``.
    The workers are child processes that end with this one (Dask's nannies watch their parent)."""
    import dask
    from dask.distributed import LocalCluster

    environ = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_MALLOC.items()}
    with dask.config.set({**environ, **LOCAL_CLUSTER_CONFIG}), contextlib.nullcontext() if verbose else _no_stderr():
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0")


@contextlib.contextmanager
def _no_stderr() -> Iterator[None]:
    """File descriptor 2 on /dev/null inside the block: processes started there (Dask's workers and
    multiprocessing's resource tracker) print nothing on the terminal, whenever they stop."""
    sys.stderr.flush()
    saved = os.dup(2)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)

