"""The query at scale (``linkedit bench -s synthesis --large N``): a sharded atlas of N four-bars built and searched.

Opt-in (10,000,000 four-bars take minutes to build on 2 cores). Prints the bytes per linkage (stored and
measured on disk), the query time through the family's quantizer at 1,000,000 curves (the atlas's first 100
shards) and at N, in-process and on a local Dask cluster (the workers keep their shards between queries), the
recall of the exact top 10 at N, and the query time extrapolated to 100,000,000 curves by the rows it scans.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import resource
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.resources import available_memory, size_text
from linkedit.synthesis import fourbar, shards
from linkedit.synthesis.atlas import Atlas, stored_bytes
from linkedit.synthesis.chunks import CHUNK, build_chunk
from linkedit.synthesis.cluster import dask_logs, local_cluster, usable_cores
from linkedit.synthesis.index import Index, Lists, nearest_rows, probe_count, quantizer_side, target_variants
from linkedit.synthesis.shard_search import ClusterIndex, remote_atlas

#: Curves the extrapolation aims at, and the issue's target for a query over them.
HUNDRED_MILLION = 100_000_000
LARGE_QUERY_TARGET = 1.0  # s
#: Curves of the first figure (the atlas's first shards).
SMALL = 1_000_000
#: Held-out targets (seed 988) of the recall and the timings.
TARGETS = 50


def _first(book: Atlas, folder: Path, shard_count: int) -> Atlas:
    """The atlas of the first ``shard_count`` shards of the four-bar family of ``folder``."""
    entry = shards.read_manifest(folder)["families"]["four-bar"]
    head = shards.read_family(folder, "four-bar", book.seed, entry["quantizer"]["cells"], len(entry["columns"]),
                              entry["shards"][:shard_count])
    return Atlas(folder, {"four-bar": head | {"centroids": book.families["four-bar"]["centroids"]}}, book.seed)


def _scanned(index: Index, variants: list[np.ndarray]) -> float:
    """Mean rows a query of ``index`` (one family, through its quantizer) scans: those of its probed cells."""
    lists = index.lists[0]
    assert isinstance(lists, Lists)
    return float(np.mean([np.sum(np.diff(lists.offsets)[lists.probed(v)]) for v in variants]))


def _exact_top(lists: Lists, variants: np.ndarray, count: int, block: int = 2_000_000) -> np.ndarray:
    """The exact ``count`` nearest rows of the family ``lists`` indexes (every row, block by block: no copy of
    the family's descriptors), nearest first."""
    found = [nearest_rows(variants, lists.vectors[b:b + block].T, lists.norms[b:b + block], count)
             for b in range(0, len(lists.vectors), block)]
    rows = np.concatenate([r + b for (r, _), b in zip(found, range(0, len(lists.vectors), block))])
    dist = np.concatenate([d for _, d in found])
    return rows[np.argsort(dist, kind="stable")[:count]]


def _median_query(index: Index | ClusterIndex, variants: list[np.ndarray]) -> float:
    times = []
    for v in variants:
        t0 = time.perf_counter()
        index.query(v, 64)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run(echo: Callable[[str], None], count: int | None, workers: int, scheduler: str | None = None,
        folder: Path | None = None) -> None:
    """Build a sharded atlas of ``count`` four-bars on the Dask cluster at ``scheduler`` (of ``workers`` worker
    threads), else on a local cluster of ``workers`` when Dask is installed, else in-process — or take the one built
    before in ``folder`` —; then time and check queries over it (see the module docstring)."""
    held = build_chunk("four-bar", 988, 0, TARGETS).params
    variants = [target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0]) for k, row in enumerate(held)]
    dask = importlib.util.find_spec("distributed") is not None
    start = dask and scheduler is None
    with (dask_logs(False) if dask else contextlib.nullcontext()), \
            (local_cluster(workers, verbose=False) if start else contextlib.nullcontext()) as cluster, \
            tempfile.TemporaryDirectory() as tmp:
        address = scheduler or (cluster.scheduler_address if cluster is not None else None)
        load = os.getloadavg()[0]
        if folder is None:
            assert count is not None
            folder = Path(tmp) / "atlas"
            t0 = time.perf_counter()
            shards.build(folder, ["four-bar"], count, seed=1, scheduler=address)
            t_build = time.perf_counter() - t0
            built = (f"built in {t_build:.0f} s ({count / t_build:,.0f} linkages/s, "
                     f"{f'{workers} Dask workers' if address else 'in-process'})")
        else:
            count = shards.counts(shards.read_manifest(folder)).get("four-bar", 0)
            if not count:
                raise InputError("holds no four-bars (build it with `linkedit atlas build --family four-bar`)",
                                 file=str(folder), field="--large-atlas")
            built = f"built before in {folder}"
        small = min(count, SMALL)
        on_disk = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
        t0 = time.perf_counter()
        book = shards.load(folder)
        t_load = time.perf_counter() - t0
        held_bytes = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        index = Index(book, scan_limit=0)
        t_large, rows_large = _median_query(index, variants), _scanned(index, variants)
        book_small = _first(book, folder, -(-small // CHUNK))
        head = Index(book_small, scan_limit=0)
        t_small, rows_small = _median_query(head, variants), _scanned(head, variants)
        cells = len(book.families["four-bar"]["centroids"])
        del head
        lists = index.lists[0]
        assert isinstance(lists, Lists)
        # the extrapolation's figures: rows gathered from the atlas order, as a 100,000,000 family's are (its
        # cell-ordered copy, 12 GB, is made only where it takes at most a quarter of the memory then available)
        copied = lists.cell_vectors is not None
        g_small, g_large = ((_median_query(Index(book_small, scan_limit=0, ordered=False), variants),
                             _median_query(Index(book, scan_limit=0, ordered=False), variants)) if copied
                            else (t_small, t_large))
        del book_small
        recall = [len(set(_exact_top(lists, v, 10).tolist()) & {h.row for h in index.query(v, 10)}) / 10
                  for v in variants]
        del lists, index, book
        remote = "not measured (pip install 'linkedit[cluster]')"
        need = count * (shards.shard_bytes("four-bar") + shards.QUERY_BYTES)
        if address is not None and need > available_memory() / 2:
            remote = f"not measured (its workers would hold {size_text(need)}; {size_text(available_memory())} free)"
        elif address is not None:
            with remote_atlas(folder, address, scan_limit=0) as (_, far):
                t0 = time.perf_counter()
                far.query(variants[0], 64)
                first = time.perf_counter() - t0
                remote = (f"{1e3 * _median_query(far, variants):.0f} ms median ({workers} workers; the first query, "
                          f"reading the shards onto the workers, {first:.1f} s)")
    cores = usable_cores()
    gathered = (f"; {1e3 * g_small:.0f} and {1e3 * g_large:.0f} ms with the rows gathered from the atlas order, "
                "as a 100,000,000 family's are where its cell-ordered copy does not fit" if copied else "")
    # the time grows with the rows scanned, N/C·(a probed cell's share): the line through both figures
    if count > small and rows_large > rows_small:
        per = (g_large - g_small) / (rows_large - rows_small)
        basis = (f"the line through the {small:,} and {count:,} figures ({rows_small:,.0f} and {rows_large:,.0f} rows "
                 f"scanned), {1e9 * per:.0f} ms per million rows scanned")
    else:
        per = g_large / rows_large
        basis = f"proportional to the {count:,} figure's {rows_large:,.0f} rows (give --large above {SMALL:,} for a line)"
    big_cells = quantizer_side(HUNDRED_MILLION) ** 2
    probes, big_probes = probe_count(cells), probe_count(big_cells)
    rows_100m = rows_large * HUNDRED_MILLION / count * cells / big_cells * big_probes / probes  # a 100M build's cells
    t_100m = g_large + per * (rows_100m - rows_large)
    echo(f"query at scale, sharded atlas of {count:,} four-bars ({cores} cores usable of the machine's "
         f"{os.cpu_count()}, load average {load:.2f} before, {os.getloadavg()[0]:.2f} after): {built}, "
         f"{on_disk / count:.0f} bytes per linkage on disk ({shards.shard_bytes('four-bar')} stored + HDF5 overhead; "
         f"an atlas file: {stored_bytes('four-bar')}), loaded in {t_load:.1f} s, this process's peak memory then "
         f"{size_text(held_bytes)} ({held_bytes / count:.0f} bytes per linkage)")
    echo(f"  query through the family's quantizer ({cells:,} cells, {probes} probed), median of {TARGETS} held-out targets: "
         f"{f'{1e3 * t_small:.0f} ms at {small:,}, ' if count > small else ''}{1e3 * t_large:.0f} ms at {count:,} "
         f"(recall of the exact top 10 "
         f"{np.mean(recall):.3f}, target ≥ 0.99){gathered}; on the cluster at {count:,}: {remote}")
    if count >= HUNDRED_MILLION:
        return
    echo(f"  extrapolated to {HUNDRED_MILLION:,}: {t_100m:.2f} s in-process on these {cores} cores (target ≤ "
         f"{LARGE_QUERY_TARGET:g} s) — basis: the time grows with the rows of the probed cells, "
         f"{basis}; a 100,000,000 build's quantizer has {big_cells:,} cells, {big_probes} probed, so ≈ "
         f"{rows_100m:,.0f} rows scanned (the {count:,} figure's × {HUNDRED_MILLION / count:,.0f} × "
         f"{cells:,}/{big_cells:,} × {big_probes}/{probes}; its {big_cells:,} centroids add < 1 ms)")
