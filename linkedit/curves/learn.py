"""Learning the weights of the curve distance from labelled pairs (Coros et al. 2013, §5.2).

With squared term differences Δ_m² of each pair, d² = Σ w_m Δ_m² is linear in the weights, so
the fit is one linear program (scipy's HiGHS), with a soft margin: a mislabelled pair costs its
slack instead of dictating the weights.

    minimize    mean over similar pairs of d²  +  λ Σ w_m  +  C · mean over dissimilar pairs of ξ
    subject to  d² + ξ ≥ 1 for every dissimilar pair,   w ≥ 0,  ξ ≥ 0.

C is chosen by k-fold cross-validation over the pairs (the largest C among the best held-out
separations); the held-out separation is reported as an AUC — the chance that a held-out similar
pair is closer than a held-out dissimilar one — beside each single term's AUC.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog

#: Soft-margin costs C tried by cross-validation.
COSTS = (0.1, 1.0, 10.0, 100.0, 1000.0)
#: Folds of the cross-validation (fewer when there are fewer pairs of a kind).
FOLDS = 5


@dataclass(frozen=True)
class LearnedWeights:
    """The fitted weights and how well they separate the labelled pairs."""

    weights: dict[str, float]
    similar: np.ndarray  #: (S,) learned distances of the similar pairs
    dissimilar: np.ndarray  #: (D,) learned distances of the dissimilar pairs
    cost: float | None = None  #: the soft-margin C (None: hard margin)
    held_out_auc: float | None = None  #: cross-validated AUC of the learned distance
    term_auc: dict[str, float] = field(default_factory=dict)  #: AUC of each term alone (all pairs)

    @property
    def separated(self) -> bool:
        """Every similar pair is closer than every dissimilar one."""
        return bool(self.similar.max() < self.dissimilar.min())


class Inseparable(ValueError):
    """A dissimilar pair has no difference in any term: no weights can push it apart."""

    def __init__(self, index: int) -> None:
        super().__init__(f"dissimilar pair {index} does not differ in any term")
        self.index = index


def auc(similar: np.ndarray, dissimilar: np.ndarray) -> float:
    """P(similar distance < dissimilar distance), ties counting one half."""
    s, d = np.asarray(similar)[:, None], np.asarray(dissimilar)[None, :]
    return float(np.mean((s < d) + 0.5 * (s == d)))


def _fit(sim2: np.ndarray, dis2: np.ndarray, regularization: float, cost: float | None) -> np.ndarray:
    """Weights (T,) from squared differences; ``cost`` None: hard margin."""
    n_terms, n_dis = sim2.shape[1], len(dis2)
    if cost is None:
        c = sim2.mean(axis=0) + regularization
        result = linprog(c, A_ub=-dis2, b_ub=-np.ones(n_dis), bounds=(0, None), method="highs")
        x = result.x if result.status == 0 else None
    else:
        c = np.concatenate([sim2.mean(axis=0) + regularization, np.full(n_dis, cost / n_dis)])
        a_ub = np.hstack([-dis2, -np.eye(n_dis)])
        result = linprog(c, A_ub=a_ub, b_ub=-np.ones(n_dis), bounds=(0, None), method="highs")
        x = None if result.status != 0 else result.x[:n_terms]
    if x is None:  # cannot happen once every dissimilar pair differs somewhere; kept as a guard
        raise RuntimeError(f"linear program failed: {result.message}")
    return np.maximum(x, 0.0)


def _folds(count: int, folds: int, rng: np.random.Generator) -> np.ndarray:
    return rng.permutation(np.arange(count) % folds)


def cross_validate(similar2: np.ndarray, dissimilar2: np.ndarray, regularization: float,
                   costs: tuple[float, ...] = COSTS, folds: int = FOLDS, seed: int = 0) -> dict[float, float]:
    """Held-out AUC of each cost: every pair's distance from the fit that did not see it."""
    k = min(folds, len(similar2), len(dissimilar2))
    rng = np.random.default_rng(seed)
    fs, fd = _folds(len(similar2), k, rng), _folds(len(dissimilar2), k, rng)
    out = {}
    for cost in costs:
        ds, dd = np.empty(len(similar2)), np.empty(len(dissimilar2))
        for fold in range(k):
            w = _fit(similar2[fs != fold], dissimilar2[fd != fold], regularization, cost)
            ds[fs == fold], dd[fd == fold] = similar2[fs == fold] @ w, dissimilar2[fd == fold] @ w
        out[cost] = auc(ds, dd)
    return out


def learn_weights(terms: list[str], similar: np.ndarray, dissimilar: np.ndarray,
                  regularization: float = 1e-3, cost: float | None = None) -> LearnedWeights:
    """Fit nonnegative diagonal weights.

    ``similar`` (S, T) and ``dissimilar`` (D, T) hold the term differences Δ (not squared) of
    each labelled pair, columns in the order of ``terms``. ``cost`` fixes the soft-margin C;
    without it C is cross-validated (hard margin when there are fewer than 2 pairs of a kind).
    """
    sim2, dis2 = np.asarray(similar, float) ** 2, np.asarray(dissimilar, float) ** 2
    dead = np.flatnonzero(~np.any(dis2 > 0, axis=1))
    if dead.size:
        raise Inseparable(int(dead[0]))
    held_out = None
    if cost is None and min(len(sim2), len(dis2)) >= 2:
        scores = cross_validate(sim2, dis2, regularization)
        top = max(scores.values())
        cost = max(c for c, s in scores.items() if s >= top - 1e-12)
        held_out = top
    w = _fit(sim2, dis2, regularization, cost)
    term_auc = {t: auc(sim2[:, i], dis2[:, i]) for i, t in enumerate(terms)}
    return LearnedWeights(weights=dict(zip(terms, w.tolist())), similar=np.sqrt(sim2 @ w),
                          dissimilar=np.sqrt(dis2 @ w), cost=cost, held_out_auc=held_out, term_auc=term_auc)
