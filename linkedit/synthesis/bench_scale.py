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
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from linkedit.synthesis import fourbar, shards
from linkedit.synthesis.atlas import Atlas, stored_bytes
from linkedit.synthesis.chunks import CHUNK, build_chunk
from linkedit.synthesis.cluster import dask_logs, local_cluster, usable_cores
from linkedit.synthesis.index import PROBE, Index, Lists, nearest_rows, quantizer_side, target_variants
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
    parts = [shards.read_shard(folder, "four-bar", book.seed, entry["quantizer"]["cells"], len(entry["columns"]), s)
             for s in entry["shards"][:shard_count]]
    return Atlas(folder, {"four-bar": shards.merge(parts) | {"centroids": book.families["four-bar"]["centroids"]}},
                 book.seed)


def _scanned(index: Index, variants: list[np.ndarray]) -> float:
    """Mean rows a query of ``index`` (one family, through its quantizer) scans: those of its probed cells."""
    lists = index.lists[0]
    assert isinstance(lists, Lists)
    return float(np.mean([np.sum(np.diff(lists.offsets)[lists.probed(v)]) for v in variants]))


def _median_query(index: Index | ClusterIndex, variants: list[np.ndarray]) -> float:
    times = []
    for v in variants:
        t0 = time.perf_counter()
        index.query(v, 64)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run(echo: Callable[[str], None], count: int, workers: int, scheduler: str | None = None) -> None:
    """Build a sharded atlas of ``count`` four-bars on the Dask cluster at ``scheduler`` (of ``workers`` worker
    threads), else on a local cluster of ``workers`` when Dask is installed, else in-process; then time and
    check queries over it (see the module docstring)."""
    small = min(count, SMALL)
    held = build_chunk("four-bar", 988, 0, TARGETS).params
    variants = [target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0]) for k, row in enumerate(held)]
    dask = importlib.util.find_spec("distributed") is not None
    start = dask and scheduler is None
    with (dask_logs(False) if dask else contextlib.nullcontext()), \
            (local_cluster(workers, verbose=False) if start else contextlib.nullcontext()) as cluster, \
            tempfile.TemporaryDirectory() as tmp:
        address = scheduler or (cluster.scheduler_address if cluster is not None else None)
        folder = Path(tmp) / "atlas"
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        shards.build(folder, ["four-bar"], count, seed=1, scheduler=address)
        t_build = time.perf_counter() - t0
        on_disk = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
        t0 = time.perf_counter()
        book = shards.load(folder)
        t_load = time.perf_counter() - t0
        index = Index(book, scan_limit=0)
        t_large, rows_large = _median_query(index, variants), _scanned(index, variants)
        head = Index(_first(book, folder, -(-small // CHUNK)), scan_limit=0)
        t_small, rows_small = _median_query(head, variants), _scanned(head, variants)
        cells = len(book.families["four-bar"]["centroids"])
        del head
        vectors = book.families["four-bar"]["index"]
        columns, norms = np.ascontiguousarray(vectors.T), np.einsum("kd,kd->k", vectors, vectors)
        recall = [len(set(nearest_rows(v, columns, norms, 10)[0].tolist()) & {h.row for h in index.query(v, 10)}) / 10
                  for v in variants]
        del columns, norms, index, book
        remote = "not measured (pip install 'linkedit[cluster]')"
        if address is not None:
            with remote_atlas(folder, address, scan_limit=0) as (_, far):
                t0 = time.perf_counter()
                far.query(variants[0], 64)
                first = time.perf_counter() - t0
                remote = (f"{1e3 * _median_query(far, variants):.0f} ms median ({workers} workers; the first query, "
                          f"reading the shards onto the workers, {first:.1f} s)")
    cores = usable_cores()
    # the time grows with the rows scanned, N/C·(a probed cell's share): the line through both figures
    if count > small and rows_large > rows_small:
        per = (t_large - t_small) / (rows_large - rows_small)
        basis = (f"the line through the {small:,} and {count:,} figures ({rows_small:,.0f} and {rows_large:,.0f} rows "
                 f"scanned), {1e9 * per:.0f} ms per million rows scanned")
    else:
        per = t_large / rows_large
        basis = f"proportional to the {count:,} figure's {rows_large:,.0f} rows (give --large above {SMALL:,} for a line)"
    big_cells = quantizer_side(HUNDRED_MILLION) ** 2
    rows_100m = rows_large * HUNDRED_MILLION / count * cells / big_cells  # a 100M build's quantizer: big_cells
    t_100m = t_large + per * (rows_100m - rows_large)
    echo(f"query at scale, sharded atlas of {count:,} four-bars ({cores} cores usable of the machine's {os.cpu_count()}, load average {load:.2f} before, "
         f"{os.getloadavg()[0]:.2f} after): built in {t_build:.0f} s ({count / t_build:,.0f} linkages/s, "
         f"{f'{workers} Dask workers' if address else 'in-process'}), {on_disk / count:.0f} bytes per linkage on "
         f"disk ({shards.shard_bytes('four-bar')} stored + HDF5 overhead; an atlas file: "
         f"{stored_bytes('four-bar')}), loaded in {t_load:.1f} s")
    echo(f"  query through the family's quantizer ({cells:,} cells, {PROBE} probed), median of {TARGETS} held-out targets: "
         f"{f'{1e3 * t_small:.0f} ms at {small:,}, ' if count > small else ''}{1e3 * t_large:.0f} ms at {count:,} "
         f"(recall of the exact top 10 "
         f"{np.mean(recall):.3f}, target ≥ 0.99); on the cluster at {count:,}: {remote}")
    echo(f"  extrapolated to {HUNDRED_MILLION:,}: {t_100m:.2f} s in-process on these {cores} cores (target ≤ "
         f"{LARGE_QUERY_TARGET:g} s) — basis: the time grows with the rows of the {PROBE} probed cells, "
         f"{basis}; a 100,000,000 build's quantizer has {big_cells:,} cells, so ≈ {rows_100m:,.0f} rows scanned "
         f"(the {count:,} figure's × {HUNDRED_MILLION // count} × {cells:,}/{big_cells:,}; its {big_cells:,} "
         f"centroids add < 1 ms); memory in-process ≈ 300 bytes per linkage (30 GB at 100M: specs/atlas-hdf5.md), "
         f"spread over the workers on a cluster")
