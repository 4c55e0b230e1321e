"""Sharded atlases: a folder of HDF5 shards, one per chunk, and a manifest listing the complete ones.

The task that builds a chunk also stores it (:func:`store_chunks`, in-process or on a Dask worker):
its parameters, smallest d_s, index descriptors and each row's cell of the family's quantizer
(:func:`linkedit.synthesis.index.assign`; the quantizer is trained once, by the client, when the family's first
build starts: :func:`write_quantizer`), written atomically. The client collects only each shard's
entry (chunk, rows, checksum) into ``manifest.json``, rewritten atomically every few seconds and
whenever the build stops, so an interrupted build leaves complete shards and a manifest of only
those, and ``--resume`` builds the chunks it still lists as pending. Curves are not stored: they are
the family's closed form of the parameters, recomputed on demand. Layout: ``specs/atlas-hdf5.md``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import numpy as np

from linkedit import __version__
from linkedit.errors import InputError
from linkedit.io.atomic import deferred_interrupts, durable_path, lock_path, locked
from linkedit.io.h5read import open_result
from linkedit.io.hdf5 import writing
from linkedit.resources import require_disk, require_memory
from linkedit.synthesis.atlas import Atlas, check_options
from linkedit.synthesis.atlas import load as load_file
from linkedit.synthesis.chunks import (CHUNK, HARMONICS, Chunk, build_chunk, build_memory, chunk_sizes,
                                      report_kept, reporting)
from linkedit.synthesis.cluster import CONNECT_TIMEOUT, Runner, chunk_runner
from linkedit.synthesis.families import SPEC_TEXTS, family
from linkedit.synthesis.index import SAMPLE_PER_CELL, assign, quantizer_side, train_quantizer
from linkedit.synthesis.manifest import (FORMAT_VERSION, MANIFEST, folder_of, new_family, new_manifest, read_manifest,
                                         save, shard_file)

#: The chunk index of a family's quantizer training sample (beyond any chunk a build plans).
TRAIN_CHUNK = 2**62
#: Seconds between rewrites of the manifest while a build runs (and at its end, however it ends).
SAVE_EVERY = 2.0
WIDTH = 4 * HARMONICS - 3


def is_sharded(path: str | Path) -> bool:
    """Whether ``path`` names a sharded atlas (an existing folder with a manifest, or no ``.h5`` suffix)."""
    path = Path(path)
    return (path / MANIFEST).is_file() or path.suffix.lower() not in (".h5", ".hdf5")


def checksum(params: np.ndarray, min_ds: np.ndarray, index: np.ndarray, cell: np.ndarray) -> str:
    """SHA-256 of a shard's content: its params (float64), min_ds and index (float32) and cell (uint16) bytes,
    little-endian."""
    h = hashlib.sha256()
    for data, kind in ((params, "<f8"), (min_ds, "<f4"), (index, "<f4"), (cell, "<u2")):
        h.update(np.ascontiguousarray(data, dtype=kind).data)
    return h.hexdigest()


def write_shard(folder: Path, name: str, seed: int, index: int, chunk: Chunk,
                quantizer: tuple[np.ndarray, np.ndarray]) -> dict[str, Any]:
    """Store chunk ``index`` of family ``name`` as its shard, each row's cell in ``quantizer`` (top, leaves)
    with it (atomically: a ``.part`` file renamed when whole); return its manifest entry."""
    min_ds = chunk.min_ds.astype(np.float32)
    cell = assign(chunk.index, *quantizer).astype(np.uint16)
    file = shard_file(name, index)
    with durable_path(folder / file) as tmp, writing(tmp) as f:
        f.attrs.update({"format_version": FORMAT_VERSION, "kind": "atlas-shard", "generator": f"linkedit {__version__}",
                        "family": name, "chunk": index, "rows": len(chunk.params), "seed": seed})
        f.create_dataset("params", data=chunk.params)
        f.create_dataset("min_ds", data=min_ds)
        f.create_dataset("index", data=chunk.index)
        f.create_dataset("cell", data=cell)
    return {"chunk": index, "rows": len(chunk.params), "file": file,
            "sha256": checksum(chunk.params, min_ds, chunk.index, cell)}


def write_quantizer(folder: Path, name: str, seed: int, count: int) -> dict[str, Any]:
    """Train family ``name``'s quantizer for a first build of ``count`` linkages (:func:`quantizer_side`) on a
    sample of :data:`SAMPLE_PER_CELL` rows per cell, chunk :data:`TRAIN_CHUNK` (a pure function of ``seed``), and
    store it as ``<folder>/quantizer.h5``; return its manifest entry."""
    side = quantizer_side(count)
    sample = build_chunk(name, seed, TRAIN_CHUNK, SAMPLE_PER_CELL * side * side, SPEC_TEXTS.get(name)).index
    top, leaves = train_quantizer(sample, side, seed)
    file = f"{folder_of(name)}/quantizer.h5"
    with durable_path(folder / file) as tmp, writing(tmp) as f:
        f.attrs.update({"format_version": FORMAT_VERSION, "kind": "atlas-quantizer", "generator": f"linkedit {__version__}",
                        "family": name, "seed": seed, "sample": len(sample)})
        f.create_dataset("top", data=top)
        f.create_dataset("centroids", data=leaves)
    return {"file": file, "cells": len(leaves), "sha256": _quantizer_sum(top, leaves)}


@lru_cache(maxsize=4)
def _kept_quantizer(folder: str, name: str, entry: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`read_quantizer`, read once per process (a worker's tasks use it for every chunk they store)."""
    return read_quantizer(Path(folder), name, json.loads(entry))


def _quantizer_sum(top: np.ndarray, leaves: np.ndarray) -> str:
    h = hashlib.sha256()
    for data in (top, leaves):
        h.update(np.ascontiguousarray(data, dtype="<f4").data)
    return h.hexdigest()


def read_quantizer(folder: Path, name: str, entry: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Family ``name``'s quantizer (top (T, D), leaves (T·T, D) float32), checked against its manifest ``entry``."""
    file = folder / entry["file"]
    if not file.is_file():
        raise InputError(f"{entry['file']} listed in {MANIFEST} is missing", file=str(folder))
    cells, side = entry["cells"], int(round(np.sqrt(entry["cells"])))
    with open_result(file, kind="atlas-quantizer") as f:
        top = f.array("top", shape=(side, WIDTH), kinds="f").astype(np.float32, copy=False)
        leaves = f.array("centroids", shape=(cells, WIDTH), kinds="f").astype(np.float32, copy=False)
        if side * side != cells or _quantizer_sum(top, leaves) != entry["sha256"]:
            raise f.error("/", f"its content does not match its checksum in {MANIFEST} (changed since it was built)")
    return top, leaves


def store_chunks(folder: str, quantizers: dict[str, dict[str, Any]], name: str, seed: int, jobs: list[tuple[int, int]],
                 spec: str | None = None) -> list[dict[str, Any]]:
    """Build chunks ``jobs`` ((index, size) pairs) of family ``name`` and store each as a shard in the atlas
    folder ``folder`` (one Dask task: the folder must be on a file system the worker shares), each row's cell in
    the family's quantizer (``quantizers``: the manifest entries, per family); their entries."""
    path = Path(folder)
    quantizer = _kept_quantizer(folder, name, json.dumps(quantizers[name]))
    entries = []
    for index, size in jobs:
        chunk = build_chunk(name, seed, index, size, spec)
        report_kept(size)  # the chunk built: a task of an interrupted Dask build stops here, before its write
        entries.append(write_shard(path, name, seed, index, chunk, quantizer))
    return entries


def shard_bytes(name: str) -> int:
    """Bytes one linkage of family ``name`` takes in a shard: params (float64), min_ds and index (float32) and its
    cell (uint16; the family's one quantizer, ≤ 3.8 MB, is not counted)."""
    return 8 * len(family(name).PARAMETERS) + 4 + 4 * WIDTH + 2


#: Bytes per linkage a query holds beyond a shard's (:func:`shard_bytes`): its cell's list (int64 row), its
#: descriptor's norm (float32) and the sort that groups the rows by cell (int64)
QUERY_BYTES = 20


# --- building -------------------------------------------------------------------------------------------


def build(path: str | Path, names: list[str], count: int | None, *, seed: int = 1, resume: bool = False,
          scheduler: str | None = None, workers: int | None = None, connect_timeout: float = CONNECT_TIMEOUT,
          verbose: bool = False, progress: Callable[[int, int, float], None] | None = None) -> dict[str, int]:
    """Build (or append to) the sharded atlas in folder ``path``: ``count`` more linkages of every family in
    ``names``, each chunk stored as a shard by the task that built it (see :func:`linkedit.synthesis.atlas.build`
    for ``seed``, ``scheduler``, ``workers``, ``connect_timeout``, ``verbose`` and ``progress``). ``resume``:
    build only the chunks an interrupted build left pending (``count``, if given, must be that build's).
    Returns the linkage count per family."""
    path = Path(path)
    check_options(seed, scheduler, workers)
    building = lock_path(path / MANIFEST).exists()  # a build's, under way or killed before its first manifest
    if (not (path / MANIFEST).is_file() and path.exists() and not building
            and (not path.is_dir() or any(path.iterdir()))):
        raise InputError(f"exists and is not a sharded atlas (no {MANIFEST}); refusing to write into it",
                         file=str(path))
    if not resume and count is not None:  # before the plan: a list of 10⁸ chunks would not fit either
        _require_room(path, {name: count for name in names})
    check_shards(path, _checked(path, names, count, seed, resume))  # a refusal needs no cluster
    new = not path.exists()
    try:  # connected before anything is written: a scheduler that does not answer leaves the folder as it was
        with chunk_runner(scheduler, workers, connect_timeout=connect_timeout, verbose=verbose) as run, \
                locked(path / MANIFEST):
            manifest = _checked(path, names, count, seed, resume)
            jobs = _planned(path, manifest, names, count, resume)
            _run(path, manifest, jobs, seed, progress, run)
    finally:
        if new and path.is_dir() and not any(path.iterdir()):  # refused before anything was written
            path.rmdir()
    return counts(manifest)


def counts(manifest: dict[str, Any]) -> dict[str, int]:
    """The linkages of each family that ``manifest`` lists in complete shards."""
    return {name: sum(s["rows"] for s in entry["shards"]) for name, entry in manifest["families"].items()}


def _require_room(path: Path, left: dict[str, int]) -> None:
    """InputError (exit 2) unless the disk holds the shards of ``left`` (linkages per family) and the memory
    the build (:func:`~linkedit.synthesis.chunks.build_memory`): checked before anything is planned or written."""
    what = f"{sum(left.values()):,} linkages"
    require_disk(sum(n * shard_bytes(name) for name, n in left.items()), path / MANIFEST, what, field="--count")
    require_memory(build_memory(sum(left.values())), what, field="--count")


def _checked(path: Path, names: list[str], count: int | None, seed: int, resume: bool) -> dict[str, Any]:
    """The manifest of the atlas folder ``path`` (a new one's if none), after an InputError unless a build of
    ``names`` (``count`` each; ``resume``: the interrupted one's) with ``seed`` may run there."""
    manifest = read_manifest(path) if (path / MANIFEST).is_file() else new_manifest(seed)
    if manifest["seed"] != seed:
        raise InputError(f"this atlas was built with --seed {manifest['seed']}; use the same seed",
                         file=str(path), field="--seed")
    build = manifest["build"]
    if resume:
        if build is None:
            raise InputError("nothing to resume: no build of this atlas was interrupted", file=str(path),
                             field="--resume")
        if count is not None and count != build["count"] or sorted(names) != sorted(build["families"]):
            raise InputError(f"the interrupted build was --family {','.join(build['families'])} -n {build['count']}; "
                             "resume it with those", file=str(path), field="--resume")
    elif build is not None:
        chunks = sum(len(entry["pending"]) for entry in manifest["families"].values())
        raise InputError(f"a build of {chunks} more chunks was interrupted here; finish it with --resume",
                         file=str(path), field="--resume")
    elif count is None:
        raise InputError("give the number of linkages to add", field="--count")
    if resume:
        left = _plan(path, manifest, names, count, resume)
        _require_room(path, {name: sum(size for _, size in left[name]) for name in left})
    return manifest


def _plan(path: Path, manifest: dict[str, Any], names: list[str], count: int | None,
          resume: bool) -> dict[str, list[tuple[int, int]]]:
    """The chunks to build per family (a build :func:`_check` allowed), recorded in ``manifest`` as pending (a
    new build, whose new families' quantizers it writes) or read from it."""
    if resume:
        pending = {name: [tuple(job) for job in entry["pending"]] for name, entry in manifest["families"].items()}
        return {name: pending.get(name, []) for name in manifest["build"]["families"]}  # type: ignore[misc]
    assert count is not None  # _check refused a new build without one
    jobs = {}
    for name in names:
        entry = manifest["families"].setdefault(name, new_family(name))
        if entry["quantizer"] is None:  # the family's first build: its quantizer, sized for it
            entry["quantizer"] = write_quantizer(path, name, manifest["seed"], count)
        jobs[name] = chunk_sizes(count, entry["chunks"])
        entry["pending"] = [list(job) for job in jobs[name]]
        entry["chunks"] += len(jobs[name])
        entry["partial_chunk"] = bool(jobs[name]) and jobs[name][-1][1] < CHUNK
    manifest["build"] = {"count": count, "families": names}
    return jobs


def _planned(path: Path, manifest: dict[str, Any], names: list[str], count: int | None,
             resume: bool) -> dict[str, list[tuple[int, int]]]:
    """:func:`_plan`, then the manifest saved. Cut short before that (Ctrl-C while a quantizer is trained, an
    error), the quantizers it wrote for families new to the manifest and their folders are removed: nothing the
    manifest does not know is left (a new atlas folder holding only them was refused by every later build)."""
    known = set(manifest["families"])
    try:
        jobs = _plan(path, manifest, names, count, resume)
        save(path, manifest)
    except BaseException:
        for name in set(manifest["families"]) - known:
            (path / folder_of(name) / "quantizer.h5").unlink(missing_ok=True)
            with contextlib.suppress(OSError):  # not empty: not only this build's
                (path / folder_of(name)).rmdir()
        raise
    return jobs


def _run(path: Path, manifest: dict[str, Any], jobs: dict[str, list[tuple[int, int]]], seed: int,
         progress: Callable[[int, int, float], None] | None, run: Runner) -> None:
    """Build and store ``jobs`` with ``run`` (a :func:`~linkedit.synthesis.cluster.chunk_runner`'s), listing each shard in ``manifest`` as its entry comes back; the manifest is
    saved (:func:`_flush`) every :data:`SAVE_EVERY` seconds, and at least :data:`SAVE_SHARE`⁻¹ times as long as
    the last save took (a manifest of n shards takes O(n) to write: the saves stay a bounded share of the
    build however many shards it has), and when the build ends, however it ends."""
    total = sum(size for family_jobs in jobs.values() for _, size in family_jobs)
    done, start = 0, time.perf_counter()
    finished: dict[str, set[int]] = {name: set() for name in jobs}  # listed in "shards", still in "pending"
    store = partial(store_chunks, str(path.absolute()), {name: manifest["families"][name]["quantizer"] for name in jobs})
    saved, wait = time.monotonic(), SAVE_EVERY

    def within(kept: int) -> None:  # a chunk's draws screened in-process: ``kept`` of its linkages so far
        if progress is not None:
            progress(done + kept, total, time.perf_counter() - start)

    try:
        with reporting(within):
            for name, family_jobs in jobs.items():
                shards, listed = manifest["families"][name]["shards"], finished[name]
                for index, shard in run(name, seed, family_jobs, task=store):
                    shards.append(shard)
                    listed.add(index)
                    done += shard["rows"]
                    if progress is not None:
                        progress(done, total, time.perf_counter() - start)
                    if time.monotonic() - saved > wait:
                        began = time.monotonic()
                        with deferred_interrupts():
                            _flush(path, manifest, finished)
                        saved = time.monotonic()
                        wait = max(SAVE_EVERY, (saved - began) / SAVE_SHARE)
        manifest["build"] = None
    finally:
        with deferred_interrupts():
            _flush(path, manifest, finished)


#: Most share of a build's time its manifest saves take (see :func:`_run`).
SAVE_SHARE = 0.05


def _flush(path: Path, manifest: dict[str, Any], finished: dict[str, set[int]]) -> None:
    """Save ``manifest`` with the chunks in ``finished`` (per family, already in its ``shards``) taken off its
    ``pending``: one pass over each list, O(shards) per save (each shard filtering the list was O(shards²))."""
    for name, listed in finished.items():
        if listed:
            entry = manifest["families"][name]
            entry["pending"] = [job for job in entry["pending"] if job[0] not in listed]
            listed.clear()
    save(path, manifest)


# --- reading --------------------------------------------------------------------------------------------


def load(path: str | Path, threads: int | None = None) -> Atlas:
    """Read the sharded atlas in folder ``path`` (every shard checked against its manifest entry, read by
    ``threads`` threads): per family its params, min_ds, index and cell concatenated, and its quantizer's leaves
    (``centroids``)."""
    path = Path(path)
    manifest = read_manifest(path)
    if manifest["build"] is not None:
        raise InputError(f"a build was interrupted: {sum(len(e['pending']) for e in manifest['families'].values())} "
                         "chunks are missing; finish it with `linkedit atlas build ... --resume`", file=str(path))
    rows = {name: sum(shard["rows"] for shard in entry["shards"]) for name, entry in manifest["families"].items()}
    require_memory(sum(n * (shard_bytes(name) + QUERY_BYTES) for name, n in rows.items()),
                   f"a query over its {sum(rows.values()):,} linkages", file=str(path))
    families: dict[str, dict[str, np.ndarray]] = {}
    with ThreadPoolExecutor(threads) as pool:
        for name, entry in manifest["families"].items():
            if not entry["shards"]:
                continue
            families[name] = read_family(path, name, manifest["seed"], entry["quantizer"]["cells"],
                                         len(entry["columns"]), entry["shards"], pool)
            families[name]["centroids"] = read_quantizer(path, name, entry["quantizer"])[1]
    if not families:
        raise InputError("the atlas is empty", file=str(path))
    return Atlas(path, families, manifest["seed"])


def check_shards(folder: Path, manifest: dict[str, Any], threads: int | None = None) -> None:
    """Check every shard and quantizer ``manifest`` lists in ``folder`` as a query reads them (:func:`read_shard`,
    :func:`read_quantizer`; none kept): an InputError naming the first that disagrees, the other reads cancelled.
    An append or ``--resume`` does this before it writes anything."""

    def check(name: str, cells: int, width: int, shard: dict[str, Any]) -> None:
        read_shard(folder, name, manifest["seed"], cells, width, shard)

    with ThreadPoolExecutor(threads) as pool:
        try:
            for name, entry in manifest["families"].items():
                read_quantizer(folder, name, entry["quantizer"])
                list(pool.map(partial(check, name, entry["quantizer"]["cells"], len(entry["columns"])),
                              entry["shards"]))
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise


def read_family(folder: Path, name: str, seed: int, cells: int, width: int, shards: list[dict[str, Any]],
                pool: ThreadPoolExecutor | None = None) -> dict[str, np.ndarray]:
    """The ``shards`` (manifest entries) of family ``name`` (a quantizer of ``cells`` cells, ``width`` parameters)
    as one array per key,
    in their order (:func:`read_shard`, on ``pool``'s threads when given): each shard copied into its rows of arrays
    allocated once (memory: the family's, not twice it as a concatenation would take)."""
    starts = np.cumsum([0] + [shard["rows"] for shard in shards]).tolist()
    out: dict[str, np.ndarray] = {}

    def put(k: int) -> None:
        part = read_shard(folder, name, seed, cells, width, shards[k])
        for key, array in part.items():
            if key not in out:  # the first shard read sets the layout (setdefault: one array if two threads race)
                out.setdefault(key, np.empty((starts[-1], *array.shape[1:]), dtype=array.dtype))
            out[key][starts[k]:starts[k + 1]] = array

    list((pool.map if pool is not None else map)(put, range(len(shards))))
    return out


def read_shard(folder: Path, name: str, seed: int, cells: int, width: int,
               shard: dict[str, Any]) -> dict[str, np.ndarray]:
    """One shard's arrays, checked against its manifest entry (layout, rows, checksum), the family's quantizer
    of ``cells`` cells and its ``width`` parameters."""
    file, rows = folder / shard["file"], shard["rows"]
    if not file.is_file():
        raise InputError(f"shard {shard['file']} listed in {MANIFEST} is missing", file=str(folder))
    with open_result(file, kind="atlas-shard") as f:
        if (f.attr("family"), f.attr("chunk", kind=int), f.attr("seed", kind=int)) != (name, shard["chunk"], seed):
            raise f.error("/", f"not chunk {shard['chunk']} of {name} with seed {seed}")
        if f.attr("rows", kind=int) != rows:
            raise f.error("/", f"its rows attribute is {f.attr('rows', kind=int)}, {MANIFEST} lists {rows} rows for "
                          "it (one of them changed since it was built)")
        out = {"params": f.array("params", shape=(rows, width), kinds="f"),
               "min_ds": f.array("min_ds", shape=(rows,), kinds="f"),
               "index": f.array("index", shape=(rows, WIDTH), kinds="f").astype(np.float32, copy=False),
               "cell": f.array("cell", shape=(rows,), kinds="u").astype(np.uint16)}
        if checksum(out["params"], out["min_ds"], out["index"], out["cell"]) != shard["sha256"]:
            raise f.error("/", f"its content does not match its checksum in {MANIFEST} (changed since it was built)")
        if out["cell"].max(initial=0) >= cells:
            raise f.error("cell", f"a cell beyond the family's quantizer's {cells}")
    return out


def open_atlas(path: str | Path) -> Atlas:
    """An atlas for queries: a sharded folder (with a manifest), else an atlas file or a folder of them (InputError
    if a sharded atlas is in that folder too: it would be left out of the search)."""
    path = Path(path)
    if (path / MANIFEST).is_file():
        return load(path)
    inside = sorted(p for p in path.iterdir() if (p / MANIFEST).is_file()) if path.is_dir() else []
    if inside:
        raise InputError(f"{inside[0].name} in it is a sharded atlas, which a folder of atlas files does not read: "
                         f"give it on its own (--atlas {inside[0]})", file=str(path), field="--atlas")
    return load_file(path)
