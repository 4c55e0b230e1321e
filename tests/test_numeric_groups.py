"""Numeric groups (complex loops) against an independent continuation written here: the rest
pose's branch followed sample by sample in small steps, with every link length as a row."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.planar import catalog, simulate
from linkedit.planar.kinematics import evaluate
from linkedit.planar.plan import Geometry, compile_plan
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES
from tests.planar_specs import TRIAD


def rest_branch(spec: LinkageSpec, angles: np.ndarray, step_deg: float = 0.5) -> tuple[list[str], np.ndarray, int]:
    """The joints of a crank-driven group (every moving joint but the motor's), (T, n) complex at
    motor turns ``angles`` (T,) radians from rest, monotonic (either sense), continued from the rest pose by
    Newton's method on |z_a − z_b|² − L² (every pair of every link) in steps of at most
    ``step_deg``; and the first sample the rest branch cannot reach (a fold: Newton lands more
    than 1 % of the size away or det J changes sign), or −1."""
    j = {k: complex(*v) for k, v in spec.joints.items()}
    motor, pivot = spec.motor.joint, spec.motor.pivot
    unknown = [k for k in spec.joints if k not in spec.ground and k != motor]
    pairs = sorted({tuple(sorted((a, b))) for link in spec.links.values() for i, a in enumerate(link)
                    for b in link[i + 1:] if a in unknown or b in unknown})
    a_, b_ = (np.array([p[i] for p in pairs]) for i in (0, 1))
    length2 = np.array([abs(j[a] - j[b]) ** 2 for a, b in pairs])
    incidence = np.array([[(a == k) - (b == k) for k in unknown] for a, b in pairs], dtype=float)  # (rows, n)
    names = list(spec.joints)
    rest = np.array([j[k] for k in names])
    ia, ib = (np.array([names.index(k) for k in v]) for v in (a_, b_))
    own, m, p = np.array([names.index(k) for k in unknown]), names.index(motor), names.index(pivot)

    def newton(x: np.ndarray, theta: float) -> tuple[np.ndarray, float]:
        z = rest.copy()
        z[m] = rest[p] + (rest[m] - rest[p]) * np.exp(1j * theta)
        for _ in range(30):
            z[own] = x[0::2] + 1j * x[1::2]
            d = z[ia] - z[ib]
            jac = np.empty((len(pairs), x.size))
            jac[:, 0::2], jac[:, 1::2] = 2 * incidence * d.real[:, None], 2 * incidence * d.imag[:, None]
            dx = np.linalg.solve(jac, length2 - np.abs(d) ** 2)
            x = x + dx
            if np.abs(dx).max() < 1e-15 * np.abs(x).max():
                break
        return x, float(np.linalg.det(jac))

    size = size_of(spec)
    x, det0 = newton(np.array([c for k in unknown for c in (j[k].real, j[k].imag)]), 0.0)
    out = np.full((angles.size, len(unknown)), np.nan, dtype=complex)
    theta = 0.0
    for n, target in enumerate(angles):
        parts = max(1, int(np.ceil(abs(np.degrees(target - theta)) / step_deg)))
        for sub in np.linspace(theta, target, parts + 1)[1:]:
            y, det = newton(x.copy(), sub)
            if not np.isfinite(y).all() or np.sign(det) != np.sign(det0) or np.abs(y - x).max() > 0.01 * size:
                return unknown, out, n
            x = y
        theta = target
        out[n] = x[0::2] + 1j * x[1::2]
    return unknown, out, -1


def size_of(spec: LinkageSpec) -> float:
    """The rest pose's diameter (the tolerances' unit)."""
    z = np.array([complex(*p) for p in spec.joints.values()])
    return float(np.abs(z[:, None] - z[None, :]).max())


def link_lengths_kept(spec: LinkageSpec, names: list[str], z: np.ndarray) -> float:
    """Largest change of any link's pair distance over samples (T, J) complex, joints ``names``."""
    worst = 0.0
    for link in spec.links.values():
        for i, a in enumerate(link):
            for b in link[i + 1:]:
                rest = abs(complex(*spec.joints[a]) - complex(*spec.joints[b]))
                worst = max(worst, float(np.abs(np.abs(z[:, names.index(a)] - z[:, names.index(b)]) - rest).max()))
    return worst


def test_the_complex_loop_example_stays_on_its_rest_branch_at_every_sample(run_cli, tmp_path):
    """``simulate`` of the example writes the independent continuation's positions (to 1e-12 of
    its size) and keeps every link's length (to 1e-9 of its size) at each of its 360 samples."""
    spec = load_model(LinkageSpec, EXAMPLES / "complex-loop.yaml")
    out = tmp_path / "loop.h5"
    assert run_cli("simulate", EXAMPLES / "complex-loop.yaml", "-o", out).exit_code == 0
    with h5py.File(out) as f:
        names = [n.decode() for n in f["joint"][()]]
        xy, angle = f["joints/position"][()], f["motor_angle"][()]
    z = xy[..., 0] + 1j * xy[..., 1]
    group, ref, fold = rest_branch(spec, angle - angle[0])
    assert fold == -1
    size = size_of(spec)
    assert np.abs(z[:, [names.index(k) for k in group]] - ref).max() <= 1e-12 * size
    assert link_lengths_kept(spec, names, z) <= 1e-9 * size


@pytest.mark.parametrize("samples", [360, 97, 90])
def test_a_group_that_locks_up_inside_the_cycle_is_assembled_on_both_sides_of_the_lock(samples):
    """The triad folds between two samples turning forward from rest, and again turning backward
    (the cycle's last samples are the ones before its first): every sample the independent
    continuation reaches either way is on the rest branch, the samples between the two folds are
    the group's one lock-up, its motor angles the assembled samples either side. (It used to
    report every sample from the first fold to the cycle's end as locked: `--partial` wrote NaN
    where the linkage assembles, and the interval ended at 0°.)"""
    spec = load_model(LinkageSpec, "triad.yaml", TRIAD)
    m = simulate(spec, samples, partial=True)
    names = m.plan.joint_names
    turn = m.motor_angle - m.motor_angle[0]
    group, ref, fold = rest_branch(spec, turn, step_deg=0.125)
    _, back, stop = rest_branch(spec, turn[:0:-1] - 2 * np.pi, step_deg=0.125)  # samples T-1, T-2, … turning back
    assert 0 < fold < samples and 0 < stop < samples - fold
    free = samples - stop  # the first sample of the cycle's end that the backward turn reaches
    assert m.assembled[:fold].all() and not m.assembled[fold:free].any() and m.assembled[free:].all()
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    cols = [names.index(k) for k in group]
    assert np.abs(z[:fold][:, cols] - ref[:fold]).max() <= 1e-12 * size_of(spec)
    assert np.abs(z[free:][::-1][:, cols] - back[:stop]).max() <= 1e-12 * size_of(spec)
    assert link_lengths_kept(spec, names, z[m.assembled]) <= 1e-9 * size_of(spec)
    (lock,) = m.lockups
    # each fold lies between an assembled sample and a failing one: the interval reported holds
    # both (a group's continuation cannot restart between the samples to find them)
    first, last = (np.degrees(m.motor_angle[k]) % 360 for k in (fold - 1, free))
    assert f"motor angles within {first:.1f}°…{last:.1f}° (the assembled" in lock.describe()
    assert lock.run == (fold, free - 1) and not lock.exact
    assert "the numeric group T1, T2, T3 cannot be assembled on its rest-pose branch" in lock.describe()


def test_the_rest_branch_is_kept_at_any_sampling():
    """Coarse and fine samplings of the example land on the same positions (one branch)."""
    spec = catalog.complex_loop()
    group, ref, fold = rest_branch(spec, np.radians(np.arange(720) / 2))
    assert fold == -1
    for samples in (8, 24, 720):
        m = simulate(spec, samples)
        z = m.positions[..., 0] + 1j * m.positions[..., 1]
        assert np.abs(z[:, [m.plan.joint_names.index(k) for k in group]] - ref[:: 720 // samples]).max() <= 1e-12 * size_of(spec)


def in_metres(spec: LinkageSpec) -> LinkageSpec:
    """The same linkage with every joint divided by 1000 and its unit m."""
    d = spec.model_dump()
    d["units"], d["joints"] = "m", {k: [x / 1000, y / 1000] for k, (x, y) in d["joints"].items()}
    return LinkageSpec.model_validate(d)


@pytest.mark.parametrize("metres", [False, True])
def test_complex_loop_derivatives_are_those_of_the_rest_branch(metres):
    """At mm and m scales, every sample of the complex loop keeps each link's length (to 1e-12
    of its size), and its velocities and accelerations (d/dθ, d²/dθ² of the motor angle) are the
    central differences of the independent continuation at θ ± h."""
    spec = catalog.complex_loop()
    spec = in_metres(spec) if metres else spec
    m = simulate(spec, 36)
    size, names = size_of(spec), m.plan.joint_names
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    assert link_lengths_kept(spec, names, z) <= 1e-12 * size
    h = 1e-3
    theta = m.motor_angle - m.motor_angle[0]
    group, ref, fold = rest_branch(spec, (theta[:, None] + np.array([-h, 0.0, h])).ravel())
    assert fold == -1
    ref = ref.reshape(theta.size, 3, -1)
    cols = [names.index(k) for k in group]
    v, a = (q[:, cols, 0] + 1j * q[:, cols, 1] for q in (m.velocity, m.acceleration))
    assert np.abs(v - (ref[:, 2] - ref[:, 0]) / (2 * h)).max() <= 1e-6 * size
    assert np.abs(a - (ref[:, 2] - 2 * ref[:, 1] + ref[:, 0]) / h**2).max() <= 1e-6 * size


def test_a_groups_singularity_distance_is_the_hadamard_ratio_of_its_rows():
    """The complex loop's d_s at every sample is (det J / ∏ ‖row‖)² of its constraint rows' J
    built here at ``simulate``'s positions — |z_a − z_b|² of each binary link and of the body's
    frame pair T1, T2; Re and Im of z_T3 − z_T1 − c·(z_T2 − z_T1), c from the rest pose, placing
    its third joint (:mod:`linkedit.planar.constraints`) — the dyad's sin² of the angle between
    its two rows generalized: within (0, 1]."""
    spec = catalog.complex_loop()
    m = simulate(spec, 72)
    names = m.plan.joint_names
    z = m.positions[..., 0] + 1j * m.positions[..., 1]  # (T, J)
    at = {k: z[:, names.index(k)] for k in spec.joints}
    rest = {k: complex(*p) for k, p in spec.joints.items()}
    c = (rest["T3"] - rest["T1"]) / (rest["T2"] - rest["T1"])
    one = np.ones(z.shape[0])
    # per row: joint → w (T,) with d(row) = Re(w·dz), dz = dx + i·dy: w.real·dx − w.imag·dy
    rows = [{a: 2 * np.conj(at[a] - at[b]), b: 2 * np.conj(at[b] - at[a])}
            for a, b in [("P1", "T1"), ("P2", "T2"), ("A", "T3"), ("T1", "T2")]]
    rigid = {"T3": one, "T1": -(1 - c) * one, "T2": -c * one}
    rows += [rigid, {k: -1j * w for k, w in rigid.items()}]  # Re and Im (Im q = Re(−i·q))
    group = ["T1", "T2", "T3"]
    jac = np.zeros((z.shape[0], len(rows), 2 * len(group)))
    for r, row in enumerate(rows):
        for k, w in row.items():
            if k in group:
                n = 2 * group.index(k)
                jac[:, r, n], jac[:, r, n + 1] = w.real, -w.imag
    want = (np.linalg.det(jac) / np.linalg.norm(jac, axis=2).prod(axis=1)) ** 2
    (ds,) = m.step_singularity.T
    assert np.abs(ds - want).max() <= 1e-12
    assert 0.0 < ds.min() and ds.max() <= 1.0


def perturbed(spec: LinkageSpec, rng: np.random.Generator, spread: float, **moved: tuple[float, float]) -> LinkageSpec:
    """``spec`` with every moving joint shifted by N(0, (spread·size)²) per coordinate (ground
    joints kept), and the joints ``moved`` put where given."""
    d = spec.model_dump()
    size = size_of(spec)
    d["joints"] = {k: (list(moved[k]) if k in moved else [x, y] if k in spec.ground else
                       [x + spread * size * rng.normal(), y + spread * size * rng.normal()])
                   for k, (x, y) in d["joints"].items()}
    return LinkageSpec.model_validate(d)


@pytest.mark.parametrize("example", ["complex-loop", "lifting-arm"])
def test_k_linkages_through_a_group_in_one_evaluation_are_each_linkage_alone(example):
    """K perturbations of the example, each at its own rest pose (own link lengths, own rest
    angle), evaluated in one call with a linkage axis, give every linkage's positions,
    velocities, accelerations and d_s of its evaluation alone (to 1e-12); the batch's group
    joints are the independent continuation's (rest_branch) of each perturbed spec. One linkage
    that cannot assemble the whole cycle (a longer crank: it folds at 37.5°; for the lifting arm driven over twice
    its stroke, a boom pivoted nearer its rod end) is NaN from its fold on, alone (the crank's up to
    its fold turning back from rest: the cycle's last samples), the others whole."""
    spec = load_model(LinkageSpec, EXAMPLES / f"{example}.yaml")
    plan = compile_plan(spec)
    rng = np.random.default_rng(7)
    specs = [perturbed(spec, rng, 0.01) for _ in range(4)]
    # one the group cannot follow through the cycle: a longer crank; a boom pivoted nearer its cylinder's rod end
    specs.append(perturbed(spec, rng, 0.0, **({"A": (18.5, 0.0)} if example == "complex-loop" else {"R": (20.0, 0.0)})))
    names = plan.joint_names
    points = np.stack([plan.normalized_points(plan.points_for(np.array([s.joints[n] for n in names], dtype=float)))
                       for s in specs])
    K, T = len(specs), 48
    geom = Geometry.of(plan, points)
    turn = np.linspace(0.0, 2.0 * np.pi, T, endpoint=False)
    if plan.linear:
        turn = np.linspace(0.0, 2.0 * spec.motor.stroke[1] / plan.scale, T)  # twice the stroke
    both = evaluate(plan, geom, turn if plan.linear else geom.rest_angle + turn, order=2)
    assert both.z.shape == (plan.n_points, K, T)
    folds = 0
    for k in range(K):
        one = Geometry.of(plan, points[k])
        alone = evaluate(plan, one, turn if plan.linear else one.rest_angle + turn, order=2)
        for a in ("z", "dz", "ddz", "ds"):
            mine, ref = getattr(both, a)[:, k], getattr(alone, a)
            assert np.array_equal(np.isnan(mine), np.isnan(ref))
            assert np.nanmax(np.abs(mine - ref)) <= 1e-12 * max(1.0, np.nanmax(np.abs(ref)))
        placed = np.isfinite(both.z[:, k]).all(axis=0)
        folds += not placed.all()
        if not plan.linear and k in (0, K - 1):  # the independent continuation of the perturbed spec, in its units
            group, ref, fold = rest_branch(specs[k], turn)
            _, back, stop = rest_branch(specs[k], turn[:0:-1] - 2.0 * np.pi)  # turning back from rest
            free = T if fold < 0 else T - stop  # the cycle's end is the turn back's start
            assert np.array_equal(placed, (np.arange(T) < (fold if fold >= 0 else T)) | (np.arange(T) >= free))
            ref[free:] = back[:T - free][::-1]
            z = both.z[plan.row_of[[names.index(g) for g in group]], k].T * plan.scale + plan.origin
            assert np.abs(z[placed] - ref[placed]).max() <= 1e-12 * size_of(specs[k])
    assert folds == 1


def test_a_triad_is_traced_in_its_bodys_pose_through_its_fold_too(monkeypatch):
    """The complex loop's group is a triad (a body hung from three known joints): every sample is
    solved as the body's pose (3 unknowns, :mod:`linkedit.planar.rules.triad`) without the general
    group solver — a triad that folds inside the cycle too, continued sample by sample up to its
    fold and reporting its lock-up there (the test above checks where)."""
    import linkedit.planar.rules.group as group

    calls = []
    general = group.solve_group
    monkeypatch.setattr(group, "solve_group", lambda *a: calls.append(a[3].shape) or general(*a))
    m = simulate(catalog.complex_loop(), 360)
    assert m.assembled.all()
    m = simulate(load_model(LinkageSpec, "triad.yaml", TRIAD), 90, partial=True)
    assert not m.assembled.all() and m.assembled[0] and not calls


def test_a_dyad_beside_a_group_passing_a_change_point_between_samples_is_a_toggle():
    """The complex-loop six-bar with a parallelogram on its crank (E = A + G − O, G on the frame 60 mm
    from O at −0.3°): E's dyad passes its change points at crank angles 179.7° and 359.7°, between
    the 360 samples, and every sample assembles. It was exit 0 (the group's own continuation had
    checked its samples between, so the closed-form rules were not checked there: E kept its side
    and the parallelogram became an anti-parallelogram); it is reported as at 1440 samples."""
    d = load_model(LinkageSpec, EXAMPLES / "complex-loop.yaml").model_dump()
    g = 60.0 * np.exp(np.radians(-0.3) * 1j)
    d["joints"] |= {"G": [g.real, g.imag], "E": [8.0 + g.real, g.imag]}
    d["ground"] = [*d["ground"], "G"]
    d["links"] |= {"coupler2": ["A", "E"], "rocker2": ["G", "E"]}
    spec = LinkageSpec.model_validate(d)
    for samples in (360, 1440):
        with pytest.raises(MechanismError, match="joint E reaches a toggle position") as info:
            simulate(spec, samples)
        assert str(info.value).count("change point") == 2
        assert "179.7°" in str(info.value) and "359.7°" in str(info.value)


def test_one_sample_of_a_group_that_locks_up_inside_the_cycle_is_refused(run_cli, tmp_path):
    """``-n 1`` samples only the rest pose, where the triad assembles: the cycle is still checked
    between (as at more samples), so its lock-up is one line naming the group, exit 1, and nothing
    is written (it used to exit 0: a group's continuation checks between samples, none with one)."""
    path = tmp_path / "triad.yaml"
    path.write_text(TRIAD)
    out = tmp_path / "t.h5"
    r = run_cli("simulate", path, "-n", "1", "-o", out)
    assert r.exit_code == 1 and "Traceback" not in r.output, r.output
    assert "the numeric group T1, T2, T3 cannot be assembled" in r.output and "between the requested samples" in r.output
    assert not out.exists()
