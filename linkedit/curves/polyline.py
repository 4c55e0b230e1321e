"""Polylines: resampling by arc length and point-to-polyline distances, the one place for both.

A curve is planar, (..., M) complex, or spatial, (..., M, D) real; leading axes are a batch of curves,
evaluated at once (no loop over curves). A closed polyline includes the segment from its last point back
to its first.
"""

from __future__ import annotations

import numpy as np


def _inner(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of points: planar (...) complex or spatial (..., D) real → (...)."""
    return a.real * b.real + a.imag * b.imag if np.iscomplexobj(a) else np.sum(a * b, axis=-1)


def _norm(a: np.ndarray) -> np.ndarray:
    """Lengths of points: planar (...) complex or spatial (..., D) real → (...)."""
    return np.abs(a) if np.iscomplexobj(a) else np.sqrt(np.sum(a * a, axis=-1))


def _scaled(t: np.ndarray, e: np.ndarray) -> np.ndarray:
    """t (...) times the points e: planar (...) complex or spatial (..., D)."""
    return t * e if np.iscomplexobj(e) else t[..., None] * e


def _segments(s: np.ndarray, at: np.ndarray, step: np.ndarray) -> np.ndarray:
    """For rows s (R, M) non-decreasing from 0 and at (R, K) ≈ k · step (R, 1), ≥ 0 and non-decreasing: the
    flat index r·M + j of the last s[r, j] ≤ at[r, k], as :func:`numpy.searchsorted` (side right) less one →
    (R, K) int. Counted from how many grid points lie below each vertex (≈ ⌈s / step⌉, one histogram over all
    rows), then moved to the exact index by comparing at with s itself."""
    n_rows, m = s.shape
    count = at.shape[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        below = np.nan_to_num(np.clip(np.ceil(s / np.where(step > 0, step, np.inf)), 0, count)).astype(np.intp)
    hist = np.bincount((below + (count + 1) * np.arange(n_rows)[:, None]).ravel(), minlength=n_rows * (count + 1))
    first = m * np.arange(n_rows)[:, None]
    j = np.cumsum(hist.reshape(n_rows, count + 1)[:, :count], axis=1) - 1 + first  # vertices not above grid point k
    np.minimum(np.maximum(j, first, out=j), first + m - 1, out=j)
    flat_s = s.ravel()
    while True:
        up = (j < first + m - 1) & (np.take(flat_s, np.minimum(j + 1, flat_s.size - 1)) <= at)
        down = (j > first) & (np.take(flat_s, j) > at)
        if not (up.any() or down.any()):
            return j
        j += up
        j -= down


def arc_resample(z: np.ndarray, count: int, closed: bool) -> np.ndarray:
    """``count`` points equally spaced in arc length along the polylines z: planar (..., M) complex or spatial
    (..., M, D) real → (..., count) or (..., count, D); a closed one from z[0] round to it (spacing L / count), an
    open one from its first point to its last (spacing L / (count − 1)). Each curve's points are those of
    :func:`numpy.interp` over its cumulative lengths, bit for bit (each coordinate apart)."""
    planar = np.iscomplexobj(z)
    ax = -1 if planar else -2
    pts = np.concatenate([z, np.take(z, [0], axis=ax)], axis=ax) if closed else z
    lead, n = pts.shape[:ax], pts.shape[ax]
    coords = np.ascontiguousarray(pts).view(float).reshape(*lead, n, 2) if planar else pts
    coords = coords.reshape(-1, n, coords.shape[-1])  # (R, n, D)
    steps = _norm(np.diff(pts, axis=ax)).reshape(len(coords), n - 1)
    s = np.zeros((len(coords), n))
    np.cumsum(steps, axis=1, out=s[:, 1:])
    total = s[:, -1:]
    spaces = count if closed else count - 1
    step = total / spaces if spaces > 0 else np.zeros_like(total)
    at = np.arange(count) * step
    if not closed and count > 1:
        at[:, -1] = total[:, 0]  # as numpy.linspace: the end exactly
    # numpy.interp: slope · (x − xⱼ) + yⱼ on the segment j with xⱼ ≤ x < xⱼ₊₁; from the end on, the last point
    # (slope 0)
    slope = np.zeros_like(coords)
    with np.errstate(divide="ignore", invalid="ignore"):  # zero-length segments: never taken
        np.divide(np.diff(coords, axis=1), np.diff(s, axis=1)[..., None], out=slope[:, :-1])
    j = _segments(s, at, step)
    flat = (len(coords) * n, coords.shape[-1])
    out = np.take(slope.reshape(flat), j, axis=0)
    out *= (at - np.take(s, j))[..., None]
    out += np.take(coords.reshape(flat), j, axis=0)
    if planar:
        return out.view(complex).reshape(*lead, count)
    return out.reshape(*lead, count, coords.shape[-1])


def distances_to(points: np.ndarray, curve: np.ndarray, closed: bool) -> np.ndarray:
    """Distance of each of ``points`` to the polyline ``curve``: planar (..., N) and (..., M) complex, or spatial
    (..., N, D) and (..., M, D) real → (..., N)."""
    ax = -1 if np.iscomplexobj(curve) else -2  # the axis along the polyline
    m = curve.shape[ax]
    a = curve if closed else np.take(curve, np.arange(m - 1), axis=ax)
    b = np.roll(curve, -1, axis=ax) if closed else np.take(curve, np.arange(1, m), axis=ax)
    e = np.expand_dims(b - a, ax - 1)
    length2 = np.maximum(_inner(e, e), 1e-300)
    rel = np.expand_dims(points, ax) - np.expand_dims(a, ax - 1)
    t = np.clip(_inner(rel, e) / length2, 0.0, 1.0)
    return _norm(rel - _scaled(t, e)).min(axis=-1)


def near_distances(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Distance of ``points`` to a densely sampled closed curve, planar (..., N) and (..., M) complex or spatial
    (..., N, D) and (..., M, D) real → (..., N): the nearest vertex, then the two segments that meet there (the
    fast version of :func:`distances_to`, exact unless a segment passes nearer than both its ends and the next
    vertex)."""
    planar = np.iscomplexobj(curve)
    if planar:
        dx = points.real[..., :, None] - curve.real[..., None, :]
        dy = points.imag[..., :, None] - curve.imag[..., None, :]
        dx *= dx
        dy *= dy
        dx += dy
    else:
        gap = points[..., :, None, :] - curve[..., None, :, :]
        dx = np.einsum("...d,...d->...", gap, gap)
    j = np.argmin(dx, axis=-1)  # (..., N)
    m = curve.shape[-1 if planar else -2]
    best = np.full(j.shape, np.inf)
    for k in (j - 1, j):
        at, after = (k % m, (k + 1) % m) if planar else ((k % m)[..., None], ((k + 1) % m)[..., None])
        a = np.take_along_axis(curve, at, axis=-1 if planar else -2)
        e = np.take_along_axis(curve, after, axis=-1 if planar else -2) - a
        rel = points - a
        t = np.clip(_inner(rel, e) / np.maximum(_inner(e, e), 1e-300), 0, 1)
        best = np.minimum(best, _norm(rel - _scaled(t, e)))
    return best
