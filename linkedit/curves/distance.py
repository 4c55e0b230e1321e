"""Distances between described curves.

Terms (each a (Ca, Cb) matrix of nonnegative numbers):

* every per-curve feature: the absolute difference (angles wrapped to [0, π]);
* ``points``: RMS distance between the normalized resampled curves, minimized over cyclic
  shift (both curves closed; refined below one sample), direction of travel and rotation:
  2D curves by the best rotation angle (Procrustes, so a nearly isotropic curve, whose
  principal frame is arbitrary, still aligns), 3D curves over the sign ambiguity of the
  principal frame (proper rotations only: a mirror image stays different unless ``mirror``);
* ``turning``: the same for the turning-angle sequences (no frame; ``mirror`` negates them);
* ``efd``: Euclidean distance of normalized elliptic Fourier descriptors (3D curves, and
  ``mirror``, also against the mirror image: a 3D frame's in-plane handedness hangs on the
  sign of its out-of-plane axis, which rounding decides for a nearly planar curve).

The alignment over all N cyclic shifts is an FFT cross-correlation, batched over blocks of
curve pairs: ‖a - shift_s(b)‖² = ‖a‖² + ‖b‖² - 2 (a ⋆ b)(s); for 2D curves as complex numbers
z = x + iy the best rotation gives ‖a‖² + ‖b‖² - 2 |(a ⋆ b)(s)|. The best whole shift is
refined by the parabola through the correlation at it and its two neighbours. The distance is then
summed from the differences at the best alignment (less the refinement's gain), not from the energies:
a pair of one shape scores 0, and d(a, b) = d(b, a), to rounding. An open curve
against a closed one is matched to the closed one's best-fitting stretch (:mod:`.partial`).

The weighted distance is d = sqrt(Σ_m w_m Δ_m²).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.fft

from linkedit.curves.descriptors import Descriptors
from linkedit.curves.efd import efd_distance
from linkedit.curves.features import ANGULAR
from linkedit.curves.partial import partial_rms

PAIRWISE = ("points", "turning", "efd")
#: Bytes of complex spectra processed per block (bounds memory, keeps blocks cache friendly).
BLOCK_BYTES = 1 << 22


def term_names(desc: Descriptors) -> tuple[str, ...]:
    """The terms of the distance between curves described like ``desc``."""
    return desc.names + PAIRWISE


def _frame_signs(dim: int, frame_flips: bool, mirror: bool) -> np.ndarray:
    """Sign patterns (K, D) of the frame changes compared (real mode: 1D and 3D).

    3D: the four proper patterns (even number of flips), all eight with ``mirror``; 1D: the
    identity, and the negation with ``mirror``.
    """
    if dim == 3 and frame_flips:
        proper = [[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]
        return np.array(proper + ([[-s for s in p] for p in proper] if mirror else []), dtype=float)
    patterns = [np.ones(dim)] + ([-np.ones(dim)] if mirror else [])
    return np.array(patterns)


def _variants(b: np.ndarray, reverse_sign: np.ndarray, complex_mode: bool, signs: np.ndarray,
              mirror: bool) -> np.ndarray:
    """(Cb, 2K, N) complex: every compared version of b — frame patterns (or, 2D, the mirror
    image), forward then reversed (r_k = σ b_{-k})."""
    n = b.shape[1]
    rev = (b * reverse_sign)[:, (-np.arange(n)) % n]
    if complex_mode:
        forward, backward = b[..., 0] + 1j * b[..., 1], rev[..., 0] + 1j * rev[..., 1]
        versions = [forward, np.conj(forward)] if mirror else [forward]
        versions += [backward, np.conj(backward)] if mirror else [backward]
        return np.stack(versions, axis=1)
    return np.stack([(x[:, None, :, :] * signs[None, :, None, :]) for x in (b, rev)], axis=1).reshape(
        len(b), 2 * len(signs), n, -1)


def _scores(a_spec: np.ndarray, v_spec: np.ndarray, complex_mode: bool, n: int) -> np.ndarray:
    """Correlation scores (r, c, V, N): Σ_k a_k · v_{k+s} (real mode) or |Σ_k conj(a_k) v_{k+s}| (2D)."""
    if complex_mode:
        prod = a_spec[:, None, None, :] * v_spec[None, :, :, :]
        corr = scipy.fft.ifft(prod, n=n, axis=-1, overwrite_x=True)
        power = corr.real * corr.real
        power += corr.imag * corr.imag
        return np.sqrt(power, out=power)
    prod = np.einsum("adf,cvdf->acvf", a_spec, v_spec)
    return scipy.fft.irfft(prod, n=n, axis=-1, overwrite_x=True, workers=-1)


def _spectrum(x: np.ndarray, complex_mode: bool) -> np.ndarray:
    """FFT along the sample axis: (…, N) complex → (…, N); real (…, N, D) → (…, D, F)."""
    if complex_mode:
        return np.fft.fft(x, axis=-1)
    return np.fft.rfft(x, axis=-2).swapaxes(-1, -2)


@dataclass(frozen=True)
class Peak:
    """The best alignment of each pair (arrays of one shape)."""

    variant: np.ndarray  #: index into the compared versions (direction × frame pattern)
    shift: np.ndarray  #: shift in samples (fractional for closed pairs)
    whole: np.ndarray  #: int: the best whole shift in samples
    gain: np.ndarray  #: what the sub-sample refinement adds to the whole shift's correlation (≥ 0)


def _best(scores: np.ndarray, both_closed: np.ndarray) -> tuple[Peak, np.ndarray]:
    """Best alignment over versions and shifts of scores (…, V, N), and its correlation (refined below one
    sample for closed pairs); open pairs: start to start (forward versions, shift 0) or start to end
    (reversed versions, shift 1)."""
    n = scores.shape[-1]
    half = scores.shape[-2] // 2
    lead = scores.shape[:-2]
    flat = scores.reshape(*lead, -1)
    best = np.argmax(flat, axis=-1)
    open_scores = np.concatenate([scores[..., :half, 0], scores[..., half:, 1 % n]], axis=-1)
    open_best = np.argmax(open_scores, axis=-1)
    variant = np.where(both_closed, best // n, open_best)
    shift = np.where(both_closed, best % n, (open_best >= half).astype(int) % n).astype(float)
    c0 = np.take_along_axis(flat, best[..., None], -1)[..., 0]
    row = (best // n) * n
    cm = np.take_along_axis(flat, (row + (best - 1) % n)[..., None], -1)[..., 0]
    cp = np.take_along_axis(flat, (row + (best + 1) % n)[..., None], -1)[..., 0]
    curve = cm - 2.0 * c0 + cp
    delta = np.divide(cm - cp, 2.0 * curve, out=np.zeros_like(c0), where=curve < 0)
    refined = c0 - 0.25 * (cm - cp) * delta
    gain = np.where(both_closed, np.maximum(refined - c0, 0.0), 0.0)
    score = np.where(both_closed, c0, np.take_along_axis(open_scores, open_best[..., None], -1)[..., 0]) + gain
    return Peak(variant, np.where(both_closed, shift + delta, shift), shift.astype(int), gain), score


def _squared_residual(a: np.ndarray, b: np.ndarray, reverse_sign: np.ndarray, signs: np.ndarray, mirror: bool,
                      peak: Peak, score: np.ndarray, complex_mode: bool) -> np.ndarray:
    """Σ |a_k - u v_{k+s}|² (r, c) of each pair at its best version v and whole shift s (2D: u the best unit
    turn; real mode: u = 1), less twice the refinement's gain. ‖a‖² + ‖v‖² - 2·score loses ~ε(‖a‖² + ‖v‖²):
    the pairs whose result is below a sixteenth of that sum (a pair of one shape: ~1e-8 under the square root,
    unequal both ways) are summed from their differences instead, so every result is good to rounding.
    a: (r, N) complex or (r, N, D); b: (c, N, D) (its versions as :func:`_variants` makes them); score: (r, c)
    the refined correlation."""
    n = a.shape[1]
    energy_a = np.sum(np.abs(a.reshape(len(a), -1)) ** 2, axis=1)
    total = energy_a[:, None] + np.einsum("cnd,cnd->c", b, b)[None, :]
    d2 = total - 2.0 * score
    r, c = np.nonzero(d2 < total / 16.0)
    if not len(r):
        return np.maximum(d2, 0.0)
    used, k = np.unique(c, return_inverse=True)  # the versions of the columns needed
    v = _variants(b[used], reverse_sign, complex_mode, signs, mirror)[k, peak.variant[r, c]]  # (P, N[, D])
    index = (np.arange(n)[None, :] + peak.whole[r, c][:, None]) % n
    if complex_mode:
        v = np.take_along_axis(v, index, axis=-1)
        corr = np.einsum("pn,pn->p", np.conj(a[r]), v)
        size = np.abs(corr)
        turn = np.divide(np.conj(corr), size, out=np.ones_like(corr), where=size > 0)
        diff = a[r] - turn[:, None] * v
        near = np.einsum("pn,pn->p", diff.real, diff.real) + np.einsum("pn,pn->p", diff.imag, diff.imag)
    else:
        diff = a[r] - np.take_along_axis(v, index[..., None], axis=-2)
        near = np.einsum("pnd,pnd->p", diff, diff)
    d2[r, c] = near - 2.0 * peak.gain[r, c]
    return np.maximum(d2, 0.0)


def _peaks(a: np.ndarray, b: np.ndarray, closed_a: np.ndarray, closed_b: np.ndarray, reverse_sign: np.ndarray,
           frame_flips: bool, mirror: bool, rows: slice, cols: slice) -> tuple[Peak, np.ndarray]:
    """Best alignments of a[rows] against b[cols] as (r, c) arrays, and the squared residual (r, c) at them
    (:func:`_squared_residual`)."""
    n, dim = a.shape[1], a.shape[2]
    complex_mode = dim == 2 and frame_flips
    signs = _frame_signs(dim, frame_flips, mirror)
    ar = a[rows, :, 0] + 1j * a[rows, :, 1] if complex_mode else a[rows]
    v_spec = _spectrum(_variants(b[cols], reverse_sign, complex_mode, signs, mirror), complex_mode)
    scores = _scores(np.conj(_spectrum(ar, complex_mode)), v_spec, complex_mode, n)
    peak, score = _best(scores, closed_a[rows, None] & closed_b[None, cols])
    return peak, _squared_residual(ar, b[cols], reverse_sign, signs, mirror, peak, score, complex_mode)


def _block_rows(n_b: int, versions: int, n: int) -> int:
    return max(1, BLOCK_BYTES // (16 * max(n_b, 1) * versions * n))


def aligned_rms(a: np.ndarray, b: np.ndarray | None, closed_a: np.ndarray, closed_b: np.ndarray | None = None, *,
                reverse_sign: np.ndarray | float = 1.0, frame_flips: bool = True, mirror: bool = False) -> np.ndarray:
    """RMS distance of sequences a (Ca, N, D) and b (Cb, N, D), best alignment → (Ca, Cb).

    Pairs of closed curves: minimized over cyclic shifts (refined below one sample) and both
    directions; otherwise the sequences are compared start to start and start to end. 2D
    sequences with ``frame_flips`` (points) are also turned by the best angle; 3D ones take
    the best sign pattern of the frame. Reversing multiplies each dimension by
    ``reverse_sign`` (-1 for signed turning angles). ``mirror`` also compares the mirror image.
    ``b=None`` compares ``a`` with itself (only half the pairs are computed).
    """
    symmetric = b is None
    if b is None:
        b, closed_b = a, closed_a
    elif closed_b is None:
        raise ValueError("closed_b is needed with b")
    n, dim = a.shape[1], a.shape[2]
    sigma = np.broadcast_to(np.asarray(reverse_sign, dtype=float), (dim,))
    versions = 2 * len(_frame_signs(dim, frame_flips, mirror))
    out = np.empty((len(a), len(b)))
    rows = _block_rows(len(b), versions, n)
    for start in range(0, len(a), rows):
        stop = min(start + rows, len(a))
        cols = slice(start, None) if symmetric else slice(None)
        _, d2 = _peaks(a, b, closed_a, closed_b, sigma, frame_flips, mirror, slice(start, stop), cols)
        out[start:stop, cols] = np.sqrt(d2 / n)
    if symmetric:
        upper = np.triu(out)
        out = upper + np.triu(upper, 1).T
    return out


@dataclass(frozen=True)
class Alignment:
    """How each curve was placed onto a reference (normalized frame), arrays (C,)."""

    reversed: np.ndarray  #: bool: travelled the other way
    mirrored: np.ndarray  #: bool: mirror image (only with ``mirror``)
    shift: np.ndarray  #: phase offset in samples: sample k of the reference meets sample k + shift (fractional)
    rotation: np.ndarray  #: (C, D, D) the rotation (2D: best angle; 3D: a sign pattern) applied to the curve


def alignment(reference: np.ndarray, closed_ref: bool, points: np.ndarray, closed: np.ndarray, *,
              mirror: bool = False) -> Alignment:
    """The best alignment of curves (C, N, D) onto a reference (N, D), as :func:`aligned_rms` finds it."""
    n, dim = points.shape[1], points.shape[2]
    signs = _frame_signs(dim, True, mirror)
    peak, _ = _peaks(reference[None], points, np.array([closed_ref]), np.asarray(closed), np.ones(dim), True, mirror,
                  slice(0, 1), slice(None))
    variant, shift = peak.variant[0], peak.shift[0]
    if dim == 2:
        versions = 2 if mirror else 1
        reverse, mirrored = variant >= versions, (variant % versions) == 1
        b = points[..., 0] + 1j * points[..., 1]
        b = np.where(mirrored[:, None], np.conj(b), b)
        b = np.where(reverse[:, None], b[:, (-np.arange(n)) % n], b)
        corr = np.sum(np.conj(reference[:, 0] + 1j * reference[:, 1])[None] * _roll(b, np.round(shift)), axis=1)
        # the rotation of the whole-sample alignment (the refined shift moves it by far less than a step)
        angle = -np.angle(corr)
        c, s = np.cos(angle), np.sin(angle)
        rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
        rot = rot @ np.where(mirrored[:, None, None], np.diag([1.0, -1.0]), np.eye(2))
    else:
        pattern = signs[variant % len(signs)]
        reverse, mirrored = variant >= len(signs), np.prod(pattern, axis=1) < 0
        rot = pattern[:, :, None] * np.eye(dim)
    return Alignment(reverse, mirrored, shift, rot)


def _roll(b: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Rows of b (C, N) with sample k + shift_c at k (shift rounded to whole samples)."""
    n = b.shape[1]
    index = (np.arange(n)[None, :] + shift.astype(int)[:, None]) % n
    return np.take_along_axis(b, index, axis=1)


def align(reference: np.ndarray, closed_ref: bool, points: np.ndarray, closed: np.ndarray, *,
          mirror: bool = False) -> np.ndarray:
    """Curves (C, N, D) shifted (whole samples), reversed and turned onto a reference (N, D)."""
    n = points.shape[1]
    al = alignment(reference, closed_ref, points, closed, mirror=mirror)
    placed = np.einsum("cde,cne->cnd", al.rotation, points)
    placed = np.where(al.reversed[:, None, None], placed[:, (-np.arange(n)) % n], placed)
    index = (np.arange(n)[None, :] + np.round(al.shift).astype(int)[:, None]) % n
    return np.take_along_axis(placed, index[:, :, None], axis=1)


def term_distances(a: Descriptors, b: Descriptors | None = None, *, mirror: bool = False,
                   partial: bool = False) -> dict[str, np.ndarray]:
    """Every term as a (Ca, Cb) matrix (``b=None``: ``a`` against itself); ``mirror``: mirror images count as equal.

    ``partial``: an open curve against a closed one is compared by where it fits best along
    the closed one (:func:`partial_rms`, the ``points`` term; 2D or 3D); the other terms describe whole
    curves and count 0 for such pairs.
    """
    symmetric = b is None
    other = a if b is None else b
    if other.names != a.names or other.points.shape[1:] != a.points.shape[1:]:
        raise ValueError("descriptors of different kinds (dimension, samples or anchors) cannot be compared")
    out: dict[str, np.ndarray] = {}
    for i, name in enumerate(a.names):
        diff = np.abs(a.features[:, i][:, None] - other.features[:, i][None, :])
        out[name] = np.minimum(diff, 2 * np.pi - diff) if name in ANGULAR else diff
    dim = a.points.shape[2]
    out["points"] = aligned_rms(a.points, None if symmetric else other.points, a.closed, other.closed, mirror=mirror)
    out["turning"] = aligned_rms(a.turning[:, :, None], None if symmetric else other.turning[:, :, None],
                                 a.closed, other.closed, reverse_sign=-1.0 if dim == 2 else 1.0, frame_flips=False,
                                 mirror=mirror and dim == 2)
    out["efd"] = efd_distance(a.efd, other.efd, mirror=mirror or dim == 3)
    if partial:
        mixed = a.closed[:, None] != other.closed[None, :]
        if mixed.any():
            for name in out:
                out[name] = np.where(mixed, 0.0, out[name])
            ao, bc = ~a.closed, other.closed
            if ao.any() and bc.any():
                block = partial_rms(a.points[ao], other.points[bc], mirror=mirror, refine=True)
                out["points"][np.ix_(ao, bc)] = block
            if a.closed.any() and (~other.closed).any():
                block = partial_rms(other.points[~other.closed], a.points[a.closed], mirror=mirror, refine=True).T
                out["points"][np.ix_(a.closed, ~other.closed)] = block
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
