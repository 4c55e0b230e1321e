"""Unit quaternions [w, x, y, z] and rotation vectors, batched over leading axes.

A rotation vector ``v`` (radians) is the axis times the angle; ``exp`` maps it to a unit
quaternion and ``log`` back (choosing the sign of q so that w ≥ 0: q and −q are the same
orientation). Orientation increments are applied in the world frame: ``q ← exp(δ) ⊗ q``, or
by the cheaper :func:`turned`, which agrees with it to second order in |δ|.

The rotation matrices the closed form (:mod:`linkedit.gcs.closed_form`) builds are here too:
:func:`rotated`, :func:`spin_matrix` and :func:`frame_rotation`.
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
    """(16, 9): rotation matrix of a unit q = outer(q, q).ravel() @ T (homogeneous quadratic
    form, symmetric in the pair)."""
    w, x, y, z = range(4)
    T = np.zeros((4, 4, 3, 3))

    def add(k: int, l: int, i: int, j: int, c: float) -> None:
        T[k, l, i, j] += c / 2
        T[l, k, i, j] += c / 2

    for i, signs in enumerate([(1, 1, -1, -1), (1, -1, 1, -1), (1, -1, -1, 1)]):
        for k, c in enumerate(signs):
            add(k, k, i, i, c)
    for args in ((x, y, 0, 1, 2), (w, z, 0, 1, -2), (x, z, 0, 2, 2), (w, y, 0, 2, 2),
                 (x, y, 1, 0, 2), (w, z, 1, 0, 2), (y, z, 1, 2, 2), (w, x, 1, 2, -2),
                 (x, z, 2, 0, 2), (w, y, 2, 0, -2), (y, z, 2, 1, 2), (w, x, 2, 1, 2)):
        add(*args)
    return T.reshape(16, 9)


def _cross_tensor() -> np.ndarray:
    """(9, 3): u × v = outer(u, v).ravel() @ T."""
    T = np.zeros((3, 3, 3))
    for i, j, k in [(0, 1, 2), (1, 2, 0), (2, 0, 1)]:
        T[i, j, k], T[j, i, k] = 1.0, -1.0
    return T.reshape(9, 3)


def _pairs(n: int, upper: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) of an n × n outer product, row-major (or its upper triangle)."""
    return np.triu_indices(n) if upper else np.divmod(np.arange(n * n), n)


_PRODUCT = _product_tensor()
_CROSS = _cross_tensor()
_P4, _P3 = _pairs(4), _pairs(3)
_U4 = _pairs(4, upper=True)
#: the rotation-matrix form on the 10 distinct products q_i q_j (i ≤ j)
_MATRIX = _matrix_tensor().reshape(4, 4, 9)
_MATRIX_UPPER = (_MATRIX + np.swapaxes(_MATRIX, 0, 1) * (1.0 - np.eye(4))[:, :, None])[_U4]
_ONES = {3: np.ones(3), 4: np.ones(4)}
_CONJUGATE = np.array([1.0, -1.0, -1.0, -1.0])
_EYE = np.eye(3)
#: a ⊗ b⁻¹ = outer(a, b).ravel() @ _PRODUCT_INVERSE (b's vector part negated in the table)
_PRODUCT_INVERSE = (_PRODUCT.reshape(4, 4, 4) * _CONJUGATE[:, None]).reshape(16, 4)
#: ½ (0, v) ⊗ q = outer(v, q) @ _HALF_PRODUCT_V
_PV = np.divmod(np.arange(12), 4)
_HALF_PRODUCT_V = 0.5 * _PRODUCT.reshape(4, 4, 4)[1:].reshape(12, 4)


def _outer(a: np.ndarray, b: np.ndarray, pairs: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The products a_i b_j for the index ``pairs``, (..., len(pairs)) (gathers beat broadcasting)."""
    return a.take(pairs[0], axis=-1) * b.take(pairs[1], axis=-1)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b, (..., 4)."""
    if a.shape != b.shape:
        a, b = np.broadcast_arrays(a, b)
    return _outer(a, b, _P4) @ _PRODUCT


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a ⊗ b⁻¹ for unit quaternions, (..., 4): the world-frame turn from b to a (equal to
    ``multiply(a, conjugate(b))``, one array operation fewer)."""
    if a.shape != b.shape:
        a, b = np.broadcast_arrays(a, b)
    return _outer(a, b, _P4) @ _PRODUCT_INVERSE


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u × v for (..., 3) arrays (faster than ``np.cross`` on small batches)."""
    if u.shape != v.shape:
        u, v = np.broadcast_arrays(u, v)
    return _outer(u, v, _P3) @ _CROSS


def outer(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Outer products u vᵀ of (..., 3) arrays, flattened: (..., 9)."""
    return _outer(u, v, _P3)


def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (..., k) arrays, (...) (a matrix product: faster than ``sum``)."""
    return (u * v) @ _ONES[u.shape[-1]]


def conjugate(q: np.ndarray) -> np.ndarray:
    """q⁻¹ for a unit quaternion, (..., 4)."""
    return q * _CONJUGATE


def normalize(q: np.ndarray) -> np.ndarray:
    """q / |q|, (..., 4)."""
    return q / np.sqrt(dot(q, q))[..., None]


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation by ``angle`` (radians, (...)) about the unit ``axis`` ((..., 3) or (3,)), (..., 4)."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    half = 0.5 * angle[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def exp(v: np.ndarray) -> np.ndarray:
    """Rotation vector (..., 3) → unit quaternion (..., 4)."""
    v = np.asarray(v, dtype=float)
    theta = np.sqrt(dot(v, v))
    half = 0.5 * theta
    # sin(θ/2)/θ, whose limit 1/2 is exact to rounding below θ = 1e-8
    k = np.divide(np.sin(half), theta, out=np.full_like(theta, 0.5), where=theta > 1e-8)
    q = np.empty(v.shape[:-1] + (4,))
    np.cos(half, out=q[..., 0])
    np.multiply(k[..., None], v, out=q[..., 1:])
    return q


def turned(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) turned by world-frame rotation vectors v (n, 3):
    normalize((1, v/2) ⊗ q), which agrees with exp(v) ⊗ q to second order in |v| (a retraction:
    the solver's local coordinates only need the first) with no trigonometry."""
    return normalize(q + _outer(v, q, _PV) @ _HALF_PRODUCT_V)


def log(q: np.ndarray) -> np.ndarray:
    """Unit quaternion (..., 4) → rotation vector (..., 3) with angle in [0, π]; q and −q agree."""
    q = np.asarray(q, dtype=float)
    w = q[..., 0]
    v = q[..., 1:]
    s = np.sqrt(dot(v, v))
    # angle / |v| with the sign of w (−q is taken when w < 0): 2 arctan2(s, |w|) / s is
    # accurate for small s, and for s below 1e-300 the factor is irrelevant (|v| = s)
    k = 2.0 * np.arctan2(s, np.abs(w)) / np.maximum(s, 1e-300)
    return np.copysign(k, w)[..., None] * v


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    return (_outer(q, q, _U4) @ _MATRIX_UPPER).reshape(q.shape[:-1] + (3, 3))


def _from_matrix_tensor() -> tuple[np.ndarray, np.ndarray]:
    """(9, 16) and (16,): the matrix K = 4 q qᵀ of a rotation matrix R is R.ravel() @ T + C
    (its diagonal from the trace and diagonal of R, the rest from sums and differences of
    symmetric entries)."""
    T, C = np.zeros((3, 3, 4, 4)), np.zeros((4, 4))
    C[:] = np.eye(4)
    for k, signs in enumerate([(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]):
        for i, c in enumerate(signs):
            T[i, i, k, k] = c
    for (k, l), (i, j, c) in (((0, 1), (2, 1, 1)), ((0, 1), (1, 2, -1)), ((0, 2), (0, 2, 1)), ((0, 2), (2, 0, -1)),
                              ((0, 3), (1, 0, 1)), ((0, 3), (0, 1, -1)), ((1, 2), (0, 1, 1)), ((1, 2), (1, 0, 1)),
                              ((1, 3), (0, 2, 1)), ((1, 3), (2, 0, 1)), ((2, 3), (1, 2, 1)), ((2, 3), (2, 1, 1))):
        T[i, j, k, l] = T[i, j, l, k] = c
    return T.reshape(9, 16), C.ravel()


_FROM_MATRIX, _FROM_MATRIX_CONSTANT = _from_matrix_tensor()


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) of rotation matrices (..., 3, 3) (either sign): from the row of
    4 q qᵀ with the largest diagonal entry (Shepperd's method: no division by a small number)."""
    R = np.asarray(R, dtype=float)
    K = (R.reshape(-1, 9) @ _FROM_MATRIX + _FROM_MATRIX_CONSTANT).reshape(-1, 4, 4)
    lanes = np.arange(len(K))
    pick = np.argmax(K.reshape(-1, 16)[:, ::5], axis=1)
    q = K[lanes, pick] / (2.0 * np.sqrt(K[lanes, pick, pick]))[:, None]
    return q.reshape(R.shape[:-2] + (4,))


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


def left_jacobian_coefficient(theta2: np.ndarray) -> np.ndarray:
    """c(θ) = (1 − (θ/2) cot(θ/2)) / θ² of :func:`left_jacobian_inverse`, from θ² (...)
    (series below θ = 1e-4)."""
    if theta2.max(initial=0.0) < 1e-8:  # every angle in the series range (a solved pose's error)
        return 1.0 / 12.0 + theta2 / 720.0
    half = 0.5 * np.sqrt(theta2)
    large = half >= 0.5e-4
    c = np.where(large, 0.0, 1.0 / 12.0 + theta2 / 720.0)
    np.divide(1.0 - half / np.tan(half, where=large, out=np.ones_like(half)), theta2, out=c, where=large)
    return c


def left_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    """J_l⁻¹(φ) (..., 3, 3) for rotation vectors φ (..., 3): d log(exp(δ) ⊗ exp(φ)) / dδ at δ = 0
    (for angles below π); J_l⁻¹ = I − ½[φ]× + c·[φ]×², [φ]×² = φφᵀ − θ² I
    (c: :func:`left_jacobian_coefficient`).

    The right inverse Jacobian (perturbation on the right) is its transpose.
    """
    theta2 = dot(phi, phi)
    c = left_jacobian_coefficient(theta2)
    k2 = (outer(phi, phi) * c[..., None]).reshape(phi.shape[:-1] + (3, 3))
    return k2 + (1.0 - c * theta2)[..., None, None] * _EYE - 0.5 * skew(phi)


def rotated(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for rotation matrices R (B, 3, 3) and vectors v (3,) or (B, 3): (B, 3)."""
    return R @ v if v.ndim == 1 else (R @ v[:, :, None])[:, :, 0]


def spin_matrix(n: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """The rotation matrices (B, 3, 3) by the angles theta (B,) about the unit axes n (B, 3)
    (Rodrigues)."""
    K = skew(n)
    return np.eye(3) + np.sin(theta)[:, None, None] * K + (1.0 - np.cos(theta))[:, None, None] * (K @ K)


def frame_rotation(frame: np.ndarray, n: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The rotation matrices (B, 3, 3) taking a frame (rows (3, 3): a unit axis, a unit
    direction across it and their cross product) onto the unit axis n (B, 3) and the direction
    of j across n (B, 3)."""
    world = np.empty(n.shape + (3,))
    world[:, :, 0] = n
    world[:, :, 1] = j / np.sqrt(dot(j, j))[:, None]
    world[:, :, 2] = cross(n, world[:, :, 1])
    return world @ frame
