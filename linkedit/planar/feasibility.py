"""The one predicate that decides whether a linkage works, for every command.

A linkage **works with singularity margin m** (m = 0: it only has to assemble) when

* it assembles at every sample: every dyad rule's and every step's singularity distance d_s
  (:mod:`linkedit.planar.diagnostics`) is a number above :data:`TOGGLE` (:func:`assembles`);
  d_s ≤ TOGGLE is a toggle position to rounding, where the joint's velocity is undefined;
* every d_s stays at or above m over the whole cycle, between the samples too (:func:`works`).

One density everywhere: a cycle is checked at :data:`CHECK_SAMPLES` input samples (0.25° of a
crank turn). ``simulate`` asked for fewer samples checks lock-ups there too (so does the edit's
final check, which simulates); the atlas families, the synthesis refinement and the polished
result are held to their margin there. Between samples, :func:`lowest` bounds d_s from below:
every sample is lowered by a quarter of its second difference when positive, twice the dip of
the parabola through a sampled minimum and its two neighbours (the true minimum of a smooth d_s
lies within Δ²/8 of the sampled one; the factor two covers the third-order terms while the
minimum's shape is smooth on the scale of a few samples). The four-bar and slider-crank families
compute the exact minimum over the continuous cycle in closed form instead.
"""

from __future__ import annotations

import numpy as np

#: d_s at or below this (rounding of sin² at a toggle) counts as a toggle: not assembled
TOGGLE = 1e-12
#: samples per cycle at which every command checks a linkage (lock-ups, the margin)
CHECK_SAMPLES = 1440


def assembles(ds: np.ndarray) -> np.ndarray:
    """Whether each d_s (any shape) lets its joint be placed: a number above TOGGLE (NaN: False)."""
    return np.greater(ds, TOGGLE)


def lowest(ds: np.ndarray, cyclic: bool = True) -> np.ndarray:
    """A lower bound of d_s over the cycle, (...), from d_s (..., T) at T evenly spaced inputs
    (``cyclic``: the last sample is followed by the first); −1 where a sample does not assemble.

    Every sample is lowered by max(Δ², 0)/4, Δ² its second difference (see the module)."""
    ds = np.asarray(ds, dtype=float)
    if ds.shape[-1] < 3:
        low = ds.min(axis=-1, initial=np.inf)
    else:
        if cyclic:
            second = np.roll(ds, 1, axis=-1) + np.roll(ds, -1, axis=-1) - 2.0 * ds
        else:  # the ends take their neighbour's curvature
            inner = ds[..., :-2] + ds[..., 2:] - 2.0 * ds[..., 1:-1]
            second = np.concatenate([inner[..., :1], inner, inner[..., -1:]], axis=-1)
        with np.errstate(invalid="ignore"):
            low = (ds - 0.25 * np.maximum(second, 0.0)).min(axis=-1)
    return np.where(assembles(ds).all(axis=-1), low, -1.0)


def works(low: np.ndarray | float, margin: float) -> np.ndarray:
    """Whether linkages with the lowest d_s ``low`` (any shape; :func:`lowest`, or a closed form)
    keep the singularity ``margin`` m > 0: low ≥ m (NaN: False)."""
    return np.greater_equal(low, margin)


def margin_of(margin_deg: float) -> float:
    """The singularity margin sin² μ of the transmission band [μ, 180° − μ], μ in degrees."""
    return float(np.sin(np.radians(margin_deg)) ** 2)
