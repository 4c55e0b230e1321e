"""The bench's mechanism variants (examples/3d/bench/, issue 22's Speed section) solve right:
each against a closed form derived in its spec, at 73 steps, to 1e-9 of its size."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from tests.conftest import EXAMPLES
from tests.gcs_oracles import crank_rocker

BENCH = EXAMPLES / "3d" / "bench"
STEPS = 73


def _track(run_cli, tmp_path, stem: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    out = tmp_path / f"{stem}.h5"
    r = run_cli("solve3d", BENCH / f"{stem}.yaml", "-o", out, "--steps", str(STEPS))
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        return f["t"][()], f[f"tracks/{name}/position"][()]


def _cylinder_rocker(t: np.ndarray) -> np.ndarray:
    d = 1.5 + 1.3 * (1 - np.abs(2 * t - 1))  # the stroke's keyframes 1.5, 2.8, 1.5, evenly spread
    phi = np.arccos((6 - d**2) / (2 * np.sqrt(5))) - np.arctan2(1, 2)
    return 3 * np.column_stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)])


def _offset_slider_crank(t: np.ndarray) -> np.ndarray:
    theta, r, rod, e = 2 * np.pi * t, 1.0, 3.0, 0.5
    x = r * np.cos(theta) + np.sqrt(rod**2 - (r * np.sin(theta) - e) ** 2)
    return np.column_stack([x, np.full_like(x, e), np.zeros_like(x)])


def _jansen_xy_pins(t: np.ndarray) -> np.ndarray:
    """The foot G of the planar leg (LinkEdit's symbolic kinematics, t = k / (T − 1), the last
    the first again) turned upright: (x, y) → (0, x, y)."""
    from linkedit.planar import compile_plan, simulate
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model

    spec = load_model(LinkageSpec, EXAMPLES / "jansen.yaml")
    foot = simulate(compile_plan(spec), len(t) - 1).positions[:, list(spec.joints).index("G")]
    foot = np.concatenate([foot, foot[:1]])
    return np.column_stack([np.zeros(len(t)), foot[:, 0], foot[:, 1]])


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _steered_spherical_four_bar(t: np.ndarray) -> np.ndarray:
    """The coupler point P: the crank angle θ linear in t between the keyframes; the coupler's
    axis c on the cone about the rocker's ground axis d (c = cos β d + sin β (cos ψ e₁ + sin ψ e₂))
    at the coupler's angle α from the crank's axis b = Rz(θ) b₀: A cos ψ + B sin ψ = cos α −
    cos β d·b, ψ = atan2(B, A) + acos(…/√(A² + B²)) on the rest pose's side; P keeps its
    coordinates in the frame (b, c, b × c)."""
    theta = np.radians(np.interp(t, [0, 0.1, 0.3, 0.4, 0.6, 0.8, 1], [0, 70, 120, 90, 200, 290, 360]))
    b0, c0 = _unit([-0.296198133, 0.171010072, 0.939692621]), _unit([0.517911233, 0.762112194, 0.388526652])
    d = _unit([0.866025404, 0.0, 0.5])
    P0 = np.array([-0.045024807, 0.875592490, 0.872531122])
    cos_a, cos_b = b0 @ c0, c0 @ d
    sin_b = np.sqrt(1 - cos_b**2)
    e1 = _unit(np.cross(d, [0.0, 1.0, 0.0]))
    e2 = np.cross(d, e1)
    b = np.column_stack([np.cos(theta) * b0[0] - np.sin(theta) * b0[1],
                         np.sin(theta) * b0[0] + np.cos(theta) * b0[1], np.full_like(theta, b0[2])])
    A, B = sin_b * b @ e1, sin_b * b @ e2
    base, half = np.arctan2(B, A), np.arccos((cos_a - cos_b * b @ d) / np.hypot(A, B))
    # the rest pose's side: the root giving c₀ at θ = 0
    psi0 = np.arctan2(c0 @ e2, c0 @ e1)
    side = 1.0 if abs(np.angle(np.exp(1j * (base[0] + half[0] - psi0)))) < 1e-6 else -1.0
    psi = base + side * half
    c = cos_b * d + sin_b * (np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2)
    coords = np.linalg.solve(np.column_stack([b0, c0, np.cross(b0, c0)]), P0)
    return coords[0] * b + coords[1] * c + coords[2] * np.cross(b, c)


@pytest.mark.parametrize("stem, track, closed_form, size", [
    ("cylinder-rocker", "tip", _cylinder_rocker, 3.0),
    ("welded-crank-rocker", "P", lambda t: crank_rocker(2 * np.pi * t), 10.0),
    ("offset-slider-crank", "slider", _offset_slider_crank, 4.0),
    ("jansen-xy-pins", "foot", _jansen_xy_pins, 150.0),
    ("steered-spherical-four-bar", "P", _steered_spherical_four_bar, 2.4),
])
def test_a_bench_variant_follows_its_closed_form(run_cli, tmp_path, stem, track, closed_form, size):
    t, p = _track(run_cli, tmp_path, stem, track)
    assert np.allclose(t, np.arange(STEPS) / (STEPS - 1))
    assert np.abs(p - closed_form(t)).max() < 1e-9 * size


def test_the_upright_jansen_leg_is_solved_in_waves_through_its_ill_conditioned_poses():
    """The Jansen leg with its pin axes along world x (issue 22: 2.18× SolveSpace): around a
    third of its cycle J's smallest singular value falls to ~5e-3 of its largest — badly
    conditioned, full rank (as the SVD's rank counts it) — and the waves must keep those steps
    (not hand 48 of them to the step-by-step continuation): the same poses, on the closed form."""
    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.tolerances import Options
    from linkedit.spec.mechanism3d import MechanismSpec
    from linkedit.spec.yamlload import load_model

    system, _ = compile_mechanism(load_model(MechanismSpec, BENCH / "jansen-xy-pins.yaml"))
    t = np.arange(361) / 360
    on, off = solve_run(system, t), solve_run(system, t, Options(waves=False))
    assert (on.status == 0).all() and (off.status == 0).all()
    assert on.batched.sum() >= 355
    # full rank at every step, as the SVD counts it (not "cannot tell" there)
    assert (on.rank == system.n_unknowns).all() and (off.rank == system.n_unknowns).all()
    size = system.length_scale
    assert np.abs(on.position - off.position).max() <= 1e-9 * size
    foot = system.member_names.index("lower")
    G = on.position[:, foot] + quat.rotate(on.orientation[:, foot], np.array([-16.20800349253176, -46.241762756042064, 0.0]))
    assert np.abs(G - _jansen_xy_pins(t)).max() < 1e-9 * 150.0
