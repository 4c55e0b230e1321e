"""Learning the weights of the curve distance from labelled pairs (Coros et al. 2013, §5.2).

With squared term differences Δ_m² of each pair, d² = Σ w_m Δ_m² is linear in the weights, so
the fit is one linear program (scipy's HiGHS):

    minimize    mean over similar pairs of d²  +  λ Σ w_m
    subject to  d² ≥ 1 for every dissimilar pair,   w ≥ 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog


@dataclass(frozen=True)
class LearnedWeights:
    """The fitted weights and how well they separate the labelled pairs."""

    weights: dict[str, float]
    similar: np.ndarray  #: (S,) learned distances of the similar pairs
    dissimilar: np.ndarray  #: (D,) learned distances of the dissimilar pairs (all ≥ 1)

    @property
    def separated(self) -> bool:
        """Every similar pair is closer than every dissimilar one."""
        return bool(self.similar.max() < self.dissimilar.min())


class Inseparable(ValueError):
    """A dissimilar pair has no difference in any term: no weights can push it apart."""

    def __init__(self, index: int) -> None:
        super().__init__(f"dissimilar pair {index} does not differ in any term")
        self.index = index


def learn_weights(terms: list[str], similar: np.ndarray, dissimilar: np.ndarray,
                  regularization: float = 1e-3) -> LearnedWeights:
    """Fit nonnegative diagonal weights.

    ``similar`` (S, T) and ``dissimilar`` (D, T) hold the term differences Δ (not squared) of
    each labelled pair, columns in the order of ``terms``.
    """
    sim2, dis2 = np.asarray(similar, float) ** 2, np.asarray(dissimilar, float) ** 2
    dead = np.flatnonzero(~np.any(dis2 > 0, axis=1))
    if dead.size:
        raise Inseparable(int(dead[0]))
    cost = sim2.mean(axis=0) + regularization
    result = linprog(cost, A_ub=-dis2, b_ub=-np.ones(len(dis2)), bounds=(0, None), method="highs")
    if result.status != 0:  # cannot happen once every dissimilar pair differs somewhere; kept as a guard
        raise RuntimeError(f"linear program failed: {result.message}")
    w = np.maximum(result.x, 0.0)
    return LearnedWeights(weights=dict(zip(terms, w.tolist())), similar=np.sqrt(sim2 @ w),
                          dissimilar=np.sqrt(dis2 @ w))
