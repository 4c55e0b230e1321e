"""The RSSR family: a spatial four-bar of a crank (R) and a rocker (R) joined by a coupler with a ball
joint (S) at each end; the tracked point rides on the line through the two balls.

Family frame (crank length 1): the crank turns about z at the origin, its tip A = (cos θ, sin θ, 0)
(θ = 2π t counter-clockwise, t = 0 the rest pose); the rocker turns about the axis
n = (0, sin τ, cos τ) through its pivot Q = (q_x, q_y, q_z), its tip B = Q + ρ (cos ψ u + sin ψ w) with
u = (1, 0, 0), w = n × u = (0, cos τ, −sin τ); the coupler keeps |B − A| = L. With r = A − Q that is

    K₁ cos ψ + K₂ sin ψ = K₃,  K₁ = 2ρ r·u,  K₂ = 2ρ r·w,  K₃ = |r|² + ρ² − L²,
    ψ = atan2(K₂, K₁) + branch·arccos(K₃ / √(K₁² + K₂²)).

The coupler point P = A + λ (B − A) lies on the line through the balls: the coupler's idle spin about
that line (it has one, held by ball joints only) does not move it.

Parameters per linkage, columns of a (K, 8) array: qx, qy, qz, tau (radians), rocker ρ, coupler L,
point λ, branch.

Transmission: the rocker is driven through the coupler's component along the rocker tip's path
t = −sin ψ u + cos ψ w; d_s = ((A − B)·t / L)², sin² of the angle between the coupler and the plane of
the rocker arm and its axis (0: a dead point, where the two values of ψ meet). Since
(A − B)·t = (K₂ cos ψ − K₁ sin ψ)/(2ρ) = ∓√(K₁² + K₂² − K₃²)/(2ρ), d_s = (K₁² + K₂² − K₃²)/(2ρL)², a
trigonometric polynomial of degree 2 in θ; its lowest value over the cycle is bounded from CHECK crank
samples (:func:`linkedit.planar.feasibility.lowest`).
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.feasibility import CHECK_SAMPLES, assembles, lowest, margin_of

NAME = "rssr"
ID = 12
DIM = 3
PARAMETERS = ("qx", "qy", "qz", "tau", "rocker", "coupler", "point", "branch")
#: Smallest transmission angle kept in an atlas (degrees); the singularity margin is sin² of it.
MU_MIN_DEG = 20.0
#: The example's design (examples/3d/rssr.yaml turned −90° about z: pivot (0, −4, 2), axis y), sampled around.
SEEDS = np.array([[0.0, -4.0, 2.0, np.pi / 2, 3.0, 5.5, 0.5, 1.0]])
#: Crank samples at which the lowest d_s is bounded (the atlas and the refinement): every command's density.
CHECK = CHECK_SAMPLES


def margin(margin_deg: float = MU_MIN_DEG) -> float:
    """The singularity margin min d_s = sin² μ its linkages keep in the transmission band [μ, 180° − μ]
    (μ = ``margin_deg``; an atlas linkage's: MU_MIN_DEG)."""
    return margin_of(margin_deg)


def joints(params: np.ndarray, angle: np.ndarray) -> dict[str, np.ndarray]:
    """Crank tip A, rocker tip B, coupler point P, rocker pivot Q and axis n (K, T, 3) each and d_s (K, T)
    at crank angles ``angle`` (K or 1, T) radians; NaN where the coupler cannot reach the rocker's circle."""
    qx, qy, qz, tau, rho, length, lam, branch = (params[:, i:i + 1] for i in range(8))
    zero = 0.0 * angle
    a = np.stack(np.broadcast_arrays(np.cos(angle), np.sin(angle), zero), axis=-1)
    q = np.stack([qx, qy, qz], axis=-1)  # (K, 1, 3)
    w = np.stack(np.broadcast_arrays(0.0 * tau, np.cos(tau), -np.sin(tau)), axis=-1)
    k1, k2, k3 = _terms(params, angle)
    with np.errstate(invalid="ignore", divide="ignore"):
        psi = np.arctan2(k2, k1) + branch * np.arccos(k3 / np.hypot(k1, k2))
    cos, sin = np.cos(psi)[..., None], np.sin(psi)[..., None]
    u = np.array([1.0, 0.0, 0.0])
    b = q + rho[..., None] * (cos * u + sin * w)
    ds = (k1 * k1 + k2 * k2 - k3 * k3) / np.square(2.0 * rho * length)
    return {"A": np.broadcast_to(a, b.shape), "B": b, "P": a + lam[..., None] * (b - a), "ds": ds,
            "Q": np.broadcast_to(q, b.shape), "n": np.broadcast_to(np.cross(u, w), b.shape)}


def _terms(params: np.ndarray, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K₁, K₂, K₃ (K, T) of the rocker's equation at crank angles ``angle`` (K or 1, T) radians."""
    qx, qy, qz, tau, rho, length = (params[:, i:i + 1] for i in range(6))
    cos, sin = np.cos(angle), np.sin(angle)
    k1 = 2.0 * rho * (cos - qx)
    k2 = 2.0 * rho * (np.cos(tau) * (sin - qy) + np.sin(tau) * qz)
    k3 = 1.0 + qx * qx + qy * qy + qz * qz + rho * rho - length * length - 2.0 * (qx * cos + qy * sin)
    return k1, k2, k3


def _angles(samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    return 2.0 * np.pi * (np.asarray(phase, dtype=float).reshape(-1, 1) + np.arange(samples)[None, :] / samples)


def _ds(params: np.ndarray, samples: int) -> np.ndarray:
    """d_s (K, T) at ``samples`` crank angles."""
    k1, k2, k3 = _terms(params, _angles(samples))
    return (k1 * k1 + k2 * k2 - k3 * k3) / np.square(2.0 * params[:, 4:5] * params[:, 5:6])


def min_singularity(params: np.ndarray, margin: float | None = None) -> np.ndarray:
    """A lower bound of d_s over the cycle (K,) from CHECK crank samples; −1 where the coupler cannot
    reach the rocker's circle at some sample. With ``margin``, a linkage with a sample below it among every
    fourth of those keeps that sample's value (it fails the margin either way); only the others are bounded."""
    if margin is None:
        return lowest(_ds(params, CHECK))
    coarse = _ds(params, CHECK // 4)
    out = np.where(assembles(coarse).all(axis=1), coarse.min(axis=1), -1.0)  # ≥ the true minimum
    rest = out >= margin
    out[rest] = lowest(_ds(params[rest], CHECK))
    return out


def sample(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` parameter rows from the family's distribution (not yet filtered):

    three quarters over a wide range — qx, qy uniform in [−4, 4], qz uniform in [−3, 3], tau uniform in
    [0°, 180°), rocker log-uniform in [0.5, 4], coupler log-uniform in [1, 8], point uniform in
    [−0.5, 1.5], branch ±1 — and one quarter around the example's design: lengths times e^{N(0, 0.2²)},
    the pivot plus N(0, 0.5²), tau plus N(0, 0.2²), the point uniform as above, branch kept.
    """
    wide = count - count // 4
    out = np.empty((count, 8))
    out[:wide, 0:2] = rng.uniform(-4.0, 4.0, (wide, 2))
    out[:wide, 2] = rng.uniform(-3.0, 3.0, wide)
    out[:wide, 3] = rng.uniform(0.0, np.pi, wide)
    out[:wide, 4] = np.exp(rng.uniform(np.log(0.5), np.log(4.0), wide))
    out[:wide, 5] = np.exp(rng.uniform(0.0, np.log(8.0), wide))
    out[:wide, 7] = rng.choice([-1.0, 1.0], wide)
    near = count - wide
    base = SEEDS[rng.integers(0, len(SEEDS), near)]
    out[wide:, 0:3] = base[:, 0:3] + rng.normal(0.0, 0.5, (near, 3))
    out[wide:, 3] = base[:, 3] + rng.normal(0.0, 0.2, near)
    out[wide:, 4:6] = base[:, 4:6] * np.exp(rng.normal(0.0, 0.2, (near, 2)))
    out[wide:, 7] = base[:, 7]
    out[:, 6] = rng.uniform(-0.5, 1.5, count)
    return out


def curves(params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    """Coupler-point curves (K, T, 3) at θ = 2π(phase + t/T), t = 0..T−1 (family frame); one array
    evaluation over linkages and samples; NaN where the coupler cannot reach the rocker's circle."""
    return joints(params, _angles(samples, phase))["P"]


def to_spec(row: np.ndarray, *, phase: float, scale: float, matrix: np.ndarray, shift: np.ndarray, name: str,
            units: str, description: str) -> dict:
    """The 3D mechanism spec (a dict for :class:`~linkedit.spec.mechanism3d.MechanismSpec`) of parameter
    ``row`` at crank phase ``phase``, placed by p ↦ shift + scale·matrix·p (``matrix`` orthogonal; a
    reflection turns the crank the other way about its placed axis), track ``target`` = P on the coupler.

    Every member's frame is the world at the rest pose (position 0, no rotation): shape points are world
    points."""
    pose = {k: v[0, 0] for k, v in joints(row[None], _angles(1, phase)).items()}
    place = lambda p: [float(v) for v in shift + scale * matrix @ p]  # noqa: E731
    o, q = place(np.zeros(3)), place(pose["Q"])
    z = np.array([0.0, 0.0, 1.0])
    drive = [float(x) for x in np.sign(np.linalg.det(matrix)) * (matrix @ z)]
    return {
        "name": name, "units": units, "description": description,
        "shapes": {
            "crank": {"points": {"pivot": o, "tip": place(pose["A"])}, "lines": [["pivot", "tip"]]},
            "rocker": {"points": {"pivot": q, "tip": place(pose["B"])}, "lines": [["pivot", "tip"]]},
            "coupler": {"points": {"a": place(pose["A"]), "b": place(pose["B"]), "P": place(pose["P"])},
                        "lines": [["a", "P", "b"]] if 0.0 <= row[6] <= 1.0 else
                        [["a", "b"], ["a" if row[6] < 0.0 else "b", "P"]]},
        },
        "members": {"crank": {"shape": "crank"}, "rocker": {"shape": "rocker"}, "coupler": {"shape": "coupler"}},
        "constraints": {
            "crank_pivot": {"type": "pin", "member": "crank", "point": "pivot", "axis": [float(x) for x in matrix @ z],
                            "world": o},
            "rocker_pivot": {"type": "pin", "member": "rocker", "point": "pivot",
                             "axis": [float(x) for x in matrix @ pose["n"]], "world": q},
            "ball_a": {"type": "location", "member": "coupler", "point": "a", "other": "crank", "other_point": "tip"},
            "ball_b": {"type": "location", "member": "coupler", "point": "b", "other": "rocker", "other_point": "tip"},
        },
        "inputs": {"drive": {"type": "orientation", "member": "crank",
                             "rotation": {"axis": drive, "angles_deg": [0, 360]}}},
        "outputs": {"tracks": {"target": {"member": "coupler", "point": "P"}}},
    }
