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
refined by the parabola through the correlation at it and its two neighbours.

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
from linkedit.curves.polyline import arc_resample

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

    score: np.ndarray  #: best correlation (refined below one sample for closed pairs)
    variant: np.ndarray  #: index into the compared versions (direction × frame pattern)
    shift: np.ndarray  #: shift in samples (fractional for closed pairs)


def _best(scores: np.ndarray, both_closed: np.ndarray) -> Peak:
    """Best alignment over versions and shifts of scores (…, V, N); open pairs: start to start
    (forward versions, shift 0) or start to end (reversed versions, shift 1)."""
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
    score = np.where(both_closed, np.maximum(refined, c0), np.take_along_axis(open_scores, open_best[..., None], -1)[..., 0])
    return Peak(score, variant, np.where(both_closed, shift + delta, shift))


def _peaks(a: np.ndarray, b: np.ndarray, closed_a: np.ndarray, closed_b: np.ndarray, reverse_sign: np.ndarray,
           frame_flips: bool, mirror: bool, rows: slice, cols: slice) -> Peak:
    """Best alignments of a[rows] against b[cols] as (r, c) arrays."""
    n, dim = a.shape[1], a.shape[2]
    complex_mode = dim == 2 and frame_flips
    signs = _frame_signs(dim, frame_flips, mirror)
    if complex_mode:
        a_spec = np.conj(_spectrum(a[rows, :, 0] + 1j * a[rows, :, 1], True))
        v_spec = _spectrum(_variants(b[cols], reverse_sign, True, signs, mirror), True)
    else:
        a_spec = np.conj(_spectrum(a[rows], False))
        v_spec = _spectrum(_variants(b[cols], reverse_sign, False, signs, mirror), False)
    scores = _scores(a_spec, v_spec, complex_mode, n)
    return _best(scores, closed_a[rows, None] & closed_b[None, cols])


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
    energy_a, energy_b = np.einsum("cnd,cnd->c", a, a), np.einsum("cnd,cnd->c", b, b)
    out = np.empty((len(a), len(b)))
    rows = _block_rows(len(b), versions, n)
    for start in range(0, len(a), rows):
        stop = min(start + rows, len(a))
        cols = slice(start, None) if symmetric else slice(None)
        peak = _peaks(a, b, closed_a, closed_b, sigma, frame_flips, mirror, slice(start, stop), cols)
        d2 = (energy_a[start:stop, None] + energy_b[None, cols] - 2.0 * peak.score) / n
        out[start:stop, cols] = np.sqrt(np.maximum(d2, 0.0))
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
    peak = _peaks(reference[None], points, np.array([closed_ref]), np.asarray(closed), np.ones(dim), True, mirror,
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


#: Partial matching: points of the open curve compared, samples of the closed curve's outline;
#: a grid: offsets along the outline, fractions of its length the open curve may cover (geometric,
#: 10 % to all) and points of the open curve compared. The coarse grid screens many candidates, the
#: fine one ranks and places the best; the screening grid is the cheapest (a whole atlas's pool).
PARTIAL_POINTS = 32
PARTIAL_OUTLINE = 256
Grid = tuple[int, np.ndarray, int]
FINE: Grid = (96, np.geomspace(0.1, 1.0, 24), PARTIAL_POINTS)
COARSE: Grid = (32, np.geomspace(0.1, 1.0, 12), PARTIAL_POINTS)
SCREEN: Grid = (16, np.geomspace(0.1, 1.0, 6), 12)


def _partial_setup(open_points: np.ndarray, grid: Grid = FINE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Query points (Ca, n, D) centred, their means (Ca, D), and the window index (F, S, 2, n)."""
    offset_count, fractions, count = grid
    n = open_points.shape[1]
    q = open_points[:, np.linspace(0, n - 1, count).round().astype(int)]
    mean = q.mean(axis=1)
    k = np.arange(count) / (count - 1)
    offsets = np.arange(offset_count) * PARTIAL_OUTLINE // offset_count
    steps = fractions[:, None] * k[None, :] * PARTIAL_OUTLINE  # (F, n)
    index = np.stack([offsets[None, :, None] + steps[:, None, :],
                      offsets[None, :, None] - steps[:, None, :]], axis=2)  # (F, S, 2, n)
    return q - mean[:, None], mean, np.round(index).astype(int) % PARTIAL_OUTLINE


def _complex(p: np.ndarray) -> np.ndarray:
    """Planar points (..., 2) as complex numbers (...)."""
    return p[..., 0] + 1j * p[..., 1]


def _partial_fits(q: np.ndarray, rings: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For centred queries q (Ca, n) and closed outlines (B, L), complex: residual² per window (B, Ca, W),
    the best fits α (B, Ca, W) (q ≈ α (w − mean w)) and the window means (B, W)."""
    w = rings[:, index.reshape(-1, index.shape[-1])]  # (B, W, n)
    w_mean = w.mean(axis=-1)
    w -= w_mean[..., None]
    w_energy = np.maximum(np.einsum("bwn,bwn->bw", w.real, w.real) + np.einsum("bwn,bwn->bw", w.imag, w.imag),
                          1e-300)
    inner = np.conj(w) @ q.T  # (B, W, Ca): <w, q>
    alpha = (inner / w_energy[..., None]).transpose(0, 2, 1)
    fit = (inner.real ** 2 + inner.imag ** 2) / w_energy[..., None]
    residual = np.sum(np.abs(q) ** 2, axis=1)[None, :, None] - fit.transpose(0, 2, 1)
    return residual, alpha, w_mean


def _partial_fits3(q: np.ndarray, rings: np.ndarray, index: np.ndarray, mirror: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For centred 3D queries q (Ca, n, 3) and closed outlines (B, L, 3): residual² per window (B, Ca, W) of
    the best similarity q ≈ s·R·(w − mean w) (Umeyama: R orthogonal, proper unless ``mirror``; the singular
    values of the 3×3 cross-covariances in closed form, :func:`_singular3`), the cross-covariances
    A = Σ w qᵀ (B, Ca, W, 3, 3) (q is centred: w's mean drops out), the window energies |w − mean w|² (B, W)
    and the window means (B, W, 3)."""
    flat = index.reshape(-1, index.shape[-1])
    w = rings[:, flat]  # (B, W, n, 3)
    w_mean = w.mean(axis=2)
    squares = np.einsum("bld,bld->bl", rings, rings)[:, flat].sum(axis=-1)
    w_energy = np.maximum(squares - flat.shape[1] * np.einsum("bwd,bwd->bw", w_mean, w_mean), 1e-300)
    cross = np.swapaxes(w, -1, -2)[:, None] @ q[None, :, None]
    sigma = _singular3(cross)  # (B, Ca, W, 3), descending
    if not mirror:  # a proper rotation: the smallest singular value counts with det's sign
        sigma[..., 2] *= np.sign(_det3(cross))
    fit = sigma.sum(axis=-1) ** 2 / w_energy[:, None, :]
    residual = np.einsum("cnd,cnd->c", q, q)[None, :, None] - fit
    return residual, cross, w_energy, w_mean


def _det3(a: np.ndarray) -> np.ndarray:
    """Determinants (...) of 3×3 matrices (..., 3, 3), by cofactors (vectorized: no per-matrix LAPACK call)."""
    return (a[..., 0, 0] * (a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1])
            - a[..., 0, 1] * (a[..., 1, 0] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 0])
            + a[..., 0, 2] * (a[..., 1, 0] * a[..., 2, 1] - a[..., 1, 1] * a[..., 2, 0]))


def _singular3(a: np.ndarray) -> np.ndarray:
    """Singular values (..., 3), largest first, of 3×3 matrices ``a`` (..., 3, 3): the square roots of the
    eigenvalues of aᵀa by the trigonometric solution of its characteristic cubic (no per-matrix LAPACK call;
    accurate to ~1e-8 of the largest, enough to rank fits)."""
    b = np.swapaxes(a, -1, -2) @ a
    off = b[..., 0, 1] ** 2 + b[..., 0, 2] ** 2 + b[..., 1, 2] ** 2
    mean = np.trace(b, axis1=-2, axis2=-1) / 3.0
    diag = np.diagonal(b, axis1=-2, axis2=-1) - mean[..., None]
    p = np.sqrt((np.sum(diag ** 2, axis=-1) + 2.0 * off) / 6.0)
    safe = np.where(p > 0, p, 1.0)
    c = (b - mean[..., None, None] * np.eye(3)) / safe[..., None, None]
    phi = np.arccos(np.clip(_det3(c) / 2.0, -1.0, 1.0)) / 3.0
    top = mean + 2.0 * p * np.cos(phi)
    low = mean + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    lam = np.stack([top, 3.0 * mean - top - low, low], axis=-1)
    return np.sqrt(np.maximum(lam, 0.0))


#: Closed outlines compared together in :func:`partial_rms` (bounds the window arrays).
PARTIAL_BATCH = 32


def partial_rms(open_points: np.ndarray, closed_points: np.ndarray, *, mirror: bool = False,
                grid: Grid = FINE, refine: bool = False) -> np.ndarray:
    """RMS distance (units of the open curve's major extent) of open curves (Ca, N, D) from the
    best-fitting stretch of closed curves (Cb, N', D) → (Ca, Cb), D = 2 or 3.

    Over every stretch (start offset, fraction of the length, direction; with ``mirror`` also of
    the mirror image) of the closed curve, sampled at the open curve's relative arc lengths, the
    best similarity transform (scale, rotation, translation: a complex least-squares fit in the plane,
    Umeyama's in space) places the stretch on the open curve; the smallest residual wins. The open
    curves are sampled evenly along their length. ``grid``: :data:`FINE`, :data:`COARSE` or :data:`SCREEN`;
    ``refine``: each pair's best stretch moved past the grid (:func:`_refined_windows`), so a distance is the
    stretch's, not the grid's spacing (a screen may skip it: it only orders candidates).
    """
    q, _, index = _partial_setup(open_points, grid)
    outline = arc_resample(closed_points, PARTIAL_OUTLINE, True)  # (Cb, L, D)
    out = np.empty((len(q), len(outline)))
    for start in range(0, len(outline), PARTIAL_BATCH):
        rings = outline[start:start + PARTIAL_BATCH]
        if q.shape[-1] == 3:
            residual = _partial_fits3(q, rings, index, mirror)[0]
        else:
            qc, rc = _complex(q), _complex(rings)
            residual = _partial_fits(qc, rc, index)[0]  # (B, Ca, W)
            if mirror:
                residual = np.minimum(residual, _partial_fits(qc, np.conj(rc), index)[0])
        if refine:
            best = _refined_windows(q, rings, residual.argmin(axis=2), grid, mirror, open_points.shape[1])
        else:
            best = residual.min(axis=2)
        out[:, start:start + PARTIAL_BATCH] = np.sqrt(np.maximum(best, 0.0) / q.shape[1]).T
    return out


#: Compass steps of :func:`_refined_windows` at most (each moves a stretch's end or halves the step), and the step
#: (outline samples) below which a pair is done.
REFINE_STEPS, REFINE_TOLERANCE = 40, 1e-4


def _refined_windows(q: np.ndarray, rings: np.ndarray, best: np.ndarray, grid: Grid, mirror: bool, n: int
                     ) -> np.ndarray:
    """Residual² (B, Ca) of each pair's best stretch refined past the grid: from the grid's best window ``best``
    (B, Ca), its start and end (continuous positions along the outline, linearly interpolated) moved by a compass
    search, vectorized over the pairs, that keeps only improvements (the grid steps lengths by ~10 %: an exact
    stretch would otherwise score the grid's misfit). The stretch is sampled where q's points lie along the open
    curve of ``n`` even samples they were picked from (:func:`_partial_setup`)."""
    offset_count, fractions, count = grid
    f, s, way = np.unravel_index(best, (len(fractions), offset_count, 2))
    start = (s * PARTIAL_OUTLINE // offset_count).astype(float)
    span = fractions[f] * PARTIAL_OUTLINE * np.where(way == 0, 1.0, -1.0)
    x = np.stack([start, start + span], axis=-1)  # (B, Ca, 2)
    k = np.linspace(0, n - 1, count).round() / (n - 1)
    planar = q.shape[-1] == 2
    ring = _complex(rings) if planar else rings  # (B, L) or (B, L, 3)
    pair_b, pair_c = (g.ravel() for g in np.indices(best.shape))  # the pairs, flat (P,)

    def residual(ends: np.ndarray, live: np.ndarray) -> np.ndarray:
        """Residual² (M, P') of the stretches ``ends`` (M, P', 2) of the pairs ``live`` (P',)."""
        at = ends[..., :1] + (ends[..., 1:] - ends[..., :1]) * k  # (M, P', n)
        low = np.floor(at)
        frac = at - low
        i = low.astype(int) % PARTIAL_OUTLINE
        rb, qp = pair_b[live][:, None], q[pair_c[live]]  # (P', 1), (P', n, D)
        if planar:
            w = ring[rb, i] * (1.0 - frac) + ring[rb, (i + 1) % PARTIAL_OUTLINE] * frac  # (M, P', n)
            w -= w.mean(axis=-1, keepdims=True)
            energy = np.sum(w.real ** 2 + w.imag ** 2, axis=-1)
            fit = np.abs(np.sum(np.conj(w) * _complex(qp), axis=-1)) ** 2
            if mirror:
                fit = np.maximum(fit, np.abs(np.sum(w * _complex(qp), axis=-1)) ** 2)
        else:
            w = ring[rb, i] * (1.0 - frac[..., None]) + ring[rb, (i + 1) % PARTIAL_OUTLINE] * frac[..., None]
            w -= w.mean(axis=-2, keepdims=True)
            energy = np.einsum("mpnd,mpnd->mp", w, w)
            cross = np.swapaxes(w, -1, -2) @ qp  # (M, P', 3, 3)
            sigma = _singular3(cross)
            if not mirror:
                sigma[..., 2] *= np.sign(_det3(cross))
            fit = sigma.sum(axis=-1) ** 2
        return np.einsum("pnd,pnd->p", qp, qp) - fit / np.maximum(energy, 1e-300)

    x = x.reshape(-1, 2)
    every = np.arange(len(x))
    value = residual(x[None], every)[0]
    step = np.maximum(PARTIAL_OUTLINE / offset_count, 0.11 * np.abs(span)).ravel()  # (P,)
    moves = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0],  # one end
                      [1.0, 1.0], [-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0]])  # both: shift, stretch
    for _ in range(REFINE_STEPS):
        live = every[step > REFINE_TOLERANCE]
        if not live.size:
            break
        tries = x[live] + moves[:, None, :] * step[live][None, :, None]  # (8, P', 2)
        values = residual(tries, live)
        pick = values.argmin(axis=0)
        got = values[pick, np.arange(live.size)]
        better = got < value[live]
        x[live[better]] = tries[pick[better], np.flatnonzero(better)]
        value[live[better]] = got[better]
        step[live[~better]] /= 2
    return value.reshape(best.shape)


def partial_placement(open_points: np.ndarray, closed_points: np.ndarray, *,
                      mirror: bool = False) -> tuple[float, complex, complex, bool]:
    """The best stretch of one closed curve (N, 2) for one open curve (N, 2), both normalized:
    (RMS, α, β, mirrored) with open ≈ α·w + β for w the closed curve's points (conjugated when
    mirrored)."""
    q, q_mean, index = _partial_setup(open_points[None])
    ring = _complex(arc_resample(closed_points[None], PARTIAL_OUTLINE, True))
    best = (np.inf, 0j, 0j, False)
    for mirrored, r in ((False, ring), (True, np.conj(ring)))[: 2 if mirror else 1]:
        residual, alpha, w_mean = _partial_fits(_complex(q), r, index)
        k = int(np.argmin(residual[0, 0]))
        rms = float(np.sqrt(max(residual[0, 0, k], 0.0) / PARTIAL_POINTS))
        if rms < best[0]:
            shift = _complex(q_mean[0]) - alpha[0, 0, k] * w_mean[0, k]
            best = (rms, complex(alpha[0, 0, k]), complex(shift), mirrored)
    return best


def partial_placement3(open_points: np.ndarray, closed_points: np.ndarray, *,
                       mirror: bool = False) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The best stretch of one closed 3D curve (N', 3) for one open curve (N, 3) (:func:`partial_rms`):
    (RMS, scale, matrix (3, 3) orthogonal — det −1 only with ``mirror`` —, shift (3,)) with
    open ≈ shift + scale·matrix·w for w the closed curve's points; RMS (of that fit, exact) in the open
    curve's units."""
    q, q_mean, index = _partial_setup(open_points[None])
    ring = arc_resample(closed_points[None], PARTIAL_OUTLINE, True)
    residual, cross, w_energy, w_mean = _partial_fits3(q, ring, index, mirror)
    k = int(np.argmin(residual[0, 0]))
    u, sigma, vt = np.linalg.svd(cross[0, 0, k])  # cross = Σ w qᵀ = U Σ Vᵀ: R = V Uᵀ
    flip = np.ones(3)
    if not mirror and np.linalg.det(vt.T @ u.T) < 0:
        flip[2] = -1.0
    matrix = vt.T @ np.diag(flip) @ u.T
    scale = float((sigma * flip).sum() / w_energy[0, k])
    shift = q_mean[0] - scale * matrix @ w_mean[0, k]
    gap = q[0] + q_mean[0] - shift - scale * ring[0, index.reshape(-1, index.shape[-1])[k]] @ matrix.T
    return float(np.sqrt(np.mean(np.sum(gap * gap, axis=1)))), scale, matrix, shift
