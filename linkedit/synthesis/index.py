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
the recall).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.curves.efd import variant_signs
from linkedit.synthesis.atlas import HARMONICS, Atlas, index_efd, index_vector


@dataclass(frozen=True)
class Hit:
    family: str
    row: int
    distance: float  #: Euclidean distance of index descriptors (best variant)


def target_variants(z: np.ndarray) -> np.ndarray:
    """Index descriptors (8, D) float32 of a closed target polyline z (M,) complex, or (M, 3) for a spatial
    atlas (:func:`~linkedit.synthesis.atlas.index_efd`): every sign variant."""
    efd = index_efd(z[None])[0]
    signs = variant_signs(HARMONICS)
    signs = np.concatenate([signs, signs * np.array([1.0, 1.0, -1.0, -1.0])])  # and mirrored
    return index_vector(efd[None] * signs).astype(np.float32)


#: families up to this many linkages are scanned whole (1M in ≤ 50 ms); larger ones through :class:`Lists`
SCAN_LIMIT = 2_000_000
#: cells a query scans per variant (of ~2·√K): the exact top-10 is found ≥ 99 % of the time
PROBE = 16


def nearest_rows(variants: np.ndarray, columns: np.ndarray, norms: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` rows of descriptors ``columns`` (D, K) nearest to any of ``variants`` (V, D),
    and their squared distances less |q|² (|x|² − 2·max_v v·x), nearest first: the one exact ranking."""
    d2 = norms - 2.0 * (variants @ columns).max(axis=0)
    k = min(count, d2.size)
    rows = np.argpartition(d2, k - 1)[:k] if k else np.zeros(0, dtype=int)
    rows = rows[np.argsort(d2[rows], kind="stable")]
    return rows, d2[rows]


class Lists:
    """Inverted lists of descriptors (K, D): ``cells`` k-means centroids (trained on a sample),
    the rows grouped by their nearest centroid. :meth:`query` scans the ``probe`` cells nearest to
    each variant and ranks those rows exactly (:func:`nearest_rows`)."""

    def __init__(self, vectors: np.ndarray, cells: int | None = None, seed: int = 0) -> None:
        count = len(vectors)
        cells = min(cells or int(np.clip(2.0 * np.sqrt(count), 1, 16384)), count)
        rng = np.random.default_rng(seed)
        sample = vectors[np.sort(rng.choice(count, min(count, 20 * cells), replace=False))]
        centroids = sample[rng.choice(len(sample), cells, replace=False)].astype(np.float32)
        for _ in range(8):  # Lloyd's iterations on the sample (a cell left empty keeps its centroid)
            cell = _nearest(sample, centroids)
            sums = np.zeros_like(centroids)
            np.add.at(sums, cell, sample)
            size = np.bincount(cell, minlength=cells)
            full = size > 0
            centroids[full] = sums[full] / size[full, None]
        self.centroids = centroids
        cell = _nearest(vectors, centroids)
        self.rows = np.argsort(cell, kind="stable")
        self.offsets = np.searchsorted(cell[self.rows], np.arange(cells + 1))
        ordered = vectors[self.rows]
        self.columns = np.ascontiguousarray(ordered.T)
        self.norms = np.einsum("kd,kd->k", ordered, ordered)

    def query(self, variants: np.ndarray, count: int, probe: int = PROBE) -> tuple[np.ndarray, np.ndarray]:
        """Rows (atlas order) and squared distances less |q|², nearest first (see :func:`nearest_rows`)."""
        d2 = np.einsum("cd,cd->c", self.centroids, self.centroids)[None] - 2.0 * variants @ self.centroids.T  # (V, C)
        p = min(probe, d2.shape[1])
        cells = np.unique(np.argpartition(d2, p - 1, axis=1)[:, :p])
        spans = [np.arange(self.offsets[c], self.offsets[c + 1]) for c in cells]
        at = np.concatenate(spans) if spans else np.zeros(0, dtype=int)
        found, dist = nearest_rows(variants, self.columns[:, at], self.norms[at], count)
        return self.rows[at[found]], dist


def _nearest(vectors: np.ndarray, centroids: np.ndarray, block: int = 32768) -> np.ndarray:
    """The nearest centroid (K,) of each of ``vectors`` (K, D), in blocks (memory: block × cells)."""
    c2 = np.einsum("cd,cd->c", centroids, centroids)
    out = np.empty(len(vectors), dtype=np.int64)
    for start in range(0, len(vectors), block):
        out[start:start + block] = np.argmin(c2 - 2.0 * vectors[start:start + block] @ centroids.T, axis=1)
    return out


class Index:
    """An atlas's index descriptors, ready for queries: scanned whole, or through :class:`Lists`
    for a family of more than SCAN_LIMIT linkages."""

    def __init__(self, atlas: Atlas, scan_limit: int = SCAN_LIMIT) -> None:
        self.names = list(atlas.families)
        vectors = [atlas.families[n]["index"] for n in self.names]
        self.lists = [Lists(v) if len(v) > scan_limit else None for v in vectors]
        self.norms = [np.einsum("kd,kd->k", v, v) if ls is None else None for v, ls in zip(vectors, self.lists)]
        self.columns = [np.ascontiguousarray(v.T) if ls is None else None  # (D, K): the product runs along K
                        for v, ls in zip(vectors, self.lists)]

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
