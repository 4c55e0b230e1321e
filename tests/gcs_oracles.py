"""Closed-form kinematics of 3D test mechanisms (independent of the solver), and a spec scaler."""

from __future__ import annotations

import copy

import numpy as np


def scaled_spec(data: dict, s: float) -> dict:
    """The spec data with every length multiplied by ``s`` (directions, angles and
    orientations unchanged)."""
    out = copy.deepcopy(data)
    mul = lambda v: [s * float(c) for c in v]  # noqa: E731
    for shape in out.get("shapes", {}).values():
        shape["points"] = {k: mul(v) for k, v in shape["points"].items()}
    for m in out["members"].values():
        if "position" in m:
            m["position"] = mul(m["position"])
        if isinstance(m.get("shape"), dict):
            m["shape"]["points"] = {k: mul(v) for k, v in m["shape"]["points"].items()}

    def constraint(c: dict) -> None:
        if c["type"] == "group":
            for sub in c["constraints"].values():
                constraint(sub)
            return
        if c["type"] in ("location", "pin", "revolute", "weld", "distance") and "world" in c:
            c["world"] = mul(c["world"])
        if c["type"] == "distance":
            c["value"] = s * float(c["value"])
        if c["type"] == "on_line":
            c["line"]["point"] = mul(c["line"]["point"])
        for key in ("point", "other_point"):
            if isinstance(c.get(key), list):
                c[key] = mul(c[key])
        if c["type"] == "on_plane":
            c["plane"]["point"] = mul(c["plane"]["point"])

    for c in out.get("constraints", {}).values():
        constraint(c)
    for joint in out.get("joints", {}).values():
        joint["at"] = mul(joint["at"])
    for inp in out.get("inputs", {}).values():
        for key in ("point", "other_point"):
            if isinstance(inp.get(key), list):
                inp[key] = mul(inp[key])
        if inp["type"] == "location":
            inp["keyframes"] = [mul(k) for k in inp["keyframes"]]
        if inp["type"] == "distance":
            inp["keyframes"] = [s * float(k) for k in inp["keyframes"]]
            if "world" in inp:
                inp["world"] = mul(inp["world"])
    for tr in out.get("outputs", {}).get("tracks", {}).values():
        if isinstance(tr.get("point"), list):
            tr["point"] = mul(tr["point"])
    return out


def crank_rocker(theta: np.ndarray) -> np.ndarray:
    """examples/3d/crank-rocker.yaml: coupler point P (T, 3) at crank angles θ (T,) (rest branch:
    rocker tip above the line from the crank tip to the rocker pivot)."""
    A0, B0 = np.array([-3.0, 3.0]), np.array([2.0, -3.0])
    A = A0 + np.column_stack([np.cos(theta), np.sin(theta)])
    B = _circles(A, 5.0, B0, 5.75, +1)
    ex = (B - A) / 5.0
    ey = np.column_stack([-ex[:, 1], ex[:, 0]])
    P = A + 2.5 * ex + 2.5 * ey
    return np.column_stack([P, np.zeros(len(P))])


def _circles(c1: np.ndarray, r1: float, c2: np.ndarray, r2: float, side: int) -> np.ndarray:
    """Intersection (T, 2) of circles about c1 (T, 2) and c2 (2,): the one to the ``side``
    (+1 left) of the line c1 → c2."""
    d = c2 - c1
    L = np.linalg.norm(d, axis=1)
    a = (r1**2 - r2**2 + L**2) / (2 * L)
    h = np.sqrt(r1**2 - a**2)
    u = d / L[:, None]
    n = np.column_stack([-u[:, 1], u[:, 0]])
    return c1 + a[:, None] * u + side * h[:, None] * n


def rssr(theta: np.ndarray) -> np.ndarray:
    """examples/3d/rssr.yaml: rocker tip (T, 3) at crank angles θ (T,), on the rest branch."""
    O2 = np.array([4.0, 0.0, 2.0])
    A = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    D = A - O2
    K1, K2 = D[:, 1], D[:, 2]
    K3 = (np.sum(D * D, axis=1) + 9.0 - 5.5**2) / 6.0
    psi = np.arctan2(K2, K1) + np.arccos(K3 / np.hypot(K1, K2))
    return O2 + 3.0 * np.column_stack([np.zeros_like(psi), np.cos(psi), np.sin(psi)])


def spatial_slider_crank(theta: np.ndarray) -> np.ndarray:
    """examples/3d/spatial-slider-crank.yaml: slider point (T, 3) at crank angles θ (T,)."""
    C = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    L0 = np.array([2.5, 0.5, 1.0])
    D = C - L0
    s = D[:, 0] + np.sqrt(9.0 - D[:, 1] ** 2 - D[:, 2] ** 2)
    return L0 + s[:, None] * np.array([1.0, 0.0, 0.0])


def spherical_four_bar(theta: np.ndarray) -> np.ndarray:
    """examples/3d/spherical-four-bar.yaml: the coupler's joint axis c (T, 3) (a unit vector) at
    crank turns θ (T,) from the rest pose: c is 70° from the crank's axis b(θ) and 50° from
    the fixed rocker axis d (the arcs of the spec's rest pose), on the rest pose's side of the plane through b and d."""
    b0 = np.array([-0.296198133, 0.171010072, 0.939692621])
    c0 = np.array([0.517911233, 0.762112194, 0.388526652])
    d = np.array([0.866025404, 0.0, 0.5])
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    b = np.column_stack([cos_t * b0[0] - sin_t * b0[1], sin_t * b0[0] + cos_t * b0[1], np.full_like(theta, b0[2])])
    b0, c0, d = (v / np.linalg.norm(v) for v in (b0, c0, d))
    cb, cd = b0 @ c0, c0 @ d  # the spec's arcs (70° and 50° to its nine digits)
    # c = α b + β d + γ (b × d): c·b = cb, c·d = cd, |c| = 1
    bd = b @ d
    det = 1.0 - bd**2
    alpha = (cb - cd * bd) / det
    beta = (cd - cb * bd) / det
    n = np.cross(b, d)
    rest = alpha[:, None] * b + beta[:, None] * d
    gamma = np.sqrt((1.0 - np.sum(rest * rest, axis=1)) / np.sum(n * n, axis=1))
    side = np.sign(np.cross(b0, d) @ c0)
    return rest + side * gamma[:, None] * n


def spin_gradient(position: np.ndarray, orientation: np.ndarray, a: np.ndarray, b: np.ndarray,
                  rest_position: np.ndarray, rest_orientation: np.ndarray, size: float) -> np.ndarray:
    """The derivative (T,) of ½(|p − p₀|²/L² + θ²) — a member's squared distance from its rest
    pose (p₀, q₀) in the solver's scaled metric, θ the angle of q q₀⁻¹ — as the member spins
    about the world line through its own points a and b (member space (3,)), by central
    differences of 1e-4 rad; zero where the spin is the one nearest the rest pose. position
    (T, 3) and orientation (T, 4) of the member, its rest pose (3,), (4,), the size L."""
    from linkedit.gcs import quaternions as quat

    R = quat.to_matrix(orientation)
    A, B = position + R @ a, position + R @ b
    u = (B - A) / np.linalg.norm(B - A, axis=1, keepdims=True)

    def half_distance(e: float) -> np.ndarray:
        turn = np.concatenate([np.full((len(u), 1), np.cos(e / 2)), np.sin(e / 2) * u], axis=1)
        p = A + quat.rotate(turn, position - A)
        q = quat.multiply(turn, orientation)
        rel = quat.multiply(q, quat.conjugate(np.broadcast_to(rest_orientation, q.shape)))
        theta = 2 * np.arcsin(np.clip(np.linalg.norm(rel[:, 1:], axis=1), 0.0, 1.0))
        return 0.5 * (((p - rest_position) ** 2).sum(axis=1) / size**2 + theta**2)

    e = 1e-4
    return (half_distance(e) - half_distance(-e)) / (2 * e)


def pinned_four_bar(name: str, coupler: dict[str, list[float]], tracks: dict[str, dict[str, str]]) -> dict:
    """A 3D spec of a planar four-bar of pins (m): crank and rocker 1 long, ground 4, both at 90° at
    rest, the coupler's points ``coupler`` (``a`` at the crank's tip, ``b`` at the rocker's), the
    crank driven a full turn over 361 steps."""
    return {
        "name": name, "units": "m",
        "shapes": {"bar": {"points": {"pivot": [0, 0, 0], "tip": [1, 0, 0]}}, "coupler": {"points": coupler}},
        "members": {"crank": {"position": [0, 0, 0], "orientation": {"axis": [0, 0, 1], "angle_deg": 90}, "shape": "bar"},
                    "coupler": {"position": [0, 1, 0], "shape": "coupler"},
                    "rocker": {"position": [4, 0, 0], "orientation": {"axis": [0, 0, 1], "angle_deg": 90},
                               "shape": "bar"}},
        "constraints": {
            "crank_pivot": {"type": "pin", "member": "crank", "point": "pivot", "world": [0, 0, 0]},
            "crank_coupler": {"type": "pin", "member": "crank", "point": "tip", "other": "coupler", "other_point": "a"},
            "coupler_rocker": {"type": "pin", "member": "coupler", "point": "b", "other": "rocker", "other_point": "tip"},
            "rocker_pivot": {"type": "pin", "member": "rocker", "point": "pivot", "world": [4, 0, 0]}},
        "inputs": {"drive": {"type": "orientation", "member": "crank",
                             "rotation": {"axis": [0, 0, 1], "angles_deg": [0, 360]}}},
        "outputs": {"steps": 361, "tracks": tracks},
    }
