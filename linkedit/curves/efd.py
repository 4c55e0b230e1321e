"""Elliptic Fourier descriptors (Kuhl & Giardina 1982), batched, normalized for start point,
rotation and scale.

The descriptors of a curve are those of its resampled normalized polyline, parametrized by arc
length (uniform over the samples): exact Fourier coefficients of the piecewise-linear curve,
computed as one matrix product per stack. An open curve is made closed by retracing it
(there and back), which adds no chord. 3D curves use their projection onto the principal plane.

Normalization leaves two ambiguities, start point shifted by half a period and direction of
travel; both act as sign changes of the coefficients (:func:`variant_signs`), and
:func:`efd_distance` takes the smallest distance over them.
"""

from __future__ import annotations

import functools

import numpy as np


@functools.lru_cache(maxsize=32)
def _tables(period: int, harmonics: int) -> np.ndarray:
    """(P, 2H): differences cos φ_p - cos φ_{p-1} and sin φ_p - sin φ_{p-1}, φ_p = 2π n p / P, times P / (2 n² π²)."""
    p = np.arange(1, period + 1)[:, None]
    n = np.arange(1, harmonics + 1)[None, :]
    phi, prev = 2 * np.pi * n * p / period, 2 * np.pi * n * (p - 1) / period
    factor = period / (2 * n**2 * np.pi**2)
    return np.concatenate([(np.cos(phi) - np.cos(prev)) * factor, (np.sin(phi) - np.sin(prev)) * factor], axis=1)


def efd_coefficients(points: np.ndarray, harmonics: int) -> np.ndarray:
    """Coefficients (a, b, c, d) of harmonics 1..H of closed polylines (C, P, 2) → (C, H, 4).

    Point p is reached at parameter p (of a period P); x(t) ≈ Σ a_n cos(2πnt/P) + b_n sin(2πnt/P),
    y(t) ≈ Σ c_n cos + d_n sin.
    """
    n_curves, period, _ = points.shape
    delta = np.roll(points, -1, axis=1) - points  # row p - 1: point p - point p-1, p = 1..P (point P = point 0)
    coeff = (delta.transpose(0, 2, 1) @ _tables(period, harmonics)).reshape(n_curves, 2, 2, harmonics)
    # coeff[c, axis, cos/sin, n] → (a, b, c, d) = (x cos, x sin, y cos, y sin)
    return coeff.transpose(0, 3, 1, 2).reshape(n_curves, harmonics, 4)


def normalize_efd(coeffs: np.ndarray) -> np.ndarray:
    """Kuhl–Giardina normalization, (C, H, 4) → (C, H, 4) with a1 = 1, b1 = c1 = 0.

    Start point: the first harmonic's ellipse starts at its major axis; rotation: major axis
    along x; scale: semi-major axis 1. This needs an elliptic (not circular, not vanishing)
    first harmonic; a curve traced twice per cycle has none and its descriptors stay finite
    but are not normalized.
    """
    a, b, c, d = (coeffs[:, :, i] for i in range(4))
    a1, b1, c1, d1 = a[:, 0], b[:, 0], c[:, 0], d[:, 0]
    theta = 0.5 * np.arctan2(2 * (a1 * b1 + c1 * d1), a1**2 - b1**2 + c1**2 - d1**2)
    n = np.arange(1, coeffs.shape[1] + 1)[None, :]
    cos, sin = np.cos(n * theta[:, None]), np.sin(n * theta[:, None])
    a_s, b_s = a * cos + b * sin, b * cos - a * sin
    c_s, d_s = c * cos + d * sin, d * cos - c * sin
    psi = np.arctan2(c_s[:, 0], a_s[:, 0])
    # a curve traced twice per cycle has no first harmonic: keep it finite (its EFD is not normalized)
    semi_major = np.maximum(np.hypot(a_s[:, 0], c_s[:, 0]), 1e-9 * np.sqrt(np.sum(coeffs**2, axis=(1, 2))) + 1e-300)
    cp, sp = (np.cos(psi) / semi_major)[:, None], (np.sin(psi) / semi_major)[:, None]
    return np.stack([cp * a_s + sp * c_s, cp * b_s + sp * d_s, cp * c_s - sp * a_s, cp * d_s - sp * b_s], axis=2)


def curve_efd(points: np.ndarray, closed: np.ndarray, harmonics: int) -> np.ndarray:
    """Normalized descriptors of resampled curves (C, N, D) → (C, H, 4); open curves retraced."""
    planar = points[:, :, :2]
    closed = np.broadcast_to(np.asarray(closed, dtype=bool), points.shape[:1])
    out = np.empty((points.shape[0], harmonics, 4))
    if closed.any():
        out[closed] = normalize_efd(efd_coefficients(planar[closed], harmonics))
    if (~closed).any():
        there = planar[~closed]
        out[~closed] = normalize_efd(efd_coefficients(np.concatenate([there, there[:, -2:0:-1]], axis=1), harmonics))
    return out


@functools.lru_cache(maxsize=32)
def variant_signs(harmonics: int) -> np.ndarray:
    """(4, H, 4) sign patterns: identity, half-period start shift, reversed, both."""
    n = np.arange(1, harmonics + 1)[:, None]
    half = np.broadcast_to((-1.0) ** (n + 1), (harmonics, 4))
    reverse = np.broadcast_to(np.array([1.0, -1.0, 1.0, -1.0]), (harmonics, 4))
    ones = np.ones((harmonics, 4))
    return np.stack([ones, half, reverse, half * reverse])


#: Numbers of the differences formed per block in :func:`efd_distance` (bounds memory).
EFD_BLOCK = 1 << 21


def efd_distance(a: np.ndarray, b: np.ndarray, *, mirror: bool = False) -> np.ndarray:
    """Euclidean distance of normalized descriptors, smallest over the variants: (Ca, H, 4), (Cb, H, 4) → (Ca, Cb).

    ``mirror`` also compares the mirror image (y → -y in the normalized frame: c, d negated).
    """
    fa, fb = a.reshape(len(a), -1), b.reshape(len(b), -1)
    signs = variant_signs(a.shape[1])
    if mirror:
        signs = np.concatenate([signs, signs * np.array([1.0, 1.0, -1.0, -1.0])])
    signs = signs.reshape(len(signs), -1)
    best = np.argmax(np.stack([fa @ (fb * s).T for s in signs]), axis=0)
    out = np.empty(best.shape)
    rows = max(1, EFD_BLOCK // max(fb.size, 1))
    for start in range(0, len(fa), rows):  # summed from the differences: one shape scores 0 to rounding
        diff = fa[start:start + rows, None] - fb[None] * signs[best[start:start + rows]]
        out[start:start + rows] = np.sqrt(np.einsum("abk,abk->ab", diff, diff))
    return out


def polyline_efd(z: np.ndarray, harmonics: int) -> np.ndarray:
    """Normalized descriptors of closed planar polylines z (C, M) complex, parametrized by arc
    length → (C, H, 4): the fast index descriptor of :mod:`linkedit.synthesis`.

    Kuhl–Giardina's sums with the true cumulative chord length t_p (period 1), so the points
    need not be equally spaced (e.g. a linkage sampled uniformly in crank angle). Summed by
    parts, harmonic n is Σ_p w_p e^{2πi n t_p} / (2n²π²) with w_p the change of slope dz/dt
    at vertex p: one cos/sin per vertex, the harmonics by the angle-addition recurrence, one
    batched matrix product — the trigonometric table and the product in float32 (descriptors
    good to ~1e-6, plenty for an index; :func:`efd_coefficients` is the exact one). The slopes
    are taken per unit of length (dz/dt over the curve's length: unit vectors), which scales every
    coefficient by the same factor the normalization removes: the float32 product sees numbers of
    order 1 whatever the curve's units.
    """
    delta = np.roll(z, -1, axis=1) - z  # segment p: vertex p → p+1 (the last closes the curve)
    seg = np.abs(delta)
    total = seg.sum(axis=1, keepdims=True)
    t = np.cumsum(seg, axis=1)
    t *= 2.0 * np.pi / total  # angle at vertex p+1 (the last is 2π: vertex 0)
    slope = np.divide(delta, seg, out=np.zeros_like(delta), where=seg > 0)
    w = slope - np.roll(slope, -1, axis=1)  # at vertex p+1: slope_p − slope_{p+1}
    angle = t.astype(np.float32)
    trig = np.empty((2 * harmonics, len(z), z.shape[1]), dtype=np.float32)  # rows 2n, 2n+1: cos, sin of (n+1)·t
    np.cos(angle, out=trig[0])
    np.sin(angle, out=trig[1])
    c1, s1 = trig[0], trig[1]
    tmp = np.empty_like(c1)
    for n in range(1, harmonics):
        c, s = trig[2 * n - 2], trig[2 * n - 1]
        np.multiply(c, c1, out=trig[2 * n])
        np.multiply(s, s1, out=tmp)
        trig[2 * n] -= tmp
        np.multiply(s, c1, out=trig[2 * n + 1])
        np.multiply(c, s1, out=tmp)
        trig[2 * n + 1] += tmp
    parts = np.stack([w.real, w.imag], axis=2).astype(np.float32)  # (C, M, 2): x, y
    sums = np.matmul(trig.transpose(1, 0, 2), parts).astype(float).reshape(len(z), harmonics, 2, 2)
    sums /= (2.0 * np.pi ** 2 * np.arange(1, harmonics + 1) ** 2)[:, None, None]  # [n, cos/sin, x/y]
    return normalize_efd(sums.transpose(0, 1, 3, 2).reshape(len(z), harmonics, 4))  # (x cos, x sin, y cos, y sin)
