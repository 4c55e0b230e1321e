"""Smoothing of sketched or measured curves before they are described.

A Gaussian over neighbouring input points (σ as a fraction of the point count, so the same
option suits 100 or 10,000 points): cyclic for closed curves; open curves are extended by
their point reflection about each end, which keeps the ends and straight runs in place.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d


def smooth(points: np.ndarray, closed: bool, width: float) -> np.ndarray:
    """Points (M, D) smoothed by a Gaussian of σ = ``width`` · M points; ``width`` 0 returns them unchanged."""
    points = np.asarray(points, dtype=float)
    sigma = width * len(points)
    if sigma <= 0:
        return points
    if closed:
        return gaussian_filter1d(points, sigma, axis=0, mode="wrap")
    pad = min(int(np.ceil(4 * sigma)), len(points) - 1)
    head = 2 * points[0] - points[pad:0:-1]
    tail = 2 * points[-1] - points[-2:-pad - 2:-1]
    out = gaussian_filter1d(np.concatenate([head, points, tail]), sigma, axis=0, mode="nearest")
    return out[pad:pad + len(points)]
