"""Atlases: many linkages of a family, their curves and descriptors, in one chunked HDF5 file.

An atlas is built in chunks of ``CHUNK`` linkages. A chunk is a pure function of (family,
seed, chunk index): its generator is seeded with ``[seed, family ID, index]``, it draws
parameter rows from the family's distribution until ``size`` of them turn the full cycle with
the singularity margin (the one planar predicate, :mod:`linkedit.planar.feasibility`), evaluates all of them in one array evaluation per block (over
linkages and samples), and describes each coupler curve. Chunks therefore give the same bytes
in-process or on a Dask worker, in any order, and an atlas grown by appending chunks k, k+1, …
equals one built at once. Layout: ``specs/atlas-hdf5.md``.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import h5py
import numpy as np

from linkedit import __version__
from linkedit.curves.efd import polyline_efd
from linkedit.curves.normalize import normalize
from linkedit.errors import InputError, LinkeditError
from linkedit.io.atomic import atomic_path, deferred_interrupts, locked
from linkedit.io.h5read import ResultReader, open_result
from linkedit.io.hdf5 import writing
from linkedit.planar.feasibility import works
from linkedit.resources import require_disk
from linkedit.synthesis.families import SPEC_TEXTS, family

FORMAT_VERSION = "1"
#: Linkages per chunk (the unit of work and of seeding).
CHUNK = 10_000
#: Curve samples per cycle used for the descriptors (uniform in crank angle).
SAMPLES = 64
#: Every ``COARSE_STEP``-th sample is stored: curves at SAMPLES / COARSE_STEP points.
COARSE_STEP = 2
#: Elliptic Fourier harmonics of the index descriptor.
HARMONICS = 8
#: Linkages evaluated together inside a chunk (their working arrays stay in the CPU cache).
BLOCK = 1024
#: Seconds a Dask scheduler has to answer (``--connect-timeout``).
CONNECT_TIMEOUT = 10.0


def dimension(fam: object) -> int:
    """2 for a planar family (curves (K, T) complex), 3 for a spatial one (``DIM = 3``: curves (K, T, 3))."""
    return int(getattr(fam, "DIM", 2))


def index_efd(z: np.ndarray) -> np.ndarray:
    """Normalized arc-length EFDs (K, H, 4) of closed curves: planar z (K, T) complex
    (:func:`~linkedit.curves.efd.polyline_efd`), spatial (K, T, 3) those of their projection onto their
    principal plane (:func:`~linkedit.curves.normalize.normalize`, as ``linkedit features`` describes 3D curves)."""
    if z.ndim == 3:
        p = normalize(z, True, SAMPLES).points
        z = p[..., 0] + 1j * p[..., 1]
    return polyline_efd(z, HARMONICS)


def index_vector(efd: np.ndarray) -> np.ndarray:
    """Normalized EFDs (K, H, 4) → the index descriptor (K, 4H − 3): everything but the
    first harmonic's a₁ = 1, b₁ = c₁ = 0, which normalization fixes."""
    flat = efd.reshape(len(efd), -1)
    return np.ascontiguousarray(flat[:, 3:])


@dataclass(frozen=True)
class Chunk:
    """One chunk of an atlas (K linkages)."""

    params: np.ndarray  #: (K, P) float64 family parameters
    min_ds: np.ndarray  #: (K,) smallest d_s over the cycle
    index: np.ndarray  #: (K, 4H − 3) float32 index descriptor
    curves: np.ndarray  #: (K, SAMPLES / COARSE_STEP, 2 or 3) float32 coarse curves, family frame


def build_chunk(name: str, seed: int, index: int, size: int = CHUNK, spec: str | None = None) -> Chunk:
    """Chunk ``index`` of family ``name``'s atlas from ``seed`` (a pure function); ``spec``: the
    linkage spec text of a family made from a spec (:func:`~linkedit.synthesis.families.spec_family`)."""
    fam = family(name, spec=spec)
    rng = np.random.default_rng([seed, fam.ID, index])
    margin = fam.margin()
    kept: list[np.ndarray] = []
    kept_ds: list[np.ndarray] = []
    have = 0
    while have < size:
        draw = fam.sample(rng, 2 * (size - have) + 16)
        ds = fam.min_singularity(draw, margin)
        keep = works(ds, margin)
        kept.append(draw[keep])
        kept_ds.append(ds[keep])
        have += int(keep.sum())
    params = np.concatenate(kept)[:size]
    desc = np.empty((size, 4 * HARMONICS - 3), dtype=np.float32)
    coarse = np.empty((size, SAMPLES // COARSE_STEP, dimension(fam)), dtype=np.float32)
    for start in range(0, size, BLOCK):
        z = fam.curves(params[start:start + BLOCK], SAMPLES)
        desc[start:start + BLOCK] = index_vector(index_efd(z))
        part = z[:, ::COARSE_STEP]
        coarse[start:start + BLOCK] = part if part.ndim == 3 else np.stack([part.real, part.imag], axis=2)
    return Chunk(params, np.concatenate(kept_ds)[:size], desc, coarse)


def chunk_sizes(count: int, first: int = 0) -> list[tuple[int, int]]:
    """(index, size) of the chunks holding ``count`` linkages, numbered from ``first``."""
    return [(first + k, min(CHUNK, count - k * CHUNK)) for k in range((count + CHUNK - 1) // CHUNK)]


#: Most chunks one Dask task builds. A task costs the scheduler, the client and the worker ~10 ms
#: of CPU whatever its size (a chunk of four-bars is ~70 ms of work), so consecutive chunks go
#: together, as long as every worker thread still gets 8 tasks (see :func:`dask_tasks`).
TASK_CHUNKS = 4


def build_chunks(name: str, seed: int, jobs: list[tuple[int, int]], spec: str | None = None) -> list[Chunk]:
    """Chunks ``jobs`` ((index, size) pairs) of family ``name``'s atlas: one Dask task (``spec``: as
    :func:`build_chunk`'s, so a worker can make a family from a spec)."""
    return [build_chunk(name, seed, index, size, spec) for index, size in jobs]


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


#: one task: chunks ``jobs`` of family ``name`` from ``seed`` (``spec``: as :func:`build_chunk`'s) → one result
#: per chunk (:func:`build_chunks`: the chunks; :func:`linkedit.synthesis.shards.store_chunks`: their shard entries)
Task = Callable[[str, int, list[tuple[int, int]], "str | None"], list[Any]]


class Runner(Protocol):
    """Runs ``task`` over chunks ``jobs`` of family ``name`` from ``seed``: (index, result) in order of ``jobs``."""

    def __call__(self, name: str, seed: int, jobs: list[tuple[int, int]], task: Task = ...) -> Iterator[tuple[int, Any]]:
        ...


@contextlib.contextmanager
def chunk_runner(scheduler: str | None = None, workers: int | None = None, *,
                 connect_timeout: float = CONNECT_TIMEOUT, verbose: bool = False) -> Iterator[Runner]:
    """Where chunks are built for the block: in-process, on the Dask scheduler at ``scheduler`` (checked
    by :func:`scheduler_address` and :func:`probe`: a ClusterError when it does not answer within
    ``connect_timeout`` seconds) or on a local cluster of ``workers`` processes, closed with the block.
    Dask's own log lines stay off the terminal unless ``verbose``."""
    if scheduler is None and not workers:
        def here(name: str, seed: int, jobs: list[tuple[int, int]], task: Task = build_chunks) -> Iterator[tuple[int, Any]]:
            spec = SPEC_TEXTS.get(name)
            return ((index, task(name, seed, [(index, size)], spec)[0]) for index, size in jobs)

        yield here
        return
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
                # scheduler, they cost twice the CPU); each is released once read, so the workers hold
                # only the results not yet written
                first = next(iter(nthreads), None)
                direct = cluster is not None or (first is not None and reaches(client, first))

                def run(name: str, seed: int, jobs: list[tuple[int, int]], task: Task = build_chunks
                        ) -> Iterator[tuple[int, Any]]:
                    runs = dask_tasks(jobs, sum(nthreads.values()))
                    spec = SPEC_TEXTS.get(name)
                    futures = deque(client.submit(task, name, seed, part, spec, pure=True) for part in runs)
                    for part in runs:
                        yield from zip([index for index, _ in part], client.gather(futures.popleft(), direct=direct))

                yield run
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


#: Largest seed: the generators take any integer ≥ 0, the atlas stores it as a signed 64-bit attribute.
MAX_SEED = 2**63 - 1


def check_options(seed: int, scheduler: str | None) -> None:
    """InputError for a seed out of range or a malformed scheduler address, before anything is opened."""
    if not 0 <= seed <= MAX_SEED:
        raise InputError(f"must be an integer from 0 to 2**63 - 1, got {seed}", field="--seed")
    if scheduler is not None:
        scheduler_address(scheduler)


def stored_bytes(name: str) -> int:
    """Bytes one linkage of family ``name`` takes in an atlas (uncompressed; see :func:`_family_group`)."""
    fam = family(name)
    return 8 * len(fam.PARAMETERS) + 8 + 4 * (4 * HARMONICS - 3) + 4 * dimension(fam) * (SAMPLES // COARSE_STEP)


def build(path: str | Path, names: list[str], count: int, *, seed: int = 1, scheduler: str | None = None,
          workers: int | None = None, connect_timeout: float = CONNECT_TIMEOUT, verbose: bool = False,
          progress: Callable[[int, int, float], None] | None = None) -> dict[str, int]:
    """Build (or append to) the atlas at ``path``: ``count`` more linkages of every family in ``names``.

    An existing atlas is grown with the next chunks of its own seed (``seed`` must match), under the
    target's lock (:func:`linkedit.io.atomic.locked`: a concurrent append waits, then is refused); the
    new file replaces the old one only when complete. A build whose file would not fit on the disk is
    refused (InputError) before any work. Returns the linkage count per family.
    ``progress(done, total, seconds)`` is called after every chunk; ``scheduler``, ``workers``,
    ``connect_timeout``, ``verbose``: see :func:`chunk_runner`.
    """
    path = Path(path)
    check_options(seed, scheduler)
    total = count * len(names)
    with locked(path):
        old = 0
        if path.exists():
            _check_existing(path, seed)
            old = path.stat().st_size
        require_disk(old + count * sum(map(stored_bytes, names)), path, f"{total:,} linkages", field="--count")
        with chunk_runner(scheduler, workers, connect_timeout=connect_timeout, verbose=verbose) as run:
            return _grow(path, names, count, seed, run, progress)


def _grow(path: Path, names: list[str], count: int, seed: int, run: Runner,
          progress: Callable[[int, int, float], None] | None) -> dict[str, int]:
    """:func:`build`'s work: a copy of the atlas at ``path`` (or a new one) grown by ``count`` linkages of
    every family of ``names``, renamed onto ``path``."""
    total = count * len(names)
    done, start = 0, time.perf_counter()
    with atomic_path(path) as tmp:
        if path.exists():
            shutil.copyfile(path, tmp)
            mode = "r+"
        else:
            mode = "w"
        with writing(tmp, mode) as f:
            if mode == "w":
                f.attrs.update({"format_version": FORMAT_VERSION, "kind": "atlas", "generator": f"linkedit {__version__}",
                                "seed": seed, "samples": SAMPLES, "coarse_samples": SAMPLES // COARSE_STEP,
                                "harmonics": HARMONICS, "chunk": CHUNK})
            for name in names:
                with deferred_interrupts():
                    group = _family_group(f, name)
                first = int(group.attrs["chunks"])
                jobs = chunk_sizes(count, first)
                for index, chunk in run(name, seed, jobs):
                    with deferred_interrupts():  # HDF5 is not cut short: a signal is raised after the chunk
                        _append(group, chunk)
                        group.attrs["chunks"] = index + 1
                    f.check()  # a full disk stops the build here, not after every chunk
                    done += len(chunk.params)
                    if progress is not None:
                        progress(done, total, time.perf_counter() - start)
                if len(jobs) and jobs[-1][1] < CHUNK:
                    group.attrs["partial_chunk"] = True  # later appends still start at the next index
            counts = {name: int(f[f"families/{name}/params"].shape[0]) for name in f["families"]}
    return counts


def _check_existing(path: Path, seed: int) -> None:
    """An atlas to append to: of this layout, built with ``seed``, every family's arrays whole."""
    try:
        with open_result(path) as f:
            if f.attr("kind", default=None) != "atlas":
                raise InputError("exists and is not a linkedit atlas (refusing to overwrite it)", file=str(path))
            built = _layout(f, growing=True)
    except InputError as exc:
        if "not a linkedit result" in str(exc) or "cannot open as HDF5" in str(exc):
            raise InputError("exists and is not a linkedit atlas (refusing to overwrite it)", file=str(path)) from None
        raise
    if built != seed:
        raise InputError(f"this atlas was built with --seed {built}; append with the same seed (or write a new file)",
                         file=str(path), field="--seed")


def _layout(f: ResultReader, growing: bool = False) -> int:
    """Check an open atlas against this version's layout before anything is read or appended (the
    root attributes, each family's known name, its arrays' shapes, number types and lengths, its
    ``chunks``; ``growing``: its arrays can be extended); returns its seed. InputError naming the file
    and the member otherwise."""
    if (f.attr("chunk", kind=int) != CHUNK or f.attr("samples", kind=int) != SAMPLES
            or f.attr("harmonics", kind=int) != HARMONICS):
        raise f.error("/", "an atlas of another layout version (chunk, samples or harmonics differ); rebuild it")
    seed = f.attr("seed", kind=int)
    if not 0 <= seed < 2**63:
        raise f.error("/", f"attribute 'seed': {seed} is not a seed")
    for name in f.names("families"):
        g = f"families/{name}"
        fam = family(name, field=f"{f.path}: families/{name}", spec=f.attr("spec", g, default=None))
        rows = f.dataset(f"{g}/params").shape[0] if f.dataset(f"{g}/params").ndim == 2 else -1
        shapes = {"params": (rows, len(fam.PARAMETERS)), "min_ds": (rows,), "index": (rows, 4 * HARMONICS - 3),
                  "curves": (rows, SAMPLES // COARSE_STEP, dimension(fam))}
        for key, shape in shapes.items():
            ds = f.dataset(f"{g}/{key}")
            size = 8 if key in ("params", "min_ds") else 4  # float64, float32 (_family_group)
            if ds.shape != shape or ds.dtype.kind != "f" or ds.dtype.itemsize != size:
                raise f.error(f"{g}/{key}", f"expected {shape} float{8 * size}, found {ds.shape} {ds.dtype}")
            if growing and (ds.chunks is None or ds.maxshape[0] is not None):
                raise f.error(f"{g}/{key}", "is stored at a fixed size (rewritten by another tool?) and cannot grow; "
                              "append to a new atlas")
        chunks = f.attr("chunks", g, kind=int)
        if not 0 <= rows <= chunks * CHUNK:
            raise f.error(g, f"attribute 'chunks': {chunks} chunks cannot hold {rows} linkages")
    return seed


def _family_group(f: h5py.File, name: str) -> h5py.Group:
    fam = family(name)
    key = f"families/{name}"
    if key in f:
        return f[key]
    g = f.create_group(key)
    width = 4 * HARMONICS - 3
    g.create_dataset("params", shape=(0, len(fam.PARAMETERS)), maxshape=(None, len(fam.PARAMETERS)),
                     dtype="f8", chunks=(CHUNK, len(fam.PARAMETERS)))
    g.create_dataset("min_ds", shape=(0,), maxshape=(None,), dtype="f8", chunks=(CHUNK,))
    g.create_dataset("index", shape=(0, width), maxshape=(None, width), dtype="f4", chunks=(CHUNK, width))
    dim = dimension(fam)
    g.create_dataset("curves", shape=(0, SAMPLES // COARSE_STEP, dim), maxshape=(None, SAMPLES // COARSE_STEP, dim),
                     dtype="f4", chunks=(min(CHUNK, 2048), SAMPLES // COARSE_STEP, dim))
    g["params"].attrs["columns"] = json.dumps(list(fam.PARAMETERS))
    g["min_ds"].attrs["description"] = "smallest d_s = sin² of the transmission angle over the cycle"
    g["index"].attrs["description"] = "normalized elliptic Fourier descriptors (arc length) minus a1, b1, c1"
    g["curves"].attrs["description"] = "tracked point over one crank cycle, family frame (ground length 1; "\
                                       "spatial families: their own, see the family)"
    g.attrs.update({"family_id": fam.ID, "margin": fam.margin(), "chunks": 0,
                    "distribution": (fam.sample.__doc__ or "").strip()})
    if name in SPEC_TEXTS:  # a family made from a spec: its text, to make it again by name
        g.attrs["spec"] = SPEC_TEXTS[name]
    return g


def _append(group: h5py.Group, chunk: Chunk) -> None:
    for key in ("params", "min_ds", "index", "curves"):
        data = getattr(chunk, key)
        ds = group[key]
        n = ds.shape[0]
        ds.resize(n + len(data), axis=0)
        ds[n:] = data


@dataclass
class Atlas:
    """An atlas read into memory for queries: per family, its arrays."""

    path: Path
    families: dict[str, dict[str, np.ndarray]]
    seed: int

    @property
    def size(self) -> int:
        return sum(len(v["params"]) for v in self.families.values())


def load(path: str | Path) -> Atlas:
    """Read an atlas file (or every ``*.h5`` atlas in a folder, merged by family)."""
    path = Path(path)
    files = sorted(path.glob("*.h5")) if path.is_dir() else [path]
    if not files:
        raise InputError("no .h5 atlas in this folder (build one with `linkedit atlas build`)", file=str(path))
    families: dict[str, dict[str, list[np.ndarray]]] = {}
    seed = 0
    for file in files:
        if not file.is_file():
            raise InputError("no such file", file=str(file))
        with open_result(file, kind="atlas") as f:
            if not f.has("families"):
                raise InputError("not a linkedit atlas (build one with `linkedit atlas build`)", file=str(file))
            seed = _layout(f)
            for name in f.names("families"):
                bucket = families.setdefault(name, {k: [] for k in ("params", "min_ds", "index", "curves")})
                for key in bucket:
                    bucket[key].append(f.array(f"families/{name}/{key}", kinds="f"))
    merged = {name: {k: np.concatenate(v) for k, v in parts.items()} for name, parts in families.items()}
    if not any(len(v["params"]) for v in merged.values()):
        raise InputError("the atlas is empty", file=str(path))
    return Atlas(path, merged, seed)
