"""Inputs: a constraint parameter interpolated over a time window [t0, t1] ⊆ [0, 1].

Vector keyframes interpolate linearly, directions by slerp on the sphere, orientation keyframes
by quaternion slerp, and a rotation input (axis + angles) interpolates the *angle* linearly, so
a 0 → 360° turn is one smooth turn (no 2π slerp ambiguity). Outside its window an input is
inactive (adds nothing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.gcs import quaternions as quat


@dataclass(frozen=True)
class Schedule:
    """Keyframed values of one constraint parameter.

    ``mode``: "vector" (K, 3) lerp; "direction" (K, 3) slerp of unit vectors; "orientation"
    (K, 4) quaternion slerp; "rotation": ``values`` are angles (K,) in radians about ``axis``,
    the orientation is ``rotation(axis, angle) ⊗ base``.
    """

    mode: str
    window: tuple[float, float]
    times: np.ndarray  # (K,) increasing, inside the window
    values: np.ndarray
    axis: np.ndarray | None = None
    base: np.ndarray | None = None

    def active(self, t: np.ndarray) -> np.ndarray:
        """(T,) bool: t inside the window (ends included)."""
        t0, t1 = self.window
        return (t >= t0 - 1e-12) & (t <= t1 + 1e-12)

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Parameter values at times ``t`` (T,): (T, 3) or (T, 4). Clamped to the first/last keyframe."""
        t = np.asarray(t, dtype=float)
        k = len(self.times)
        if k == 1:
            seg = np.zeros(t.shape, dtype=int)
            frac = np.zeros(t.shape)
        else:
            tc = np.clip(t, self.times[0], self.times[-1])
            seg = np.clip(np.searchsorted(self.times, tc, side="right") - 1, 0, k - 2)
            frac = (tc - self.times[seg]) / (self.times[seg + 1] - self.times[seg])
        nxt = np.minimum(seg + 1, k - 1)
        v0, v1 = self.values[seg], self.values[nxt]
        if self.mode == "vector":
            return v0 + frac[:, None] * (v1 - v0)
        if self.mode == "direction":
            return _slerp_directions(v0, v1, frac)
        if self.mode == "orientation":
            return quat.slerp(v0, v1, frac)
        angle = v0 + frac * (v1 - v0)
        return quat.multiply(quat.from_axis_angle(self.axis, angle), self.base)


def _slerp_directions(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Great-circle interpolation between unit vectors (T, 3)."""
    c = np.cross(a, b)
    n = np.linalg.norm(c, axis=-1, keepdims=True)
    angle = np.arctan2(n, np.sum(a * b, axis=-1, keepdims=True))
    rotvec = np.where(n > 1e-15, c / np.where(n > 1e-15, n, 1.0), 0.0) * angle * s[:, None]
    return quat.rotate(quat.exp(rotvec), a)
