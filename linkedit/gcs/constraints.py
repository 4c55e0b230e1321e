"""Residual vectors and analytic Jacobians of the four elementary constraint kinds, batched.

Every function takes member states already gathered per constraint — positions ``pa``, ``pb``
(n, 3) and rotation matrices ``Ra``, ``Rb`` (n, 3, 3); the world is a member with zero position
and identity rotation — and returns the residual (n, k) and, with ``jacobian=True``, the
Jacobian ``J`` (n, k, 2, 6): ``J[:, :, 0]`` with respect to the local coordinates of member a,
``J[:, :, 1]`` of member b, ``[dp (3), δθ (3)]``, δθ a world-frame rotation increment
(``q ← exp(δθ) ⊗ q``).

Per-constraint costs (the squared residual norm) are the paper's: |p1 − p2|² for location,
θ² = 4·arccos²(|Re(o1 o2⁻¹)|) for orientation, θ² = arccos²(â1·â2) for axis, d² for on-plane.
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat

#: residual rows per constraint kind, and independent equations (the rank of the rows)
ROWS = {"location": 3, "orientation": 3, "axis": 3, "plane": 1}
EQUATIONS = {"location": 3, "orientation": 3, "axis": 2, "plane": 1}
#: kinds whose residual is a length (the others are angles, radians)
LENGTH_KINDS = ("location", "plane")


_EYE = np.eye(3)


def _apply(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for (n, 3, 3) and (n, 3)."""
    return (R @ v[:, :, None])[:, :, 0]


def location(pa, Ra, sa, pb, Rb, sb, jacobian=False):
    """Member point a (member space ``sa``) on point b: r = xa − xb, (n, 3)."""
    wa, wb = _apply(Ra, sa), _apply(Rb, sb)
    r = pa + wa - pb - wb
    if not jacobian:
        return r
    J = np.empty((len(r), 3, 2, 6))
    J[:, :, 0, :3] = _EYE
    J[:, :, 0, 3:] = quat.skew(-wa)
    J[:, :, 1, :3] = -_EYE
    J[:, :, 1, 3:] = quat.skew(wb)
    return r, J


def orientation(qa, qb, rel, jacobian=False):
    """Orientation of a equals qb ⊗ rel: r = log(qa ⊗ (qb ⊗ rel)⁻¹), the rotation vector, (n, 3)."""
    target = quat.multiply(qb, rel)
    phi = quat.log(quat.multiply(qa, quat.conjugate(target)))
    if not jacobian:
        return phi
    jl = quat.left_jacobian_inverse(phi)
    J = np.zeros((len(phi), 3, 2, 6))
    J[:, :, 0, 3:] = jl
    J[:, :, 1, 3:] = -np.swapaxes(jl, 1, 2)
    return phi, J


def axis(Ra, ua, Rb, ub, jacobian=False):
    """Member axis a (``ua``) aligned with axis b: r = θ·n, the rotation vector turning âb onto âa.

    θ = atan2(|âa × âb|, âa·âb) ∈ [0, π] tells aligned (0) from anti-aligned (π) apart, which
    the bare cross product cannot; |r|² = arccos²(âa·âb).
    """
    wa, wb = _apply(Ra, ua), _apply(Rb, ub)
    c = quat.cross(wa, wb)
    s = np.sqrt(np.sum(c * c, axis=-1))
    d = np.sum(wa * wb, axis=-1)
    theta = np.arctan2(s, d)
    small = theta < 1e-3
    ss = np.where(small, 1.0, s)
    t2 = theta * theta
    f = np.where(small, 1.0 + t2 / 6.0, theta / ss)
    r = f[:, None] * c
    if not jacobian:
        return r
    g = np.where(small, 1.0 / 3.0 + 2.0 * t2 / 15.0, (ss - theta * d) / ss**3)
    # [wb]×[wa]× = wa wbᵀ − (wa·wb) I and [wa]×[wb]× = wb waᵀ − (wa·wb) I
    outer = wa[:, :, None] * wb[:, None, :]
    ccT = g[:, None, None] * (c[:, :, None] * c[:, None, :])
    fd = (f * d)[:, None, None] * _EYE
    fo = f[:, None, None] * outer
    J = np.zeros((len(r), 3, 2, 6))
    J[:, :, 0, 3:] = fo - fd - ccT
    J[:, :, 1, 3:] = fd - np.swapaxes(fo, 1, 2) + ccT
    return r, J


def plane(pa, Ra, sa, pb, Rb, ob, nb, jacobian=False):
    """Member point a on the plane (point ``ob``, unit normal ``nb``, in b's space): signed distance, (n, 1)."""
    wa = _apply(Ra, sa)
    u = _apply(Rb, ob)
    normal = _apply(Rb, nb)
    dist = pa + wa - pb - u
    r = np.sum(normal * dist, axis=-1)[:, None]
    if not jacobian:
        return r
    J = np.empty((len(r), 1, 2, 6))
    J[:, 0, 0, :3] = normal
    J[:, 0, 0, 3:] = quat.cross(wa, normal)
    J[:, 0, 1, :3] = -normal
    J[:, 0, 1, 3:] = quat.cross(normal, dist) - quat.cross(u, normal)
    return r, J
