"""Precision points: a few target points the tracked point must pass through, at any crank phase.

A target of precision points is not a polygon: its error is, for each point, the distance to the
closest point of the linkage's whole curve (free timing), normalized by the points' RMS radius about
their centroid. The closest point is found on the curve sampled densely (:data:`DENSE` samples per
cycle): every sample closer to the point than both its neighbours brackets a local minimum of the squared
distance over the crank phase (a curve passing the point several times, or fast, has several), each is
refined by a safeguarded Newton iteration on the closed-form curve (bisection where a step would leave its
bracket), and the closest wins, so the distance is exact to rounding. The atlas search places each candidate
on the points by a similarity fit to its closest samples (iterated, 12 start rotations, mirrored or not, its size
bounded: :data:`FIT_SIZE`) and ranks by the same measure.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from linkedit.planar.feasibility import works

#: A closed target with at most this many points and uneven spacing is taken for precision points.
DETECT_MAX = 25
#: Uneven spacing: the coefficient of variation of the chord lengths above this.
UNEVEN = 0.25
#: Curve samples per cycle the closest point is searched among.
DENSE = 720
#: A sample's bracket is searched unless the sample is farther from the point than the closest sample by this
#: many times the curve's longest chord between samples (an arc within a sample either side, turning less than
#: a half turn, is at most π/2 times its chord).
REACH = 2.0
#: Newton steps at most per bracket; the phase is taken as found when a step moves it by at most PHASE_TOL.
NEWTON = 60
PHASE_TOL = 1e-14
#: Crank-phase step (of a cycle) of the central differences giving the curve's velocity and acceleration.
STEP = 1e-6
#: Similarity-fit rounds and start rotations of the atlas ranking.
FIT_ROUNDS = 8
FIT_STARTS = 12
#: The ranking places a curve no larger than this many times the points' RMS radius (its own RMS radius about its
#: centroid): blown up, any curve meets the points on a near-straight stretch, its error falling only as the scale
#: grows without bound (points on a line: toward the infinite linkage), a valley with no exact linkage in it.
FIT_SIZE = 3.0
#: Gauss–Newton steps at most of the exact polish (:func:`newton`), halvings per step, and the RMS gap (over the
#: points' RMS radius, times √(2N)) below which it stops: the points are met to rounding.
NEWTON_STEPS = 40
HALVINGS = 30
NEWTON_TOL = 1e-13


def rms_radius(z: np.ndarray) -> float:
    """The points' (N,) complex RMS distance from their centroid."""
    return float(np.sqrt(np.mean(np.abs(z - z.mean()) ** 2)))


def spacing(z: np.ndarray, closed: bool) -> float:
    """Coefficient of variation of the chord lengths of the points (N,) complex (0: evenly spaced)."""
    chords = np.abs(np.diff(np.concatenate([z, z[:1]]) if closed else z))
    return float(chords.std() / max(chords.mean(), 1e-300))


def detect(z: np.ndarray, closed: bool) -> str | None:
    """Why the target (N,) complex is taken for precision points, or None for a sampled curve: a closed
    target of at most DETECT_MAX points spaced unevenly (chord lengths' variation above UNEVEN)."""
    if not closed or len(z) > DETECT_MAX:
        return None
    cv = spacing(z, closed)
    if cv <= UNEVEN:
        return None
    return f"detected: {len(z)} points (≤ {DETECT_MAX}), uneven spacing (chord lengths vary by {cv:.2f} > {UNEVEN})"


def spline(z: np.ndarray, closed: bool, count: int = 256) -> np.ndarray:
    """A smooth curve (count,) complex through the points (N,) complex (a cubic spline in chord length, periodic
    when ``closed``): what the atlas index is asked for, where the polygon's corners would mislead it."""
    from scipy.interpolate import CubicSpline

    ring = np.concatenate([z, z[:1]]) if closed else z
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(ring)))])
    at = np.linspace(0.0, s[-1], count, endpoint=not closed)
    return CubicSpline(s, ring, bc_type="periodic" if closed else "not-a-knot")(at)


def _vertex(f: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The parabola through (−1, f₋), (0, f₀), (1, f₊): its vertex's offset in [−1, 1] and value (where it
    opens down: offset 0, value f₀)."""
    lo, mid, hi = f
    curv = lo - 2.0 * mid + hi
    up = curv > 0
    safe = np.where(up, curv, 1.0)
    offset = np.where(up, np.clip(0.5 * (lo - hi) / safe, -1.0, 1.0), 0.0)
    value = np.where(up, mid - 0.125 * (lo - hi) ** 2 / safe, mid)
    return offset, value


def closest(points: np.ndarray, dense: np.ndarray,
            evaluate: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distances (K, N) from ``points`` (N,) complex to curves sampled at equal phases, ``dense`` (K, T)
    complex, and the closest phases (K, N) in [0, 1) (NaN where a curve has NaN samples). With ``evaluate``
    (curve indices (L,), phases (L,) → curve points (L,) complex) every local minimum the samples bracket
    near enough to hold the closest point (:data:`REACH`) is refined (:func:`_descend`) and the closest
    taken (exact to rounding); without it, the squared distance's parabola through the closest sample and
    its neighbours gives it (to ~h³·|c'|·|c''|/d for a curve passing at d ≪ its sample spacing h·|c'|: use
    ``evaluate`` there)."""
    k, n, t = len(dense), len(points), dense.shape[-1]
    gap = points[None, :, None] - dense[:, None, :]
    d2 = gap.real ** 2 + gap.imag ** 2  # (K, N, T)
    j = np.argmin(d2, axis=-1)
    near = np.take_along_axis(d2, j[..., None], axis=-1)[..., 0]
    if evaluate is None:
        lo = np.take_along_axis(d2, ((j - 1) % t)[..., None], axis=-1)[..., 0]
        hi = np.take_along_axis(d2, ((j + 1) % t)[..., None], axis=-1)[..., 0]
        offset, value = _vertex((lo, near, hi))
        return np.sqrt(np.clip(value, 0.0, near)), ((j + offset) / t) % 1.0
    # Brackets: every sample no farther than the one before and nearer than the one after (and the closest),
    # unless it is farther than the closest by REACH chords: within a sample of it the curve comes no nearer.
    reach = REACH * np.abs(np.roll(dense, -1, axis=-1) - dense).max(axis=-1)  # (K,), NaN for a broken curve
    curve, point, sample = np.nonzero(d2 <= ((np.sqrt(near) + reach[:, None]) ** 2)[..., None])
    mid = d2[curve, point, sample]
    keep = ((mid <= d2[curve, point, (sample - 1) % t]) & (mid < d2[curve, point, (sample + 1) % t])
            | (sample == j[curve, point]))
    curve, point, sample = curve[keep], point[keep], sample[keep]
    phase, dist = _descend(evaluate, curve, points[point], (sample - 1) / t, (sample + 1) / t, sample / t)
    dist = np.minimum(dist, np.sqrt(d2[curve, point, sample]))
    pair = curve * n + point
    order = np.lexsort((dist, pair))
    best = order[np.unique(pair[order], return_index=True)[1]]  # each pair's closest bracket
    out, at = np.full(k * n, np.nan), np.full(k * n, np.nan)
    out[pair[best]], at[pair[best]] = dist[best], phase[best] % 1.0
    return out.reshape(k, n), at.reshape(k, n)


def _descend(evaluate: Callable[[np.ndarray, np.ndarray], np.ndarray], curve: np.ndarray, points: np.ndarray,
             lo: np.ndarray, hi: np.ndarray, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local minima of the squared distance f(φ) = |c(φ) − p|² between curve ``curve`` (L,) (``evaluate``, see
    :func:`closest`) and ``points`` (L,) complex over the phase φ, each in its bracket [``lo``, ``hi``] (L,) from
    ``phase`` (L,): Newton steps on f' = 0 (c' and c'' by central differences of :data:`STEP`), a bisection where
    a step would leave the bracket or f'' ≤ 0, the bracket narrowed to the side f' says; a minimum is found
    where f' is zero to its rounding or a step moves φ by at most :data:`PHASE_TOL`. Returns the phases (L,)
    and the distances there (L,); every iteration evaluates the brackets still searched at once."""
    lo, hi, phase = lo.copy(), hi.copy(), phase.astype(float)
    live = np.arange(len(curve))
    eps = np.finfo(float).eps
    for _ in range(NEWTON):
        if not live.size:
            break
        at, p = phase[live], points[live]
        c = evaluate(np.tile(curve[live], 3), np.concatenate([at - STEP, at, at + STEP])).reshape(3, -1)
        velocity = (c[2] - c[0]) / (2.0 * STEP)
        gap = c[1] - p
        slope = gap.real * velocity.real + gap.imag * velocity.imag  # f'/2
        accel = (c[2] - 2.0 * c[1] + c[0]) / STEP ** 2
        curvature = np.abs(velocity) ** 2 + gap.real * accel.real + gap.imag * accel.imag  # f''/2
        rounding = 4.0 * eps * (np.abs(c[1]) + np.abs(p)) * (np.abs(gap) / STEP + np.abs(velocity))  # of f'/2
        low, high = np.where(slope < 0, at, lo[live]), np.where(slope > 0, at, hi[live])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = at - slope / curvature
        step = np.where((curvature > 0) & (step >= low) & (step <= high), step, 0.5 * (low + high))
        flat = ~(np.abs(slope) > rounding)  # (NaN: given up)
        lo[live], hi[live] = low, high
        phase[live] = np.where(flat, at, step)
        live = live[~(flat | (np.abs(step - at) <= PHASE_TOL))]
    return phase, np.abs(evaluate(curve, phase) - points)


def _placed(fam, params: np.ndarray, factor: np.ndarray, shift: np.ndarray, mirrored: bool,
            ) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Curve rows (L,), phases (L,) → points (L,) complex of family ``fam``'s curves of ``params`` (K, P), placed
    by z ↦ shift + factor·z (z conjugated when ``mirrored``), factor and shift (K,) complex."""

    def evaluate(rows: np.ndarray, phase: np.ndarray) -> np.ndarray:
        z = fam.curves(params[rows], 1, phase)[:, 0]
        return shift[rows] + factor[rows] * (np.conj(z) if mirrored else z)

    return evaluate


def family_nearest(fam, params: np.ndarray, factor: np.ndarray, shift: np.ndarray, mirrored: bool,
                   points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact distances (K, N) from ``points`` (N,) complex to family ``fam``'s curves of ``params`` (K, P),
    placed by z ↦ shift + factor·z (z conjugated when ``mirrored``), factor and shift (K,) complex, and the
    closest crank phases (K, N) in [0, 1) (NaN where a curve breaks)."""
    z = fam.curves(params, DENSE)
    with np.errstate(invalid="ignore"):
        return closest(points, shift[:, None] + factor[:, None] * (np.conj(z) if mirrored else z),
                       _placed(fam, params, factor, shift, mirrored))


def family_closest(fam, params: np.ndarray, factor: np.ndarray, shift: np.ndarray, mirrored: bool,
                   points: np.ndarray) -> np.ndarray:
    """The distances (K, N) of :func:`family_nearest`."""
    return family_nearest(fam, params, factor, shift, mirrored, points)[0]


def family_phases(fam, params: np.ndarray, factor: complex, shift: complex, mirrored: bool,
                  points: np.ndarray) -> np.ndarray:
    """The crank phases (N,) in [0, 1) of the curve points closest to ``points`` (N,) complex (one linkage
    ``params`` (P,) placed as in :func:`family_nearest`)."""
    return family_nearest(fam, params[None], np.array([factor]), np.array([shift]), mirrored, points)[1][0]


def family_at(fam, params: np.ndarray, factor: np.ndarray, shift: np.ndarray, mirrored: bool, points: np.ndarray,
              phases: np.ndarray) -> np.ndarray:
    """Signed distances (K, N) from ``points`` (N,) complex to the curves of :func:`family_nearest`, where
    ``phases`` (N,) are the first curve's closest: each curve's gap at those phases projected on the first
    curve's gap direction (the curve's normal there). The first row is its distances; the others, for curves
    whose parameters differ from it by little (a finite-difference Jacobian's), their distances to first order
    (the closest phase's own change moves them only to second order), smooth where a distance reaches 0."""
    k, n = len(params), len(points)
    with np.errstate(invalid="ignore"):
        gap = _placed(fam, params, factor, shift, mirrored)(np.repeat(np.arange(k), n), np.tile(phases, k))
    gap = gap.reshape(k, n) - points[None]
    normal = gap[0] / np.where(gap[0] != 0, np.abs(gap[0]), 1.0)
    return gap.real * normal.real + gap.imag * normal.imag


def newton(fam, params: np.ndarray, factor: complex, shift: complex, mirrored: bool, points: np.ndarray,
           margin: float) -> tuple[np.ndarray, complex, complex] | None:
    """Gauss–Newton on the precision points ``points`` (N,) complex from a placed linkage (``params`` (P,), the
    branch fixed; ``factor``, ``shift``, ``mirrored`` as in :func:`family_closest`): the unknowns are the free
    parameters, the placement and each point's crank phase (from its closest curve point), the residuals the
    gaps c(φᵢ) − pᵢ, x and y apart (2N). Each step is the least-squares one (the smallest for fewer than the
    unknowns: an exact linkage through the points is reached quadratically where one lies near), halved until
    the gaps shrink with the linkage still working with ``margin`` (min d_s ≥ margin over the whole cycle).
    Returns (params, factor, shift) of the last kept iterate, or None when no step was kept."""
    free = np.array([name != "branch" for name in fam.PARAMETERS])
    n_free, n = int(free.sum()), len(points)
    scale = rms_radius(points)
    phases = family_phases(fam, params, factor, shift, mirrored, points)
    x = np.concatenate([params[free], [np.log(abs(factor)), np.angle(factor), (shift / scale).real,
                                       (shift / scale).imag], phases])

    def unpack(xs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = np.repeat(params[None], len(xs), axis=0)
        p[:, free] = xs[:, :n_free]
        k, angle, sx, sy = xs[:, n_free:n_free + 4].T
        return p, np.exp(k + 1j * angle), (sx + 1j * sy) * scale

    def gaps(xs: np.ndarray) -> np.ndarray:
        """Residuals (K, 2N) over the points' RMS radius of unknowns xs (K, n)."""
        p, f, s = unpack(xs)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = fam.curves(np.repeat(p, n, axis=0), 1, xs[:, n_free + 4:].ravel())[:, 0].reshape(len(xs), n)
        g = (s[:, None] + f[:, None] * (np.conj(z) if mirrored else z) - points[None]) / scale
        return np.concatenate([g.real, g.imag], axis=1)

    def fine(xs: np.ndarray) -> bool:
        return bool(works(fam.min_singularity(unpack(xs[None])[0], margin)[0], margin))

    r = gaps(x[None])[0]
    norm, kept = float(np.linalg.norm(r)), False
    for _ in range(NEWTON_STEPS):
        if not np.isfinite(norm) or norm < NEWTON_TOL:
            break
        step = 1e-7 * np.maximum(1.0, np.abs(x))
        jac = ((gaps(x[None] + np.diag(step)) - r[None]) / step[:, None]).T
        if not np.isfinite(jac).all():
            break
        dx = np.linalg.lstsq(jac, -r, rcond=None)[0]
        for _ in range(HALVINGS):
            trial = x + dx
            r_trial = gaps(trial[None])[0]
            now = float(np.linalg.norm(r_trial))
            if now < norm and fine(trial):
                break
            dx *= 0.5
        else:
            break
        x, r, norm, kept = trial, r_trial, now, True
    if not kept:
        return None
    p, f, s = unpack(x[None])
    return p[0], complex(f[0]), complex(s[0])


def error(distances: np.ndarray, radius: float) -> tuple[float, float]:
    """(RMS, max) of per-point distances (N,) over the points' RMS radius."""
    d = distances / radius
    return float(np.sqrt(np.mean(d * d))), float(d.max())


def fit(points: np.ndarray, curves: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Place each curve (K, T) complex (family frame, equal phases) on ``points`` (N,) complex by a
    similarity: for FIT_STARTS rotations, mirrored or not, each scaled to the points' RMS radius about their
    centroid, FIT_ROUNDS rounds of (closest samples, least-squares similarity onto them, the placed
    curve's RMS radius at most FIT_SIZE times the points'). Returns the RMS point-to-sample distance (K,), the
    factor and shift (K,) complex and ``mirrored`` (K,) bool."""
    k = len(curves)
    p0 = points - points.mean()
    radius = rms_radius(points)
    best = (np.full(k, np.inf), np.ones(k, complex), np.zeros(k, complex), np.zeros(k, bool))
    for mirrored in (False, True):
        raw = np.conj(curves) if mirrored else curves
        centre = raw.mean(axis=1)
        spread = np.sqrt(np.mean(np.abs(raw - centre[:, None]) ** 2, axis=1))
        size = radius / np.maximum(spread, 1e-300)
        for r in range(FIT_STARTS):
            alpha = size * np.exp(2j * np.pi * r / FIT_STARTS)
            beta = points.mean() - alpha * centre
            for _ in range(FIT_ROUNDS):
                placed = beta[:, None] + alpha[:, None] * raw
                gap = points[None, :, None] - placed[:, None, :]
                j = np.argmin(gap.real ** 2 + gap.imag ** 2, axis=-1)  # (K, N)
                w = np.take_along_axis(raw, j, axis=1)
                wc = w - w.mean(axis=1, keepdims=True)
                norm = np.sum(np.abs(wc) ** 2, axis=1)
                alpha = np.where(norm > 0, np.sum(np.conj(wc) * p0[None], axis=1) / np.maximum(norm, 1e-300), alpha)
                alpha *= np.minimum(1.0, FIT_SIZE * size / np.maximum(np.abs(alpha), 1e-300))
                beta = points.mean() - alpha * w.mean(axis=1)
            placed = beta[:, None] + alpha[:, None] * raw
            gap = points[None, :, None] - placed[:, None, :]
            d = np.sqrt(np.mean(np.min(gap.real ** 2 + gap.imag ** 2, axis=-1), axis=1))
            d = np.where(np.isfinite(d), d, np.inf)
            take = d < best[0]
            best = (np.where(take, d, best[0]), np.where(take, alpha, best[1]), np.where(take, beta, best[2]),
                    np.where(take, mirrored, best[3]))
    return best
