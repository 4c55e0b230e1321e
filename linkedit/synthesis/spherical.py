"""The spherical four-bar family: four revolute joints whose axes meet at the centre O, so every
coupler point moves on a sphere about O.

Family frame (unit sphere): the crank's bearing axis a = z; the rocker's bearing axis
d = (sin γ, 0, cos γ) (ground arc γ from a); the crank carries the coupler joint's axis
b(θ) = (sin α cos θ, sin α sin θ, cos α) (crank arc α, θ = 2π t counter-clockwise about z, t = 0 the
rest pose); the coupler-rocker axis c lies at the coupler arc β from b and the rocker arc δ from d,
on the side ``branch`` = ±1 of the plane of b and d:

    c = x b + y d + branch·w (b × d)/|b × d|,  g = b·d,
    x = (cos β − g cos δ)/(1 − g²),  y = (cos δ − g cos β)/(1 − g²),  w² = 1 − x² − y² − 2xyg.

The coupler point P is the unit vector at the arc φ from b, turned by ψ about b from the arc b→c:
P = cos φ b + sin φ (cos ψ e + sin ψ b × e), e = (c − cos β b)/sin β.

Parameters per linkage, columns of a (K, 7) array (angles in radians): crank_arc α,
coupler_arc β, rocker_arc δ, ground_arc γ, point_arc φ, point_angle ψ, branch.

Transmission: the angle μ at c of the spherical triangle b c d, cos μ = (g − cos β cos δ)/(sin β sin δ)
(the spherical law of cosines), d_s = sin² μ. cos μ is linear in g, and g = cos α cos γ + sin α sin γ cos θ
runs between cos(α + γ) and cos(α − γ) (θ = π, 0): the lowest d_s over the cycle is at one of those
two, a closed form like the planar four-bar's.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.feasibility import margin_of

NAME = "spherical-four-bar"
ID = 11
DIM = 3
PARAMETERS = ("crank_arc", "coupler_arc", "rocker_arc", "ground_arc", "point_arc", "point_angle", "branch")
#: Smallest transmission angle kept in an atlas (degrees); the singularity margin is sin² of it.
MU_MIN_DEG = 20.0
#: The example's design (examples/3d/spherical-four-bar.yaml: arcs 20°, 70°, 50°, 60°), sampled around.
SEEDS = np.array([[np.radians(20), np.radians(70), np.radians(50), np.radians(60), np.radians(45), 1.0, 1.0]])


def margin(margin_deg: float = MU_MIN_DEG) -> float:
    """The singularity margin min d_s = sin² μ its linkages keep in the transmission band [μ, 180° − μ]
    (μ = ``margin_deg``; an atlas linkage's: MU_MIN_DEG)."""
    return margin_of(margin_deg)


def min_singularity(params: np.ndarray, margin: float | None = None) -> np.ndarray:
    """min over the continuous cycle of d_s = sin²μ at c, (K,), exact; −1 where the crank cannot turn."""
    alpha, beta, delta, gamma = (params[:, i] for i in range(4))
    out = np.full(len(params), np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        for g in (np.cos(alpha + gamma), np.cos(alpha - gamma)):
            cos_mu = (g - np.cos(beta) * np.cos(delta)) / (np.sin(beta) * np.sin(delta))
            out = np.minimum(out, np.where(np.abs(cos_mu) <= 1.0, 1.0 - cos_mu * cos_mu, -1.0))
    return np.where(np.isfinite(out), out, -1.0)


def sample(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` parameter rows from the family's distribution (not yet filtered):

    three quarters over a wide range — crank arc uniform in [5°, 60°], coupler, rocker and ground arcs
    uniform in [15°, 120°], point arc uniform in [10°, 120°], point angle uniform in (−180°, 180°],
    branch ±1 — and one quarter around the example's design (arcs 20°, 70°, 50°, 60°): arcs times
    e^{N(0, 0.2²)}, the point's angles uniform as above, branch ±1.
    """
    wide = count - count // 4
    out = np.empty((count, 7))
    out[:wide, 0] = rng.uniform(np.radians(5), np.radians(60), wide)
    out[:wide, 1:4] = rng.uniform(np.radians(15), np.radians(120), (wide, 3))
    near = count - wide
    base = SEEDS[rng.integers(0, len(SEEDS), near)]
    out[wide:, :4] = base[:, :4] * np.exp(rng.normal(0.0, 0.2, (near, 4)))
    out[:, 4] = rng.uniform(np.radians(10), np.radians(120), count)
    out[:, 5] = rng.uniform(-np.pi, np.pi, count)
    out[:, 6] = rng.choice([-1.0, 1.0], count)
    return out


def axes(params: np.ndarray, angle: np.ndarray) -> dict[str, np.ndarray]:
    """The joint axes a, b, c, d and the coupler point P, each (K, T, 3), at crank angles ``angle``
    (K or 1, T) radians; NaN where c cannot be placed."""
    alpha, beta, delta, gamma, phi, psi, branch = (params[:, i:i + 1] for i in range(7))
    sa, ca = np.sin(alpha), np.cos(alpha)
    b = np.stack(np.broadcast_arrays(sa * np.cos(angle), sa * np.sin(angle), ca), axis=-1)
    d = np.stack(np.broadcast_arrays(np.sin(gamma), 0.0 * gamma, np.cos(gamma)), axis=-1)
    g = np.einsum("ktj,ktj->kt", b, np.broadcast_to(d, b.shape))
    cb, cd = np.cos(beta), np.cos(delta)
    with np.errstate(invalid="ignore", divide="ignore"):
        one = 1.0 - g * g
        x = (cb - g * cd) / one
        y = (cd - g * cb) / one
        w = branch * np.sqrt((1.0 - x * x - y * y - 2.0 * x * y * g) / one)  # |b × d|² = 1 − g²
        c = x[..., None] * b + y[..., None] * d + w[..., None] * np.cross(b, d)
        e = (c - cb[..., None] * b) / np.sin(beta)[..., None]
        p = np.cos(phi)[..., None] * b + np.sin(phi)[..., None] * (np.cos(psi)[..., None] * e
                                                                   + np.sin(psi)[..., None] * np.cross(b, e))
    a = np.broadcast_to(np.array([0.0, 0.0, 1.0]), b.shape)
    return {"a": a, "b": b, "c": c, "d": np.broadcast_to(d, b.shape), "P": p}


def curves(params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    """Coupler-point curves (K, T, 3) on the unit sphere at θ = 2π(phase + t/T), t = 0..T−1; one array
    evaluation over linkages and samples; NaN where c cannot be placed."""
    angle = 2.0 * np.pi * (np.asarray(phase, dtype=float).reshape(-1, 1) + np.arange(samples)[None, :] / samples)
    return axes(params, angle)["P"]


def rest_pose(row: np.ndarray, phase: float) -> dict[str, np.ndarray]:
    """The axes a, b, c, d and the coupler point P (3,) each at crank phase ``phase`` (family frame)."""
    return {k: v[0, 0] for k, v in axes(row[None], np.array([[2.0 * np.pi * phase]])).items()}


def to_spec(row: np.ndarray, *, phase: float, scale: float, matrix: np.ndarray, shift: np.ndarray, name: str,
            units: str, description: str) -> dict:
    """The 3D mechanism spec (a dict for :class:`~linkedit.spec.mechanism3d.MechanismSpec`) of parameter
    ``row`` at crank phase ``phase``, placed by p ↦ shift + scale·matrix·p (``matrix`` orthogonal; a
    reflection turns the crank the other way about its placed axis), track ``target`` = P.

    Every member's frame is the world at the rest pose (position 0, no rotation): shape points are world
    points, the sphere's centre O and the points at the sphere's radius on each joint axis."""
    pose = rest_pose(row, phase)
    place = lambda p: [float(v) for v in shift + scale * matrix @ p]  # noqa: E731
    turn = lambda v: [float(x) for x in matrix @ v]  # noqa: E731
    o = place(np.zeros(3))
    pts = {k: place(v) for k, v in pose.items()}
    drive = [float(x) for x in np.sign(np.linalg.det(matrix)) * (matrix @ np.array([0.0, 0.0, 1.0]))]
    return {
        "name": name, "units": units, "description": description,
        "shapes": {
            "crank": {"points": {"o": o, "a": pts["a"], "b": pts["b"]}, "lines": [["o", "a"], ["o", "b"], ["a", "b"]]},
            "coupler": {"points": {"o": o, "b": pts["b"], "c": pts["c"], "P": pts["P"]},
                        "lines": [["o", "b"], ["o", "c"], ["b", "P", "c"]]},
            "rocker": {"points": {"o": o, "c": pts["c"], "d": pts["d"]}, "lines": [["o", "c"], ["o", "d"], ["c", "d"]]},
        },
        "members": {"crank": {"shape": "crank"}, "coupler": {"shape": "coupler"}, "rocker": {"shape": "rocker"}},
        "constraints": {
            "crank_bearing": {"type": "pin", "member": "crank", "point": "o", "axis": turn(pose["a"]), "world": o},
            "crank_coupler": {"type": "pin", "member": "crank", "point": "o", "axis": turn(pose["b"]),
                              "other": "coupler", "other_point": "o"},
            "coupler_rocker": {"type": "pin", "member": "coupler", "point": "o", "axis": turn(pose["c"]),
                               "other": "rocker", "other_point": "o"},
            "rocker_bearing": {"type": "pin", "member": "rocker", "point": "o", "axis": turn(pose["d"]), "world": o},
        },
        "inputs": {"drive": {"type": "orientation", "member": "crank",
                             "rotation": {"axis": drive, "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"target": {"member": "coupler", "point": "P"}}},
    }
