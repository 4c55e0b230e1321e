"""Everything the comparison needs about a stack of curves, computed as array operations."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.curves.efd import curve_efd
from linkedit.curves.features import feature_names, feature_table, turning_angles
from linkedit.curves.normalize import Normalized, normalize

DEFAULT_SAMPLES = 64
DEFAULT_HARMONICS = 10
#: Curves per block: the working arrays of a block stay in the CPU cache.
BLOCK = 256


@dataclass(frozen=True)
class Descriptors:
    """Descriptors of C curves resampled at N points in D dimensions."""

    names: tuple[str, ...]  #: per-curve feature names (columns of ``features``)
    features: np.ndarray  #: (C, F) per-curve features
    normalized: Normalized  #: resampled normalized curves (``normalized.points`` is (C, N, D))
    turning: np.ndarray  #: (C, N) turning angles, radians
    efd: np.ndarray  #: (C, H, 4) normalized elliptic Fourier descriptors

    @property
    def points(self) -> np.ndarray:
        return self.normalized.points

    @property
    def closed(self) -> np.ndarray:
        return self.normalized.closed

    def __len__(self) -> int:
        return len(self.features)

    def take(self, index: np.ndarray | list[int]) -> "Descriptors":
        """The descriptors of a subset of the curves, in the given order."""
        idx = np.asarray(index, dtype=int)
        n = self.normalized
        sub = Normalized(*(getattr(n, f)[idx] for f in n.__dataclass_fields__))
        return Descriptors(self.names, self.features[idx], sub, self.turning[idx], self.efd[idx])


def describe(points: np.ndarray, closed: np.ndarray | bool, *, samples: int = DEFAULT_SAMPLES,
             harmonics: int = DEFAULT_HARMONICS, anchors: np.ndarray | None = None) -> Descriptors:
    """Describe a stack of curves ``points`` (C, M, D) in blocks of curves (see :func:`normalize`)."""
    points = np.asarray(points, dtype=float)
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), points.shape[:1])
    if len(points) > BLOCK:
        return concatenate([describe(points[i:i + BLOCK], closed[i:i + BLOCK], samples=samples, harmonics=harmonics,
                                     anchors=None if anchors is None else anchors[i:i + BLOCK])
                            for i in range(0, len(points), BLOCK)])
    norm = normalize(points, closed, samples, anchors)
    dim = norm.points.shape[2]
    return Descriptors(names=feature_names(dim, anchors is not None), features=feature_table(norm, anchors),
                       normalized=norm, turning=turning_angles(norm.points, norm.closed),
                       efd=curve_efd(norm.points, norm.closed, harmonics))


def describe_ragged(curves: list[np.ndarray], closed: list[bool], *, samples: int = DEFAULT_SAMPLES,
                    harmonics: int = DEFAULT_HARMONICS, anchors: list[np.ndarray] | None = None) -> Descriptors:
    """Describe curves of different point counts (all of one dimension): one stack per count."""
    dims = {c.shape[1] for c in curves}
    if len(dims) != 1:
        raise ValueError("curves of one comparison must all be 2D or all 3D")
    groups: dict[int, list[int]] = {}
    for i, c in enumerate(curves):
        groups.setdefault(len(c), []).append(i)
    parts, order = [], []
    for idx in groups.values():
        anchor = None if anchors is None else np.stack([anchors[i] for i in idx])
        parts.append(describe(np.stack([curves[i] for i in idx]), np.array([closed[i] for i in idx]),
                              samples=samples, harmonics=harmonics, anchors=anchor))
        order += idx
    inverse = np.argsort(order)
    return concatenate(parts).take(inverse)


def concatenate(parts: list[Descriptors]) -> Descriptors:
    """Stack descriptors of several groups (same dimension, samples, harmonics and features)."""
    if len(parts) == 1:
        return parts[0]
    fields = parts[0].normalized.__dataclass_fields__
    norm = Normalized(*(np.concatenate([getattr(p.normalized, f) for p in parts]) for f in fields))
    return Descriptors(parts[0].names, np.concatenate([p.features for p in parts]), norm,
                       np.concatenate([p.turning for p in parts]), np.concatenate([p.efd for p in parts]))
