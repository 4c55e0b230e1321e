"""Precision points: a few target points the tracked point must pass through, at any crank phase.

A target of precision points is not a polygon: its error is, for each point, the distance to the
closest point of the linkage's whole curve (free timing), normalized by the points' RMS radius about
their centroid. The closest point is found on the curve sampled densely (:data:`DENSE` samples per
cycle), then refined on the crank phase by parabolas through three samples of the squared distance
(twice, the second ``FINER`` times narrower) and the curve evaluated there, so the distance is exact
to rounding. The atlas search places each candidate on the points by a similarity fit to its closest
samples (iterated, 12 start rotations, mirrored or not) and ranks by the same measure.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: A closed target with at most this many points and uneven spacing is taken for precision points.
DETECT_MAX = 25
#: Uneven spacing: the coefficient of variation of the chord lengths above this.
UNEVEN = 0.25
#: Curve samples per cycle the closest point is searched among.
DENSE = 720
#: The second parabola's step is the first's over this.
FINER = 64
#: Similarity-fit rounds and start rotations of the atlas ranking.
FIT_ROUNDS = 8
FIT_STARTS = 12


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
            evaluate: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distances (K, N) from ``points`` (N,) complex to curves sampled at equal phases, ``dense`` (K, T)
    complex, and the closest phases (K, N) in [0, 1). With ``evaluate`` (phases (K, N) → curve points
    (K, N) complex) the phase is refined by two parabolas and the curve evaluated there (exact to rounding);
    without it, the squared distance's parabola through the closest sample and its neighbours gives it (to
    ~h³·|c'|·|c''|/d for a curve passing at d ≪ its sample spacing h·|c'|: use ``evaluate`` there)."""
    t = dense.shape[-1]
    gap = points[None, :, None] - dense[:, None, :]
    d2 = gap.real ** 2 + gap.imag ** 2  # (K, N, T)
    j = np.argmin(d2, axis=-1)
    near = np.take_along_axis(d2, j[..., None], axis=-1)[..., 0]
    if evaluate is None:
        lo = np.take_along_axis(d2, ((j - 1) % t)[..., None], axis=-1)[..., 0]
        hi = np.take_along_axis(d2, ((j + 1) % t)[..., None], axis=-1)[..., 0]
        offset, value = _vertex((lo, near, hi))
        return np.sqrt(np.clip(value, 0.0, near)), ((j + offset) / t) % 1.0
    phase = j / t
    for h in (1.0 / t, 1.0 / (t * FINER)):
        f = tuple(np.abs(evaluate(phase + s * h) - points) ** 2 for s in (-1.0, 0.0, 1.0))
        phase = phase + _vertex(f)[0] * h  # type: ignore[arg-type]
    exact = np.abs(evaluate(phase) - points)
    return np.minimum(exact, np.sqrt(near)), phase % 1.0


def family_closest(fam, params: np.ndarray, factor: np.ndarray, shift: np.ndarray, mirrored: bool,
                   points: np.ndarray) -> np.ndarray:
    """Exact distances (K, N) from ``points`` (N,) complex to family ``fam``'s curves of ``params`` (K, P),
    placed by z ↦ shift + factor·z (z conjugated when ``mirrored``), factor and shift (K,) complex."""
    k, n = len(params), len(points)

    def place(z: np.ndarray) -> np.ndarray:
        return shift[:, None] + factor[:, None] * (np.conj(z) if mirrored else z)

    def evaluate(phase: np.ndarray) -> np.ndarray:
        return place(fam.curves(np.repeat(params, n, axis=0), 1, phase.reshape(-1)).reshape(k, n))

    with np.errstate(invalid="ignore"):
        return closest(points, place(fam.curves(params, DENSE)), evaluate)[0]


def error(distances: np.ndarray, radius: float) -> tuple[float, float]:
    """(RMS, max) of per-point distances (N,) over the points' RMS radius."""
    d = distances / radius
    return float(np.sqrt(np.mean(d * d))), float(d.max())


def fit(points: np.ndarray, curves: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Place each curve (K, T) complex (family frame, equal phases) on ``points`` (N,) complex by a
    similarity: for FIT_STARTS rotations, mirrored or not, each scaled to the points' RMS radius about their
    centroid, FIT_ROUNDS rounds of (closest samples, least-squares similarity onto them). Returns the
    RMS point-to-sample distance (K,), the factor and shift (K,) complex and ``mirrored`` (K,) bool."""
    k = len(curves)
    p0 = points - points.mean()
    radius = rms_radius(points)
    best = (np.full(k, np.inf), np.ones(k, complex), np.zeros(k, complex), np.zeros(k, bool))
    for mirrored in (False, True):
        raw = np.conj(curves) if mirrored else curves
        centre = raw.mean(axis=1)
        spread = np.sqrt(np.mean(np.abs(raw - centre[:, None]) ** 2, axis=1))
        for r in range(FIT_STARTS):
            alpha = radius / np.maximum(spread, 1e-300) * np.exp(2j * np.pi * r / FIT_STARTS)
            beta = points.mean() - alpha * centre
            for _ in range(FIT_ROUNDS):
                placed = beta[:, None] + alpha[:, None] * raw
                gap = points[None, :, None] - placed[:, None, :]
                j = np.argmin(gap.real ** 2 + gap.imag ** 2, axis=-1)  # (K, N)
                w = np.take_along_axis(raw, j, axis=1)
                wc = w - w.mean(axis=1, keepdims=True)
                norm = np.sum(np.abs(wc) ** 2, axis=1)
                alpha = np.where(norm > 0, np.sum(np.conj(wc) * p0[None], axis=1) / np.maximum(norm, 1e-300), alpha)
                beta = points.mean() - alpha * w.mean(axis=1)
            placed = beta[:, None] + alpha[:, None] * raw
            gap = points[None, :, None] - placed[:, None, :]
            d = np.sqrt(np.mean(np.min(gap.real ** 2 + gap.imag ** 2, axis=-1), axis=1))
            d = np.where(np.isfinite(d), d, np.inf)
            take = d < best[0]
            best = (np.where(take, d, best[0]), np.where(take, alpha, best[1]), np.where(take, beta, best[2]),
                    np.where(take, mirrored, best[3]))
    return best
