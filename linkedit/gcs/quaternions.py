"""Unit quaternions [w, x, y, z] and rotation vectors, batched over leading axes.

A rotation vector ``v`` (radians) is the axis times the angle; ``exp`` maps it to a unit
quaternion and ``log`` back (choosing the sign of q so that w ≥ 0: q and −q are the same
orientation). Orientation increments are applied in the world frame: ``q ← exp(δ) ⊗ q``.
"""

from __future__ import annotations

import numpy as np


def _product_tensor() -> np.ndarray:
    """(16, 4): (a ⊗ b) = outer(a, b).ravel() @ T — one matrix product instead of 28 array ops."""
    w, x, y, z = range(4)
    T = np.zeros((4, 4, 4))
    for (i, j, k, sign) in [
        (w, w, w, 1), (x, x, w, -1), (y, y, w, -1), (z, z, w, -1),
        (w, x, x, 1), (x, w, x, 1), (y, z, x, 1), (z, y, x, -1),
        (w, y, y, 1), (x, z, y, -1), (y, w, y, 1), (z, x, y, 1),
        (w, z, z, 1), (x, y, z, 1), (y, x, z, -1), (z, w, z, 1),
    ]:
        T[i, j, k] = sign
    return T.reshape(16, 4)


def _matrix_tensor() -> np.ndarray:
    """(16, 9): rotation matrix of a unit q = outer(q, q).ravel() @ T (homogeneous quadratic form)."""
    w, x, y, z = range(4)
    T = np.zeros((4, 4, 3, 3))

    def add(k: int, l: int, i: int, j: int, c: float) -> None:
        T[k, l, i, j] += c / 2
        T[l, k, i, j] += c / 2

    for i, signs in enumerate([(1, 1, -1, -1), (1, -1, 1, -1), (1, -1, -1, 1)]):
        for k, c in enumerate(signs):
            add(k, k, i, i, c)
    add(x, y, 0, 1, 2), add(w, z, 0, 1, -2), add(x, z, 0, 2, 2), add(w, y, 0, 2, 2)
    add(x, y, 1, 0, 2), add(w, z, 1, 0, 2), add(y, z, 1, 2, 2), add(w, x, 1, 2, -2)
    add(x, z, 2, 0, 2), add(w, y, 2, 0, -2), add(y, z, 2, 1, 2), add(w, x, 2, 1, 2)
    return T.reshape(16, 9)


def _cross_tensor() -> np.ndarray:
    """(9, 3): u × v = outer(u, v).ravel() @ T."""
    T = np.zeros((3, 3, 3))
    for i, j, k in [(0, 1, 2), (1, 2, 0), (2, 0, 1)]:
        T[i, j, k], T[j, i, k] = 1.0, -1.0
    return T.reshape(9, 3)


_PRODUCT = _product_tensor()
_MATRIX = _matrix_tensor()
_CROSS = _cross_tensor()


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b, (..., 4)."""
    if a.shape != b.shape:
        a, b = np.broadcast_arrays(a, b)
    return (a[..., :, None] * b[..., None, :]).reshape(a.shape[:-1] + (16,)) @ _PRODUCT


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u × v for (..., 3) arrays (faster than ``np.cross`` on small batches)."""
    if u.shape != v.shape:
        u, v = np.broadcast_arrays(u, v)
    return (u[..., :, None] * v[..., None, :]).reshape(u.shape[:-1] + (9,)) @ _CROSS


def conjugate(q: np.ndarray) -> np.ndarray:
    """q⁻¹ for a unit quaternion, (..., 4)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def normalize(q: np.ndarray) -> np.ndarray:
    """q / |q|, (..., 4)."""
    return q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation by ``angle`` (radians, (...)) about the unit ``axis`` ((..., 3) or (3,)), (..., 4)."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    half = 0.5 * angle[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def exp(v: np.ndarray) -> np.ndarray:
    """Rotation vector (..., 3) → unit quaternion (..., 4)."""
    v = np.asarray(v, dtype=float)
    theta = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    half = 0.5 * theta
    small = theta < 1e-8
    # sin(θ/2)/θ with its series near 0
    k = np.where(small, 0.5 - theta**2 / 48.0, np.sin(half) / np.where(small, 1.0, theta))
    return np.concatenate([np.cos(half), k * v], axis=-1)


def log(q: np.ndarray) -> np.ndarray:
    """Unit quaternion (..., 4) → rotation vector (..., 3) with angle in [0, π]; q and −q agree."""
    q = np.asarray(q, dtype=float)
    sign = np.where(q[..., :1] < 0.0, -1.0, 1.0)
    w = sign * q[..., :1]
    v = sign * q[..., 1:]
    s = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    angle = 2.0 * np.arctan2(s, w)
    small = s < 1e-8
    # θ / |v| with its series near 0: 2/w · (1 − s²/(3w²))
    ws = np.where(small, w, 1.0)
    k = np.where(small, 2.0 / ws * (1.0 - s * s / (3.0 * ws * ws)), angle / np.where(small, 1.0, s))
    return k * v


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    return ((q[..., :, None] * q[..., None, :]).reshape(q.shape[:-1] + (16,)) @ _MATRIX).reshape(q.shape[:-1] + (3, 3))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) by unit quaternions (..., 4)."""
    return np.einsum("...ij,...j->...i", to_matrix(q), v)


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Shortest-arc spherical interpolation from q0 to q1 at fractions ``s`` ((...) → (..., 4))."""
    rel = multiply(q1, conjugate(q0))
    return multiply(exp(np.asarray(s, dtype=float)[..., None] * log(rel)), q0)


def _skew_tensor() -> np.ndarray:
    """(3, 9): [v]× = (v @ T).reshape(3, 3)."""
    T = np.zeros((3, 3, 3))
    for i, j, k in [(0, 1, 2), (1, 2, 0), (2, 0, 1)]:
        # [v]×[i, j] = −ε_ijk v_k
        T[k, i, j], T[k, j, i] = -1.0, 1.0
    return T.reshape(3, 9)


_SKEW = _skew_tensor()


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices [v]× (..., 3, 3): [v]× u = v × u."""
    v = np.asarray(v, dtype=float)
    return (v @ _SKEW).reshape(v.shape[:-1] + (3, 3))


def left_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    """J_l⁻¹(φ) (..., 3, 3): d log(exp(δ) ⊗ exp(φ)) / dδ at δ = 0 (for angles below π).

    The right inverse Jacobian (perturbation on the right) is its transpose.
    """
    theta2 = np.sum(phi * phi, axis=-1)
    theta = np.sqrt(theta2)
    small = theta < 1e-4
    ts = np.where(small, 1.0, theta)
    c = np.where(small, 1.0 / 12.0 + theta2 / 720.0,
                 1.0 / ts**2 - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(np.where(small, 1.0, ts))))
    k = skew(phi)
    return np.eye(3) - 0.5 * k + c[..., None, None] * (k @ k)
