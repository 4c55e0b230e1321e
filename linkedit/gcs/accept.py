"""The continuation's acceptance test, one for both schedulers: a (sub-)step of length h from
a solved pose with scaled velocity v is accepted when it converges to a pose within
``predictor_tol`` of its tangent prediction (its scaled displacement d from the pose before:
|d − h·v|∞ ≤ ``predictor_tol``) and moves at most ``max_motion`` (|v|∞·|h|); otherwise the
step-by-step continuation halves it (:meth:`linkedit.gcs.continuation.Solver.advance`), and a
wave keeps its steps up to the first that fails (:mod:`linkedit.gcs.waves`).
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs.tolerances import Options


def near(moved: np.ndarray, tangent: np.ndarray, options: Options) -> np.ndarray:
    """Whether displacements ``moved`` (..., N) are within ``predictor_tol`` of the tangent
    predictions ``tangent`` (..., N), per pose (...)."""
    return np.abs(moved - tangent).max(axis=-1) <= options.predictor_tol


def within_motion(speed: np.ndarray | float, h: np.ndarray | float, options: Options) -> np.ndarray:
    """Whether steps of length h (times) from poses of largest scaled speed ``speed`` move at
    most ``max_motion``."""
    return np.asarray(speed * np.abs(h) <= options.max_motion)


def passes(moved: np.ndarray, h: np.ndarray, v0: np.ndarray, options: Options) -> np.ndarray:
    """The acceptance test of B steps (B,): displacements ``moved`` (B, N) from the poses
    before, of lengths h (B,), from those poses' scaled velocities v0 (B, N)."""
    return near(moved, h[:, None] * v0, options) & within_motion(np.abs(v0).max(axis=1), h, options)


def leading(ok: np.ndarray) -> int:
    """How many of consecutive steps pass, from the first: the index of the first False (B,)."""
    return int(np.argmin(ok)) if not ok.all() else len(ok)


def curving(t: np.ndarray, vel: np.ndarray, k: int, col: np.ndarray) -> float:
    """The second-order part of the move from step k − 1 to k (scaled), ½ h² |a|, with the
    acceleration from the velocities (T, M, 6) of the two steps before: where it exceeds
    ``predictor_tol`` the acceptance test would reject that step (the continuation sub-steps
    it), and where it exceeds half of it the steps after likely some: a wave starting there
    would keep little."""
    h, before = float(t[k] - t[k - 1]), float(t[k - 1] - t[k - 2])
    change = np.abs((vel[k - 1] - vel[k - 2]).ravel() / col).max()
    return 0.5 * h * h / abs(before) * float(change)
