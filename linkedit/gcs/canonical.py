"""The canonical pose along free directions (passive degrees of freedom): the solved pose
nearest the rest pose, and its time derivative.

Where the constraint Jacobian J has a null space N (B poses, (B, N, f): an RSSR coupler's idle
spin about the line through its ball joints), the constraints leave the pose free along it.
The pose written is the one nearest the rest pose in the solver's scaled metric — the squared
norm ½|d|² of the scaled displacement d = x ⊖ rest (positions over the mechanism's size,
world rotation vectors log(q q_rest⁻¹)) — over the poses that satisfy the constraints, so it
does not depend on the steps taken to get there. Its gradient in the local coordinates is d
itself (the rotation block: J_l⁻ᵀ(φ) φ = φ), so it is stationary where

    g = Nᵀ d = 0,

and a Newton step along the null space is α = −G⁻¹ g with the reduced Hessian

    G_ij = n_iᵀ D n_j − λᵀ J̇_{n_j} n_i,   λ = J⁺ᵀ d,

D = ∂d/∂x (identity on positions, J_l⁻¹(φ) on rotations), J̇_w the change of the scaled J along
w (central differences, by the scheduler: :meth:`linkedit.gcs.continuation.Solver.canonical`,
:func:`linkedit.gcs.free.canonical`); the second term is the null space turning
(ṅ = −J⁺ J̇ n). Along the motion (least-norm velocity v₀, J v₀ = −∂r/∂t) g stays zero, so the
velocity is the tangent of the constrained argmin:

    v = v₀ + N β,   G β = −ġ₀,   ġ₀ = Nᵀ D v₀ − λᵀ J̇_{(v₀, 1)} N

(J̇_{(v₀,1)}: along v₀ with the inputs advanced in time). Where the minimum is not unique (G
not positive definite), the Newton step is replaced by a gradient step with the metric alone,
so the poses stay on the minimum continuous with the step before.
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat

#: central-difference step (scaled pose units) of J along a free direction or the motion
STEP = 1e-5
#: Newton steps along the null space per pose, at most
ITERATIONS = 8


def metric(d: np.ndarray, w: np.ndarray) -> np.ndarray:
    """D w (B, N, k): the change of the scaled displacement from rest d (B, N) along scaled
    local moves w (B, N, k) (positions unchanged, rotations by J_l⁻¹(φ))."""
    B, N = d.shape
    M = N // 6
    out = w.reshape(B, M, 6, -1).copy()
    out[:, :, 3:] = quat.left_jacobian_inverse(d.reshape(B, M, 6)[..., 3:]) @ out[:, :, 3:]
    return out.reshape(w.shape)


def hessian(null: np.ndarray, d: np.ndarray, bend: np.ndarray) -> np.ndarray:
    """The reduced Hessian G (B, f, f) from the null spaces (B, N, f), the displacements from
    rest (B, N) and bend_ij = λᵀ J̇_{n_j} n_i (B, f, f), symmetrized."""
    G = np.swapaxes(null, 1, 2) @ metric(d, null) - bend
    return 0.5 * (G + np.swapaxes(G, 1, 2))


def step(null: np.ndarray, d: np.ndarray, G: np.ndarray) -> np.ndarray:
    """The scaled move (B, N) towards the canonical pose along the null spaces (B, N, f): the
    Newton step −N G⁻¹ g where G (B, f, f) is positive definite, else a step with the metric
    alone (NᵀDN) — downhill, so the minimum continuous with the pose is kept."""
    g = (np.swapaxes(null, 1, 2) @ d[..., None])  # (B, f, 1)
    plain = np.swapaxes(null, 1, 2) @ metric(d, null)
    plain = 0.5 * (plain + np.swapaxes(plain, 1, 2))
    convex = np.linalg.eigvalsh(G)[:, 0] > 0.0
    H = np.where(convex[:, None, None], G, plain)
    return -(null @ np.linalg.solve(H, g))[..., 0]


def velocity(v0: np.ndarray, null: np.ndarray, d: np.ndarray, G: np.ndarray, bend: np.ndarray) -> np.ndarray:
    """The canonical pose's scaled velocity (B, N) from the least-norm one v0 (B, N), the null
    spaces (B, N, f), the displacements from rest (B, N), G (B, f, f) and λᵀ J̇_{(v₀,1)} n_i (B, f)."""
    rate = (np.swapaxes(null, 1, 2) @ metric(d, v0[..., None]))[..., 0] - bend
    return v0 - (null @ np.linalg.solve(G, rate[..., None]))[..., 0]


def stationarity(null: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The largest scaled move along the null spaces (B, N, f) that the gradient asks for,
    |N Nᵀ d| (B,): zero at the canonical pose."""
    return np.abs(null @ (np.swapaxes(null, 1, 2) @ d[..., None]))[..., 0].max(axis=1)
