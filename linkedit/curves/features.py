"""Per-curve features of normalized curves (after Coros et al. 2013, §5), batched over a stack.

2D: length, area, ellipticity, self-intersections; 3D: length, the areas and ellipticities of
the three principal-plane projections (xy, yz, xz), self-intersections of the projection onto
the principal plane. Optional: distance and angle of an anchor point (e.g. the crank axle).
Lengths are in units of the major extent; angles in radians.
"""

from __future__ import annotations

import numpy as np

from linkedit.curves.normalize import Normalized

#: Per-curve feature names by dimension (the anchor pair is appended when anchors are given).
SHAPE_FEATURES = {
    2: ("length", "area", "ellipticity", "self_intersections"),
    3: ("length", "area_xy", "area_yz", "area_xz", "ellipticity_xy", "ellipticity_yz", "ellipticity_xz",
        "self_intersections"),
}
ANCHOR_FEATURES = ("anchor_distance", "anchor_angle")
#: Features whose differences wrap around (angles, radians).
ANGULAR = frozenset({"anchor_angle"})
#: Curves per block in :func:`self_intersections`.
CROSSING_BLOCK = 128
#: Distance (relative to the major extent) within which a point counts as on a segment's line.
ON_LINE = 1e-12
#: Turning angles within this of -π are reversals and count as +π.
CUSP = 1e-9


def feature_names(dim: int, anchored: bool) -> tuple[str, ...]:
    """The columns of :func:`feature_table` for curves of dimension ``dim``."""
    return SHAPE_FEATURES[dim] + (ANCHOR_FEATURES if anchored else ())


def ellipticities(extents: np.ndarray) -> np.ndarray:
    """Minor / major extent per principal plane, (C, P); 0 when both extents are 0."""
    dim = extents.shape[1]
    pairs = ((0, 1),) if dim == 2 else ((0, 1), (1, 2), (0, 2))
    major = np.stack([extents[:, i] for i, _ in pairs], axis=1)
    minor = np.stack([extents[:, j] for _, j in pairs], axis=1)
    return np.divide(minor, major, out=np.zeros_like(minor), where=major > 0)


def self_intersections(points: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Crossings between non-adjacent segments of planar polylines (C, N, 2) → (C,) int.

    Segment i runs from point i to point i+1 (the last closes the curve if ``closed``).
    Segments i and j cross when each one's end points lie on both sides of the other's line.
    A point on a line (within ``ON_LINE`` × the segment's size, i.e. rounding noise) counts as
    lying on its right: a crossing through a sample point is counted once, collinear pieces
    (straight stretches of the input) never.
    """
    n_curves, n, _ = points.shape
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), (n_curves,))
    counts = np.zeros(n_curves, dtype=np.int64)
    masks = {flag: _pair_mask(n, flag) for flag in (True, False)}
    for first in range(0, n_curves, CROSSING_BLOCK):  # blocks: the (B, N, N) arrays stay in the cache
        block = slice(first, first + CROSSING_BLOCK)
        wrapped = np.concatenate([points[block], points[block, :1]], axis=1)  # (B, N + 1, 2)
        x, y = wrapped[:, :, 0], wrapped[:, :, 1]
        ex, ey = np.diff(x, axis=1), np.diff(y, axis=1)
        # left[b, i, j]: point j lies left of the line of segment i by more than rounding noise:
        # ex_i y_j - ey_i x_j - (ex_i y_i - ey_i x_i + tolerance_i) > 0, one matrix product per curve
        offset = ex * y[:, :-1] - ey * x[:, :-1] + ON_LINE * (np.abs(ex) + np.abs(ey))
        line = np.stack([ex, -ey, -offset], axis=2)  # (B, N, 3)
        point = np.stack([y, x, np.ones_like(x)], axis=1)  # (B, 3, N + 1)
        left = np.matmul(line, point) > 0.0
        straddle = left[:, :, :-1] != left[:, :, 1:]  # segment j's ends on both sides of line i
        mask = np.where(closed[block, None, None], masks[True], masks[False])
        counts[block] = np.count_nonzero(straddle & straddle.transpose(0, 2, 1) & mask, axis=(1, 2))
    return counts


def _pair_mask(n: int, closed: bool) -> np.ndarray:
    """Segment pairs i < j that are not neighbours (and exist: an open curve has n - 1 segments)."""
    i, j = np.triu_indices(n, 2)
    keep = np.ones(i.size, dtype=bool)
    if closed:
        keep &= ~((i == 0) & (j == n - 1))
    else:
        keep &= j < n - 1
    mask = np.zeros((n, n), dtype=bool)
    mask[i[keep], j[keep]] = True
    return mask


def turning_angles(points: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Discrete curvature: the turning angle at every point, (C, N, D) → (C, N), radians.

    2D angles are signed (counter-clockwise positive) in (-π, π], a reversal counting as +π;
    3D angles are unsigned. The end points of an open curve turn by 0.
    """
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), points.shape[:1])
    edge = np.roll(points, -1, axis=1) - points  # edge k: point k → k+1
    before = np.roll(edge, 1, axis=1)  # edge k-1
    dot = np.einsum("cnd,cnd->cn", before, edge)
    if points.shape[2] == 2:
        turn = np.arctan2(before[:, :, 0] * edge[:, :, 1] - before[:, :, 1] * edge[:, :, 0], dot)
        turn[turn < CUSP - np.pi] += 2 * np.pi  # a reversal (±π up to rounding) always turns by +π
    else:
        turn = np.arctan2(np.linalg.norm(np.cross(before, edge), axis=2), dot)
    turn[~closed, 0] = 0.0
    turn[~closed, -1] = 0.0
    return turn


def feature_table(curves: Normalized, anchors: np.ndarray | None = None) -> np.ndarray:
    """The per-curve features, (C, F), columns as :func:`feature_names`.

    ``anchors`` (C, D), input units: the anchor distance is in units of the major extent, the
    angle is measured in the principal plane from the major axis (the anchor signs the axes of
    centrally symmetric curves, see :mod:`linkedit.curves.normalize`).
    """
    cols = [curves.length[:, None], curves.areas, ellipticities(curves.extents),
            self_intersections(curves.points[:, :, :2], curves.closed)[:, None].astype(float)]
    if anchors is not None:
        q = curves.transform(np.asarray(anchors, dtype=float))
        cols += [np.linalg.norm(q, axis=1)[:, None], np.arctan2(q[:, 1], q[:, 0])[:, None]]
    return np.concatenate(cols, axis=1)
