"""Slider linkages as families: K designs of one slider topology evaluated at once, and
``atlas build --family`` of a slider spec synthesizing a held-out design of it."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from linkedit.planar import catalog, compile_plan, simulate
from linkedit.planar.kinematics import _evaluate
from linkedit.planar.plan import Geometry
from linkedit.spec.linkage import LinkageSpec
from tests.conftest import EXAMPLES

#: a cylinder (linear input, slider ``piston``) pushing the rocker Q–B through the rod P–B
CYLINDER = {
    "name": "cylinder", "units": "mm",
    "joints": {"P": [0, 0], "B": [60, 25], "Q": [80, -10]}, "ground": ["Q"],
    "links": {"rod": ["P", "B"], "rocker": ["Q", "B"]},
    "sliders": {"piston": {"joint": "P", "guide": "ground", "angle_deg": 10}},
    "motor": {"slider": "piston", "stroke": [-10, 10]}, "tracks": {"tip": {"joint": "B"}},
}


def designs(spec: LinkageSpec, count: int, spread: float, seed: int) -> list[LinkageSpec]:
    """``count`` copies of ``spec`` with every joint moved by N(0, (spread·size)²)."""
    rng = np.random.default_rng(seed)
    rest = np.array(list(spec.joints.values()), dtype=float)
    size = np.ptp(rest, axis=0).max()
    out = []
    for _ in range(count):
        moved = rest + spread * size * rng.normal(size=rest.shape)
        data = spec.model_dump(mode="python")
        data["joints"] = {n: p.tolist() for n, p in zip(spec.joints, moved)}
        out.append(LinkageSpec.model_validate(data))
    return out


def batched(specs: list[LinkageSpec], samples: int) -> np.ndarray:
    """Joint positions (K, T, J) complex of the designs ``specs`` evaluated in one call (the
    first design's plan — its sliders' directions at rest — each design's own rest pose and
    branch, spec units), at the inputs ``simulate`` samples."""
    plan = compile_plan(specs[0])
    names = plan.joint_names
    rest = np.array([[s.joints[n] for n in names] for s in specs], dtype=float)
    geom = Geometry.of(plan, rest)
    motor = specs[0].motor
    if motor.linear:
        inp = np.broadcast_to(np.linspace(*motor.stroke, samples), (len(specs), samples))
    else:
        inp = geom.rest_angle + 2.0 * np.pi * np.arange(samples) / samples
    z = _evaluate(plan, geom, inp, order=0).z[plan.row_of[: plan.n_joints]]  # (J, K, T)
    return z.transpose(1, 2, 0)


@pytest.mark.parametrize("spec", [catalog.quick_return(), catalog.scotch_yoke_coupler(), catalog.slider_crank(),
                                  catalog.inverted_slider_crank(), LinkageSpec.model_validate(CYLINDER)],
                         ids=lambda s: s.name)
def test_slider_designs_evaluated_at_once_equal_each_simulated_alone(spec):
    """K perturbed designs of a slider linkage (slider, slotted link turning, yoke, linear input)
    evaluated in one call give, design for design, what `simulate` gives for that design alone
    (its own compile: rest pose, branch, normalized frame), and cannot place a joint where it locks up."""
    specs = designs(spec, 6, 0.03, seed=4)
    z = batched(specs, 90)
    for k, one in enumerate(specs):
        m = simulate(one, 90, partial=True)
        alone = m.positions[..., 0] + 1j * m.positions[..., 1]
        size = np.ptp(np.array(list(one.joints.values())), axis=0).max()
        ok = m.assembled
        assert np.abs(z[k, ok] - alone[ok]).max() <= 1e-9 * size, (spec.name, k)
        assert not np.isfinite(z[k, ~ok]).all(axis=1).any(), (spec.name, k)


def test_slider_designs_evaluated_at_once_follow_their_closed_forms():
    """Against formulas derived by hand, design by design: offset slider-cranks B_x = r cos θ +
    sqrt(l² − (r sin θ − e)²), and quick-returns (the slot through O2: the rocker points at the
    pin, C = O2 + L·(A − O2)/|A − O2|; the ram R_x = C_x + sqrt(rod² − (y_R − C_y)²))."""
    rng = np.random.default_rng(5)
    theta = 2.0 * np.pi * np.arange(120) / 120
    cranks = []
    for r, l, e in zip(rng.uniform(10, 20, 4), rng.uniform(50, 80, 4), rng.uniform(-8, 8, 4)):
        cranks.append(LinkageSpec.model_validate({
            "name": "offset-slider-crank", "units": "mm", "joints": {"O": [0, 0], "A": [r, 0], "B": [r + np.sqrt(l * l - e * e), e]},
            "ground": ["O"], "links": {"crank": ["O", "A"], "rod": ["A", "B"]},
            "sliders": {"piston": {"joint": "B", "guide": "ground", "angle_deg": 0}},
            "motor": {"joint": "A", "pivot": "O"}, "tracks": {"piston": {"joint": "B"}}}))
    b = batched(cranks, 120)[:, :, 2]
    for k, spec in enumerate(cranks):
        (ax, _), (bx, e) = spec.joints["A"], spec.joints["B"]
        r, l = ax, np.hypot(bx - ax, e)
        assert np.abs(b[k].real - (r * np.cos(theta) + np.sqrt(l * l - (r * np.sin(theta) - e) ** 2))).max() <= 1e-9
        assert np.abs(b[k].imag - e).max() <= 1e-9
    shapers = []
    slot = np.radians(63.0)  # the slot's direction at rest (one plan: the designs share their sliders' angles)
    for r, big, rod, ram in zip(rng.uniform(12, 18, 4), rng.uniform(55, 65, 4), rng.uniform(30, 40, 4),
                                rng.uniform(47, 52, 4)):
        pin = complex(r, 30)  # the crank axle O = (0, 30); O2 on y = 0, the slot through it
        pivot = complex(r - 30.0 / np.tan(slot), 0)
        o2 = pivot.real
        c = pivot + big * (pin - pivot) / abs(pin - pivot)
        shapers.append(LinkageSpec.model_validate({
            "name": "quick-return", "units": "mm",
            "joints": {"O2": [o2, 0], "O": [0, 30], "A": [r, 30], "C": [c.real, c.imag],
                       "R": [c.real + np.sqrt(rod ** 2 - (ram - c.imag) ** 2), ram]},
            "ground": ["O2", "O"], "links": {"crank": ["O", "A"], "rocker": ["O2", "C"], "rod": ["C", "R"]},
            "sliders": {"slot": {"joint": "A", "guide": "rocker", "angle_deg": 63.0},
                        "ram": {"joint": "R", "guide": "ground", "angle_deg": 0}},
            "motor": {"joint": "A", "pivot": "O"}, "tracks": {"ram": {"joint": "R"}}}))
    z = batched(shapers, 120)
    for k, spec in enumerate(shapers):
        o2, r, ram = spec.joints["O2"][0], spec.joints["A"][0], spec.joints["R"][1]
        assert abs(np.degrees(np.angle(complex(r, 30) - o2)) - 63.0) <= 1e-9
        big, rod = (np.hypot(*np.subtract(spec.joints[p], spec.joints[q])) for p, q in (("C", "O2"), ("R", "C")))
        pin = 30j + r * np.exp(1j * theta)
        c = o2 + big * (pin - o2) / np.abs(pin - o2)
        assert np.abs(z[k, :, 3] - c).max() <= 1e-9 * big
        assert np.abs(z[k, :, 4] - (c.real + np.sqrt(rod ** 2 - (ram - c.imag) ** 2) + 1j * ram)).max() <= 1e-9 * big


def test_numeric_groups_take_each_linkages_own_rest_pose():
    """A numeric group's rows come from each linkage's own rest pose (they were the spec's: K linkages and a moved
    rest pose were refused): the lifting arm scaled by 1.01 about the origin, at strokes scaled by 1.01, is the
    arm's own motion scaled by 1.01 (similar linkages), alone and beside the unscaled one in one evaluation."""
    plan = compile_plan(catalog.lifting_arm())
    rest = plan.normalized_points()
    stroke = np.array([0.0, 0.05, -0.05, 0.08])
    joints = plan.row_of[: plan.n_joints]
    both = _evaluate(plan, Geometry.of(plan, np.stack([rest, 1.01 * rest])), np.stack([stroke, 1.01 * stroke]),
                     order=0).z[joints]
    alone = _evaluate(plan, Geometry.of(plan, 1.01 * rest), 1.01 * stroke, order=0).z[joints]
    assert np.isfinite(both).all() and np.abs(both[:, 0]).max() > 0.0
    assert np.abs(both[:, 0, 0] - (rest[:, 0] + 1j * rest[:, 1])).max() <= 1e-12
    assert np.abs(both[:, 1] - 1.01 * both[:, 0]).max() <= 1e-12
    assert np.abs(alone - both[:, 1]).max() <= 1e-12


def _inputs(plan, geom, samples: int) -> np.ndarray:
    """(K, T) inputs over the cycle: motor angles, or strokes of ±0.1 (normalized frame)."""
    if plan.linear:
        return np.broadcast_to(np.linspace(-0.1, 0.1, samples), (geom.ground.shape[1], samples))
    return geom.rest_angle + np.linspace(0.0, 2.0 * np.pi, samples, endpoint=False)


@pytest.mark.parametrize("spec", [catalog.quick_return(), catalog.scotch_yoke_coupler(), catalog.two_slots(),
                                  catalog.inverted_slider_crank(), LinkageSpec.model_validate(CYLINDER)],
                         ids=lambda s: s.name)
def test_slider_designs_derivatives_at_once_equal_each_alone_and_finite_differences(spec):
    """Velocities and accelerations of K designs of a slider linkage (slider, slotted link
    turning, yoke, two slots, linear input) in one call equal each design's own (one linkage
    at its rest pose) and central differences of the positions in the input."""
    plan = compile_plan(spec)
    rest = plan.normalized_points()
    many = rest[None] + 0.01 * np.random.default_rng(3).normal(size=(4, *rest.shape))
    geom = Geometry.of(plan, many)
    inp = _inputs(plan, geom, 48)
    s = _evaluate(plan, geom, inp, order=2)
    for k in range(4):
        one = _evaluate(plan, Geometry.of(plan, many[k]), inp[k], order=2)
        good = (one.ds > 1e-3).all(axis=0)  # away from lock-ups, where the derivatives blow up
        for a, b in ((s.z, one.z), (s.dz, one.dz), (s.ddz, one.ddz), (s.ds, one.ds)):
            assert np.abs(a[:, k, good] - b[:, good]).max() <= 1e-12 * np.abs(b[:, good]).max(), spec.name
            assert np.array_equal(np.isnan(a[:, k]), np.isnan(b)), spec.name
    h1, h2 = 1e-6, 1e-4
    (p1, m1), (p2, m2) = ((_evaluate(plan, geom, inp + d, order=0).z.copy() for d in (h, -h)) for h in (h1, h2))
    ok = np.isfinite(p2).all(axis=0) & np.isfinite(m2).all(axis=0) & (s.ds > 0.1).all(axis=0)  # away from lock-ups
    assert ok.mean() > 0.3, spec.name  # two-slots turns through part of the cycle only
    for d, fd, tol in ((s.dz, (p1 - m1) / (2 * h1), 1e-7), (s.ddz, (p2 - 2 * s.z + m2) / h2 ** 2, 1e-5)):
        assert np.abs(d - fd)[:, ok].max() <= tol * np.abs(d[:, ok]).max(), spec.name


# ---------------------------------------------------------------- atlas build --family SPEC, synthesize


@pytest.fixture(scope="module")
def slider_atlases(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = {}
    for stem in ("quick-return", "scotch-yoke-coupler"):
        path = tmp_path_factory.mktemp("atlas") / f"{stem}.h5"
        r = CliRunner().invoke(app, ["atlas", "build", "--family", str(EXAMPLES / f"{stem}.yaml"), "-n", "2000", "-o",
                                     str(path), "--seed", "3", "-q"])
        assert r.exit_code == 0, r.output
        out[stem] = path
    return out


@pytest.mark.parametrize("stem, timing, mirror", [("quick-return", True, False), ("scotch-yoke-coupler", True, True),
                                                  pytest.param("scotch-yoke-coupler", False, False, marks=pytest.mark.slow)])
def test_a_slider_spec_atlas_synthesizes_a_held_out_design_of_it(run_cli, slider_atlases, tmp_path, stem, timing, mirror):
    """A design drawn apart from the atlas (another seed; its tool path turned, scaled, moved, and
    mirrored) is synthesized to ≤ 1 % RMS of its size (with --timing: the ram's position at each
    time, the quick-return's slow stroke and quick return); the written result.yaml, simulated
    again, reproduces the reported error; the atlas alone makes the family again."""
    from linkedit.planar.feasibility import works
    from linkedit.synthesis import families
    from linkedit.synthesis.refine import curve_error
    from linkedit.synthesis.synthesize import target_size

    name = (catalog.quick_return() if stem == "quick-return" else catalog.scotch_yoke_coupler()).name
    fam = families.family(name)
    draw = fam.sample(np.random.default_rng(77), 64)
    row = draw[works(fam.min_singularity(draw, fam.margin()), fam.margin())][0]
    samples = 256
    z = 40.0 * np.exp(0.3j) * fam.curves(row[None], samples)[0] + (5 - 7j)
    z = np.conj(z) if mirror else z
    target = tmp_path / "path.csv"
    rows = (f"{p.real:.12f},{p.imag:.12f}" + (f",{n / samples:.12f}" if timing else "") for n, p in enumerate(z))
    target.write_text(("x,y,t\n" if timing else "x,y\n") + "\n".join(rows))
    families.SPECS.pop(name)  # as a new process would: only the atlas knows the family
    families.SPEC_TEXTS.pop(name)
    r = run_cli("synthesize", target, "--atlas", slider_atlases[stem], "-o", tmp_path / "syn", "--top", "2",
                *(["--timing"] if timing else []))
    assert r.exit_code == 0, r.output
    report = json.loads((tmp_path / "syn" / "report.json").read_text())
    error = report["error"]["timed"]["after"] if timing else report["error"]["after"]
    assert error["rms"] <= 0.01, report["error"]
    again = tmp_path / "again.h5"
    assert run_cli("simulate", tmp_path / "syn" / "result.yaml", "-o", again, "-n", str(samples)).exit_code == 0
    with h5py.File(again) as f:
        drawn = f["tracks/target/position"][...]
    w = drawn[:, 0] + 1j * drawn[:, 1]
    size = target_size(np.stack([z.real, z.imag], axis=1), True)
    if timing:  # sample n is the target's point at time n/256
        gap = np.abs(w - z) / size
        rms, worst = float(np.sqrt(np.mean(gap ** 2))), float(gap.max())
    else:
        rms, worst = curve_error((z - z.mean()) / size, True, (w - z.mean()) / size, 1.0)
    assert rms <= 0.01
    assert abs(rms - error["rms"]) <= 0.05 * error["rms"] + 1e-7, (rms, error)
    assert abs(worst - error["max"]) <= 0.05 * error["max"] + 1e-7, (worst, error)
