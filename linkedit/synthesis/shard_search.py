"""The query of a sharded atlas on a Dask cluster's workers (``synthesize --atlas NAME --scheduler ADDRESS``).

The client reads only the manifest. Each family's shards are cut into runs of consecutive shards, one
Dask task per run and worker thread (:func:`search_shards`): the worker reads its shards from the atlas
folder (a file system every worker sees at the same path, as for the build), keeps them for the next
query, and searches them as :class:`linkedit.synthesis.index.Index` searches them in-process: a family of
up to :data:`~linkedit.synthesis.index.SCAN_LIMIT` linkages is scanned whole, a larger one through the
family's quantizer: each task scans the probed cells' rows of its own shards. Each task sends back its ``count`` best rows with their descriptors and
parameters; the client ranks the union exactly (:func:`~linkedit.synthesis.index.nearest_rows` in float64),
so a small atlas gives the in-process search's hits (whose float32 squared distances are within 1e-6).
Memory on the client: the manifest and the hits.
"""

from __future__ import annotations

import contextlib
import threading
from collections import OrderedDict
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import numpy as np

from linkedit.errors import InputError
from linkedit.synthesis.atlas import Atlas
from linkedit.synthesis.chunks import dimension
from linkedit.synthesis.cluster import CONNECT_TIMEOUT, connected
from linkedit.synthesis.families import family, of_text
from linkedit.synthesis.index import SCAN_LIMIT, Hit, Lists, nearest_rows
from linkedit.synthesis.manifest import MANIFEST, read_manifest
from linkedit.synthesis.shards import read_family, read_quantizer

#: Shard runs a worker keeps read between queries (a worker of a cluster serves many ``synthesize`` runs).
KEEP = 64
_kept: OrderedDict[tuple[Any, ...], dict[str, Any]] = OrderedDict()
_keeping = threading.Lock()


def _prepared(folder: str, name: str, spec: str | None, seed: int, quantizer: dict[str, Any],
              shards: list[dict[str, Any]], exact: bool) -> dict[str, Any]:
    """The shards ``shards`` of family ``name`` (``spec``: a spec family's text; ``quantizer``: its manifest entry)
    read and checked from ``folder``, ready to search: kept for the next query on this worker (the :data:`KEEP` runs
    used last)."""
    key = (folder, name, spec, seed, exact, quantizer["sha256"], tuple(s["sha256"] for s in shards))
    with _keeping:  # the worker's threads run queries at once
        if key in _kept:
            _kept.move_to_end(key)
            return _kept[key]
    width = len(of_text(name, spec).PARAMETERS)  # a spec family is made on the worker from its text
    arrays = read_family(Path(folder), name, seed, quantizer["cells"], width, shards)
    v = arrays["index"]
    ready: dict[str, Any] = {"index": v, "params": arrays["params"]}
    if exact:
        ready["columns"], ready["norms"] = np.ascontiguousarray(v.T), np.einsum("kd,kd->k", v, v)
    else:
        ready["lists"] = Lists.of_cells(v, read_quantizer(Path(folder), name, quantizer)[1], arrays["cell"])
    with _keeping:
        _kept[key] = ready
        while len(_kept) > KEEP:
            _kept.popitem(last=False)
    return ready


def search_shards(folder: str, name: str, spec: str | None, seed: int, quantizer: dict[str, Any],
                  shards: list[dict[str, Any]], base: int, variants: np.ndarray, count: int,
                  exact: bool) -> dict[str, np.ndarray]:
    """One Dask task: the ``count`` rows of the run of shards ``shards`` (manifest entries, consecutive; its first
    row is atlas row ``base`` of the family; ``spec``: a spec family's text) nearest to any of ``variants`` (V, D):
    their atlas rows (n,), index descriptors (n, D) and parameters (n, P). ``exact``: every row scanned, else the
    probed cells of the family's quantizer (``quantizer``: its manifest entry)."""
    ready = _prepared(folder, name, spec, seed, quantizer, shards, exact)
    if exact:
        rows, _ = nearest_rows(variants, ready["columns"], ready["norms"], count)
    else:
        rows, _ = ready["lists"].query(variants, count)
    return {"rows": rows.astype(np.int64) + base, "index": ready["index"][rows], "params": ready["params"][rows]}


class FetchedParams:
    """A family's ``params`` in a remotely searched atlas: its length, and the rows the searches fetched
    (what :func:`linkedit.synthesis.synthesize.synthesize` reads of an atlas: the params of its hits)."""

    def __init__(self, rows: int, width: int) -> None:
        self.shape = (rows, width)
        self.found: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, rows: list[int]) -> np.ndarray:
        return np.array([self.found[int(r)] for r in rows], dtype=np.float64).reshape(len(rows), self.shape[1])


class ClusterIndex:
    """An :class:`~linkedit.synthesis.index.Index` whose search runs on the workers of ``client``'s cluster
    (``nthreads``: threads per worker address): :meth:`query` as the in-process one's, the hits' params stored
    in ``atlas``. Run k of a family's shards is pinned to the worker of thread slot k (the workers in address
    order, each as many slots as it has threads): the same worker for every query and every client while the
    workers stay, so it reads the run once and keeps it (:data:`KEEP`); a query waits for a busy worker rather
    than have another read its shards again, and goes elsewhere only if that worker has left."""

    def __init__(self, client: Any, nthreads: dict[str, int], folder: Path, manifest: dict[str, Any], atlas: Atlas,
                 direct: bool, scan_limit: int = SCAN_LIMIT) -> None:
        self.client, self.direct, self.atlas = client, direct, atlas
        self.folder, self.seed = str(folder.absolute()), manifest["seed"]
        self.slots = [worker for worker in sorted(nthreads) for _ in range(nthreads[worker])]
        threads = len(self.slots)
        self.runs: dict[str, list[tuple[list[dict[str, Any]], int]]] = {}
        self.exact: dict[str, bool] = {}
        self.specs = {name: manifest["families"][name]["spec"] for name in atlas.families}
        self.quantizers = {name: manifest["families"][name]["quantizer"] for name in atlas.families}
        for name in atlas.families:
            shards = manifest["families"][name]["shards"]
            bases = np.cumsum([0] + [s["rows"] for s in shards])
            parts = np.array_split(np.arange(len(shards)), min(max(threads, 1), len(shards)))
            self.runs[name] = [([shards[k] for k in part], int(bases[part[0]])) for part in parts]
            self.exact[name] = int(bases[-1]) <= scan_limit

    def query(self, variants: np.ndarray, count: int) -> list[Hit]:
        """The ``count`` nearest linkages over all families, nearest first (exactly ranked on the client)."""
        q2 = float(np.sum(variants[0].astype(float) ** 2))
        calls = {name: [(self.slots[k % len(self.slots)], (self.folder, name, self.specs[name], self.seed,
                                                            self.quantizers[name], shards, base, variants, count,
                                                            self.exact[name]))
                        for k, (shards, base) in enumerate(runs)]
                 for name, runs in self.runs.items()}
        futures = {name: [self.client.submit(search_shards, *args, pure=False, workers=worker) for worker, args in part]
                   for name, part in calls.items()}  # pinned: a loose restriction lets Dask's work stealing move them
        hits: list[Hit] = []
        for name, parts in futures.items():
            found = self._gather(parts, calls[name])
            rows = np.concatenate([f["rows"] for f in found])
            vectors = np.concatenate([f["index"] for f in found]).astype(np.float64)  # exact: no float32 cancellation
            best, d2 = nearest_rows(variants.astype(np.float64), np.ascontiguousarray(vectors.T),
                                    np.einsum("kd,kd->k", vectors, vectors), count)
            fetched = cast(FetchedParams, self.atlas.families[name]["params"])
            params = np.concatenate([f["params"] for f in found])
            for k in best:
                fetched.found[int(rows[k])] = params[k]
            hits += [Hit(name, int(rows[k]), float(np.sqrt(max(d + q2, 0.0)))) for k, d in zip(best, d2)]
        hits.sort(key=lambda h: h.distance)
        return hits[:count]

    def _gather(self, futures: list[Any], calls: list[tuple[str, tuple[Any, ...]]]) -> list[Any]:
        """The results of ``futures`` (``calls``: each one's worker and arguments), any whose worker has left the
        cluster submitted again to any worker (checked every :data:`REPIN_CHECK` seconds)."""
        from distributed import wait

        while True:
            try:
                wait(futures, timeout=REPIN_CHECK)
                return cast(list[Any], self.client.gather(futures, direct=self.direct))
            except TimeoutError:
                present = self.client.nthreads()
                for k, (worker, args) in enumerate(calls):
                    if worker not in present and not futures[k].done():
                        futures[k] = self.client.submit(search_shards, *args, pure=False)
                        calls[k] = ("", args)


#: Seconds between checks that the workers a query's tasks are pinned to are still there.
REPIN_CHECK = 1.0


@contextlib.contextmanager
def remote_atlas(path: str | Path, scheduler: str, *, dim: int | None = None,
                 connect_timeout: float = CONNECT_TIMEOUT, verbose: bool = False,
                 scan_limit: int = SCAN_LIMIT) -> Iterator[tuple[Atlas, ClusterIndex]]:
    """The sharded atlas in folder ``path`` searched on the Dask cluster at ``scheduler``, for the block: an
    :class:`Atlas` of its families (of dimension ``dim``, if given) holding only the params of the hits, and
    its :class:`ClusterIndex`. InputError for anything but a complete sharded atlas."""
    path = Path(path)
    if not (path / MANIFEST).is_file():
        raise InputError(f"--scheduler searches a sharded atlas (a folder with {MANIFEST}, `atlas build -o NAME`); "
                         "this is not one", file=str(path))
    manifest = read_manifest(path)
    if manifest["build"] is not None:
        raise InputError(f"a build was interrupted: {sum(len(e['pending']) for e in manifest['families'].values())} "
                         "chunks are missing; finish it with `linkedit atlas build ... --resume`", file=str(path))
    families = {name: {"params": cast(np.ndarray, FetchedParams(sum(s["rows"] for s in entry["shards"]),
                                                                len(entry["columns"])))}
                for name, entry in manifest["families"].items()
                if entry["shards"] and (dim is None or dimension(family(name, spec=entry["spec"])) == dim)}
    if not families:
        kinds = {2: "planar ", 3: "spatial "}.get(dim or 0, "")
        raise InputError(f"the atlas holds no {kinds}linkages", file=str(path))
    book = Atlas(path, families, manifest["seed"])
    with connected(scheduler, connect_timeout=connect_timeout, verbose=verbose) as (client, nthreads, direct):
        yield book, ClusterIndex(client, nthreads, path, manifest, book, direct, scan_limit)
