"""Interpolated inputs: keyframed constraint parameters over a time window.

An input drives one parameter of its constraint (a world/other point, an axis direction, a
relative orientation) along keyframes. Between keyframes the value is interpolated (lerp for
points, great-circle slerp for directions, quaternion slerp for orientations, linear angle for
a rotation); outside the window the input is inactive (it constrains nothing, and the member
it drove holds still unless something else moves it).

:meth:`Schedule.rate` is the exact time derivative of the interpolated value, as a *virtual
velocity* of the constraint's member b, in b's frame: ``[u (3), ω (3)]``, u the velocity of the
driven point, ω the angular velocity that turns the driven direction or orientation (left
multiplication: value(t + dt) = exp(ω dt) ⊗ value(t)). At a keyframe the rate of the segment
that starts there is taken (the last segment's at the last keyframe).

Two consecutive keyframes exactly half a turn apart have no shortest arc (every great circle
between antipodal directions is as short, and ±q name one orientation): they are rejected by
:func:`half_turn_keyframe`'s caller, never interpolated in an arbitrary direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.gcs import quaternions as quat

#: consecutive keyframes closer than this to half a turn apart (sine of the gap) are ambiguous
HALF_TURN_TOL = 1e-9


@dataclass(frozen=True)
class Schedule:
    """Keyframed values of one constraint parameter.

    ``mode``: "vector" (K, 3) lerp; "direction" (K, 3) slerp of unit vectors; "orientation"
    (K, 4) quaternion slerp; "rotation": ``values`` are angles (K,) in radians about ``axis``,
    the orientation is ``rotation(axis, angle) ⊗ base``; "scalar" (K, 1) lerp of a
    constraint's value (a distance), whose rate is its time derivative (T, 1).
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

    def _segments(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Segment index (T,), fraction in it (T,) and 1 / segment duration (T,) (0 when clamped)."""
        t = np.asarray(t, dtype=float)
        k = len(self.times)
        if k == 1:
            zero = np.zeros(t.shape)
            return np.zeros(t.shape, dtype=int), zero, zero
        tc = np.clip(t, self.times[0], self.times[-1])
        seg = np.clip(np.searchsorted(self.times, tc, side="right") - 1, 0, k - 2)
        span = self.times[seg + 1] - self.times[seg]
        inside = (t >= self.times[0]) & (t <= self.times[-1])
        return seg, (tc - self.times[seg]) / span, np.where(inside, 1.0 / span, 0.0)

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Parameter values at times ``t`` (T,): (T, 3) or (T, 4). Clamped to the first/last keyframe."""
        seg, frac, _ = self._segments(t)
        nxt = np.minimum(seg + 1, len(self.times) - 1)
        v0, v1 = self.values[seg], self.values[nxt]
        if self.mode in ("vector", "scalar"):
            return v0 + frac[:, None] * (v1 - v0)
        if self.mode == "direction":
            return quat.rotate(quat.exp(frac[:, None] * _turn(v0, v1)), v0)
        if self.mode == "orientation":
            return quat.slerp(v0, v1, frac)
        if self.axis is None or self.base is None:
            raise ValueError("a rotation schedule needs its axis and base")
        angle = v0 + frac * (v1 - v0)
        return quat.multiply(quat.from_axis_angle(self.axis, angle), self.base)

    def rate(self, t: np.ndarray) -> np.ndarray:
        """The virtual velocity (T, 6) ``[u, ω]`` of the value at ``t`` (module docstring);
        zero outside the window and before the first / after the last keyframe."""
        seg, _, inv = self._segments(t)
        out = np.zeros((np.size(t), 1 if self.mode == "scalar" else 6))
        if len(self.times) == 1:
            return out
        v0, v1 = self.values[seg], self.values[seg + 1]
        if self.mode == "scalar":
            out[:] = (v1 - v0) * inv[:, None]
        elif self.mode == "vector":
            out[:, :3] = (v1 - v0) * inv[:, None]
        elif self.mode == "direction":
            out[:, 3:] = _turn(v0, v1) * inv[:, None]
        elif self.mode == "orientation":
            out[:, 3:] = quat.log(quat.multiply(v1, quat.conjugate(v0))) * inv[:, None]
        else:
            out[:, 3:] = ((v1 - v0) * inv)[:, None] * self.axis
        return out * self.active(np.asarray(t, dtype=float))[:, None]


def _turn(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The shortest rotation vector (T, 3) turning unit vectors a onto b (T, 3) (never antipodal:
    :func:`half_turn_keyframe`)."""
    c = quat.cross(a, b)
    n = np.sqrt(quat.dot(c, c))
    angle = np.arctan2(n, quat.dot(a, b))
    return c * np.divide(angle, n, out=np.ones_like(n), where=n > 1e-300)[:, None]


def half_turn_keyframe(mode: str, values: np.ndarray) -> int | None:
    """The first keyframe index k whose segment to k + 1 is (nearly) half a turn, so that the
    direction of turning is undefined; None when there is none."""
    if len(values) < 2 or mode not in ("direction", "orientation"):
        return None
    a, b = values[:-1], values[1:]
    if mode == "direction":
        c = quat.cross(a, b)
        ambiguous = (np.sqrt(quat.dot(c, c)) < HALF_TURN_TOL) & (quat.dot(a, b) < 0.0)
    else:
        ambiguous = np.abs(quat.multiply(b, quat.conjugate(a))[:, 0]) < HALF_TURN_TOL
    hits = np.flatnonzero(ambiguous)
    return int(hits[0]) if hits.size else None
