"""Output curves: tracked points evaluated from stored member states, and their velocities.

Exact velocities come from the members' (:func:`track_velocities`: v + ω × R s). The paper's
rule (``--velocity parabola``) takes the derivative of the parabola through a sample and its
two neighbours (non-uniform steps allowed); a cyclic curve — the run is one period of its
inputs and the ends meet, last point within 1e-6 of the curve's size of the first — wraps
around (the duplicated end sample is skipped); otherwise the end samples use the parabola
through the first (last) three samples.
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat

#: ends closer than this fraction of the curve's size make the curve cyclic
CLOSED_TOL = 1e-6


def track_positions(position: np.ndarray, orientation: np.ndarray, member: int, point: np.ndarray) -> np.ndarray:
    """World positions (T, 3) of a member-space point (3,) from member states (T, M, 3), (T, M, 4)."""
    R = quat.to_matrix(orientation[:, member])
    return position[:, member] + R @ np.asarray(point, dtype=float)


def track_velocities(orientation: np.ndarray, velocity: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Velocities (T, 3) of a member-space point (3,) from the member's orientations (T, 4) and
    velocities (T, 6) [d position / dt, world angular velocity]: v + ω × (R point)."""
    arm = quat.to_matrix(orientation) @ np.asarray(point, dtype=float)
    return velocity[:, :3] + np.cross(velocity[:, 3:], arm)


def ends_meet(p: np.ndarray) -> bool:
    """True when the curve's ends meet relative to its size (bounding-box diagonal)."""
    size = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    return bool(np.linalg.norm(p[-1] - p[0]) <= CLOSED_TOL * max(size, 1e-300))


def _parabola(t0, t1, t2, p0, p1, p2, at: str) -> np.ndarray:
    """Derivative of the parabola through three samples at the first, middle or last one."""
    h1 = (t1 - t0)[:, None]
    h2 = (t2 - t1)[:, None]
    if at == "middle":
        return (-h2 / (h1 * (h1 + h2))) * p0 + ((h2 - h1) / (h1 * h2)) * p1 + (h1 / (h2 * (h1 + h2))) * p2
    if at == "first":
        return (-(2 * h1 + h2) / (h1 * (h1 + h2))) * p0 + ((h1 + h2) / (h1 * h2)) * p1 - (h1 / (h2 * (h1 + h2))) * p2
    return (h2 / (h1 * (h1 + h2))) * p0 - ((h1 + h2) / (h1 * h2)) * p1 + ((2 * h2 + h1) / (h2 * (h1 + h2))) * p2


def velocity(t: np.ndarray, p: np.ndarray, cyclic: bool | None = None, period: float | None = None) -> np.ndarray:
    """d p / d t (T, D) of samples ``p`` (T, D) at times ``t`` (T,).

    ``cyclic=None`` decides from the curve (:func:`ends_meet`; the last sample then repeats the
    first, one ``period`` = t[-1] − t[0] later). With ``period`` given the samples are one
    period without the repeated end (t = k/T), and the curve wraps from the last to the first.
    """
    t = np.asarray(t, dtype=float)
    p = np.asarray(p, dtype=float)
    T = t.size
    if T < 3:
        if T < 2:
            return np.zeros_like(p)
        d = (p[1] - p[0]) / (t[1] - t[0])
        return np.broadcast_to(d, p.shape).copy()
    if period is not None:
        tt = np.concatenate([[t[-1] - period], t, [t[0] + period]])
        pp = np.concatenate([p[-1:], p, p[:1]])
        return _parabola(tt[:-2], tt[1:-1], tt[2:], pp[:-2], pp[1:-1], pp[2:], "middle")
    if cyclic is None:
        cyclic = ends_meet(p)
    if cyclic and T >= 4:
        per = t[-1] - t[0]
        inner = velocity(t[:-1], p[:-1], period=per)
        return np.concatenate([inner, inner[:1]])
    out = np.empty_like(p)
    out[1:-1] = _parabola(t[:-2], t[1:-1], t[2:], p[:-2], p[1:-1], p[2:], "middle")
    out[:1] = _parabola(t[:1], t[1:2], t[2:3], p[:1], p[1:2], p[2:3], "first")
    out[-1:] = _parabola(t[-3:-2], t[-2:-1], t[-1:], p[-3:-2], p[-2:-1], p[-1:], "last")
    return out
