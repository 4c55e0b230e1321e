"""Distances between described curves.

Terms (each a (Ca, Cb) matrix of nonnegative numbers):

* every per-curve feature: the absolute difference (angles wrapped to [0, π]);
* ``points``: RMS distance between the normalized resampled curves, minimized over cyclic
  shift (both curves closed), direction of travel and the sign ambiguity of the principal
  frame (proper rotations only: a mirror image stays different);
* ``turning``: the same for the turning-angle sequences (no frame);
* ``efd``: Euclidean distance of normalized elliptic Fourier descriptors.

The alignment over all N cyclic shifts is an FFT cross-correlation, batched over blocks of
curve pairs: ‖a - shift_s(b)‖² = ‖a‖² + ‖b‖² - 2 (a ⋆ b)(s).

The weighted distance is d = sqrt(Σ_m w_m Δ_m²).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.fft

from linkedit.curves.descriptors import Descriptors
from linkedit.curves.efd import efd_distance
from linkedit.curves.features import ANGULAR

PAIRWISE = ("points", "turning", "efd")
#: Bytes of complex spectra processed per block (bounds memory, keeps blocks cache friendly).
BLOCK_BYTES = 1 << 20


def term_names(desc: Descriptors) -> tuple[str, ...]:
    """The terms of the distance between curves described like ``desc``."""
    return desc.names + PAIRWISE


def _frame_signs(dim: int, frame_flips: bool) -> tuple[np.ndarray, bool]:
    """Sign patterns of the proper frame changes (K, D), and whether |correlation| covers the rest.

    2D: the half turn (-1, -1) is the negated correlation, so |·| covers it. 3D: the four
    patterns with an even number of flips.
    """
    if not frame_flips or dim == 1:
        return np.ones((1, dim)), False
    if dim == 2:
        return np.ones((1, 2)), True
    return np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float), False


def _correlations(a_spec: np.ndarray, b_spec: np.ndarray, b_rev: np.ndarray, signs: np.ndarray, n: int) -> np.ndarray:
    """(r, c, 2, K, N): Σ_k a_k · S(b)_{k+s}, forward and reversed b, every frame pattern S."""
    dim = a_spec.shape[1]
    spec = np.empty((len(a_spec), len(b_spec), 2, len(signs), a_spec.shape[2]), dtype=complex)
    for u, b in enumerate((b_spec, b_rev)):
        per_dim = [a_spec[:, None, d, :] * b[None, :, d, :] for d in range(dim)]  # (r, c, F) each
        for k, pattern in enumerate(signs):
            out = spec[:, :, u, k]
            out[...] = per_dim[0] if pattern[0] > 0 else -per_dim[0]
            for d in range(1, dim):
                if pattern[d] > 0:
                    out += per_dim[d]
                else:
                    out -= per_dim[d]
    return scipy.fft.irfft(spec, n=n, axis=-1, overwrite_x=True, workers=-1)


def _spectra(x: np.ndarray, reverse_sign: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """conj(rfft) of x (C, N, D) as (C, D, F), rfft, and the rfft of each sequence reversed (r_k = σ x_{-k})."""
    spec = np.fft.rfft(x, axis=1).transpose(0, 2, 1)
    return np.conj(spec), spec, np.conj(spec) * reverse_sign[None, :, None]


def aligned_rms(a: np.ndarray, b: np.ndarray | None, closed_a: np.ndarray, closed_b: np.ndarray | None = None, *,
                reverse_sign: np.ndarray | float = 1.0, frame_flips: bool = True) -> np.ndarray:
    """RMS distance of sequences a (Ca, N, D) and b (Cb, N, D), best alignment → (Ca, Cb).

    Pairs of closed curves: minimized over the N cyclic shifts and both directions; otherwise
    the sequences are compared start to start and start to end. Reversing multiplies each
    dimension by ``reverse_sign`` (-1 for signed turning angles). ``b=None`` compares ``a``
    with itself (only half the pairs are computed).
    """
    symmetric = b is None
    if b is None:
        b, closed_b = a, closed_a
    n, dim = a.shape[1], a.shape[2]
    sigma = np.broadcast_to(np.asarray(reverse_sign, dtype=float), (dim,))
    signs, use_abs = _frame_signs(dim, frame_flips)
    a_conj = _spectra(a, sigma)[0]
    _, b_spec, b_rev = _spectra(b, sigma)
    energy_a, energy_b = np.einsum("cnd,cnd->c", a, a), np.einsum("cnd,cnd->c", b, b)
    out = np.empty((len(a), len(b)))
    rows = max(1, BLOCK_BYTES // (16 * len(b) * 2 * len(signs) * max(dim, 2) * b_spec.shape[2]))
    for start in range(0, len(a), rows):
        stop = min(start + rows, len(a))
        cols = slice(start, None) if symmetric else slice(None)
        corr = _correlations(a_conj[start:stop], b_spec[cols], b_rev[cols], signs, n)
        if use_abs:
            np.abs(corr, out=corr)
        best = corr.reshape(corr.shape[0], corr.shape[1], -1).max(axis=2)
        both = closed_a[start:stop, None] & closed_b[None, cols]
        if not both.all():
            linear = np.maximum(corr[:, :, 0, :, 0].max(axis=2), corr[:, :, 1, :, 1].max(axis=2))
            best = np.where(both, best, linear)
        d2 = (energy_a[start:stop, None] + energy_b[None, cols] - 2.0 * best) / n
        out[start:stop, cols] = np.sqrt(np.maximum(d2, 0.0))
    if symmetric:
        upper = np.triu(out)
        out = upper + np.triu(upper, 1).T
    return out


def align(reference: np.ndarray, closed_ref: bool, points: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Curves (C, N, D) shifted, reversed and frame-flipped onto a reference (N, D) as :func:`aligned_rms` does."""
    n, dim = points.shape[1], points.shape[2]
    signs, use_abs = _frame_signs(dim, True)
    a_conj = _spectra(reference[None], np.ones(dim))[0]
    _, b_spec, b_rev = _spectra(points, np.ones(dim))
    corr = _correlations(a_conj, b_spec, b_rev, signs, n)[0]  # (C, 2, K, N)
    score = np.abs(corr) if use_abs else corr.copy()
    open_pair = ~(closed & closed_ref)
    keep = np.zeros((2, n), dtype=bool)
    keep[0, 0] = keep[1, 1] = True
    score[open_pair] = np.where(keep[:, None, :], score[open_pair], -np.inf)
    flat = score.reshape(len(points), -1).argmax(axis=1)
    u, k, s = np.unravel_index(flat, score.shape[1:])
    rows = np.arange(len(points))
    flip = np.where(corr[rows, u, k, s] < 0, -1.0, 1.0) if use_abs else np.ones(len(points))
    factor = signs[k] * flip[:, None]
    j = np.arange(n)[None, :]
    index = np.where(u[:, None] == 0, (j + s[:, None]) % n, (-j - s[:, None]) % n)
    return np.take_along_axis(points, index[:, :, None], axis=1) * factor[:, None, :]


def term_distances(a: Descriptors, b: Descriptors | None = None) -> dict[str, np.ndarray]:
    """Every term as a (Ca, Cb) matrix (``b=None``: ``a`` against itself)."""
    symmetric = b is None
    other = a if b is None else b
    if other.names != a.names or other.points.shape[1:] != a.points.shape[1:]:
        raise ValueError("descriptors of different kinds (dimension, samples or anchors) cannot be compared")
    out: dict[str, np.ndarray] = {}
    for i, name in enumerate(a.names):
        diff = np.abs(a.features[:, i][:, None] - other.features[:, i][None, :])
        out[name] = np.minimum(diff, 2 * np.pi - diff) if name in ANGULAR else diff
    dim = a.points.shape[2]
    out["points"] = aligned_rms(a.points, None if symmetric else other.points, a.closed, other.closed)
    out["turning"] = aligned_rms(a.turning[:, :, None], None if symmetric else other.turning[:, :, None],
                                 a.closed, other.closed, reverse_sign=-1.0 if dim == 2 else 1.0, frame_flips=False)
    out["efd"] = efd_distance(a.efd, other.efd)
    return out


def weighted(terms: Mapping[str, np.ndarray], weights: Mapping[str, float]) -> np.ndarray:
    """d = sqrt(Σ w_m Δ_m²) over the terms with a weight (missing weights count as 0)."""
    total = np.zeros(next(iter(terms.values())).shape)
    for name, w in weights.items():
        if w and name in terms:
            total += w * terms[name] ** 2
    return np.sqrt(total)


def nearest(dist: np.ndarray) -> np.ndarray:
    """Index of each curve's nearest other curve in a square distance matrix (C, C) → (C,)."""
    d = dist.copy()
    np.fill_diagonal(d, np.inf)
    return np.argmin(d, axis=1)
