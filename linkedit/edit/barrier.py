"""The singularity barrier (LinkEdit Eq. 7) on every dyad triangle at every sample.

f_s = ½·ln²(d_s/ε) where d_s < ε, else 0: zero with a continuous first derivative at ε, and
growing without bound as a triangle approaches a toggle position (d_s → 0).
"""

from __future__ import annotations

import numpy as np


def barrier(ds: np.ndarray, eps: float, scale: float) -> tuple[float, np.ndarray]:
    """Value ``scale·Σ f_s`` and its derivative with respect to ``ds`` (same shape as ``ds``)."""
    active = ds < eps
    if not active.any():
        return 0.0, np.zeros_like(ds)
    log = np.where(active, np.log(np.where(active, ds, eps) / eps), 0.0)
    return scale * 0.5 * float(np.sum(log * log)), np.where(active, scale * log / np.where(active, ds, 1.0), 0.0)
