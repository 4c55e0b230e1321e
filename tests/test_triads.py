"""Triads (a body hung by three binary links from known joints, solved as its body's pose:
:mod:`linkedit.planar.rules.triad`) of other shapes than the complex-loop example's, against the
independent continuation :func:`tests.test_numeric_groups.rest_branch`, a Hadamard ratio built
here and, through folds and near-singular rest poses, the general group solver."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.planar import compile_plan, simulate
from linkedit.planar.catalog.geometry import linkage
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.planar_specs import TRIAD
from tests.test_numeric_groups import link_lengths_kept, rest_branch, size_of

#: the complex-loop example's joints, mm
LOOP = {"O": 0j, "A": 8 + 0j, "P1": -30 + 0j, "P2": 45 + 5j, "T1": -34 + 20j, "T2": 27 + 26j, "T3": 14 + 24j}
LINKS = {"crank": ["O", "A"], "l1": ["P1", "T1"], "l2": ["P2", "T2"], "l3": ["A", "T3"], "body": ["T1", "T2", "T3"]}


def triad(joints: dict[str, complex], links: dict[str, list[str]], ground: list[str] | None = None,
          units: str = "mm", tracks: dict | None = None, **motor: object) -> LinkageSpec:
    """A crank (O, A)-driven linkage of ``joints`` (those on ``links``) and ``links``."""
    used = {j for link in links.values() for j in link}
    return linkage({k: z for k, z in joints.items() if k in used}, name="triad", units=units,
                   ground=ground or [g for g in ("O", "P1", "P2", "Q") if g in used], links=links,
                   motor={"joint": "A", "pivot": "O", **motor}, **({"tracks": tracks} if tracks else {}))


def across(size: float, units: str) -> LinkageSpec:
    """The example's triad scaled to ``size`` across, in ``units``."""
    k = size / size_of(triad(LOOP, LINKS))
    return triad({n: k * z for n, z in LOOP.items()}, LINKS, units=units)


SHAPES = {
    "clockwise": triad(LOOP, LINKS, direction="cw"),
    "a body of three binary links": triad(LOOP, {**{k: v for k, v in LINKS.items() if k != "body"},
                                                 "b12": ["T1", "T2"], "b23": ["T2", "T3"], "b13": ["T1", "T3"]}),
    "two links from one pivot": triad({**LOOP, "T3": -10 + 30j}, {**LINKS, "l2": ["P1", "T2"]}),
    "a fourth tracked point on the body, listed first": triad(
        {**LOOP, "T4": -5 + 40j}, {**LINKS, "body": ["T4", "T1", "T2", "T3"]}, tracks={"tip": {"joint": "T4"}}),
    "hung from a dyad's joint, the crank pin and the ground": triad(
        {**LOOP, "Q": 25 - 5j, "B": 5 - 20j},
        {**LINKS, "rod": ["A", "B"], "rocker": ["Q", "B"], "l1": ["A", "T1"], "l3": ["B", "T3"]}),
    "1e-3 m across": across(1e-3, "m"),
    "1e3 mm across": across(1e3, "mm"),
}


def general_solver(monkeypatch: pytest.MonkeyPatch) -> None:
    """Compile every group without its triad (the general group solver solves it)."""
    from linkedit.planar.rules.triad import Triad

    monkeypatch.setattr(Triad, "of", classmethod(lambda cls, *a: None))


def count_general_calls(monkeypatch: pytest.MonkeyPatch) -> list:
    """The calls of the general group solver from now on."""
    import linkedit.planar.rules.group as group

    calls: list = []
    general = group.solve_group
    monkeypatch.setattr(group, "solve_group", lambda *a: calls.append(a[3].shape) or general(*a))
    return calls


def reference(spec: LinkageSpec, angles: np.ndarray) -> tuple[list[str], np.ndarray]:
    """:func:`rest_branch` of ``spec``'s moving joints at ``angles`` (T,), (T, n) complex: a fourth
    body point T4 placed from T1, T2 as at rest (the continuation's rows are one per pair)."""
    if "T4" not in spec.joints:
        group, ref, fold = rest_branch(spec, angles)
        assert fold == -1
        return group, ref
    links = {k: [j for j in v if j != "T4"] for k, v in spec.links.items()}
    group, ref = reference(triad({k: complex(*v) for k, v in spec.joints.items()}, links), angles)
    z = {k: complex(*v) for k, v in spec.joints.items()}
    c = (z["T4"] - z["T1"]) / (z["T2"] - z["T1"])
    t1, t2 = ref[:, group.index("T1")], ref[:, group.index("T2")]
    return [*group, "T4"], np.column_stack([ref, t1 + c * (t2 - t1)])


@pytest.mark.parametrize("shape", SHAPES)
def test_a_triad_of_another_shape_is_its_bodys_pose_on_the_rest_branch(monkeypatch, shape):
    """Every shape is solved as a triad, without the general solver, at every one of 36 samples:
    positions of the independent continuation (to 1e-12 of the size), every link's length kept
    (to 1e-9), velocities and accelerations (d/dθ of the motor angle, whichever its sense) its
    central differences at θ ± h (to 1e-6 of the size), d_s in
    (0, 1] and the general solver's (to 1e-12)."""
    spec = SHAPES[shape]
    calls = count_general_calls(monkeypatch)
    plan = compile_plan(spec)
    assert [s.triad is not None for s in plan.steps if s.kind == "group"] == [True]
    m = simulate(plan, 36)
    assert m.assembled.all() and not calls
    size, names = size_of(spec), m.plan.joint_names
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    assert link_lengths_kept(spec, names, z) <= 1e-9 * size
    h = 1e-3
    theta = m.motor_angle - m.motor_angle[0]
    assert np.all(np.diff(theta) < 0) if shape == "clockwise" else np.all(np.diff(theta) > 0)
    sense = np.sign(theta[1])  # the continuation's angles in the motor's sense
    group, ref = reference(spec, (theta[:, None] + sense * np.array([-h, 0.0, h])).ravel())
    ref = ref.reshape(theta.size, 3, -1)
    cols = [names.index(k) for k in group]
    assert np.abs(z[:, cols] - ref[:, 1]).max() <= 1e-12 * size
    v, a = (q[:, cols, 0] + 1j * q[:, cols, 1] for q in (m.velocity, m.acceleration))
    assert np.abs(v - (ref[:, 2] - ref[:, 0]) / (2 * sense * h)).max() <= 1e-6 * size
    assert np.abs(a - (ref[:, 2] - 2 * ref[:, 1] + ref[:, 0]) / h**2).max() <= 1e-6 * size
    ds = m.step_singularity
    assert 0.0 < ds.min() and ds.max() <= 1.0
    general_solver(monkeypatch)
    g = simulate(spec, 36)
    assert np.abs(g.step_singularity - ds).max() <= 1e-12


def test_a_body_of_three_binary_links_has_the_hadamard_ratio_of_its_six_distances():
    """The truss body's d_s is (det J / ∏ ‖row‖)² of its six distance rows |z_a − z_b|² (the three
    links it hangs by, its three sides) built here at ``simulate``'s positions."""
    spec = SHAPES["a body of three binary links"]
    m = simulate(spec, 72)
    names = m.plan.joint_names
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    at = {k: z[:, names.index(k)] for k in spec.joints}
    group = ["T1", "T2", "T3"]
    jac = np.zeros((z.shape[0], 6, 6))
    for r, (a, b) in enumerate(spec.links[k] for k in ("l1", "l2", "l3", "b12", "b23", "b13")):
        for j, w in ((a, at[a] - at[b]), (b, at[b] - at[a])):  # ∂|z_a − z_b|²/∂(x_j, y_j) / 2
            if j in group:
                n = 2 * group.index(j)
                jac[:, r, n], jac[:, r, n + 1] = w.real, w.imag
    want = (np.linalg.det(jac) / np.linalg.norm(jac, axis=2).prod(axis=1)) ** 2
    assert np.abs(m.step_singularity[:, 0] - want).max() <= 1e-12


def _near_singular(delta: float, **motor: object) -> LinkageSpec:
    """The example with P2 moved so that the line P2–T2 misses by ``delta`` radians the point
    where the lines P1–T1 and A–T3 meet (all three meeting: d_s = 0) at rest."""
    d1, d2 = LOOP["T1"] - LOOP["P1"], LOOP["T3"] - LOOP["A"]
    meet = LOOP["P1"] + d1 * ((LOOP["A"] - LOOP["P1"]).conjugate() * d2).imag / (d1.conjugate() * d2).imag
    way = (LOOP["T2"] - meet) / abs(LOOP["T2"] - meet)
    return triad({**LOOP, "P2": LOOP["T2"] + abs(LOOP["P2"] - LOOP["T2"]) * np.exp(1j * delta) * way}, LINKS, **motor)


#: name → (spec, samples, d_s at rest within (lo, hi) or None, whether it locks up, whether the
#: triad's fast path is checked to follow it (near the singular rest: its own d_s, velocities,
#: accelerations are compared; elsewhere a linkage it cannot follow goes to the general solver))
HARD = {
    "folding inside the cycle": (load_model(LinkageSpec, "triad.yaml", TRIAD), 90, None, True),
    "two links from one pivot, folding": (triad(LOOP, {**LINKS, "l2": ["P1", "T2"]}), 90, None, True),
    "a near-singular rest, folding later": (_near_singular(3e-3), 90, (1e-7, 1e-5), True),
    "a near-singular rest, folding at once": (_near_singular(3e-3, direction="cw"), 90, (1e-7, 1e-5), True),
    "a near-singular rest, away from the fold": (_near_singular(3e-3, range_deg=[0, 120]), 7, (1e-7, 1e-5),
                                                 False),
    "a near-singular rest, the line on its other side": (_near_singular(-3e-3, range_deg=[0, 120]), 90, (1e-7, 1e-5),
                                                          False),
}


@pytest.mark.parametrize("name", HARD)
def test_a_triad_through_a_fold_or_near_singular_is_what_the_general_solver_gives(monkeypatch, name):
    """Traced in the triad's body's pose (never by the general solver: through the fold too, sample
    by sample), ``simulate`` gives the general solver's result: the same assembled samples and lock-up message, positions
    (to 1e-12 of the size), d_s (to 1e-12), velocities and accelerations (to 1e-9 of their
    largest: ~1e3 and ~1e8 mm/rad² near the singular rest)."""
    spec, samples, rest_ds, locks = HARD[name]
    calls = count_general_calls(monkeypatch)
    m = simulate(spec, samples, partial=True)
    assert not calls
    general_solver(monkeypatch)
    g = simulate(spec, samples, partial=True)
    assert np.array_equal(m.assembled, g.assembled) and m.assembled[0]
    assert (not m.assembled.all()) is locks
    assert [lk.describe() for lk in m.lockups] == [lk.describe() for lk in g.lockups]
    if rest_ds is not None:
        assert rest_ds[0] < m.step_singularity[0, 0] < rest_ds[1]
    ok = m.assembled
    assert np.isnan(m.positions[~ok]).all()
    assert np.abs(m.positions[ok] - g.positions[ok]).max() <= 1e-12 * size_of(spec)
    assert np.abs(m.step_singularity[ok] - g.step_singularity[ok]).max() <= 1e-12
    for q in ("velocity", "acceleration"):
        mine, ref = getattr(m, q)[ok], getattr(g, q)[ok]
        assert np.abs(mine - ref).max() <= 1e-9 * np.abs(ref).max()


def test_a_prediction_on_the_other_assembly_branch_is_rejected_by_the_determinants_sign(monkeypatch):
    """A sample whose prediction is exactly a solution of another assembly of the triad (found here
    by Newton's method from turned starting poses, det M of the other sign: the body flipped through
    a singular position) converges at once and close to its prediction, so only the sign of det M
    tells it from the rest pose's branch: the polish rejects it and the sample is continued from the
    one before, and ``simulate`` gives the unspoiled positions."""
    from linkedit.planar.rules import triad as tr

    spec = triad(LOOP, LINKS)
    good = simulate(spec, 72)
    polish, at, spoiled, rejected = tr.polish, 30, [], []

    def other_branch(body, hung, centre, turn):  # a solution at sample ``at`` with det M of the other sign
        p, r2, sign, reach = body.linkage(0)
        here = [complex(v) for v in hung[:, 0, at]]
        for spin in np.linspace(-np.pi, np.pi, 48, endpoint=False):
            for shift in (0, 0.3, -0.3, 0.3j, -0.3j):
                ok, _, det, g, th = tr.newton(p, r2, reach, here, complex(centre[0, at]) + shift,
                                              float(turn[0, at]) + spin, 1e-15)
                if ok and det * sign < 0:
                    return g, th
        raise AssertionError("no other assembly found")

    def spoil(body, hung, centre, turn, tol):
        if not spoiled:
            g, th = other_branch(body, hung, centre, turn)
            centre, turn = centre.copy(), turn.copy()
            centre[0, at], turn[0, at] = g, th
            spoiled.append(at)
        now, turns, ok = polish(body, hung, centre, turn, tol)
        rejected.append(np.flatnonzero(~ok[0]).tolist())
        return now, turns, ok

    monkeypatch.setattr(tr, "polish", spoil)
    m = simulate(spec, 72)
    assert spoiled and rejected[0] == [at]
    assert np.abs(m.positions - good.positions).max() <= 1e-12 * size_of(spec)


def test_inputs_that_stop_at_the_end_are_predicted_not_divided_by_zero(monkeypatch):
    """A motion whose last samples repeat a node of the sequential pass (the inputs stop there): the
    last sample's travel equals that node's, so it is that node again, not a second node at the same
    travel (a zero divided difference made every prediction NaN, and each sample was continued one
    by one). Every sample is accepted from its prediction, and the repeated samples are the sample
    they repeat."""
    from linkedit.planar.kinematics import evaluate
    from linkedit.planar.plan import Geometry
    from linkedit.planar.rules import continuation, triad as tr

    plan = compile_plan(triad(LOOP, LINKS))
    geom = Geometry.of(plan, plan.normalized_points())
    coarse, nodes = continuation.coarse, []
    monkeypatch.setattr(continuation, "coarse", lambda *a: nodes.append(coarse(*a)[0]) or coarse(*a))
    angle = geom.rest_angle + np.radians(np.arange(120.0))
    evaluate(plan, geom, angle, order=0)
    node = int(nodes[0][3])  # a node inside the motion: fine sample `node` is angle[node - 1] (the rest comes first)
    assert 0 < node < 100
    angle = np.r_[angle[:node], angle[node - 1], angle[node - 1]]
    polish, rejected = tr.polish, []

    def counted(*args):
        now, turns, ok = polish(*args)
        rejected.append(int((~ok).sum()))
        return now, turns, ok

    monkeypatch.setattr(tr, "polish", counted)
    z = evaluate(plan, geom, angle, order=2).z
    assert rejected == [0]
    assert np.isfinite(z).all() and np.array_equal(z[:, -1], z[:, -3]) and np.array_equal(z[:, -2], z[:, -3])


@pytest.mark.parametrize("samples", [37, 360, 1000])
def test_the_example_is_polished_in_two_newton_steps_from_its_prediction(monkeypatch, samples):
    """The samples between the sequential nodes start from the quintic through the six nearest
    (half strides at the ends): the complex loop's worst predicted row is 1.2e-4, from which two
    Newton steps reach GROUP_TOLERANCE (three poses: the prediction's and one per step; the cubic
    through four, whole strides, needed three steps). Every sample is accepted, the lengths held."""
    from linkedit.planar.rules import triad as tr

    spec = load_model(LinkageSpec, "examples/complex-loop.yaml")
    pose, calls = tr.pose, []
    polish = tr.polish

    def counted(*args):
        calls.append(0)
        out = polish(*args)
        calls.append(int(out[2].all()))
        return out

    def posed(*args):
        if calls:
            calls[-1] += 1
        return pose(*args)

    monkeypatch.setattr(tr, "polish", counted)
    monkeypatch.setattr(tr, "pose", posed)
    m = simulate(spec, samples)
    assert calls == [3, 1]  # three poses in the one polish, every sample accepted
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    assert link_lengths_kept(spec, m.plan.joint_names, z) <= 1e-9 * size_of(spec)


def test_samples_the_batch_steps_leave_off_go_on_alone_to_the_same_poses(monkeypatch):
    """Three predictions spoiled by 0.02 of the size (their rows ≈ 1e-2, two Newton steps leave them
    off): after the BATCH_STEPS steps of every sample, only those three go on, alone, and every
    sample is accepted, each at the unspoiled run's pose (1e-12 of the size), the lengths held."""
    from linkedit.planar.rules import triad as tr

    spec = triad(LOOP, LINKS)
    good = simulate(spec, 72)
    polish, steps, alone = tr.polish, tr._steps, []

    def spoiled(body, hung, centre, turn, tol):
        centre = centre.copy()
        centre[0, [10, 30, 50]] += 0.02 * np.exp(1j * np.array([0.3, 2.0, 4.0]))
        now, turns, ok = polish(body, hung, centre, turn, tol)
        assert ok.all()
        return now, turns, ok

    def counted(body, hung, centre, turn, tol, count):
        alone.append(centre.size if count > tr.BATCH_STEPS else None)
        return steps(body, hung, centre, turn, tol, count)

    monkeypatch.setattr(tr, "polish", spoiled)
    monkeypatch.setattr(tr, "_steps", counted)
    m = simulate(spec, 72)
    assert alone == [None, 3]
    assert np.abs(m.positions - good.positions).max() <= 1e-12 * size_of(spec)
    z = m.positions[..., 0] + 1j * m.positions[..., 1]
    assert link_lengths_kept(spec, m.plan.joint_names, z) <= 1e-9 * size_of(spec)


#: the example's triad hung from B, placed by a dyad (rod A–B, rocker Q–B) that comes apart at 85°
#: of the crank: |Q − A| > rod + rocker from there on
HUNG_FROM_A_DYAD_THAT_FAILS = triad({**LOOP, "Q": 25 - 5j, "B": 12 - 12j},
                                    {**LINKS, "rod": ["A", "B"], "rocker": ["Q", "B"], "l1": ["A", "T1"],
                                     "l3": ["B", "T3"]})


@pytest.mark.parametrize("solver", ["triad", "general"])
def test_a_group_whose_inputs_come_apart_is_placed_up_to_there_and_the_dyad_is_blamed(monkeypatch, run_cli, tmp_path,
                                                                                     solver):
    """A group hung from a joint that cannot be placed from some sample on (its inputs NaN there:
    their travel too) is continued up to that sample, and back from rest through the cycle's end
    to where the dyad closes again: ``simulate`` assembles exactly the samples where the dyad does
    (|Q − A| ≤ rod + rocker, closed form), keeping every
    link's length there, and the CLI reports the dyad's joint B (exit 1, one line), not a crash."""
    from linkedit.spec.linkage_yaml import dump_linkage

    if solver == "general":
        general_solver(monkeypatch)
    spec = HUNG_FROM_A_DYAD_THAT_FAILS
    m = simulate(spec, 72, partial=True)
    theta = m.motor_angle - m.motor_angle[0]
    z = {k: complex(*v) for k, v in spec.joints.items()}
    reach = abs(z["A"] - z["B"]) + abs(z["Q"] - z["B"])
    apart = np.abs(z["Q"] - z["A"] * np.exp(1j * theta)) > reach
    first = int(np.argmax(apart))
    again = 72 - int(np.argmax(apart[::-1]))  # the first sample after the dyad closes again (the cycle's end)
    assert 0 < first < again < 72 and apart[first:again].all()
    assert np.array_equal(m.assembled, ~apart)  # the group continued back from rest through the cycle's end too
    xy = m.positions[..., 0] + 1j * m.positions[..., 1]
    assert link_lengths_kept(spec, m.plan.joint_names, xy[~apart]) <= 1e-9 * size_of(spec)
    path = tmp_path / "apart.yaml"
    path.write_text(dump_linkage(spec))
    res = run_cli("simulate", path, "-n", 72, "-o", tmp_path / "apart.h5")
    assert res.exit_code == 1
    assert "joint B cannot be placed" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "apart.h5").exists()
