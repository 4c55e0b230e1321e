"""The closed-form engine: law of cosines, ordering, derivatives, diagnostics."""

from __future__ import annotations

import re

import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.planar import compile_plan, simulate
from linkedit.planar import law_of_cosines as loc
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.planar_specs import FIVEBAR, FOURBAR, JANSEN, LOCKING, TRIAD


def spec_of(text: str) -> LinkageSpec:
    return load_model(LinkageSpec, "inline.yaml", text)


def test_dyad_keeps_lengths_and_orientation():
    rng = np.random.default_rng(1)
    zi = rng.normal(size=(5, 7)) + 1j * rng.normal(size=(5, 7))
    zj = zi + (2 + rng.random((5, 7))) * np.exp(1j * rng.uniform(0, 6.3, (5, 7)))
    lik = 2.0 + rng.random((5, 1))
    ljk = 2.0 + rng.random((5, 1))
    sign = np.where(rng.random((5, 1)) > 0.5, 1.0, -1.0)
    zk, _ = loc.dyad(zi, zj, 0.5 * (lik**2 - ljk**2), lik**2, sign)
    assert np.allclose(np.abs(zk - zi), lik, atol=1e-12)
    assert np.allclose(np.abs(zk - zj), ljk, atol=1e-12)
    cross = ((zj - zi).conj() * (zk - zi)).imag
    assert np.all(np.sign(cross) == sign)


def test_dyad_derivatives_match_central_differences():
    rng = np.random.default_rng(2)
    z0i, z0j = rng.normal(size=(3, 1)) + 1j * rng.normal(size=(3, 1)), rng.normal(size=(3, 1)) * 0 + 3.0
    vi, vj = rng.normal(size=(3, 1)) + 1j * rng.normal(size=(3, 1)), rng.normal(size=(3, 1)) + 1j * rng.normal(size=(3, 1))
    ai, aj = rng.normal(size=(3, 1)) + 1j * rng.normal(size=(3, 1)), rng.normal(size=(3, 1)) + 1j * rng.normal(size=(3, 1))
    lik2, ljk2 = np.full((3, 1), 6.0), np.full((3, 1), 5.0)
    half, sign = 0.5 * (lik2 - ljk2), np.ones((3, 1))

    def at(s: float) -> np.ndarray:  # inputs moving along quadratic paths
        return loc.dyad(z0i + vi * s + 0.5 * ai * s * s, z0j + vj * s + 0.5 * aj * s * s, half, lik2, sign)[0]

    z, terms = loc.dyad(z0i, z0j, half, lik2, sign)
    E, Zi = np.stack([z0j - z0i, vj - vi, aj - ai]), np.stack([z0i, vi, ai])
    out = np.empty((2, 3, 1), dtype=complex)
    real, cplx = (lambda: np.empty((3, 1))), (lambda: np.empty((3, 1), dtype=complex))
    rates = loc.Rates(cplx(), cplx(), cplx(), np.empty((2, 3, 1), dtype=complex), real(), real(), real())
    loc.dyad_rates(E, z - z0i, terms.u, terms.a, terms.b, lik2, out, rates)
    out += Zi[1:]  # dyad_rates gives what joint k adds to joint i's derivatives
    h = 1e-4
    assert np.allclose(out[0], (at(h) - at(-h)) / (2 * h), atol=1e-7)
    assert np.allclose(out[1], (at(h) - 2 * z + at(-h)) / h**2, atol=1e-5)


def test_motion_derivatives_match_central_differences():
    spec = spec_of(FOURBAR)
    plan = compile_plan(spec)
    m = simulate(plan, 720)
    h = 2 * np.pi / 720  # one sample in motor angle
    p = m.positions
    fd_v = (np.roll(p, -1, 0) - np.roll(p, 1, 0)) / (2 * h)
    fd_a = (np.roll(p, -1, 0) - 2 * p + np.roll(p, 1, 0)) / h**2
    scale = np.abs(m.velocity).max()
    assert np.abs(m.velocity - fd_v).max() < 1e-4 * scale
    assert np.abs(m.acceleration - fd_a).max() < 1e-3 * np.abs(m.acceleration).max()
    track = m.tracks["coupler_point"]
    fd_tv = (np.roll(track.position, -1, 0) - np.roll(track.position, 1, 0)) / (2 * h)
    assert np.abs(track.velocity - fd_tv).max() < 1e-4 * scale


def test_link_lengths_and_rigid_track_point_are_kept():
    m = simulate(compile_plan(spec_of(FOURBAR)), 360)
    p = m.positions
    rest = m.plan.graph.rest
    for a, b in m.plan.pairs:
        assert np.abs(np.linalg.norm(p[:, a] - p[:, b], axis=1) - np.linalg.norm(rest[a] - rest[b])).max() < 1e-12
    c = m.tracks["coupler_point"].position
    for j, d in ((1, np.hypot(0.2, 1.6)), (2, np.hypot(1.0, 0.5))):
        assert np.abs(np.linalg.norm(c - p[:, j], axis=1) - d).max() < 1e-12
    assert np.all(m.orientation == m.orientation[0])


def test_jansen_ordering_levels():
    plan = compile_plan(spec_of(JANSEN))
    names = plan.joint_names
    levels = {names[k]: int(lv) for (_, _, k), lv in zip(plan.table.joints, plan.table.level)}
    assert levels == {"C": 1, "D": 1, "E": 2, "F": 3, "G": 4}
    rigid = {names[k] for (_, _, k), r in zip(plan.table.joints, plan.table.rigid) if r}
    assert rigid == {"E", "G"}


def test_complex_loop_becomes_one_numeric_group():
    plan = compile_plan(spec_of(TRIAD))
    assert [(st.kind, st.name) for st in plan.steps] == [("group", "T1, T2, T3")]


def test_under_constrained_linkage_reports_mobility():
    with pytest.raises(MechanismError, match=r"under-constrained \(mobility 2"):
        compile_plan(spec_of(FIVEBAR))


def test_over_constrained_structure_is_rejected():
    text = FOURBAR.replace("  rocker: [D, B]\n", "  rocker: [D, B]\n  brace: [O, B]\n")
    with pytest.raises(MechanismError, match=r"over-constrained \(mobility 0 .*\): its links hold the motor's joint A still$"):
        compile_plan(spec_of(text))


def test_collinear_dyad_at_rest_is_rejected():
    text = FOURBAR.replace("B: [2.2, 2.1]", "B: [2.2, 0]").replace("at: [1.2, 1.6]", "at: [1.2, 0.5]")
    with pytest.raises(MechanismError, match="collinear"):
        compile_plan(spec_of(text))


def test_collinear_dyad_at_rest_says_the_motor_angle_in_0_to_360():
    """The crank at 217° with the dyad C stretched at rest was said as 'motor angle -143.0°'."""
    text = """name: stretched
units: mm
joints: {O: [0, 0], B: [32, 24], A: [-8, -6], C: [12, 9]}
ground: [O, B]
links: {crank: [O, A], coupler: [A, C], rocker: [B, C]}
motor: {joint: A, pivot: O}
"""
    angle = np.degrees(np.arctan2(-6, -8)) % 360  # 216.87°
    with pytest.raises(MechanismError, match=rf"collinear with B and A at the rest pose \(motor angle {angle:.1f}°\)"):
        compile_plan(spec_of(text))


def test_lockup_names_joint_and_motor_angles():
    spec = spec_of(LOCKING)
    with pytest.raises(MechanismError, match=r"cannot be assembled for motor angles \d+\.\d°…\d+\.\d°: joint B"):
        simulate(spec, 360)
    m = simulate(spec, 360, partial=True)
    assert 0 < m.assembled.sum() < 360
    assert np.isnan(m.positions[~m.assembled]).all() and np.isfinite(m.positions[m.assembled]).all()
    lk = m.lockups[0]
    assert lk.joint == "B" and lk.stretched
    # the reported interval is where the crank tip is farther from D than coupler + rocker
    angles = np.radians(np.arange(360))
    tip = 1.9 * np.exp(1j * angles)
    far = np.abs(tip - 3.0) > np.hypot(0.3, 2.1) + np.hypot(0.8, 2.1)
    assert np.array_equal(~m.assembled, far)


def test_partial_range_sweep_includes_both_ends():
    text = LOCKING.replace("motor: {joint: A, pivot: O}", "motor: {joint: A, pivot: O, range_deg: [-60, 60]}")
    m = simulate(spec_of(text), 121)
    assert m.assembled.all()
    assert np.isclose(np.degrees(m.motor_angle[0]), -60) and np.isclose(np.degrees(m.motor_angle[-1]), 60)


def test_clockwise_motor_turns_the_other_way():
    m = simulate(spec_of(FOURBAR.replace("pivot: O}", "pivot: O, direction: cw}")), 4)
    assert np.allclose(m.positions[1, 1], [0, -1])


def test_singularity_distance_is_sin_squared_of_the_angle_at_the_joint():
    m = simulate(spec_of(FOURBAR), 90)
    dyad = np.flatnonzero(~m.plan.table.rigid)[0]
    assert np.allclose(m.singularity[:, dyad], np.sin(m.transmission[:, dyad]) ** 2, atol=1e-12)



def test_positions_with_workspace_equal_full_evaluation():
    from linkedit.planar import catalog
    from linkedit.planar.kinematics import Workspace, evaluate, positions

    plan = compile_plan(catalog.strandbeest(3))
    geom = plan.geometry()
    angle = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    work = Workspace(plan, 50)
    fast = positions(plan, geom, angle, work).copy()
    assert np.abs(fast - evaluate(plan, geom, angle, order=0).z).max() < 1e-12
    assert positions(plan, geom, angle + 0.1, work) is work.z  # reused, not reallocated


def test_multi_level_derivatives_match_central_differences():
    """Velocities and accelerations through four levels of dyads and rigid rules (a Jansen leg)
    against central differences of the positions (step h: errors O(h²) and rounding/h²)."""
    from linkedit.planar.kinematics import evaluate

    plan = compile_plan(spec_of(JANSEN))
    geom = plan.geometry()
    angle = geom.rest_angle + np.linspace(0.0, 2 * np.pi, 60, endpoint=False)
    h = 1e-4
    s = evaluate(plan, geom, angle, order=2)
    up, down = (evaluate(plan, geom, angle + d, order=0).z for d in (h, -h))
    fd_v, fd_a = (up - down) / (2 * h), (up - 2 * s.z + down) / h**2
    assert np.abs(s.dz - fd_v).max() < 1e-7 * np.abs(s.dz).max()
    assert np.abs(s.ddz - fd_a).max() < 1e-5 * np.abs(s.ddz).max()


@pytest.mark.parametrize("name", ["strandbeest", "crank_rocker"])
def test_batches_hung_from_the_ground_read_its_positions_alone(name):
    """A dyad or rigid batch whose joints i are all ground pivots (``grounded``) reads their
    positions alone (their derivatives are 0): its velocities and accelerations still match
    central differences, with z_i gathered (Strandbeest) and read in place (four-bar)."""
    from linkedit.planar import catalog
    from linkedit.planar.kinematics import Workspace, evaluate

    spec = catalog.strandbeest(3) if name == "strandbeest" else catalog.crank_rocker()
    plan = compile_plan(spec)
    grounded = {(r.kind, r.runs[0] is None) for r in plan.rules if getattr(r, "grounded", False)}
    assert ("dyad", name == "strandbeest") in grounded
    geom = plan.geometry()
    angle = geom.rest_angle + np.linspace(0.0, 2 * np.pi, 60, endpoint=False)
    h = 1e-4
    s = evaluate(plan, geom, angle, 2, Workspace(plan, angle.size, order=2))
    up, down = (evaluate(plan, geom, angle + d, order=0).z for d in (h, -h))
    fd_v, fd_a = (up - down) / (2 * h), (up - 2 * s.z + down) / h**2
    assert np.abs(s.dz - fd_v).max() < 1e-7 * np.abs(s.dz).max()
    assert np.abs(s.ddz - fd_a).max() < 1e-5 * np.abs(s.ddz).max()


def test_evaluate_with_workspace_allocates_no_batch_arrays():
    """With a Workspace, an evaluation with derivatives writes into its buffers: the memory it
    allocates is a few motor-row arrays (T,), never a batch (R, T); results equal a fresh one."""
    import tracemalloc

    from linkedit.planar import catalog
    from linkedit.planar.kinematics import Workspace, evaluate

    plan = compile_plan(catalog.strandbeest(3))
    geom = plan.geometry()
    T = 4000
    angle = geom.rest_angle + np.linspace(0.0, 2 * np.pi, T, endpoint=False)
    work = Workspace(plan, T, order=2)
    fresh = evaluate(plan, geom, angle, order=2)
    evaluate(plan, geom, angle + 0.1, 2, work)
    tracemalloc.start()
    s = evaluate(plan, geom, angle, 2, work)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert all(np.shares_memory(a, work.orders) for a in (s.z, s.dz, s.ddz)) and s.ds is work.ds
    assert peak < 12 * T * 16  # a dyad batch alone is 12 × 2 × T complex
    for a, b in ((s.z, fresh.z), (s.dz, fresh.dz), (s.ddz, fresh.ddz), (s.ds, fresh.ds)):
        assert np.array_equal(a, b)


def test_linkage_axis_evaluates_derivatives_of_each_linkage():
    """A geometry of K linkages gives each linkage's own positions, derivatives and d_s."""
    from linkedit.planar.kinematics import evaluate
    from linkedit.planar.plan import Geometry

    plan = compile_plan(spec_of(JANSEN))
    rest = plan.normalized_points()
    rng = np.random.default_rng(3)
    many = rest[None] + 0.01 * rng.normal(size=(3, *rest.shape))
    geom = Geometry.of(plan, many)
    angle = geom.rest_angle + np.linspace(0.0, 2 * np.pi, 40, endpoint=False)  # (K, T)
    s = evaluate(plan, geom, angle, order=2)
    for k in range(3):
        one = evaluate(plan, Geometry.of(plan, many[k]), angle[k], order=2)
        for a, b in ((s.z, one.z), (s.dz, one.dz), (s.ddz, one.ddz), (s.ds, one.ds)):
            assert np.allclose(a[:, k], b, rtol=0, atol=1e-12 * np.abs(b).max(), equal_nan=True)


def parallelogram(rest_deg: float) -> LinkageSpec:
    """Crank 20, coupler 50, rocker 20, frame 50 (a parallelogram four-bar), the crank at ``rest_deg``:
    all four joints are collinear at crank angles 0° and 180° (change points: the dyad at B touches
    its toggle, d_s = 0, and every other angle assembles)."""
    c, s = 20 * np.cos(np.radians(rest_deg)), 20 * np.sin(np.radians(rest_deg))
    return LinkageSpec.model_validate({
        "name": "parallelogram", "units": "mm", "joints": {"O": [0, 0], "D": [50, 0], "A": [c, s], "B": [50 + c, s]},
        "ground": ["O", "D"], "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        "motor": {"joint": "A", "pivot": "O"}})


@pytest.mark.parametrize("samples", [36, 360, 1440])
def test_a_toggle_passed_between_samples_is_reported_as_one_at_a_sample(samples):
    """A change point between the samples (crank at 0.3° + k·360°/T, the toggles at 180° and 360°):
    exit 1 as when a sample falls on it. It was passed silently: B kept its triangle's side, so the
    parallelogram became an anti-parallelogram after 180° (B 40 mm off A + (50, 0), its velocity
    jumping from (−0.2, −20) to (0, 8.6) mm/rad), exit 0."""
    with pytest.raises(MechanismError, match="joint B reaches a toggle position") as info:
        simulate(parallelogram(0.3), samples)
    where = [float(a) for a in re.findall(r"motor angles ([\d.]+)°", str(info.value))]
    assert sorted(where) == pytest.approx([0.0, 180.0], abs=0.3), str(info.value)  # 360° is written 0°
    m = simulate(parallelogram(0.3), samples, partial=True)
    assert len(m.lockups) == 2 and m.assembled.all()


def test_a_linkage_that_only_comes_near_a_change_point_works():
    """The parallelogram with B 0.05 mm higher (coupler 50.000025, rocker 20.05: not a change point,
    shortest + longest 70.000025 < 70.05): B comes within 0.25° of its toggle (d_s ≈ 1.9e-5) and
    back on its own branch; not a toggle."""
    data = parallelogram(0.3).model_dump()
    data["joints"]["B"] = (data["joints"]["B"][0], data["joints"]["B"][1] + 0.05)
    m = simulate(LinkageSpec.model_validate(data), 1440)
    assert not m.lockups and m.assembled.all()
    assert 1e-5 < np.nanmin(m.singularity) < 3e-5
