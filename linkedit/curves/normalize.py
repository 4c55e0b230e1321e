"""Normalization of a stack of curves (C curves of M points in D = 2 or 3 dimensions).

A curve is the polyline through its points (closed curves include the segment from the last
point back to the first). Every quantity here is exact for that polyline, so inserting points
on it, starting it at another point or reversing it changes nothing:

* the points are first moved and scaled into their bounding box (centre 0, largest side 1), so
  no square under- or overflows, whatever the units; results are reported in input units;
* the centroid, principal axes and third moments are those of the polyline as a uniform wire
  (integrated segment by segment, not averaged over the points);
* the principal frame is a proper rotation (det = +1), axes ordered by decreasing second
  moment, each axis signed so the third moment along it is positive, except the least skewed
  axis, which makes det = +1. An axis whose skewness is below ``SKEWED`` (a centrally
  symmetric curve: rounding would pick the sign) is signed, when an anchor is given, so the
  anchor lies on its positive side (major axis first);
* a nearly isotropic curve (second moments within ``ISOTROPIC`` of each other, like a rounded
  triangle) has arbitrary principal axes: its major axis is turned (in the plane of the first
  two axes) towards the vertex farthest from the centroid, which turns with the curve;
* the scale is the extent of the curve along the major axis; the length is that of the
  resampled polyline (an input with noise or many tiny zigzags does not inflate it);
* closed curves are resampled from a canonical start, open ones from their first to their last
  point, at N points equally spaced in arc length. The start of a closed curve is the point of
  greatest distance r from the centroid, located between input points: the farthest vertex
  (the polyline's maximum of r is always a vertex), moved to the peak of the parabola through
  r² there and half a resampling step either side along the polyline. A smooth curve sampled
  more densely thus moves its start by much less than half an input step. A farthest vertex
  where the curve reverses along itself (turning by more than ``CUSP_TURN``, like a rocker's
  path) stays the start: the samples then include the reversal point instead of straddling it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Extents below this fraction of the major extent count as zero (a straight or planar curve).
FLAT = 1e-12
#: Skewness |∫x³ ds| / (∫x² ds)^1.5 below which an axis's sign is left to the anchor.
SKEWED = 1e-9
#: Components of a vector below this fraction of its largest one count as 0 (rounding).
OFF_AXIS = 1e-9
#: A vertex turning by more than this (rad) is a reversal: a start there stays at the vertex.
CUSP_TURN = 5 * np.pi / 6
#: Half-width of the parabola that places the start, in resampling steps.
START_WIDTH = 0.5
#: Second moment ratio (minor / major) above which the principal axes are arbitrary: the
#: major axis is then turned towards the farthest vertex instead.
ISOTROPIC = 0.8


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
        return np.einsum("cd,cde->ce", (anchors - self.centroid) / self.scale[:, None], self.frame)


#: Principal planes whose projected areas are reported: 2D (x, y); 3D xy, yz, xz.
PLANES = {2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 2))}


def normalize(points: np.ndarray, closed: np.ndarray | bool, samples: int = 64,
              anchors: np.ndarray | None = None) -> Normalized:
    """Normalize a stack of curves ``points`` (C, M, D), ``closed`` (C,) or one flag for all.

    ``anchors`` (C, D), input units, sign the axes of centrally symmetric curves (see above).
    Every curve must have a positive length (the loaders check it); a curve spanning more than
    the float range gives NaN (callers check the results).
    """
    p = np.array(np.asarray(points, dtype=float).transpose(0, 2, 1), order="C")  # (C, D, M): fast reductions
    n_curves, dim, m = p.shape
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), (n_curves,))

    # bounding box: centre and largest side, input units; from here on p is in box units
    lo, hi = p.min(axis=2), p.max(axis=2)
    box_centre = 0.5 * lo + 0.5 * hi
    with np.errstate(over="ignore"):
        box = (hi - lo).max(axis=1)
    p -= box_centre[:, :, None]
    with np.errstate(invalid="ignore"):
        p /= box[:, None, None]

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
    anchored = None if anchors is None else \
        (np.asarray(anchors, dtype=float) - box_centre) / box[:, None] - centroid
    signs = _axis_signs(frame, eigval, third, anchored)
    frame = frame * signs[:, None, :]
    x *= signs[:, :, None]
    step_f *= signs[:, :, None]
    x_next = x + step_f

    iso = eigval[:, 1] >= ISOTROPIC * eigval[:, 0]
    if iso.any():
        turn = _toward_farthest(x[iso])  # (I, D, D)
        frame[iso] = frame[iso] @ turn
        x[iso] = turn.transpose(0, 2, 1) @ x[iso]
        step_f[iso] = turn.transpose(0, 2, 1) @ step_f[iso]
        x_next = x + step_f

    extents = x.max(axis=2) - x.min(axis=2)
    scale = extents[:, 0].copy()
    rel = extents / scale[:, None]
    rel[rel < FLAT] = 0.0
    areas = np.stack([0.5 * np.abs(np.sum(x[:, i] * x_next[:, j] - x_next[:, i] * x[:, j], axis=1))
                      for i, j in PLANES[dim]], axis=1) / scale[:, None] ** 2

    frac = np.zeros((n_curves, m + 1))  # arc length at each vertex / total (vertex m: back to the start)
    np.cumsum(seg, axis=1, out=frac[:, 1:])
    frac /= total[:, None]
    start = np.where(closed, _closed_start(x, x_next, step_f, seg, frac, START_WIDTH / samples), 0.0)
    resampled = _resample(x, x_next, frac, closed, start, samples) / scale[:, None, None]
    edges = np.diff(resampled, axis=2, append=resampled[:, :, :1])
    edge_length = np.sqrt(np.einsum("cdn,cdn->cn", edges, edges))
    edge_length[~closed, -1] = 0.0
    return Normalized(points=np.ascontiguousarray(resampled.transpose(0, 2, 1)), closed=closed.copy(),
                      centroid=box_centre + centroid * box[:, None], frame=frame, scale=scale * box,
                      length=edge_length.sum(axis=1), extents=rel, areas=areas)


def _toward_farthest(x: np.ndarray) -> np.ndarray:
    """Rotations (C, D, D) in the plane of the first two axes that turn the first axis towards
    each curve's farthest vertex from the centroid (x: (C, D, M) centred, principal frame)."""
    r2 = np.einsum("cdm,cdm->cm", x, x)
    near = r2 >= r2.max(axis=1, keepdims=True) * (1.0 - 1e-9)
    vertex = np.argmax(np.where(near, x[:, 0, :], -np.inf), axis=1)
    v = x[np.arange(len(x)), :2, vertex]
    c, s = (v / np.linalg.norm(v, axis=1, keepdims=True)).T
    turn = np.broadcast_to(np.eye(x.shape[1]), (len(x), x.shape[1], x.shape[1])).copy()
    turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1] = c, -s, s, c
    return turn


def _axis_signs(frame: np.ndarray, eigval: np.ndarray, third: np.ndarray, anchored: np.ndarray | None) -> np.ndarray:
    """Signs (C, D) of the principal axes: by third moment, by anchor where that is ~0, det = +1.

    The axis left to the determinant is the least skewed one, or among axes signed by the
    anchor the most minor one, so the anchor signs the major axis first.
    """
    n_curves, dim = third.shape
    skew = np.abs(third) / np.maximum(eigval, 1e-12 * eigval[:, :1]) ** 1.5
    decided = skew > SKEWED
    key = third
    rank = np.where(decided, 2.0 + skew, skew)  # argmin → the axis signed by the determinant
    if anchored is not None:
        q = np.einsum("cd,cde->ce", anchored, frame)
        with np.errstate(invalid="ignore"):
            off = np.abs(q) > OFF_AXIS * np.abs(q).max(axis=1, keepdims=True)
        by_anchor = ~decided & off
        key = np.where(by_anchor, q, third)
        rank = np.where(by_anchor, 1.0 + (dim - np.arange(dim)) / (dim + 1.0), rank)
    signs = np.where(key >= 0.0, 1.0, -1.0)
    signs[np.arange(n_curves), np.argmin(rank, axis=1)] *= np.sign(np.linalg.det(frame)) * np.prod(signs, axis=1)
    return signs


def _closed_start(x: np.ndarray, x_next: np.ndarray, step: np.ndarray, seg: np.ndarray, frac: np.ndarray,
                  width: float) -> np.ndarray:
    """Start of closed curves as a fraction of their length (C,): see the module docstring.

    The vertex farthest from the centroid (ties: the one with the largest first principal
    coordinate), moved to the peak of the parabola through r² there
    and at ± ``width`` (a fraction of the length) along the polyline, unless it is a reversal.
    """
    rows = np.arange(len(x))
    r2 = np.einsum("cdm,cdm->cm", x, x)
    # vertices tied for farthest (to rounding) are told apart by the first principal coordinate,
    # so the choice does not depend on the input's start index
    near = r2 >= r2.max(axis=1, keepdims=True) * (1.0 - 1e-9)
    vertex = np.argmax(np.where(near, x[:, 0, :], -np.inf), axis=1)
    at = frac[rows, vertex]
    side = _points_at(x, x_next, frac, (at[:, None] + np.array([-width, width])) % 1.0)  # (C, D, 2)
    drop = r2[rows, vertex][:, None] - np.einsum("cdk,cdk->ck", side, side)  # ≥ 0: the polyline's maximum is a vertex
    total = drop.sum(axis=1)
    shift = np.divide(width * (drop[:, 0] - drop[:, 1]), 2.0 * total, out=np.zeros_like(total), where=total > 0)
    before, after = step[rows, :, vertex - 1], step[rows, :, vertex]
    cusp = np.einsum("cd,cd->c", before, after) < np.cos(CUSP_TURN) * seg[rows, vertex - 1] * seg[rows, vertex]
    return np.where(cusp, at, (at + shift) % 1.0)


def _resample(x: np.ndarray, x_next: np.ndarray, frac: np.ndarray, closed: np.ndarray, start: np.ndarray,
              samples: int) -> np.ndarray:
    """Points (C, D, N) at equal arc length: closed k L / N from ``start`` (a fraction of L), open k L / (N - 1)."""
    k = np.arange(samples)
    return _points_at(x, x_next, frac, np.where(closed[:, None], (k / samples + start[:, None]) % 1.0,
                                                k / max(samples - 1, 1)))


def _points_at(x: np.ndarray, x_next: np.ndarray, frac: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Points (C, D, K) of the polylines at arc-length fractions ``target`` (C, K) in [0, 1]."""
    n_curves, _, m = x.shape
    # ``frac`` made globally increasing (row r lives in [2r, 2r + 1]) so one searchsorted serves all curves
    offset = 2.0 * np.arange(n_curves)[:, None]
    pos = np.searchsorted((frac + offset).ravel(), (target + offset).ravel(), side="right").reshape(target.shape)
    index = np.clip(pos - 1 - (m + 1) * np.arange(n_curves)[:, None], 0, m - 1)
    s0 = np.take_along_axis(frac, index, axis=1)
    length = np.take_along_axis(frac, index + 1, axis=1) - s0
    t = np.divide(target - s0, length, out=np.zeros_like(length), where=length > 0)
    t = np.clip(t, 0.0, 1.0)[:, None, :]
    a = np.take_along_axis(x, index[:, None, :], axis=2)
    b = np.take_along_axis(x_next, index[:, None, :], axis=2)
    return a + t * (b - a)
