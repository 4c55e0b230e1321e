"""Predictions of the step-by-step continuation: a solved pose with its velocity and the
history of the poses before it (:class:`Pose`), and the Lagrange polynomial through them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.linalg import Linear
from linkedit.gcs.system import State, System

#: degree of the polynomial through the last accepted poses that starts a step when it agrees
#: with the second-order tangent prediction (higher degrees amplify the poses' own errors, up to
#: the tolerance, more than they follow the motion at a few hundred steps per cycle)
PREDICT_ORDER = 7


@dataclass
class Pose:
    """A solved pose at time ``t``: state, residual, linearization, scaled velocity (N,) and
    the change of velocity per unit time since the pose before (N,) (None for the first)."""

    t: float
    state: State
    r: np.ndarray
    linear: Linear
    velocity: np.ndarray
    trend: np.ndarray | None = None
    #: the accepted poses of this continuation up to this one, newest last: times (k,) and
    #: states (k, 7M) (positions (M, 3) then quaternions (M, 4), flattened), k ≤ PREDICT_ORDER + 1
    history: tuple[np.ndarray, np.ndarray] | None = None

    def followed_by(self, t: float, state: State, r: np.ndarray, linear: "Linear", velocity: np.ndarray) -> "Pose":
        """The next accepted pose of the continuation."""
        ts, Z = self.history or (np.array([self.t]), _flat(self.state)[None])
        keep = slice(-PREDICT_ORDER, None)
        history = (np.concatenate([ts[keep], [t]]), np.concatenate([Z[keep], _flat(state)[None]]))
        return Pose(t, state, r, linear, velocity, (velocity - self.velocity) / (t - self.t), history)

    def extrapolated(self, t: float) -> State | None:
        """The Lagrange polynomial through the history's poses at t (quaternions component-wise,
        then normalized: consecutive solved quaternions never flip sign); None with fewer than
        three poses."""
        if self.history is None or len(self.history[0]) < 3:
            return None
        ts, Z = self.history
        z = lagrange_weights(ts, t) @ Z
        M = self.state.position.shape[0]
        return State(z[:3 * M].reshape(M, 3), quat.normalize(z[3 * M:].reshape(M, 4)))


def _flat(x: State) -> np.ndarray:
    """Positions then quaternions of a state, flattened (7M,)."""
    return np.concatenate([x.position.ravel(), x.orientation.ravel()])

def lagrange_weights(nodes: np.ndarray, t: float) -> np.ndarray:
    """Weights (k,) of the Lagrange polynomial through distinct ``nodes`` (k,) at a time ``t``
    that is none of them: w_j = ∏_{i≠j} (t − t_i) / (t_j − t_i)."""
    d = t - nodes
    between = nodes[:, None] - nodes  # t_j − t_i, 1 on the diagonal (i = j is left out)
    between.flat[::len(nodes) + 1] = 1.0
    return (d.prod() / d) / between.prod(axis=1)


#: solved poses (and their velocities) the polynomial extrapolation goes through
NODES = 4


class Extrapolation:
    """Batched predictions of poses from solved ones (the waves' part)."""

    system: System

    def osculating(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray, around: np.ndarray,
                   t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (B, M, 3) and quaternions (B, M, 4) at times ``t`` (B,), each from the
        osculating polynomial (degree 2k − 1) through k consecutive ones of n solved poses
        (the first of them ``around`` (B,)) and their time derivatives: times (n,), flat poses
        and derivatives (n, 7M) (:func:`flat`; quaternions component-wise, then normalized)."""
        k = min(NODES, len(t_nodes))
        x, which, idx, tau, half = _windows(t_nodes, around, t, k)
        # the interpolant's weights on the node values and rates: w A = (1, τ, τ², …) at τ
        w = (tau[:, None] ** np.arange(2 * k))[:, None, :] @ np.linalg.inv(_hermite(x))[which]  # (B, 1, 2k)
        around = nodes[idx]  # (B, k, 7M), from the first: coordinates equal at every pose stay exactly so
        Z = around[:, :1] + w[:, :, :k] @ (around - around[:, :1]) + (w[:, :, k:] * half[:, None, None]) @ rates[idx]
        return self._split(Z[:, 0])

    def extrapolated(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray,
                     t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`osculating`, every time from the same k poses: times (k,), flat poses and
        their time derivatives (k, 7M), normalized by the farthest time."""
        t0, k = t_nodes[-1], len(t_nodes)
        span = max(float(np.ptp(t_nodes)), float(np.abs(t - t0).max()))
        A = _hermite((t_nodes - t0) / span)
        w = np.linalg.solve(A.T, ((t - t0) / span) ** np.arange(2 * k)[:, None])  # (2k, B)
        # from the last pose: coordinates equal at every pose stay exactly so
        return self._split(nodes[-1] + w[:k].T @ (nodes - nodes[-1]) + (span * w[k:].T) @ rates)

    def _split(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        M = self.system.n_members
        return Z[:, :3 * M].reshape(-1, M, 3), quat.normalize(Z[:, 3 * M:].reshape(-1, M, 4))


def lagrange(t_nodes: np.ndarray, nodes: np.ndarray, around: np.ndarray, t: np.ndarray, k: int) -> np.ndarray:
    """Flat poses (B, 7M) at times t (B,), each from the polynomial (degree k − 1) through k
    consecutive of n flat poses (times (n,), poses (n, 7M)), the first of them ``around`` (B,)."""
    k = min(k, len(t_nodes))
    x, which, idx, tau, _ = _windows(t_nodes, around, t, k)
    # the weights on the node values: w A = (1, τ, τ², …) at τ, A the nodes' powers
    w = (tau[:, None] ** np.arange(k))[:, None, :] @ np.linalg.inv(x[..., None] ** np.arange(k))[which]
    return (w @ nodes[idx])[:, 0]


def _windows(t_nodes: np.ndarray, around: np.ndarray, t: np.ndarray,
             k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The windows of k consecutive nodes (times (n,)) that times t (B,) are predicted from,
    the first of each ``around`` (B,), with each window's times centred and scaled onto
    [−1, 1] (well-conditioned systems): the distinct windows' node times so scaled (W, k),
    which window each time uses (B,), its node indices (B, k), the time so scaled (B,), and
    the half width (B,) of its window."""
    first, which = np.unique(around, return_inverse=True)
    window = first[:, None] + np.arange(k)  # (W, k)
    tw = t_nodes[window]
    mid, half = 0.5 * (tw[:, 0] + tw[:, -1]), np.maximum(0.5 * np.ptp(tw, axis=1), np.finfo(float).tiny)
    return (tw - mid[:, None]) / half[:, None], which, window[which], (t - mid[which]) / half[which], half[which]


def _hermite(x: np.ndarray) -> np.ndarray:
    """The osculating interpolation matrices (..., 2k, 2k) at normalized node times x (..., k):
    rows the values then the derivatives of the monomials 1, x, …, x^(2k−1)."""
    powers = np.arange(2 * x.shape[-1])
    return np.concatenate([x[..., None] ** powers, powers * x[..., None] ** np.maximum(powers - 1, 0)], axis=-2)


def flat(P: np.ndarray, Q: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses as flat states (B, 7M) — positions (B, M, 3) then quaternions (B, M, 4) — and their
    time derivatives (B, 7M) from the real velocities V (B, M, 6): ṗ, and q̇ = ½ (0, ω) ⊗ q."""
    B, M = P.shape[:2]
    w = np.concatenate([np.zeros(V.shape[:2] + (1,)), V[..., 3:]], axis=2)
    dq = 0.5 * quat.multiply(w.reshape(-1, 4), Q.reshape(-1, 4)).reshape(B, 4 * M)
    return (np.concatenate([P.reshape(B, 3 * M), Q.reshape(B, 4 * M)], axis=1),
            np.concatenate([V[..., :3].reshape(B, 3 * M), dq], axis=1))
