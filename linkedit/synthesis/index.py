"""The fast query: nearest atlas curves to a target by the index descriptor.

The index descriptor is the arc-length elliptic Fourier descriptor, normalized for start,
rotation and scale (:func:`linkedit.curves.efd.polyline_efd`). Its remaining ambiguities —
start shifted by half a period, direction of travel, and (a four-bar mirrored is still a
four-bar) the mirror image — are sign patterns, applied to the target rather than to the
atlas: one (8, D) × (D, K) product per family (the atlas held transposed, so the product runs
along its long side).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.curves.efd import polyline_efd, variant_signs
from linkedit.synthesis.atlas import HARMONICS, Atlas, index_vector


@dataclass(frozen=True)
class Hit:
    family: str
    row: int
    distance: float  #: Euclidean distance of index descriptors (best variant)


def target_variants(z: np.ndarray) -> np.ndarray:
    """Index descriptors (8, D) float32 of a closed target polyline z (M,) complex: every sign variant."""
    efd = polyline_efd(z[None], HARMONICS)[0]
    signs = variant_signs(HARMONICS)
    signs = np.concatenate([signs, signs * np.array([1.0, 1.0, -1.0, -1.0])])  # and mirrored
    return index_vector(efd[None] * signs).astype(np.float32)


class Index:
    """An atlas's index descriptors with their squared norms, ready for queries."""

    def __init__(self, atlas: Atlas) -> None:
        self.names = list(atlas.families)
        vectors = [atlas.families[n]["index"] for n in self.names]
        self.norms = [np.einsum("kd,kd->k", v, v) for v in vectors]
        self.columns = [np.ascontiguousarray(v.T) for v in vectors]  # (D, K): the product runs along K

    def query(self, variants: np.ndarray, count: int) -> list[Hit]:
        """The ``count`` nearest linkages over all families, nearest first."""
        q2 = float(np.sum(variants[0].astype(float) ** 2))
        hits: list[Hit] = []
        for name, columns, norm in zip(self.names, self.columns, self.norms):
            best = (variants @ columns).max(axis=0)
            d2 = norm - 2.0 * best
            k = min(count, len(d2))
            rows = np.argpartition(d2, k - 1)[:k]
            hits += [Hit(name, int(r), float(np.sqrt(max(d2[r] + q2, 0.0)))) for r in rows]
        hits.sort(key=lambda h: h.distance)
        return hits[:count]
