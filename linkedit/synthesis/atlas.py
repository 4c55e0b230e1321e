"""Atlases: many linkages of a family, their curves and descriptors, in one chunked HDF5 file.

An atlas is built in chunks of ``CHUNK`` linkages (:mod:`linkedit.synthesis.chunks`: a chunk is a pure
function of (family, seed, chunk index)), in-process or on Dask (:mod:`linkedit.synthesis.cluster`), and
appended here in chunk order: an atlas grown by appending chunks k, k+1, … equals one built at once.
Layout: ``specs/atlas-hdf5.md``.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from linkedit import __version__
from linkedit.errors import InputError
from linkedit.io.atomic import atomic_path, deferred_interrupts, locked
from linkedit.io.h5read import ResultReader, open_result
from linkedit.io.hdf5 import writing
from linkedit.resources import require_disk, require_memory
from linkedit.synthesis.chunks import (CHUNK, COARSE_STEP, HARMONICS, SAMPLES, Chunk, build_memory, chunk_sizes, reporting,
                                      dimension)
from linkedit.synthesis.chunks import build_chunk as build_chunk  # re-exported: callers build chunks through atlas
from linkedit.synthesis.cluster import CONNECT_TIMEOUT, Runner, chunk_runner, scheduler_address
from linkedit.synthesis.families import SPEC_TEXTS, family

FORMAT_VERSION = "1"


#: Largest seed: the generators take any integer ≥ 0, the atlas stores it as a signed 64-bit attribute.
MAX_SEED = 2**63 - 1


def check_options(seed: int, scheduler: str | None, workers: int | None = None) -> None:
    """InputError for a seed out of range, a malformed scheduler address or a scheduler and a local cluster's
    ``workers`` both, before anything is opened."""
    if not 0 <= seed <= MAX_SEED:
        raise InputError(f"must be an integer from 0 to 2**63 - 1, got {seed}", field="--seed")
    if scheduler is not None and workers is not None:
        raise InputError("a local cluster or --scheduler's, not both", field="--workers")
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
    new file replaces the old one only when complete. A build whose file would not fit on the disk (or
    whose working memory, :func:`~linkedit.synthesis.chunks.build_memory`, not in memory) is refused
    (InputError) before any work. Returns the linkage count per family.
    ``progress(done, total, seconds)`` is called after every chunk, and in-process as a chunk's draws are
    screened (:func:`~linkedit.synthesis.chunks.reporting`); ``scheduler``, ``workers``,
    ``connect_timeout``, ``verbose``: see :func:`linkedit.synthesis.cluster.chunk_runner`.
    """
    path = Path(path)
    check_options(seed, scheduler, workers)
    total = count * len(names)
    with locked(path):
        old = 0
        if path.exists():
            _check_existing(path, seed)
            old = path.stat().st_size
        require_disk(old + count * sum(map(stored_bytes, names)), path, f"{total:,} linkages", field="--count")
        require_memory(build_memory(total), f"{total:,} linkages", field="--count")
        with chunk_runner(scheduler, workers, connect_timeout=connect_timeout, verbose=verbose) as run:
            return _grow(path, names, count, seed, run, progress)


def _grow(path: Path, names: list[str], count: int, seed: int, run: Runner,
          progress: Callable[[int, int, float], None] | None) -> dict[str, int]:
    """:func:`build`'s work: a copy of the atlas at ``path`` (or a new one) grown by ``count`` linkages of
    every family of ``names``, renamed onto ``path``."""
    total = count * len(names)
    done, start = 0, time.perf_counter()

    def within(kept: int) -> None:  # a chunk's draws screened in-process: ``kept`` of its linkages so far
        if progress is not None:
            progress(done + kept, total, time.perf_counter() - start)

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
                with reporting(within):
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
