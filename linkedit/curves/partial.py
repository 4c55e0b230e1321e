"""Partial matching: an open curve against the best-fitting stretch of a closed one.

Every stretch of a grid (start along the closed curve's outline, fraction of its length, direction;
:data:`FINE`, :data:`COARSE`, :data:`SCREEN`) is sampled at the open curve's relative arc lengths and
placed on it by the best similarity transform (a complex least-squares fit in the plane, Umeyama's in
space); the smallest residual wins (:func:`partial_rms`), refined past the grid on request, and
:func:`partial_placement` / :func:`partial_placement3` give the winning placement itself.
"""

from __future__ import annotations

import numpy as np

from linkedit.curves.polyline import arc_resample

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
    fit = _fit3(cross, mirror) / w_energy[:, None, :]
    residual = np.einsum("cnd,cnd->c", q, q)[None, :, None] - fit
    return residual, cross, w_energy, w_mean


def _fit3(cross: np.ndarray, mirror: bool) -> np.ndarray:
    """(Σ σ)² (...) of the cross-covariances ``cross`` (..., 3, 3) of centred stretches and queries: the
    best similarity's fit times the stretch's energy (Umeyama; the smallest singular value counts with
    det's sign for a proper rotation, unless ``mirror``)."""
    sigma = _singular3(cross)  # (..., 3), descending
    if not mirror:
        sigma[..., 2] *= np.sign(_det3(cross))
    return sigma.sum(axis=-1) ** 2


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
            fit = _fit3(np.swapaxes(w, -1, -2) @ qp, mirror)  # from (M, P', 3, 3)
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
