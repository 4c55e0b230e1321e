"""Predictions of the step-by-step continuation: a solved pose with its velocity and the
history of the poses before it (:class:`Pose`), and the Lagrange polynomial through them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.linalg import Linear
from linkedit.gcs.system import State

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

