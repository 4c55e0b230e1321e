"""Residual vectors and analytic Jacobians of the elementary constraint kinds, batched.

The functions take world-frame quantities already gathered per constraint (n of them): member
vectors turned into the world frame ``wa``, ``wb`` (n, 3), world points ``xa``, ``xb`` (n, 3)
(position + turned member point) or quaternions ``qa``, ``qb`` (n, 4); the world is a member
with zero position and identity orientation. Each writes its residual rows into ``out`` (n, k)
and, with ``jacobian=True``, returns from the same intermediates the Jacobian ``J``
(n, k, 2, 6): ``J[:, :, 0]`` with respect to the local coordinates of member a, ``J[:, :, 1]``
of member b, ``[dp (3), δθ (3)]``, δθ a world-frame rotation increment (``q ← exp(δθ) ⊗ q``).

Per-constraint costs (the squared residual norm) are the paper's: |p1 − p2|² for location,
θ² = 4·arccos²(|Re(o1 o2⁻¹)|) for orientation, θ² = arccos²(â1·â2) for axis, d² for on-plane;
and for the designer's kinds: d² (distance from a line) for point-on-line, (|p1 − p2| − D)²
for a distance D, (θ − α)² for an angle α between axes, sin²θ for parallel axes (either way).
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat

#: residual rows per constraint kind, and independent equations (the rank of the rows)
ROWS = {"location": 3, "orientation": 3, "axis": 3, "plane": 1, "line": 3, "distance": 1, "angle": 1,
        "parallel": 3}
EQUATIONS = {"location": 3, "orientation": 3, "axis": 2, "plane": 1, "line": 2, "distance": 1, "angle": 1,
             "parallel": 2}
#: kinds whose residual is a length (the others are angles, radians)
LENGTH_KINDS = ("location", "plane", "line", "distance")
#: kinds with a scalar target ``value`` (a length, or an angle in radians) that an input may drive
VALUE_KINDS = ("distance", "angle")
#: member vectors each kind turns into the world frame: (vector, member "a" or "b")
VECTORS = {"location": (("sa", "a"), ("sb", "b")), "orientation": (),
           "axis": (("sa", "a"), ("sb", "b")), "plane": (("sa", "a"), ("sb", "b"), ("nb", "b")),
           "line": (("sa", "a"), ("sb", "b"), ("nb", "b")), "distance": (("sa", "a"), ("sb", "b")),
           "angle": (("sa", "a"), ("sb", "b")), "parallel": (("sa", "a"), ("sb", "b"))}

_EYE = np.eye(3)


def _rotation_layout(blocks: np.ndarray) -> np.ndarray:
    """(F, 36): for a residual of the orientations only whose Jacobian block for a is
    Σ_f x_f B_f (``blocks`` B (F, 3, 3)) and for b its negative transpose, the flat
    (3, 2, 6) Jacobian is x @ layout for features x (n, F)."""
    P = np.zeros((len(blocks), 3, 2, 6))
    P[:, :, 0, 3:] = blocks
    P[:, :, 1, 3:] = -np.swapaxes(blocks, 1, 2)
    return P.reshape(len(blocks), 36)


def _location_layout() -> tuple[np.ndarray, np.ndarray]:
    """(6, 36) and (36,): the flat location Jacobian [I, −[wa]×, −I, [wb]×] = (wa, wb) @ L + C."""
    L = np.zeros((6, 3, 2, 6))
    skews = quat.skew(_EYE)  # [e_k]×
    L[:3, :, 0, 3:] = -skews
    L[3:, :, 1, 3:] = skews
    C = np.zeros((3, 2, 6))
    C[:, 0, :3] = _EYE
    C[:, 1, :3] = -_EYE
    return L.reshape(6, 36), C.ravel()


_UNITS = np.eye(9).reshape(9, 3, 3)  # E_ij
#: axis features: the 9 entries of f·wa wbᵀ − g·c cᵀ, and f·(wa·wb) (times −I)
_AXIS_LAYOUT = _rotation_layout(np.concatenate([_UNITS, -_EYE[None]]))
#: orientation features: the 9 entries of c·φφᵀ, 1 − c·θ² (times I), φ (times −½[e_k]×)
_ORIENTATION_LAYOUT = _rotation_layout(np.concatenate([_UNITS, _EYE[None], -0.5 * quat.skew(_EYE)]))
_LOCATION_LAYOUT, _LOCATION_CONSTANT = _location_layout()


def location(xa: np.ndarray, xb: np.ndarray, wa: np.ndarray, wb: np.ndarray, out: np.ndarray,
             jacobian: bool = False) -> np.ndarray | None:
    """Point a on point b: r = xa − xb, (n, 3); ``wa``, ``wb``: the member points turned into
    the world frame (without the positions). J = [I, −[wa]×] for a, [−I, [wb]×] for b."""
    np.subtract(xa, xb, out=out)
    if not jacobian:
        return None
    J = np.concatenate([wa, wb], axis=1) @ _LOCATION_LAYOUT + _LOCATION_CONSTANT
    return J.reshape(-1, 3, 2, 6)


def orientation(qa: np.ndarray, qb: np.ndarray | None, rel_inverse: np.ndarray, out: np.ndarray,
                jacobian: bool = False) -> np.ndarray | None:
    """Orientation of a equals qb ⊗ rel: r = φ = log(qa ⊗ rel⁻¹ ⊗ qb⁻¹), the rotation vector,
    (n, 3); ``qb`` None: every b is the world (qb = 1). J = J_l⁻¹(φ) for a, −J_l⁻¹(φ)ᵀ for b
    (:func:`~linkedit.gcs.quaternions.left_jacobian_inverse`)."""
    err = quat.multiply(qa, rel_inverse)
    out[:] = quat.log(err if qb is None else quat.relative(err, qb))
    if not jacobian:
        return None
    theta2 = quat.dot(out, out)
    c = quat.left_jacobian_coefficient(theta2)
    features = np.concatenate([quat.outer(c[:, None] * out, out), (1.0 - c * theta2)[:, None], out], axis=1)
    return (features @ _ORIENTATION_LAYOUT).reshape(-1, 3, 2, 6)


def axis(wa: np.ndarray, wb: np.ndarray, out: np.ndarray, jacobian: bool = False) -> np.ndarray | None:
    """Axis a (world frame, unit, (n, 3)) aligned with axis b: r = θ·c / |c|, c = âa × âb, the
    rotation vector turning âb onto âa, (n, 3).

    θ = atan2(|âa × âb|, âa·âb) ∈ [0, π] tells aligned (0) from anti-aligned (π) apart, which
    the bare cross product cannot; |r|² = arccos²(âa·âb). The Jacobian with respect to a is
    A = f·wa wbᵀ − f·(wa·wb) I − g·c cᵀ (f = θ / sin θ, g = (sin θ − θ cos θ) / sin³ θ, series
    near θ = 0), with respect to b −Aᵀ.
    """
    c = quat.cross(wa, wb)
    s = np.sqrt(quat.dot(c, c))
    d = quat.dot(wa, wb)
    if d.min(initial=0.0) < 0.0:  # a pair more than 90° apart (one test where all are near aligned)
        opposite = (s < 1e-12) & (d < 0.0)
        if opposite.any():
            # exactly anti-aligned: any axis ⊥ a turns b onto a; take a fixed one so r = π·n̂
            # stays finite (cost π²) and the Jacobian large but finite
            c[opposite] = 1e-12 * _perpendicular(wa[opposite])
            s[opposite] = 1e-12
    theta = np.arctan2(s, d)
    # θ / sin θ, whose limit 1 is exact to rounding below θ = 1e-8
    f = np.divide(theta, s, out=np.ones_like(s), where=theta > 1e-8)
    np.multiply(f[:, None], c, out=out)
    if not jacobian:
        return None
    t2 = theta * theta
    large = theta >= 1e-3
    g = 1.0 / 3.0 + 2.0 * t2 / 15.0
    np.divide(s - theta * d, s**3, out=g, where=large)
    # [wb]×[wa]× = wa wbᵀ − (wa·wb) I
    entries = quat.outer(f[:, None] * wa, wb) - quat.outer(g[:, None] * c, c)
    features = np.concatenate([entries, (f * d)[:, None]], axis=1)
    return (features @ _AXIS_LAYOUT).reshape(-1, 3, 2, 6)


def _perpendicular(v: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each unit vector of ``v`` (n, 3), chosen deterministically."""
    least = np.argmin(np.abs(v), axis=1)
    e = np.zeros_like(v)
    e[np.arange(len(v)), least] = 1.0
    p = quat.cross(v, e)
    return p / np.sqrt(quat.dot(p, p))[:, None]


def plane(xa: np.ndarray, xo: np.ndarray, wa: np.ndarray, u: np.ndarray, normal: np.ndarray, out: np.ndarray,
          jacobian: bool = False) -> np.ndarray | None:
    """Point a (``xa``) on the plane through ``xo`` with unit ``normal`` (world frame, (n, 3)):
    the signed distance, (n, 1); ``wa``, ``u``: the member point and the plane point turned
    into the world frame (without the positions)."""
    dist = xa - xo
    out[:, 0] = quat.dot(normal, dist)
    if not jacobian:
        return None
    J = np.empty((len(xa), 1, 2, 6))
    J[:, 0, 0, :3] = normal
    J[:, 0, 0, 3:] = quat.cross(wa, normal)
    J[:, 0, 1, :3] = -normal
    J[:, 0, 1, 3:] = quat.cross(normal, dist) - quat.cross(u, normal)
    return J


def line(xa: np.ndarray, xo: np.ndarray, wa: np.ndarray, u: np.ndarray, direction: np.ndarray, out: np.ndarray,
         jacobian: bool = False) -> np.ndarray | None:
    """Point a (``xa``) on the line through ``xo`` with unit ``direction`` n (world frame,
    (n, 3)): r = n × (xa − xo), (n, 3), whose norm is the distance from the line (two
    independent rows); ``wa``, ``u``: the member point and the line point turned into the world
    frame (without the positions). J = [[n]×, −[n]×[wa]×] for a, [−[n]×, [d]×[n]× + [n]×[u]×]
    for b (d = xa − xo)."""
    d = xa - xo
    out[:] = quat.cross(direction, d)
    if not jacobian:
        return None
    N = quat.skew(direction)
    J = np.empty((len(xa), 3, 2, 6))
    J[:, :, 0, :3] = N
    J[:, :, 0, 3:] = -N @ quat.skew(wa)
    J[:, :, 1, :3] = -N
    J[:, :, 1, 3:] = quat.skew(d) @ N + N @ quat.skew(u)
    return J


def distance(xa: np.ndarray, xb: np.ndarray, wa: np.ndarray, wb: np.ndarray, value: np.ndarray, out: np.ndarray,
             jacobian: bool = False) -> np.ndarray | None:
    """Point a at distance ``value`` (n,) from point b: r = |xa − xb| − value, (n, 1); ``wa``,
    ``wb`` as in :func:`location`. With û = (xa − xb) / |xa − xb|: J = [ûᵀ, (wa × û)ᵀ] for a,
    [−ûᵀ, −(wb × û)ᵀ] for b (û = x̂ where the points coincide: any direction lengthens)."""
    e = xa - xb
    n = np.sqrt(quat.dot(e, e))
    out[:, 0] = n - value
    if not jacobian:
        return None
    u = np.divide(e, n[:, None], out=np.tile(_EYE[0], (len(e), 1)), where=n[:, None] > 0.0)
    J = np.empty((len(e), 1, 2, 6))
    J[:, 0, 0, :3] = u
    J[:, 0, 0, 3:] = quat.cross(wa, u)
    J[:, 0, 1, :3] = -u
    J[:, 0, 1, 3:] = -quat.cross(wb, u)
    return J


def angle(wa: np.ndarray, wb: np.ndarray, value: np.ndarray, out: np.ndarray,
          jacobian: bool = False) -> np.ndarray | None:
    """Axes a and b (world frame, unit, (n, 3)) at the angle ``value`` (n,) (radians, in
    (0, π)): r = θ − value, θ = atan2(|âa × âb|, âa·âb), (n, 1). Turning a about ĉ = âa × âb /
    |âa × âb| closes the angle: J = [0, −ĉᵀ] for a, [0, ĉᵀ] for b (ĉ any axis ⊥ a where the axes
    are parallel)."""
    c = quat.cross(wa, wb)
    s = np.sqrt(quat.dot(c, c))
    out[:, 0] = np.arctan2(s, quat.dot(wa, wb)) - value
    if not jacobian:
        return None
    flat = s < 1e-12
    if flat.any():
        c[flat] = _perpendicular(wa[flat])
        s[flat] = 1.0
    c /= s[:, None]
    J = np.zeros((len(wa), 1, 2, 6))
    J[:, 0, 0, 3:] = -c
    J[:, 0, 1, 3:] = c
    return J


def parallel(wa: np.ndarray, wb: np.ndarray, out: np.ndarray, jacobian: bool = False) -> np.ndarray | None:
    """Axes a and b (world frame, unit, (n, 3)) parallel, pointing either way: r = âa × âb,
    (n, 3) (|r| = sin θ; two independent rows). J = [0, [wb]×[wa]×] for a, [0, −[wa]×[wb]×] for b."""
    out[:] = quat.cross(wa, wb)
    if not jacobian:
        return None
    A, B = quat.skew(wa), quat.skew(wb)
    J = np.zeros((len(wa), 3, 2, 6))
    J[:, :, 0, 3:] = B @ A
    J[:, :, 1, 3:] = -A @ B
    return J
