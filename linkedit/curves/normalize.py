"""Normalization of a stack of curves (C curves of M points in D = 2 or 3 dimensions).

A curve is the polyline through its points (closed curves include the segment from the last
point back to the first). Every quantity here is exact for that polyline, so inserting points
on it, starting it at another point or reversing it changes nothing:

* the centroid, principal axes and third moments are those of the polyline as a uniform wire
  (integrated segment by segment, not averaged over the points);
* the principal frame is a proper rotation (det = +1), axes ordered by decreasing second
  moment, signs fixed so the third moment along each axis is positive, except the least
  skewed axis, which makes det = +1;
* the scale is the extent of the curve along the major axis;
* closed curves are resampled from a canonical start (the vertex farthest from the centroid),
  open ones from their first to their last point, at N points equally spaced in arc length.
  (A curve that reverses along itself, like a rocker's path, reverses at such a vertex: the
  samples then include the reversal points instead of straddling them.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Extents below this fraction of the major extent count as zero (a straight or planar curve).
FLAT = 1e-12


@dataclass(frozen=True)
class Normalized:
    """A stack of normalized curves; lengths in units of the major extent unless stated."""

    points: np.ndarray  #: (C, N, D) resampled points, centred, in the principal frame, scaled
    closed: np.ndarray  #: (C,) bool
    centroid: np.ndarray  #: (C, D) wire centroid, input units
    frame: np.ndarray  #: (C, D, D) principal axes as columns (proper rotation)
    scale: np.ndarray  #: (C,) major extent, input units
    length: np.ndarray  #: (C,) polyline length / major extent
    extents: np.ndarray  #: (C, D) extent along each principal axis / major extent (first is 1)
    areas: np.ndarray  #: (C, P) |signed area| of the principal-plane projections / major extent²

    def transform(self, anchors: np.ndarray) -> np.ndarray:
        """Map points given in input units, (C, D), into each curve's normalized frame."""
        return np.einsum("cd,cde->ce", anchors - self.centroid, self.frame) / self.scale[:, None]


#: Principal planes whose projected areas are reported: 2D (x, y); 3D xy, yz, xz.
PLANES = {2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 2))}


def normalize(points: np.ndarray, closed: np.ndarray | bool, samples: int = 64) -> Normalized:
    """Normalize a stack of curves ``points`` (C, M, D), ``closed`` (C,) or one flag for all.

    Every curve must have a positive length (the loaders check it).
    """
    p = np.ascontiguousarray(np.asarray(points, dtype=float).transpose(0, 2, 1))  # (C, D, M): fast reductions
    n_curves, dim, m = p.shape
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), (n_curves,))
    rows = np.arange(n_curves)

    # segment i runs from point i to point i+1 (the last one closes the curve; weight 0 if open)
    step = np.empty_like(p)
    np.subtract(p[:, :, 1:], p[:, :, :-1], out=step[:, :, :-1])
    np.subtract(p[:, :, 0], p[:, :, -1], out=step[:, :, -1])
    seg = np.sqrt(np.einsum("cdm,cdm->cm", step, step))
    seg[~closed, m - 1] = 0.0
    total = seg.sum(axis=1)
    mid = p + 0.5 * step
    centroid = (mid @ seg[:, :, None])[:, :, 0] / total[:, None]

    # second moments of the wire: ∫ x xᵀ ds = Σ l (m mᵀ + d dᵀ / 12) per segment
    mid -= centroid[:, :, None]
    cov = (mid * seg[:, None, :]) @ mid.transpose(0, 2, 1)
    cov += (step * seg[:, None, :]) @ step.transpose(0, 2, 1) / 12.0
    cov /= total[:, None, None]
    eigval, eigvec = np.linalg.eigh(cov)
    eigval, frame = eigval[:, ::-1], eigvec[:, :, ::-1]

    # vertices in the principal frame; third moments ∫ x³ ds = Σ l (m³ + m d² / 4) per segment
    centred = p - centroid[:, :, None]
    x = frame.transpose(0, 2, 1) @ centred
    step_f = frame.transpose(0, 2, 1) @ step
    mid_f = x + 0.5 * step_f
    cube = np.square(step_f)
    cube *= 0.25
    cube += np.square(mid_f)
    cube *= mid_f
    third = (cube @ seg[:, :, None])[:, :, 0] / total[:, None]
    skew = np.abs(third) / np.maximum(eigval, 1e-12 * eigval[:, :1]) ** 1.5
    signs = np.where(third >= 0.0, 1.0, -1.0)
    signs[rows, np.argmin(skew, axis=1)] *= np.sign(np.linalg.det(frame)) * np.prod(signs, axis=1)
    frame = frame * signs[:, None, :]
    x *= signs[:, :, None]
    x_next = x + step_f * signs[:, :, None]

    extents = x.max(axis=2) - x.min(axis=2)
    scale = extents[:, 0].copy()
    rel = extents / scale[:, None]
    rel[rel < FLAT] = 0.0
    areas = np.stack([0.5 * np.abs(np.sum(x[:, i] * x_next[:, j] - x_next[:, i] * x[:, j], axis=1))
                      for i, j in PLANES[dim]], axis=1) / scale[:, None] ** 2

    start = np.where(closed, np.argmax(np.einsum("cdm,cdm->cm", x, x), axis=1), 0)
    resampled = _resample(x, x_next, seg, total, closed, start, samples) / scale[:, None, None]
    return Normalized(points=np.ascontiguousarray(resampled.transpose(0, 2, 1)), closed=closed.copy(), centroid=centroid,
                      frame=frame, scale=scale, length=total / scale, extents=rel, areas=areas)


def _resample(x: np.ndarray, x_next: np.ndarray, seg: np.ndarray, total: np.ndarray, closed: np.ndarray,
              start: np.ndarray, samples: int) -> np.ndarray:
    """Points (C, D, N) at equal arc length: closed k L / N from ``start``, open k L / (N - 1) from point 0."""
    n_curves, dim, m = x.shape
    # cumulative arc length as a fraction of the total, one row per curve, made globally
    # increasing (row r lives in [2r, 2r + 1]) so a single searchsorted serves all curves
    frac = np.zeros((n_curves, m + 1))
    np.cumsum(seg, axis=1, out=frac[:, 1:])
    frac /= total[:, None]
    k = np.arange(samples)
    target = np.where(closed[:, None], k / samples, k / max(samples - 1, 1))
    target = np.where(closed[:, None], (target + frac[np.arange(n_curves), start][:, None]) % 1.0, target)
    offset = 2.0 * np.arange(n_curves)[:, None]
    pos = np.searchsorted((frac + offset).ravel(), (target + offset).ravel(), side="right").reshape(n_curves, samples)
    index = np.clip(pos - 1 - (m + 1) * np.arange(n_curves)[:, None], 0, m - 1)
    s0 = np.take_along_axis(frac, index, axis=1)
    length = np.take_along_axis(seg, index, axis=1) / total[:, None]
    t = np.divide(target - s0, length, out=np.zeros_like(length), where=length > 0)
    t = np.clip(t, 0.0, 1.0)[:, None, :]
    a = np.take_along_axis(x, index[:, None, :], axis=2)
    b = np.take_along_axis(x_next, index[:, None, :], axis=2)
    return a + t * (b - a)
