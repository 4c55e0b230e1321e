"""The closed form's spherical dyads (cones) and sliders (linkedit.gcs.closed_form): on untuned
random spherical four-bars and offset slider-cranks (random planes, axes, frames, offsets and
scales) the rebuilt poses are the independent formulas' (cone intersection on the sphere; the
slider-crank's x = a + sqrt(l² − (b − e)²)), satisfy every constraint to rounding, and are the
step-by-step solver's poses; the waves take them and converge at the first evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.gcs.system import State
from linkedit.gcs.tolerances import Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import validate

T = 120


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _turn(axis: np.ndarray, angle: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rodrigues: v (3,) turned about the unit axis (3,) by the angles (T,): (T, 3)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1 - c)


def _members(rng: np.random.Generator, names: list[str], centre: np.ndarray, spread: float) -> dict:
    """Members at random rest frames near ``centre``."""
    return {n: {"position": (centre + spread * rng.normal(size=3)).tolist(),
                "orientation": _unit(rng.normal(size=4)).tolist()} for n in names}


def _solve(data: dict):
    system = compile_mechanism(validate(MechanismSpec, data, file="test"))[0]
    t = np.linspace(0.0, 1.0, T)
    table = system.step_table(t)
    off = solve_run(system, t, Options(waves=False))
    assert (off.status == 0).all()
    form = ClosedForm.compile(system)
    P, Q, valid = form.poses(table, np.arange(T), off.orientation[0],
                             form.signs(off.position[0], off.orientation[0], table, 0))
    assert valid.all()
    worst = max(np.abs(system.evaluate(State(P[k], Q[k]), table, k).r * system.row_scale).max() for k in range(T))
    assert worst <= 1e-13
    assert np.abs(P - off.position).max() <= 1e-9 * system.length_scale
    assert np.minimum(np.abs(Q - off.orientation), np.abs(Q + off.orientation)).max() <= 1e-9
    on = solve_run(system, t)
    assert on.batched.sum() >= T - 8 and on.iterations[on.batched].mean() <= 1.05  # restarts at keyframes
    assert np.abs(on.position - off.position).max() <= 1e-9 * system.length_scale
    return system, form, t, P, Q


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_random_spherical_four_bar_is_rebuilt_where_the_cones_meet(seed):
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-3, 3)
    centre = scale * rng.normal(size=3)
    a = _unit(rng.normal(size=3))  # the crank's ground axis
    # the rest pose's axes: b at 15–30° from a, c at 60–80° from b, d at 40–60° from c
    def tilt(v: np.ndarray, deg: float) -> np.ndarray:
        w = _unit(np.cross(v, rng.normal(size=3)))
        return _turn(w, np.radians([deg]), v)[0]
    b0 = tilt(a, rng.uniform(15, 30))
    c0 = tilt(b0, rng.uniform(60, 80))
    d = tilt(c0, rng.uniform(40, 60))
    at = centre.tolist()
    sweep = 40.0
    data = {"name": "spherical", "units": "m",
            "members": _members(rng, ["crank", "coupler", "rocker"], centre, 0.5 * scale),
            "joints": {"A": {"type": "revolute", "members": ["crank", "world"], "at": at, "axis": a.tolist()},
                       "B": {"type": "revolute", "members": ["coupler", "crank"], "at": at, "axis": b0.tolist()},
                       "C": {"type": "revolute", "members": ["rocker", "coupler"], "at": at, "axis": c0.tolist()},
                       "D": {"type": "revolute", "members": ["rocker", "world"], "at": at, "axis": d.tolist()}},
            "inputs": {"drive": {"type": "orientation", "member": "crank",
                                 "rotation": {"axis": a.tolist(), "angles_deg": [0, sweep, -sweep, 0]}}},
            "outputs": {"steps": T}}
    system, form, t, P, Q = _solve(data)
    assert [type(r).__name__ for r in form.rules] == ["Driven", "Cone"]
    # the oracle: c on the cone about d at β from it, at α from b = R_a(θ) b₀ (A cos ψ + B sin ψ = C)
    theta = np.radians(np.interp(t, [0, 1 / 3, 2 / 3, 1], [0, sweep, -sweep, 0]))
    b = _turn(a, theta, b0)
    cos_a, cos_b = b0 @ c0, c0 @ d
    e1 = _unit(np.cross(d, rng.normal(size=3)))
    e2 = np.cross(d, e1)
    sin_b = np.sqrt(1 - cos_b**2)
    A, B = sin_b * b @ e1, sin_b * b @ e2
    base, half = np.arctan2(B, A), np.arccos((cos_a - cos_b * b @ d) / np.hypot(A, B))
    psi0 = np.arctan2(c0 @ e2, c0 @ e1)
    side = 1.0 if abs(np.angle(np.exp(1j * (base[0] + half[0] - psi0)))) < 1e-9 else -1.0
    psi = base + side * half
    c = cos_b * d + sin_b * (np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2)
    coupler = system.member_names.index("coupler")
    local = quat.rotate(quat.conjugate(np.asarray(data["members"]["coupler"]["orientation"])), c0)
    assert np.abs(quat.rotate(Q[:, coupler], local) - c).max() < 1e-12


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_random_offset_slider_crank_is_rebuilt_on_its_line(seed):
    rng = np.random.default_rng(10 + seed)
    scale = 10.0 ** rng.uniform(-3, 3)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    u, v, n = frame.T  # the slider's line direction, across it in the plane, the pin axes
    r, rod, e = scale, scale * rng.uniform(3, 5), scale * rng.uniform(-1.5, 1.5)
    pivot = scale * rng.normal(size=3)
    theta0 = rng.uniform(0, 2 * np.pi)
    tip = pivot + r * (np.cos(theta0) * u + np.sin(theta0) * v)
    sign = rng.choice([-1.0, 1.0])  # the slider ahead of or behind the crank
    slide0 = (tip - pivot) @ u + sign * np.sqrt(rod**2 - ((tip - pivot) @ v - e) ** 2)
    wrist = pivot + slide0 * u + e * v
    data = {"name": "slider-crank", "units": "m",
            "members": _members(rng, ["crank", "rod", "slider"], pivot, scale),
            "joints": {"pivot": {"type": "revolute", "members": ["crank", "world"], "at": pivot.tolist(), "axis": n.tolist()},
                       "tip": {"type": "revolute", "members": ["rod", "crank"], "at": tip.tolist(), "axis": n.tolist()},
                       "wrist": {"type": "revolute", "members": ["rod", "slider"], "at": wrist.tolist(), "axis": (-n).tolist()},
                       "guide": {"type": "prismatic", "members": ["slider", "world"], "at": wrist.tolist(),
                                 "axis": u.tolist()}},
            "inputs": {"drive": {"type": "orientation", "member": "crank",
                                 "rotation": {"axis": n.tolist(), "angles_deg": [0, 360]}}},
            "outputs": {"steps": T}}
    system, form, t, P, Q = _solve(data)
    assert [type(r).__name__ for r in form.rules] == ["Driven", "Slider"]
    theta = theta0 + 2 * np.pi * t
    x = r * np.cos(theta) + sign * np.sqrt(rod**2 - (r * np.sin(theta) - e) ** 2)
    slider = system.member_names.index("slider")
    local = quat.rotate(quat.conjugate(np.asarray(data["members"]["slider"]["orientation"])),
                        wrist - np.asarray(data["members"]["slider"]["position"]))
    at = P[:, slider] + quat.rotate(Q[:, slider], local)
    assert np.abs(at - (pivot + x[:, None] * u + e * v)).max() < 1e-12 * scale * 10


def _spin_is_nearest_rest(system, P, Q, link: str, one: np.ndarray, two: np.ndarray) -> None:
    """The link's pose at each step is, of its spins about the line through its ball joints
    (world points one, two (T, 3)), the one nearest its rest pose in the scaled metric
    |ΔP|²/L² + |log(R R_restᵀ)|² (a grid of 720 spins, then ±1e-4 rad about the pose)."""
    m, L = system.member_names.index(link), system.length_scale
    rest_p, rest_q = system.rest.position[m], system.rest.orientation[m]
    u = _unit(two - one)

    def distance(angle: np.ndarray) -> np.ndarray:  # (T, K) for spins (K,) away from the pose
        turn = np.concatenate([np.cos(angle / 2)[None, :, None] * np.ones((len(u), 1, 1)),
                               np.sin(angle / 2)[None, :, None] * u[:, None, :]], axis=2)
        q = quat.multiply(turn, np.broadcast_to(Q[:, m, None], turn.shape))
        p = one[:, None] + quat.rotate(turn, (P[:, m] - one)[:, None])
        phi = quat.log(quat.multiply(q, quat.conjugate(np.broadcast_to(rest_q, q.shape))))
        return ((p - rest_p) ** 2).sum(axis=2) / L**2 + (phi**2).sum(axis=2)

    here = distance(np.zeros(1))
    assert (here <= distance(np.linspace(-np.pi, np.pi, 720)).min(axis=1)[:, None] + 1e-12).all()
    assert (here < distance(np.array([-1e-4, 1e-4]))).all()


def _ball_points(P, Q, system, data, member: str, point: np.ndarray) -> np.ndarray:
    """A member's point (given in the world at rest) at each step (T, 3)."""
    m = system.member_names.index(member)
    spec = data["members"][member]
    local = quat.rotate(quat.conjugate(np.asarray(spec["orientation"])), point - np.asarray(spec["position"]))
    return P[:, m] + quat.rotate(Q[:, m], local)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_random_rssr_coupler_is_spun_to_its_canonical_pose(seed):
    """A rocker reaching a link with ball joints at both ends (a random RSSR, the coupler's
    frame off the line of its balls) is rebuilt where the rocker's circle meets the sphere about
    the crank tip, the link at its canonical spin: the nearest its rest pose."""
    rng = np.random.default_rng(20 + seed)
    scale = 10.0 ** rng.uniform(-3, 3)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    pivot, z = scale * rng.normal(size=3), frame[:, 2]
    tip = pivot + scale * frame[:, 0]
    rocker_axis = _unit(frame @ np.array([1.0, 0.0, 0.0]) + 0.3 * rng.normal(size=3))
    rocker_pivot = pivot + scale * (frame @ np.array([4.0, 0.0, 2.0]))
    # the rocker's tip 3 from its pivot across its axis, on the side where the coupler is 5.5 long
    across = _unit(np.cross(rocker_axis, rng.normal(size=3)))
    arm = 3.0 * scale * np.array([np.cos(a) * across + np.sin(a) * np.cross(rocker_axis, across)
                                  for a in np.linspace(0, 2 * np.pi, 3601)])
    reach = np.linalg.norm(rocker_pivot + arm - tip, axis=1)
    length = 0.5 * (reach.min() + reach.max())
    rocker_tip = rocker_pivot + arm[np.argmin(np.abs(reach - length) + 10 * (arm @ frame[:, 2] < 0))]
    data = {"name": "rssr", "units": "m",
            "members": _members(rng, ["crank", "rocker", "coupler"], pivot, scale),
            "joints": {"A": {"type": "revolute", "members": ["crank", "world"], "at": pivot.tolist(), "axis": z.tolist()},
                       "D": {"type": "revolute", "members": ["rocker", "world"], "at": rocker_pivot.tolist(),
                             "axis": rocker_axis.tolist()},
                       "B": {"type": "spherical", "members": ["coupler", "crank"], "at": tip.tolist()},
                       "C": {"type": "spherical", "members": ["coupler", "rocker"], "at": rocker_tip.tolist()}},
            "inputs": {"drive": {"type": "orientation", "member": "crank",
                                 "rotation": {"axis": z.tolist(), "angles_deg": [0, 25, -25, 0]}}},
            "outputs": {"steps": T}}
    system, form, t, P, Q = _solve(data)
    assert [type(r).__name__ for r in form.rules] == ["Driven", "Swing", "Spun"]
    one = _ball_points(P, Q, system, data, "crank", tip)
    two = _ball_points(P, Q, system, data, "rocker", rocker_tip)
    assert np.abs(np.linalg.norm(two - one, axis=1) - np.linalg.norm(rocker_tip - tip)).max() < 1e-12 * scale * 10
    _spin_is_nearest_rest(system, P, Q, "coupler", one, two)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_random_spatial_slider_crank_rod_is_spun_to_its_canonical_pose(seed):
    """A slider on a line skew to the crank's plane reaching a rod with ball joints at both
    ends: the slider where the line meets the sphere about the crank tip (the independent
    quadratic), the rod at its canonical spin."""
    rng = np.random.default_rng(30 + seed)
    scale = 10.0 ** rng.uniform(-3, 3)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    pivot, z = scale * rng.normal(size=3), frame[:, 2]
    tip = pivot + scale * frame[:, 0]
    direction = _unit(frame @ np.array([1.0, 0.2, 0.3]))
    base = pivot + scale * (frame @ np.array([2.5, 0.5, 1.0]))
    rod = 3.0 * scale
    b = (base - tip) @ direction
    slide0 = -b + np.sqrt(b * b - (base - tip) @ (base - tip) + rod**2)
    wrist = base + slide0 * direction
    data = {"name": "spatial-slider-crank", "units": "m",
            "members": _members(rng, ["crank", "rod", "slider"], pivot, scale),
            "joints": {"A": {"type": "revolute", "members": ["crank", "world"], "at": pivot.tolist(), "axis": z.tolist()},
                       "B": {"type": "spherical", "members": ["rod", "crank"], "at": tip.tolist()},
                       "C": {"type": "spherical", "members": ["rod", "slider"], "at": wrist.tolist()},
                       "guide": {"type": "prismatic", "members": ["slider", "world"], "at": wrist.tolist(),
                                 "axis": direction.tolist()}},
            "inputs": {"drive": {"type": "orientation", "member": "crank",
                                 "rotation": {"axis": z.tolist(), "angles_deg": [0, 360]}}},
            "outputs": {"steps": T}}
    system, form, t, P, Q = _solve(data)
    assert [type(r).__name__ for r in form.rules] == ["Driven", "Reach", "Spun"]
    theta = 2 * np.pi * t
    crank_tip = pivot + _turn(z, theta, tip - pivot)
    b = (base - crank_tip) @ direction
    s = -b + np.sqrt(b * b - ((base - crank_tip) ** 2).sum(axis=1) + rod**2)
    slider = _ball_points(P, Q, system, data, "slider", wrist)
    assert np.abs(slider - (base + s[:, None] * direction)).max() < 1e-12 * scale * 10
    _spin_is_nearest_rest(system, P, Q, "rod", crank_tip, slider)
