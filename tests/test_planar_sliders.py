"""Sliders, numeric groups, rocker and linear inputs: closed-form references derived by hand."""

from __future__ import annotations

import re

import h5py
import numpy as np
import yaml
import pytest

from linkedit.errors import MechanismError
from linkedit.planar import catalog, compile_plan, simulate
from linkedit.planar.catalog.sliders import QUICK_RETURN, SLIDER_CRANK, TWO_SLOTS
from linkedit.planar.graph import LinkageGraph, mobility
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage
from tests.conftest import EXAMPLES


def joint(m, name: str) -> np.ndarray:
    """(T,) complex positions of joint ``name``."""
    p = m.positions[:, m.plan.joint_names.index(name)]
    return p[:, 0] + 1j * p[:, 1]


def with_joints(spec: LinkageSpec, **moved) -> LinkageSpec:
    data = spec.model_dump()
    data["joints"] = {**data["joints"], **moved}
    return LinkageSpec.model_validate(data)


def slider_crank_x(theta: np.ndarray, r: float, l: float, e: float) -> np.ndarray:
    return r * np.cos(theta) + np.sqrt(l * l - (r * np.sin(theta) - e) ** 2)


# ---------------------------------------------------------------- closed-form references


def test_offset_slider_crank_matches_the_textbook_formula_over_a_full_turn():
    n = SLIDER_CRANK
    m = simulate(catalog.slider_crank(), 360)
    theta = m.motor_angle
    b = joint(m, "B")
    assert np.abs(b.real - slider_crank_x(theta, n["r"], n["l"], n["e"])).max() <= 1e-9
    assert np.abs(b.imag - n["e"]).max() <= 1e-9  # stays on its line
    # velocity and acceleration against the formula's derivative and its central differences
    h = 1e-4
    root = np.sqrt(n["l"] ** 2 - (n["r"] * np.sin(theta) - n["e"]) ** 2)
    dx = -n["r"] * np.sin(theta) - (n["r"] * np.sin(theta) - n["e"]) * n["r"] * np.cos(theta) / root
    ddx = (slider_crank_x(theta + h, n["r"], n["l"], n["e"]) - 2 * b.real
           + slider_crank_x(theta - h, n["r"], n["l"], n["e"])) / h**2
    names = m.plan.joint_names
    assert np.abs(m.velocity[:, names.index("B"), 0] - dx).max() <= 1e-9
    assert np.abs(m.velocity[:, names.index("B"), 1]).max() <= 1e-9
    assert np.abs(m.acceleration[:, names.index("B"), 0] - ddx).max() <= 1e-5
    # the coupler point stays rigid on the rod
    a, c = joint(m, "A"), joint(m, "C")
    rest = catalog.slider_crank().joints
    for p, q, name in ((a, c, "AC"), (b, c, "BC"), (a, b, "AB")):
        length = np.hypot(*np.subtract(rest[name[0]], rest[name[1]]))
        assert np.abs(np.abs(p - q) - length).max() <= 1e-9


def test_slotted_links_are_closed_form_rules():
    kinds = {b.__name__: [st.kind for st in compile_plan(b()).steps]
             for b in (catalog.quick_return, catalog.scotch_yoke, catalog.inverted_slider_crank, catalog.slider_crank)}
    assert kinds == {"quick_return": ["rotate", "slider"], "scotch_yoke": ["yoke"],
                     "inverted_slider_crank": ["rotate"], "slider_crank": ["slider"]}


def test_quick_return_rocker_follows_the_crank_pin_and_drives_the_ram():
    n = QUICK_RETURN
    m = simulate(catalog.quick_return(), 360)
    a, c, r = joint(m, "A"), joint(m, "C"), joint(m, "R")
    phi = np.angle(a)  # the slot passes through O2 = origin: the rocker points at the pin
    assert np.abs(c - n["rocker"] * np.exp(1j * phi)).max() <= 1e-9
    ram = c.real + np.sqrt(n["rod"] ** 2 - (n["ram"] - c.imag) ** 2)
    assert np.abs(r.real - ram).max() <= 1e-9 and np.abs(r.imag - n["ram"]).max() <= 1e-9
    # quick return: the forward stroke takes more of the turn than the return
    forward = np.mean(np.gradient(np.unwrap(np.angle(c))) > 0)
    assert 0.55 < max(forward, 1 - forward) < 0.75


def test_scotch_yoke_moves_by_r_cos_theta():
    m = simulate(catalog.scotch_yoke(), 360)
    theta = m.motor_angle
    for name, x0 in (("Y1", 50.0), ("Y2", 90.0)):
        y = joint(m, name)
        assert np.abs(y.real - (x0 + 20.0 * (np.cos(theta) - 1.0))).max() <= 1e-9
        assert np.abs(y.imag).max() <= 1e-9
    a = joint(m, "A")
    assert np.abs(a.real - (joint(m, "Y1").real - 30.0)).max() <= 1e-9  # the pin stays in the slot


def test_inverted_slider_crank_arm_points_through_the_pivot():
    m = simulate(catalog.inverted_slider_crank(), 360)
    a, x = joint(m, "A"), joint(m, "X")
    turn = (60.0 - a) / np.abs(60.0 - a)  # the arm's direction: from A through Q
    assert np.abs(x - (a + (100 + 10j - 20) * turn)).max() <= 1e-9


def test_stephenson_slider_output_keeps_rod_and_line():
    m = simulate(catalog.stephenson_slider(), 360)
    c, e = joint(m, "C"), joint(m, "E")
    assert np.abs(e.imag - 20.0).max() <= 1e-9
    assert np.abs(e.real - (c.real + np.sqrt(60.0**2 - (c.imag - 20.0) ** 2))).max() <= 1e-9


def test_cylinder_driven_boom_matches_two_circles():
    spec = catalog.lifting_arm()
    m = simulate(spec, 101)
    o, p = 0j, complex(*spec.joints["P"])
    r0, t0 = complex(*spec.joints["R"]), complex(*spec.joints["T"])
    stroke = m.motor_angle
    assert stroke[0] == 0.0 and stroke[-1] == 25.0
    # R: at |OR| from O and |PR0| + s from P, on the rest pose's side of O→P
    a, b = abs(r0 - o), abs(r0 - p) + stroke
    d = abs(p - o)
    along = (a * a - b * b + d * d) / (2 * d)
    side = np.sign(((p - o).conjugate() * (r0 - o)).imag)
    r = o + (p - o) / d * (along + 1j * side * np.sqrt(a * a - along * along))
    assert np.abs(joint(m, "R") - r).max() <= 1e-9
    assert np.abs(joint(m, "T") - (o + (t0 - o) * (r - o) / (r0 - o))).max() <= 1e-9
    # derivatives per unit of stroke against central differences of the reference
    h = 1e-3
    names = m.plan.joint_names

    def ref(s):
        b = abs(r0 - p) + s
        along = (a * a - b * b + d * d) / (2 * d)
        return o + (p - o) / d * (along + 1j * side * np.sqrt(a * a - along * along))

    dr = (ref(stroke + h) - ref(stroke - h)) / (2 * h)
    ddr = (ref(stroke + h) - 2 * ref(stroke) + ref(stroke - h)) / h**2
    v = m.velocity[:, names.index("R")]
    acc = m.acceleration[:, names.index("R")]
    assert np.abs(v[:, 0] + 1j * v[:, 1] - dr).max() <= 1e-6
    assert np.abs(acc[:, 0] + 1j * acc[:, 1] - ddr).max() <= 1e-6


# ---------------------------------------------------------------- complex loops


@pytest.mark.parametrize("samples", [360, 24])
def test_complex_loop_matches_the_numeric_engine(samples):
    from linkedit.gcs.planar_bridge import numeric_motion

    plan = compile_plan(catalog.complex_loop())
    assert [st.kind for st in plan.steps] == ["group"]
    m = simulate(plan, samples)
    ref = numeric_motion(plan, samples)
    assert np.abs(m.positions - ref.positions).max() <= 1e-8
    # the branch of the rest pose is kept: coarse samples land on the fine cycle's positions
    fine = simulate(plan, 360)
    assert np.abs(m.positions - fine.positions[:: 360 // samples]).max() <= 1e-9


@pytest.mark.parametrize("solver", ["general", "triad"])
def test_complex_loop_polish_rejects_a_wrong_prediction_and_continues_sequentially(monkeypatch, solver):
    """The batched polish accepts a sample only when Newton converges close to its predictor on the
    rest pose's side of every singular position: predictions thrown far off (towards the group's
    other assembly) are rejected and those samples continued one by one from the sample before —
    in the group's joints (the general solver) or in its body's pose (a triad,
    :mod:`linkedit.planar.rules.triad`). The positions are those of the unspoiled run."""
    from linkedit.planar.rules import continuation, general_group, triad

    good = simulate(compile_plan(catalog.complex_loop()), 360)
    if solver == "general":
        monkeypatch.setattr(triad.Triad, "of", classmethod(lambda cls, *a: None))
    plan = compile_plan(catalog.complex_loop())
    assert (plan.steps[0].triad is None) == (solver == "general")
    predict = continuation.predict
    spoiled = []

    def wrong(travel, known, solved, want):
        out = predict(travel, known, solved, want)
        bad = np.arange(want.size) % 3 == 0
        if solver == "general":  # point-mirrored joints
            out[bad] = 2.0 * out[bad][:, [0, 1, 0, 1, 0, 1]].mean(axis=1, keepdims=True) - out[bad]
        else:  # the body turned half a turn about its centre
            out[bad, 2] += np.pi
        spoiled.append(int(bad.sum()))
        return out

    rejected = []
    module, name = (general_group, "_polish") if solver == "general" else (triad, "polish")
    polish = getattr(module, name)

    def counted(*args):
        result = polish(*args)
        accept = result[0] if solver == "general" else result[-1]
        rejected.append(int((~accept).sum()))
        return result

    monkeypatch.setattr(continuation, "predict", wrong)
    monkeypatch.setattr(module, name, counted)
    m = simulate(plan, 360)
    assert sum(spoiled) > 100 and sum(rejected) >= sum(spoiled) // 2
    assert np.abs(m.positions - good.positions).max() <= 1e-9


def test_complex_loop_keeps_its_links_rigid_every_sample():
    spec = catalog.complex_loop()
    m = simulate(spec, 360)
    for members in spec.links.values():
        for i, a in enumerate(members):
            for b in members[i + 1:]:
                rest = np.hypot(*np.subtract(spec.joints[a], spec.joints[b]))
                assert np.abs(np.abs(joint(m, a) - joint(m, b)) - rest).max() <= 1e-9


def test_validate_shows_the_numeric_group_rule(run_cli):
    r = run_cli("validate", EXAMPLES / "complex-loop.yaml")
    assert r.exit_code == 0, r.output
    assert "level 1: T1, T2, T3 ← (A, P1, P2) numeric group" in r.output
    r = run_cli("validate", EXAMPLES / "slider-crank.yaml")
    assert "B ← (A) slider piston" in r.output


# ---------------------------------------------------------------- inputs


def test_oscillating_rocker_input_goes_back_and_forth():
    base = catalog.crank_rocker().model_dump()
    base["motor"]["oscillate_deg"] = [-30.0, 45.0]
    spec = LinkageSpec.model_validate(base)
    m = simulate(spec, 72)
    a = joint(m, "A")
    t = m.t
    expected = np.radians(-30.0 + 75.0 * 0.5 * (1 - np.cos(2 * np.pi * t)))
    assert np.abs(np.angle(a * np.exp(-1j * expected))).max() <= 1e-12
    # B from the law of cosines on the same side as at rest
    o, d = complex(*spec.joints["O"]), complex(*spec.joints["D"])
    b0 = complex(*spec.joints["B"])
    lc, lr = abs(b0 - complex(*spec.joints["A"])), abs(b0 - d)
    e = d - a
    along = (lc * lc - lr * lr + abs(e) ** 2) / (2 * abs(e))
    b = a + e / abs(e) * (along + 1j * np.sqrt(lc * lc - along * along))
    assert np.abs(joint(m, "B") - b).max() <= 1e-9
    assert m.cyclic


def test_a_rocker_input_locked_around_its_turn_names_the_angles_it_swings_through(run_cli, tmp_path):
    """The slider-crank with a 25 mm rod swinging 0° → 250° → 0°: the rod cannot reach the slot for
    |20 sin θ − 12| > 25, θ past 220.5°, on the way out to 250° and back. The message said "motor
    angles 221.3°…221.3°" (the first and last locked samples, both on the way back through 221.3°)."""
    spec = catalog.slider_crank().model_dump()
    n = SLIDER_CRANK
    spec["joints"]["B"] = (n["r"] + np.sqrt(25.0**2 - n["e"] ** 2), n["e"])
    spec["joints"]["C"] = (30.0, 8.0)
    spec["motor"]["oscillate_deg"] = [0.0, 250.0]
    path = tmp_path / "swing.yaml"
    path.write_text(dump_linkage(LinkageSpec.model_validate(spec)))
    r = run_cli("simulate", path, "-o", tmp_path / "swing.h5", "-n", "100")
    assert r.exit_code == 1, r.output
    found = re.search(r"motor angles ([\d.]+)°…([\d.]+)°…([\d.]+)°: slider piston cannot place joint B", r.output)
    assert found, r.output
    edge = 180 + np.degrees(np.arcsin((25.0 - n["e"]) / n["r"]))  # 220.5°
    out, turn, back = (float(g) for g in found.groups())
    assert out == round(edge, 1) and turn == 250.0 and back == out


def test_linear_input_result_file_has_the_stroke(run_cli, tmp_path):
    out = tmp_path / "arm.h5"
    r = run_cli("simulate", EXAMPLES / "lifting-arm.yaml", "-o", out, "--samples", "11", "--svg", tmp_path / "arm.svg")
    assert r.exit_code == 0, r.output
    assert "(joint Q at stroke 0 mm)" in r.output  # the stroke's unit (was "at stroke 0")
    with h5py.File(out) as f:
        assert f.attrs["input"] == "linear" and "motor_angle" not in f
        assert np.allclose(f["stroke"][()], np.linspace(0, 25, 11))
        assert f["joints/velocity"].attrs["units"] == "mm/mm"
        assert [k.decode() for k in f["steps/kind"][()]] == ["group"]
        assert f["diagnostics/step_singularity"].shape == (11, 1)
        assert np.isfinite(f["joints/position"][()]).all()


# ---------------------------------------------------------------- failures


def test_slider_that_runs_off_its_reach_names_the_slider_and_angles(run_cli, tmp_path):
    spec = catalog.slider_crank().model_dump()
    n = SLIDER_CRANK
    spec["joints"]["B"] = (n["r"] + np.sqrt(25.0**2 - n["e"] ** 2), n["e"])  # rod 25: too short below
    spec["joints"]["C"] = (30.0, 8.0)
    path = tmp_path / "short.yaml"
    path.write_text(dump_linkage(LinkageSpec.model_validate(spec)))
    out = tmp_path / "short.h5"
    r = run_cli("simulate", path, "-o", out)
    assert r.exit_code == 1 and "Traceback" not in r.output
    found = re.search(r"motor angles ([\d.]+)°…([\d.]+)°: slider piston cannot place joint B", r.output)
    assert found, r.output
    # |r sin θ − e| > l where sin θ < −(l − e)/r: θ in (180° + 40.5°, 360° − 40.5°)
    edge = np.degrees(np.arcsin((25.0 - n["e"]) / n["r"]))
    assert abs(float(found.group(1)) - (180 + edge)) <= 1.0 and abs(float(found.group(2)) - (360 - edge)) <= 1.0
    assert not out.exists()


BAD_SLIDERS = [
    ("{joint: Z, guide: ground}", "sliders.piston.joint", "unknown joint 'Z'"),
    ("{link: nothing, guide: ground}", "sliders.piston.link", "unknown link 'nothing'"),
    ("{joint: B, guide: frame}", "sliders.piston.guide", "guide 'frame' is not a link"),
    ("{joint: B, guide: rod}", "sliders.piston.joint", "cannot slide on its own link"),
    ("{joint: O, guide: ground}", "sliders.piston.joint", "ground joint"),
    ("{link: rod, guide: rod}", "sliders.piston.guide", "cannot slide on itself"),
    ("{guide: ground}", "sliders.piston", "exactly one of joint"),
]


@pytest.mark.parametrize("entry, field, message", BAD_SLIDERS)
def test_bad_slider_spec_is_one_line_exit_2(run_cli, tmp_path, entry, field, message):
    text = (EXAMPLES / "slider-crank.yaml").read_text()
    text = re.sub(r"  piston: \{joint: B, guide: ground, angle_deg: 0\}.*", f"  piston: {entry}", text)
    assert entry in text
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    r = run_cli("validate", path)
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert len(line.splitlines()) == 1 and "Traceback" not in line
    assert re.match(rf"linkedit: error: .*bad\.yaml:\d+: {re.escape(field)}", line), line
    assert message in line


def test_bad_linear_input_is_exit_2(run_cli, tmp_path):
    text = (EXAMPLES / "lifting-arm.yaml").read_text().replace("slider: cylinder", "slider: ram")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    r = run_cli("validate", path)
    assert r.exit_code == 2 and "motor.slider: unknown slider 'ram'" in r.output


def test_mobility_counts_prismatic_pairs():
    spec = catalog.slider_crank()
    assert mobility(LinkageGraph.from_spec(spec)) .rank == 1
    free = spec.model_copy(update={"sliders": {}})
    m = mobility(LinkageGraph.from_spec(free))
    assert m.rank == 2 and m.grubler == 2
    yoke = mobility(LinkageGraph.from_spec(catalog.scotch_yoke()))
    assert (yoke.grubler, yoke.rank, yoke.redundant) == (1, 1, 0)


def test_edit_moves_a_cylinders_driven_joint_along_its_slot(run_cli, tmp_path):
    script = tmp_path / "scripts" / "move.yaml"
    script.parent.mkdir()
    script.write_text("samples: 36\noperations:\n  - name: move\n    displace: {joint: R, to: [60, 12]}\n")
    out = tmp_path / "out"
    r = run_cli("edit", EXAMPLES / "lifting-arm.yaml", script, "-o", out)
    assert r.exit_code == 0, r.output
    edited = yaml.safe_load((out / "lifting-arm-edited.yaml").read_text())
    moved = np.subtract(edited["joints"]["R"], [60, 10])
    u = np.radians(63.43494882292201)  # the barrel's direction: R stays on its slot line
    assert abs(-np.sin(u) * moved[0] + np.cos(u) * moved[1]) < 1e-9 * 150
    # the closest point of that line to the target (60, 12)
    assert np.allclose(moved, 2 * np.sin(u) * np.array([np.cos(u), np.sin(u)]), atol=0.05)


def test_numeric_engine_writes_a_complex_loop(run_cli, tmp_path):
    """Its motion has no per-step singularity distances: the file's minimum is over the dyads
    (it raised IndexError while writing the result; found by helper-21)."""
    import h5py

    out, ref = tmp_path / "x.h5", tmp_path / "ref.h5"
    r = run_cli("simulate", EXAMPLES / "complex-loop.yaml", "--engine", "numeric", "-o", out)
    assert r.exit_code == 0, r.output
    assert run_cli("simulate", EXAMPLES / "complex-loop.yaml", "-o", ref).exit_code == 0
    with h5py.File(out) as f, h5py.File(ref) as g:
        xy, expected = f["joints/position"][...], g["joints/position"][...]
    size = np.ptp(expected.reshape(-1, 2), axis=0).max()
    assert np.isfinite(xy).all() and np.abs(xy - expected).max() < 1e-8 * size


@pytest.mark.parametrize("example", ["slider-crank", "scotch-yoke", "inverted-slider-crank", "lifting-arm"])
def test_numeric_engine_moves_sliders_and_linear_inputs_as_the_symbolic_one(run_cli, tmp_path, example):
    """``--engine numeric`` models pins in slots (a ground pin in a moving slot as a sleeve), translating
    links and a cylinder's stroke as 3D constraints: the result file equals the symbolic engine's
    to 1e-8 of the size, sample for sample (it refused sliders before)."""
    import h5py

    out, ref = tmp_path / "n.h5", tmp_path / "s.h5"
    r = run_cli("simulate", EXAMPLES / f"{example}.yaml", "--engine", "numeric", "-o", out, "-n", "72")
    assert r.exit_code == 0, r.output
    assert run_cli("simulate", EXAMPLES / f"{example}.yaml", "-o", ref, "-n", "72").exit_code == 0
    with h5py.File(out) as f, h5py.File(ref) as g:
        xy, expected = f["joints/position"][...], g["joints/position"][...]
        assert f.attrs["engine"] == "numeric"
    size = np.ptp(expected.reshape(-1, 2), axis=0).max()
    assert np.abs(xy - expected).max() < 1e-8 * size


def test_numeric_engine_refuses_an_oscillating_input(run_cli, tmp_path):
    spec = tmp_path / "rocker.yaml"
    spec.write_text((EXAMPLES / "crank-rocker.yaml").read_text().replace("motor: {", "motor: {oscillate_deg: [0, 30], ", 1))
    assert "oscillate_deg" in spec.read_text()
    r = run_cli("simulate", spec, "--engine", "numeric", "-o", tmp_path / "x.h5")
    assert r.exit_code == 2 and "oscillating inputs" in r.output


def test_rod_perpendicular_to_the_slot_at_rest_is_rejected():
    spec = with_joints(catalog.slider_crank(), B=(20.0, 50.0), C=(25.0, 30.0))
    spec = spec.model_copy(update={"sliders": {"piston": spec.sliders["piston"].model_copy(update={"angle_deg": 0.0})}})
    with pytest.raises(MechanismError, match="perpendicular"):
        compile_plan(spec)


def piston_driven() -> LinkageSpec:
    """The slider-crank driven by its piston (a linear input on a frame slot): B moves −25…0 mm."""
    data = catalog.slider_crank().model_dump()
    data["motor"] = {"slider": "piston", "stroke": [-25.0, 0.0]}
    return LinkageSpec.model_validate(data)


def test_piston_driven_crank_matches_two_circles():
    spec = piston_driven()
    plan = compile_plan(spec)
    assert [st.kind for st in plan.steps] == ["drive"]
    m = simulate(spec, 51)
    b0, a0 = complex(*spec.joints["B"]), complex(*spec.joints["A"])
    b = b0 + m.motor_angle  # the stroke, along +x
    assert np.abs(joint(m, "B") - b).max() <= 1e-12
    r, l = abs(a0), abs(b0 - a0)
    side = np.sign((b0.conjugate() * a0).imag)

    def crank_pin(b):
        d = np.abs(b)
        along = (r * r - l * l + d * d) / (2 * d)
        return b / d * (along + 1j * side * np.sqrt(r * r - along * along))

    assert np.abs(joint(m, "A") - crank_pin(b)).max() <= 1e-9
    h = 1e-4
    v = m.velocity[:, m.plan.joint_names.index("A")]
    assert np.abs(v[:, 0] + 1j * v[:, 1] - (crank_pin(b + h) - crank_pin(b - h)) / (2 * h)).max() <= 1e-6


def test_transmission_warning_of_a_linear_input_says_the_stroke(run_cli, tmp_path):
    """validate's transmission warning names where the angle is worst: for a cylinder the stroke in
    the spec's units (it said "motor angle" and the stroke read as radians: -2 mm → -114.6°)."""
    data = piston_driven().model_dump()
    data["motor"]["stroke"] = [-25.0, -2.0]  # B at 88.96 − 25 … 88.96 − 2 mm: the rod nearly in line at the end
    path = tmp_path / "piston.yaml"
    path.write_text(dump_linkage(LinkageSpec.model_validate(data)))
    # the angle O–A–B at the crank pin, from the two circles: cos α = (r² + l² − |OB|²) / (2 r l)
    n = SLIDER_CRANK
    stroke = np.linspace(-25.0, -2.0, 24)
    ob2 = (n["r"] + np.sqrt(n["l"] ** 2 - n["e"] ** 2) + stroke) ** 2 + n["e"] ** 2
    alpha = np.degrees(np.arccos((n["r"] ** 2 + n["l"] ** 2 - ob2) / (2 * n["r"] * n["l"])))
    worst = int(np.argmax(np.abs(alpha - 90)))
    r = run_cli("validate", path, "-n", "24")
    assert r.exit_code == 0, r.output
    assert (f"transmission angle at joint A leaves 40°–140°: {alpha[worst]:.1f}° at stroke {stroke[worst]:g} mm"
            in r.output), r.output


# ---------------------------------------------------------------- a joint in two slots


def test_joint_in_two_slots_is_their_crossing_with_velocity_and_acceleration():
    """P rides in the slotted crank (the line through O at the crank angle θ) and in the rail
    y = h: x_P = h·cot θ, dx/dθ = −h/sin²θ, d²x/dθ² = 2h·cos θ/sin³θ; Q on the column x = c at
    the rod's length below P: y_Q = h − sqrt(l² − (c − x_P)²)."""
    spec = catalog.two_slots()
    n = TWO_SLOTS
    h, c, rod = n["h"], n["column"], n["rod"]
    plan = compile_plan(spec)
    assert [(st.kind, st.name) for st in plan.steps] == [("lines", "arm and rail"), ("slider", "column")]
    m = simulate(plan, 61)
    theta = m.motor_angle
    assert np.allclose(np.degrees(theta), np.linspace(25.0, 85.0, 61), atol=1e-12)
    x = h / np.tan(theta)
    assert np.abs(joint(m, "P") - (x + 1j * h)).max() <= 1e-9
    assert np.abs(joint(m, "Q") - (c + 1j * (h - np.sqrt(rod**2 - (c - x) ** 2)))).max() <= 1e-9
    p = list(spec.joints).index("P")
    v, a = m.velocity[:, p], m.acceleration[:, p]
    assert np.abs(v[:, 0] + h / np.sin(theta) ** 2).max() <= 1e-9 * h and np.abs(v[:, 1]).max() <= 1e-12
    assert np.abs(a[:, 0] - 2 * h * np.cos(theta) / np.sin(theta) ** 3).max() <= 1e-9 * h
    # d_s = sin² of the angle between the slots: the crank's angle to the rail
    assert np.allclose(m.step_singularity[:, 0], np.sin(theta) ** 2, rtol=0, atol=1e-12)


def test_validate_shows_the_two_slot_rule(run_cli):
    r = run_cli("validate", EXAMPLES / "two-slots.yaml")
    assert r.exit_code == 0, r.output
    assert "level 1: P ← (O, A) two slots, sliders arm and rail" in r.output


def test_parallel_slots_lock_up_naming_both_sliders(run_cli, tmp_path):
    spec = catalog.two_slots().model_dump(mode="json", exclude_none=True)
    spec["joints"]["Q"] = [40.0, -9970.0]  # a rod so long that Q follows P far out
    spec["motor"]["range_deg"] = [130.0, 140.0]  # θ = 175°…185°: the crank's slot turns parallel to the rail
    path = tmp_path / "parallel.yaml"
    path.write_text(yaml.safe_dump(spec))
    r = run_cli("simulate", path, "-o", tmp_path / "p.h5", "--samples", "11")
    assert r.exit_code == 1 and "Traceback" not in r.output, r.output
    # the sample at 180° finds the slots parallel; the interval is where the linkage does not
    # assemble around it (P runs out of the rod's reach of the column: Q fails from 179.8°)
    assert ("motor angles 179.8°…180.2°: sliders arm and rail: the two slots of joint P are parallel "
            "(d_s = 0)") in r.output
    assert not (tmp_path / "p.h5").exists()


# ---------------------------------------------------------------- a slot on a turning link


def test_pin_in_a_slot_of_the_crank_has_closed_form_velocity_and_acceleration(monkeypatch):
    """B rides in a slot of the crank (the line y' = 5 in the crank's frame, turned by θ) at the rod's
    length l from the ground joint C: with C' = C·e^(−iθ), B = e^(iθ)·(t + 5i), t = Re C' +
    sqrt(l² − (5 − Im C')²). Its velocity and acceleration, from the rule's closed form (the guide's
    rigid motion and the rod's fixed length, no Jacobian solve), against this formula's 5-point
    differences; K linkages give each linkage's."""
    from linkedit.planar.rules import base
    from linkedit.planar.kinematics import evaluate
    from linkedit.planar.plan import Geometry
    from linkedit.planar.simulate import motor_angles

    c, b = 10 + 10j, 40 + 5j
    spec = LinkageSpec.model_validate({
        "name": "crank-slot", "units": "mm", "joints": {"O": [0, 0], "A": [20, 0], "B": [40, 5], "C": [10, 10]},
        "ground": ["O", "C"], "links": {"crank": ["O", "A"], "rod": ["C", "B"]},
        "sliders": {"slot": {"joint": "B", "guide": "crank", "angle_deg": 0}}, "motor": {"joint": "A", "pivot": "O"}})
    plan = compile_plan(spec)
    assert [(r.kind, r.slot.a >= 0) for r in plan.rules] == [("slider", True)]  # the slot turns

    def pin(theta: np.ndarray) -> np.ndarray:
        cp = c * np.exp(-1j * theta)
        return np.exp(1j * theta) * (cp.real + np.sqrt(abs(b - c) ** 2 - (5 - cp.imag) ** 2) + 5j)

    theta = motor_angles(spec, 120)[1]

    def no_solve(*args: object) -> None:
        raise AssertionError("a slider's rates took the generic Jacobian solve")
    monkeypatch.setattr(base, "solve", no_solve)
    h = 1e-3
    near = [pin(theta + k * h) for k in (-2, -1, 0, 1, 2)]
    v = (near[0] - 8 * near[1] + 8 * near[3] - near[4]) / (12 * h)
    a = (-near[0] + 16 * near[1] - 30 * near[2] + 16 * near[3] - near[4]) / (12 * h * h)
    row = plan.row_of[list(spec.joints).index("B")]
    one = evaluate(plan, plan.geometry(), theta, 2)
    pts = np.array(list(spec.joints.values()), dtype=float)
    many = evaluate(plan, Geometry.of(plan, np.stack([pts, pts])), theta, 2)
    assert np.abs(one.z[row] - near[2]).max() <= 1e-12 * abs(b)
    for got, want, tol in ((one.dz[row], v, 1e-9), (one.ddz[row], a, 1e-6)):
        assert np.abs(got - want).max() <= tol * np.abs(want).max()
    assert many.dz.shape[1:] == many.ddz.shape[1:] == (2, theta.size)
    assert np.allclose(many.dz[row], one.dz[row], rtol=0, atol=1e-13 * np.abs(v).max())
    assert np.allclose(many.ddz[row], one.ddz[row], rtol=0, atol=1e-13 * np.abs(a).max())


@pytest.mark.parametrize("make, kind", [(catalog.quick_return, "rotate"), (catalog.inverted_slider_crank, "rotate"),
                                        (catalog.scotch_yoke_coupler, "yoke"), (catalog.two_slots, "lines")])
def test_slotted_link_rates_are_closed_form_and_match_differences(monkeypatch, make, kind):
    """A slotted link turning (``rotate``) or translating (``yoke``) to meet its pin, a joint in two
    slots, one turning with the crank (``lines``), and the sliders beside them: every joint's velocity and acceleration without a Jacobian solve,
    against 5-point differences of the positions (closed form, tested above) over the motor angle."""
    from linkedit.planar.kinematics import evaluate
    from linkedit.planar.plan import Geometry
    from linkedit.planar.rules import base
    from linkedit.planar.simulate import motor_angles

    spec = make()
    plan = compile_plan(spec)
    assert kind in [s.kind for s in plan.steps]

    def no_solve(*args: object) -> None:
        raise AssertionError("a step's rates took the generic Jacobian solve")
    monkeypatch.setattr(base, "solve", no_solve)
    geom = Geometry.of(plan, plan.normalized_points())
    theta, h = motor_angles(spec, 90)[1], 2e-4
    near = [evaluate(plan, geom, theta + k * h, 0).z for k in (-2, -1, 0, 1, 2)]
    v = (near[0] - 8 * near[1] + 8 * near[3] - near[4]) / (12 * h)
    a = (-near[0] + 16 * near[1] - 30 * near[2] + 16 * near[3] - near[4]) / (12 * h * h)
    s = evaluate(plan, geom, theta, 2)
    assert np.array_equal(s.z, near[2])
    scale = np.abs(near[2]).max()
    assert np.abs(s.dz - v).max() <= 1e-9 * scale and np.abs(s.ddz - a).max() <= 1e-6 * scale


def test_a_rod_passing_perpendicular_to_its_slot_between_samples_is_a_toggle():
    """Crank 20, rod 25, slot 5 mm below the pivot: r sin θ − e reaches l at θ = 90° (the rod
    perpendicular to the slot, d_s = 0) and falls back. Sampled at 0.3° + k°, B kept its side of A
    and its velocity jumped from −42 to +2.4 mm/rad between 89.3° and 90.3°, exit 0; now the toggle
    is reported there, as when a sample falls on it."""
    r, l, e = 20.0, 25.0, -5.0
    a = r * np.exp(1j * np.radians(0.3))
    data = catalog.slider_crank().model_dump()
    data["joints"] = {"O": (0.0, 0.0), "A": (a.real, a.imag), "B": (a.real + np.sqrt(l * l - (a.imag - e) ** 2), e),
                      "C": (a.real + 1.0, a.imag + 1.0)}
    spec = LinkageSpec.model_validate(data)
    with pytest.raises(MechanismError, match="slider piston reaches a toggle position") as info:
        simulate(spec, 360)
    (where,) = re.findall(r"motor angles ([\d.]+)°", str(info.value))
    assert float(where) == pytest.approx(90.0, abs=0.3)
