"""The fast query: nearest atlas curves to a target by the index descriptor.

The index descriptor is the arc-length elliptic Fourier descriptor, normalized for start,
rotation and scale (:func:`linkedit.curves.efd.polyline_efd`). Its remaining ambiguities —
start shifted by half a period, direction of travel, and (a four-bar mirrored is still a
four-bar) the mirror image — are sign patterns, applied to the target rather than to the
atlas: one (8, D) × (D, K) product per family (the atlas held transposed, so the product runs
along its long side).

A family of more than :data:`SCAN_LIMIT` linkages is searched through :class:`Lists`, a coarse
quantizer (k-means cells of the descriptors; each query scans the cells nearest to any of its
variants, then ranks those linkages exactly): the scanned fraction, not the atlas, sets the
time, with the exact top-10 found ≥ 99 % of the time (``linkedit bench -s synthesis`` measures
the recall). A sharded atlas (:mod:`linkedit.synthesis.shards`) has one quantizer per family
(:func:`train_quantizer`, two levels so a shard's rows are assigned cheaply: :func:`assign`), and each
shard stores its rows' cells: the query probes the :func:`probe_count` cells nearest to the target over the
whole family, so its work grows with the rows of those cells, not with the number of shards.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.blas import single_threaded
from linkedit.curves.efd import variant_signs
from linkedit.resources import available_memory
from linkedit.synthesis.atlas import Atlas
from linkedit.synthesis.chunks import HARMONICS, index_efd, index_vector


@dataclass(frozen=True)
class Hit:
    family: str
    row: int
    distance: float  #: Euclidean distance of index descriptors (best variant)


def target_variants(z: np.ndarray) -> np.ndarray:
    """Index descriptors (8, D) float32 of a closed target polyline z (M,) complex, or (M, 3) for a spatial
    atlas (:func:`~linkedit.synthesis.chunks.index_efd`): every sign variant."""
    efd = index_efd(z[None])[0]
    signs = variant_signs(HARMONICS)
    signs = np.concatenate([signs, signs * np.array([1.0, 1.0, -1.0, -1.0])])  # and mirrored
    return index_vector(efd[None] * signs).astype(np.float32)


#: families up to this many linkages are scanned whole (1M in ≤ 50 ms); larger ones through :class:`Lists`
SCAN_LIMIT = 2_000_000
#: cells a query scans (of ~2·√K; those nearest to any variant of the target), at least: the exact top-10 is
#: found ≥ 99 % of the time (of 400,000 four-bars: 0.996 in 1,296 cells, 0.993 in 16,384; 32 cells: 0.987 in 16,384)
PROBE = 64
#: ... and at least this share of the cells (16,384 cells: 128 scanned): of 100,000,000 four-bars in 16,384 cells,
#: 64 found 0.991 of the exact top 10 of 100 held-out targets (0.986 of the first 50), 96 0.999, 128 all of them,
#: in 259, 387 and 548 ms (medians, 2 loaded cores)
PROBE_SHARE = 1 / 128


def probe_count(cells: int) -> int:
    """The cells a query of a family quantized in ``cells`` cells scans (:data:`PROBE`, :data:`PROBE_SHARE`)."""
    return min(cells, max(PROBE, round(PROBE_SHARE * cells)))


def nearest_rows(variants: np.ndarray, columns: np.ndarray, norms: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` rows of descriptors ``columns`` (D, K) nearest to any of ``variants`` (V, D),
    and their squared distances less |q|² (|x|² − 2·max_v v·x), nearest first: the one exact ranking.
    The product in the descriptors' float32 screens the rows whose rounding bound (per row) reaches
    the ``count``-th; those are ranked in float64. (Ranked in float32, whose rounding, ~1e-7, exceeds the
    distances of near neighbours in a large atlas, 7 % of the exact top 10 of 400,000 four-bars were
    swapped out.)"""
    d2 = norms - 2.0 * (variants @ columns).max(axis=0)
    k = min(count, d2.size)
    if not k:
        return np.zeros(0, dtype=int), np.zeros(0)
    # each row's rounding bound, D·ε·(|x|² + 2·|v|max·|x|) (Cauchy–Schwarz on the float32 products):
    # a row can be in the exact top ``count`` only if its lower bound is within the count-th upper bound
    v_max = float(np.sqrt(np.einsum("vd,vd->v", variants, variants).max()))
    bound = (columns.shape[0] * float(np.finfo(np.float32).eps)) * (norms + (2.0 * v_max) * np.sqrt(norms))
    upper = d2 + bound
    rows = np.flatnonzero(d2 - bound <= np.partition(upper, k - 1)[k - 1])
    x = columns[:, rows].astype(np.float64)
    exact = np.einsum("dk,dk->k", x, x) - 2.0 * (variants.astype(np.float64) @ x).max(axis=0)
    best = np.argsort(exact, kind="stable")[:k]
    return rows[best], exact[best]


def cells_of(vectors: np.ndarray, cells: int | None = None, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The coarse quantizer of descriptors ``vectors`` (K, D): ``cells`` k-means centroids (C, D) float32
    (trained on a sample; 2·√K by default), the rows grouped by their nearest centroid (K,) and each
    cell's start in that order (C + 1,): what :class:`Lists` searches, and what an atlas shard stores."""
    with single_threaded():  # small products: OpenBLAS's threads cost 30× on a loaded machine
        return _cells_of(vectors, cells, seed)


def _cells_of(vectors: np.ndarray, cells: int | None, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    count = len(vectors)
    cells = min(cells or int(np.clip(2.0 * np.sqrt(count), 1, 16384)), count)
    rng = np.random.default_rng(seed)
    sample = vectors[np.sort(rng.choice(count, min(count, 20 * cells), replace=False))]
    centroids = sample[rng.choice(len(sample), cells, replace=False)].astype(np.float32)
    for _ in range(8):  # Lloyd's iterations on the sample (a cell left empty keeps its centroid)
        cell = _nearest(sample, centroids)
        sums = np.stack([np.bincount(cell, weights=column, minlength=cells) for column in sample.T], axis=1)
        size = np.bincount(cell, minlength=cells)
        full = size > 0
        centroids[full] = sums[full] / size[full, None]
    return (centroids, *grouped(_nearest(vectors, centroids), cells))


def grouped(cell: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows (K,) grouped by their ``cell`` (K,) of ``cells``, and each cell's start in that order (C + 1,)."""
    rows = np.argsort(cell, kind="stable")
    return rows, np.searchsorted(cell[rows], np.arange(cells + 1))


#: Most top cells of a sharded family's quantizer, and leaves per top cell (16,384 cells at most).
MAX_SIDE = 128
#: Sample rows per cell a quantizer is trained on.
SAMPLE_PER_CELL = 16


def quantizer_side(count: int) -> int:
    """Top cells (and leaves per top cell) of the quantizer of a sharded family first built with ``count``
    linkages: C = side² ≈ 2·√count cells (as :func:`cells_of`), side from 4 to :data:`MAX_SIDE`."""
    return int(np.clip(round(np.sqrt(2.0 * np.sqrt(count))), 4, MAX_SIDE))


def train_quantizer(sample: np.ndarray, side: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A two-level quantizer of descriptors ``sample`` (S, D): ``side`` top k-means centroids (T, D) float32 and
    ``side`` leaves per top cell (T·T, D) float32, the k-means centroids of the sample's rows in it (a top cell of
    fewer rows than ``side`` repeats its centroid; such leaves stay empty). Leaf t·T + l is cell l of top cell t."""
    with single_threaded():
        top, rows, offsets = _cells_of(sample, side, seed)
        top = np.concatenate([top, np.repeat(top[-1:], side - len(top), axis=0)])  # a sample of fewer rows
        leaves = np.repeat(top, side, axis=0)
        for t in range(len(offsets) - 1):  # a loop over the top cells, not the rows
            members = sample[rows[offsets[t]:offsets[t + 1]]]
            if len(members):
                found = _cells_of(members, side, seed + 1 + t)[0]
                leaves[t * side:t * side + len(found)] = found
    return top, leaves


def assign(vectors: np.ndarray, top: np.ndarray, leaves: np.ndarray) -> np.ndarray:
    """The cell (K,) of each of ``vectors`` (K, D) in the quantizer (``top``, ``leaves``: :func:`train_quantizer`):
    the nearest leaf of its nearest top cell (2·side products per row, not side²)."""
    side = len(leaves) // len(top)
    with single_threaded():
        rows, offsets = grouped(_nearest(vectors, top), len(top))
        cell = np.empty(len(vectors), dtype=np.int64)
        for t in range(len(top)):
            part = rows[offsets[t]:offsets[t + 1]]
            if len(part):
                cell[part] = t * side + _nearest(vectors[part], leaves[t * side:(t + 1) * side])
    return cell


#: A family's descriptors are also kept in cell order when that copy (and its norms) takes at most this share of the
#: memory available: a query's cells are then contiguous runs of it, not rows gathered one by one from the whole
#: family (2,000,000 four-bars: 9 ms a query instead of 41, medians; a copy of 240 MB made in 0.9 s). A larger family
#: (100,000,000 four-bars: 12 GB more) is searched in atlas order: the same rows, the same distances.
ORDERED_SHARE = 0.25


class Lists:
    """Inverted lists of descriptors ``vectors`` (K, D): ``centroids`` (C, D), ``rows`` (atlas rows
    grouped by cell) and ``offsets`` (C + 1,) into them, as :func:`cells_of` makes them (or as a sharded
    family's cells give them: :meth:`of_cells`). :meth:`query` scans the cells nearest to each variant and
    ranks those rows exactly (:func:`nearest_rows`). The descriptors are kept as given (a reference, in atlas
    order), with their norms, and copied in cell order (``cell_vectors``, ``cell_norms``) when ``ordered``
    (by default when the copy fits: :data:`ORDERED_SHARE`); without the copy a query gathers its cells' rows."""

    def __init__(self, vectors: np.ndarray, centroids: np.ndarray, rows: np.ndarray, offsets: np.ndarray,
                 ordered: bool | None = None) -> None:
        self.vectors, self.centroids, self.rows, self.offsets = vectors, centroids, rows, offsets
        self.centroid_columns = np.ascontiguousarray(centroids.T)
        self.centroid_norms = np.einsum("cd,cd->c", centroids, centroids)
        self.norms = np.einsum("kd,kd->k", vectors, vectors)
        if ordered is None:
            ordered = vectors.nbytes + self.norms.nbytes <= ORDERED_SHARE * available_memory()
        self.cell_vectors: np.ndarray | None = vectors[rows] if ordered else None
        self.cell_norms: np.ndarray | None = self.norms[rows] if ordered else None

    @classmethod
    def trained(cls, vectors: np.ndarray, cells: int | None = None, seed: int = 0,
                ordered: bool | None = None) -> Lists:
        """Lists of ``vectors`` with a quantizer trained on them (:func:`cells_of`)."""
        return cls(vectors, *cells_of(vectors, cells, seed), ordered=ordered)

    @classmethod
    def of_cells(cls, vectors: np.ndarray, centroids: np.ndarray, cell: np.ndarray,
                 ordered: bool | None = None) -> Lists:
        """Lists of ``vectors`` (K, D) whose rows lie in cells ``cell`` (K,) of ``centroids`` (C, D)."""
        return cls(vectors, centroids, *grouped(cell, len(centroids)), ordered=ordered)

    def probed(self, variants: np.ndarray, probe: int | None = None) -> np.ndarray:
        """The ``probe`` cells (:func:`probe_count` by default) nearest to any of ``variants`` (V, D), in order."""
        d2 = self.centroid_norms - 2.0 * (variants @ self.centroid_columns).max(axis=0)
        p = min(probe or probe_count(len(d2)), len(d2))
        return np.sort(np.argpartition(d2, p - 1)[:p])

    def query(self, variants: np.ndarray, count: int, probe: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Rows (atlas order) and squared distances less |q|², nearest first (see :func:`nearest_rows`):
        the ``probe`` cells nearest to any variant are scanned (:func:`probe_count` by default)."""
        with single_threaded():  # small products (~10⁴–10⁵ rows): OpenBLAS's threads cost 2–5× on a loaded machine
            spans = [slice(self.offsets[c], self.offsets[c + 1]) for c in self.probed(variants, probe)]
            at = np.concatenate([self.rows[s] for s in spans])  # atlas rows, cell by cell
            if self.cell_vectors is not None and self.cell_norms is not None:  # contiguous runs of the copy
                x = np.concatenate([self.cell_vectors[s] for s in spans])
                norms = np.concatenate([self.cell_norms[s] for s in spans])
            else:
                x, norms = self.vectors[at], self.norms[at]
            found, dist = nearest_rows(variants, x.T, norms, count)
        return at[found], dist


def _nearest(vectors: np.ndarray, centroids: np.ndarray, block: int = 32768) -> np.ndarray:
    """The nearest centroid (K,) of each of ``vectors`` (K, D), in blocks (memory: block × cells)."""
    c2 = np.einsum("cd,cd->c", centroids, centroids)
    out = np.empty(len(vectors), dtype=np.int64)
    for start in range(0, len(vectors), block):
        out[start:start + block] = np.argmin(c2 - 2.0 * vectors[start:start + block] @ centroids.T, axis=1)
    return out


class Index:
    """An atlas's index descriptors, ready for queries: scanned whole, or for a family of more than
    ``scan_limit`` linkages through :class:`Lists` — a sharded family's stored quantizer and cells, else
    one trained here (``ordered``: as :class:`Lists`')."""

    def __init__(self, atlas: Atlas, scan_limit: int = SCAN_LIMIT, ordered: bool | None = None) -> None:
        self.names = list(atlas.families)
        self.lists: list[Lists | None] = []
        self.columns: list[np.ndarray | None] = []
        self.norms: list[np.ndarray | None] = []
        for name in self.names:
            arrays = atlas.families[name]
            v = arrays["index"]
            scanned = len(v) <= scan_limit
            self.lists.append(None if scanned else Lists.of_cells(v, arrays["centroids"], arrays["cell"], ordered)
                              if "cell" in arrays else Lists.trained(v, ordered=ordered))
            self.norms.append(np.einsum("kd,kd->k", v, v) if scanned else None)
            self.columns.append(np.ascontiguousarray(v.T) if scanned else None)  # (D, K): the product runs along K

    def query(self, variants: np.ndarray, count: int) -> list[Hit]:
        """The ``count`` nearest linkages over all families, nearest first."""
        q2 = float(np.sum(variants[0].astype(float) ** 2))
        hits: list[Hit] = []
        for name, columns, norm, lists in zip(self.names, self.columns, self.norms, self.lists):
            if lists is not None:
                rows, d2 = lists.query(variants, count)
            else:
                assert columns is not None and norm is not None  # scanned whole
                rows, d2 = nearest_rows(variants, columns, norm, count)
            hits += [Hit(name, int(r), float(np.sqrt(max(d + q2, 0.0)))) for r, d in zip(rows, d2)]
        hits.sort(key=lambda h: h.distance)
        return hits[:count]
