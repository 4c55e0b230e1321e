"""Timing-aware matching (``linkedit synthesize --timing``): the target's samples are positions at given times.

A closed target with sample times t_m and cycle time T is one crank turn: sample m is reached at
phase s_m = (t_m − t₀)/T after the first. It is resampled at ``SAMPLES`` equally spaced phases
s_j = j/N by a periodic cubic spline in time through the samples (straight lines between a coarse
target's samples would cut inside its curve: 0.9 % of the radius mid-way between 24 samples of a
circle), and its velocities per unit of phase are the periodic central differences
p'_j = (p_{j+1} − p_{j−1})·N/2. Errors are reported at the target's own samples (:meth:`TimedTarget.error`).

A candidate linkage's tracked point w (family frame) is placed so that at phase s it is at
β + α·w(φ₀ + σ·s) (α complex: scale and rotation; ``mirrored``: α·conj(w); σ = −1: the motor turns
the other way, ``reversed``), its velocities taken by the same central differences. The timed
distance is

    d² = (Σ_j |p_j − β − α·w_j|² + λ² Σ_j |p'_j − α·w'_j|²) / (N·size²),   λ = 1/(2π),

positions and velocities (λ: a point running round a circle of radius r has speed 2πr per turn),
minimized over α, β (linear least squares, closed form), the start phase φ₀ (every one of the N
samples at once by an FFT cross-correlation) and the four variants (mirrored, reversed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from linkedit.errors import InputError

#: Equally spaced phases the target is resampled at (and candidates evaluated at).
SAMPLES = 256
#: Weight of the velocity residuals against the position residuals.
VELOCITY_WEIGHT = 1.0 / (2.0 * np.pi)


@dataclass(frozen=True)
class TimedTarget:
    points: np.ndarray  #: (N,) complex, at phases j/N after the first sample
    velocities: np.ndarray  #: (N,) complex, per unit of phase
    size: float
    samples: np.ndarray  #: (M,) complex, the target's own samples
    phases: np.ndarray  #: (M,) their phases s_m in [0, 1) (s_0 = 0)

    def error(self, drawn: np.ndarray) -> tuple[float, float]:
        """(RMS, max) distance, over the size, from each sample to ``drawn`` (M,) complex: the linkage's
        point at the sample's phase."""
        d = np.abs(drawn - self.samples) / self.size
        return float(np.sqrt(np.mean(d * d))), float(d.max())


def central(z: np.ndarray) -> np.ndarray:
    """Periodic central differences per unit of phase of samples (..., N) at equally spaced phases."""
    n = z.shape[-1]
    return (np.roll(z, -1, axis=-1) - np.roll(z, 1, axis=-1)) * (n / 2.0)


def timed_target(points: np.ndarray, times: np.ndarray | None, period: float | None, closed: bool, size: float,
                 origin: str) -> TimedTarget:
    """The target (M,) complex with its times, resampled at SAMPLES equally spaced phases; an
    InputError (exit 2) when it has no usable times."""
    if times is None:
        raise InputError("--timing needs the sample times: a CSV t column or a result.h5 track", file=origin)
    if not closed or period is None:
        raise InputError("--timing needs a closed target (one crank turn, its times spanning the cycle)",
                         file=origin)
    steps = np.diff(times)
    if not (steps > 0).all() or not period > times[-1] - times[0]:
        raise InputError("the sample times must increase strictly and stay within one cycle", file=origin)
    phase = (times - times[0]) / period
    ring = np.concatenate([phase, [1.0]])
    loop = np.concatenate([points, points[:1]])
    z = CubicSpline(ring, np.column_stack([loop.real, loop.imag]), bc_type="periodic")(np.arange(SAMPLES) / SAMPLES)
    z = z[:, 0] + 1j * z[:, 1]
    return TimedTarget(z, central(z), size, points.copy(), phase)


@dataclass(frozen=True)
class TimedFit:
    distance: np.ndarray  #: (K,) timed distance over the target's size
    scale: np.ndarray  #: (K,)
    angle: np.ndarray  #: (K,) radians
    shift: np.ndarray  #: (K,) complex
    phase: np.ndarray  #: (K,) φ₀: the family phase at the target's first sample
    mirrored: np.ndarray  #: (K,) bool
    reversed: np.ndarray  #: (K,) bool


def timed_fit(target: TimedTarget, curves: np.ndarray) -> TimedFit:
    """The best placement and start phase of each candidate curve (K, N) complex (family frame,
    N = SAMPLES equally spaced phases from 0) on the timed target."""
    n = target.points.shape[0]
    lam2 = VELOCITY_WEIGHT ** 2
    a = target.points - target.points.mean()
    da = target.velocities
    a_spec, da_spec = np.conj(np.fft.fft(a)), np.conj(np.fft.fft(da))
    reversed_curves = curves[:, (-np.arange(n)) % n]  # v[m] = w(−m/N)
    best = None
    for mirrored in (False, True):
        for backwards in (False, True):
            b = reversed_curves if backwards else curves
            b = np.conj(b) if mirrored else b
            b = b - b.mean(axis=1, keepdims=True)
            db = central(b)
            corr = np.fft.ifft(a_spec * np.fft.fft(b, axis=1) + lam2 * da_spec * np.fft.fft(db, axis=1), axis=1)
            # corr[k, s] = Σ_j conj(a_j)·b_{j+s} + λ² Σ_j conj(a'_j)·b'_{j+s}
            norm = np.sum(np.abs(b) ** 2, axis=1) + lam2 * np.sum(np.abs(db) ** 2, axis=1)
            s = np.argmax(np.abs(corr), axis=1)
            c = corr[np.arange(len(curves)), s]
            left = np.sum(np.abs(a) ** 2) + lam2 * np.sum(np.abs(da) ** 2) - np.abs(c) ** 2 / norm
            d = np.sqrt(np.maximum(left, 0.0) / n) / target.size
            alpha = np.conj(c) / norm
            start = (-s if backwards else s) % n / n
            mean = (reversed_curves if backwards else curves).mean(axis=1)
            beta = target.points.mean() - alpha * (np.conj(mean) if mirrored else mean)
            fit = TimedFit(d, np.abs(alpha), np.angle(alpha), beta, start, np.full(len(d), mirrored),
                           np.full(len(d), backwards))
            if best is None:
                best = fit
            else:
                take = fit.distance < best.distance
                best = TimedFit(*(np.where(take, getattr(fit, f), getattr(best, f))
                                  for f in TimedFit.__dataclass_fields__))
    assert best is not None
    return best


def timed_sequence(curves: np.ndarray, reversed_: bool) -> np.ndarray:
    """Curves (K, N) evaluated from phase φ₀ on, as met by the target's phases j/N: w(φ₀ + σ j/N)."""
    n = curves.shape[-1]
    return curves[..., (-np.arange(n)) % n] if reversed_ else curves
