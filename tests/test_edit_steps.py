"""edit on linkages with slider rules and a complex loop (numeric group).

* the forward model (a slider's closed form, a group's continued Newton solve, re-derived from
  each rest pose) equals ``simulate`` of the spec with that rest pose, at random rest poses;
* its Jacobian (implicit-function tangents through the steps, the barrier on slider rules
  active) against central differences;
* through the CLI: an edit (displace a joint, preserve a track) whose edited spec, simulated
  again, is the ``after/`` group.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.test_edit_gradient import OPS, assert_forward_model_equals_simulate, central_jacobian, fill, problem_for

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

#: example → (a track, a joint to displace, a link and a point on it, a joint to lock)
CASES = {
    "slider-crank": ("coupler_point", "C", "rod", [50, 20]),
    "quick-return": ("ram", "C", "rod", [40, 60]),
    "scotch-yoke": ("yoke", "Y2", "yoke", [70, 0]),
    "inverted-slider-crank": ("arm_tip", "X", "arm", [80, 5]),
    "inverted-slider-crank, offset slot": ("arm_tip", "X", "arm", [80, 5]),  # the slot misses the arm's pivot
    "stephenson-slider": ("coupler_point", "C", "coupler", [40, 30]),
    "complex-loop": ("body_tip", "T3", "body", [0, 24]),
    "slider-crank, rocker": ("coupler_point", "C", "rod", [50, 20]),  # oscillate_deg input
    "complex-loop, rocker": ("body_tip", "T3", "body", [0, 24]),
    "lifting-arm": ("tip", "T", "boom", [100, 15]),  # a linear input driving a numeric group
    "piston-driven crank": ("coupler_point", "C", "rod", [40, 10]),  # a linear input, closed form
    "lifting-arm, from -5": ("tip", "T", "boom", [100, 15]),  # its stroke starts off the rest pose
    "two-slots": ("foot", "Q", "rod", [35, 10]),  # a joint in two slots: their crossing
}

#: a crank turned by a piston: B pushed along its horizontal slot, A placed by a dyad from O and B
PISTON_DRIVEN = {
    "name": "piston-driven crank", "units": "mm",
    "joints": {"O": [0, 0], "A": [12, 16], "B": [60, 0], "C": [40, 20]},
    "ground": ["O"], "links": {"crank": ["O", "A"], "rod": ["A", "B", "C"]},
    "sliders": {"piston": {"joint": "B", "guide": "ground", "angle_deg": 0}},
    "motor": {"slider": "piston", "stroke": [0, -18]},
    "tracks": {"coupler_point": {"joint": "C"}, "crank_pin": {"joint": "A"}},
}


def spec_of(name: str) -> LinkageSpec:
    if name == "piston-driven crank":
        return LinkageSpec.model_validate(PISTON_DRIVEN)
    spec = load_model(LinkageSpec, EXAMPLES / f"{name.split(',')[0]}.yaml")
    if name.endswith("offset slot"):  # d_s = 1 − h²/|A−Q|² of the turning slotted link varies
        sleeve = spec.sliders["sleeve"].model_copy(update={"angle_deg": 30.0})
        spec = spec.model_copy(update={"sliders": {"sleeve": sleeve}})
    if name.endswith("from -5"):  # stroke [-5, 20]: the group is continued from the rest pose to −5 first
        spec = spec.model_copy(update={"motor": spec.motor.model_copy(update={"stroke": (-5.0, 20.0)})})
    if name.endswith("rocker"):  # a rocker input from the rest pose to 110° and back
        spec = spec.model_copy(update={"motor": spec.motor.model_copy(update={"oscillate_deg": (0.0, 110.0)})})
    return spec


def names_for(spec: LinkageSpec, name: str) -> dict:
    track, joint, link, point = CASES[name]
    x = np.array(list(spec.joints.values()))
    c = x.mean(axis=0)
    r = 0.2 * float(np.ptp(x, axis=0).max())
    return {"track": track, "joint": joint, "link": link, "point": point,
            "curve": [[c[0] + r * np.cos(a), c[1] + r * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 17)[:-1]],
            "xmin": float(x[:, 0].min() + 0.2 * np.ptp(x[:, 0])), "ymax": float(x[:, 1].max() - 0.2 * np.ptp(x[:, 1]))}


@pytest.mark.parametrize("op", ["displace at phase", "preserve part, no timing"])
@pytest.mark.parametrize("name", CASES)
def test_jacobian_through_steps_matches_central_differences(name, op):
    spec = spec_of(name)
    script = EditScript.model_validate({"samples": 40, "singularity_epsilon": 0.5, "lock": [spec.ground[0]],
                                        "operations": [fill(OPS[op], names_for(spec, name))]})
    problem = problem_for(spec, script)
    guarded = problem.kin.guarded
    rows = problem.plan.step_rows
    rng = np.random.default_rng(7)
    v = rng.normal(scale=0.003 * problem.size, size=problem.var.n)
    problem.eps[guarded] = 0.9  # the barrier active on many samples
    steps = rows[guarded[rows]]
    ds = problem.evaluate(v).ds[steps, :40]
    for n, d in zip(steps, np.sort(ds, axis=1)):  # slider rules: ε in the widest gap between middle samples
        gap = 10 + np.argmax(np.diff(d[10:30]))
        problem.eps[n] = 0.5 * (d[gap] + d[gap + 1]) if d[-1] > d[0] else 0.9
    ev, r, J = problem.residuals(v, jacobian=True)
    assert ev.works and J is not None, ev.why
    J = J.toarray()
    # the barrier active on a slider rule (a dyad's, when the linkage has none)
    watched = steps if steps.size else np.flatnonzero(guarded)
    assert (ev.ds[watched, :40] < problem.eps[watched, None]).any() or name.startswith(
        ("scotch-yoke", "complex-loop", "lifting-arm"))
    numeric = central_jacobian(problem, v, r.size)
    assert np.abs(J - numeric).max() <= 1e-6 * np.abs(numeric).max()


@pytest.mark.parametrize("name", CASES)
def test_forward_model_through_steps_equals_simulate(name):
    spec = spec_of(name)
    script = EditScript.model_validate({"samples": 48, "motor": {"free_angle": True},
                                        "operations": [{"displace": {"joint": CASES[name][1], "to": [0, 0]}}]})
    problem = problem_for(spec, script)
    rows = problem.plan.step_rows
    guarded = problem.kin.guarded[rows]

    def step_ds(ev, motion) -> None:  # the sliders' d_s too
        assert np.allclose(ev.ds[rows, :48][guarded], motion.step_singularity.T[guarded], rtol=0, atol=1e-9)

    assert_forward_model_equals_simulate(spec, problem, scale=0.02, extra=step_ds)


#: example → (track preserved, joint displaced, where to)
CLI_EDITS = {
    "slider-crank": ("coupler_point", "B", [86, 10]),  # moves the slot line: the piston's offset changes
    "quick-return": ("ram", "C", [28, 56]),
    "scotch-yoke": ("yoke", "Y1", [50, 5]),
    "inverted-slider-crank": ("arm_tip", "Q", [62, 2]),
    "stephenson-slider": ("output", "B", [65, 60]),
    "complex-loop": ("body_tip", "P2", [46, 7]),
    "slider-crank, rocker": ("coupler_point", "B", [86, 10]),
    "complex-loop, rocker": ("body_tip", "P2", [46, 7]),
    "lifting-arm": ("tip", "P", [42, -28]),  # moves the barrel's pivot: the cylinder's stroke stays 25 mm
    "piston-driven crank": ("coupler_point", "O", [3, 4]),
    "two-slots": ("foot", "A", [24, 24]),  # a longer slotted crank: the pin P rides the same lines
}


@pytest.mark.parametrize("name", CLI_EDITS)
def test_edit_through_the_cli_on_sliders_and_a_complex_loop_resimulates_exactly(run_cli, tmp_path, name):
    import yaml

    from linkedit.planar import compile_plan
    from tests.test_edit_trust import Edited

    track, joint, to = CLI_EDITS[name]
    script = tmp_path / "s.yaml"
    script.write_text(yaml.safe_dump({"samples": 90, "operations": [
        {"preserve": [track], "displace": {"joint": joint, "to": to}}]}))
    linkage = tmp_path / f"{name.split(',')[0]}.yaml"
    linkage.write_text(yaml.safe_dump(spec_of(name).model_dump(mode="json", exclude_none=True)))
    e = Edited(run_cli, tmp_path, linkage, script, "--best-effort")  # the displacement vies with the preserved curve
    e.check(run_cli, preserved=[track])
    edited = e.edited
    before = np.hypot(*np.subtract(e.original.joints[joint], to))
    now = np.hypot(*np.subtract(edited.joints[joint], to))
    assert now < 0.5 * before
    # the report measures the goal as the edited spec has it, against 1 % of the linkage's size
    goal = next(g for g in e.report["operations"][0]["goals"] if g["goal"] == f"displace {joint}")
    size = np.ptp(np.array(list(e.original.joints.values())), axis=0).max()
    assert abs(goal["error"] - now) <= 1e-9 * size and goal["tolerance"] == pytest.approx(0.01 * size)
    assert goal["met"] is bool(now <= 0.01 * size)
    # every slider rule keeps its side, the group its assembly branch
    old, new = compile_plan(e.original).steps, compile_plan(edited).steps
    def branch(s):  # a slider's or slotted link's side, a group's determinant sign
        return s.kind, getattr(s, "sign", None), getattr(s, "det_sign", None)

    assert [branch(s) for s in old] == [branch(s) for s in new]


@pytest.mark.parametrize("name", ["lifting-arm", "piston-driven crank"])
def test_a_null_edit_of_a_linear_input_leaves_the_linkage_unchanged(run_cli, tmp_path, name):
    import yaml

    from tests.test_edit_trust import Edited

    track, joint, _ = CLI_EDITS[name]
    spec = spec_of(name)
    script = tmp_path / "s.yaml"
    script.write_text(yaml.safe_dump({"samples": 60, "operations": [
        {"preserve": [track], "displace": {"joint": joint, "to": list(spec.joints[joint])}}]}))
    linkage = tmp_path / "linkage.yaml"
    linkage.write_text(yaml.safe_dump(spec.model_dump(mode="json", exclude_none=True)))
    e = Edited(run_cli, tmp_path, linkage, script)
    e.check(run_cli, preserved=[track])
    size = float(np.ptp(np.array(list(spec.joints.values())), axis=0).max())
    for n, xy in spec.joints.items():
        assert np.hypot(*np.subtract(e.edited.joints[n], xy)) <= 1e-9 * size, n


def test_the_predicate_names_a_linear_input_by_its_stroke_and_its_guide():
    from linkedit.edit.feasibility import failure
    from linkedit.planar import compile_plan

    plan = compile_plan(spec_of("piston-driven crank"))
    rest = plan.graph.rest[:, 0] + 1j * plan.graph.rest[:, 1]
    stroke = np.linspace(0.0, -18.0, 7)
    ds = np.ones((plan.n_ds, 7))
    ds[plan.table.row[np.flatnonzero(~plan.table.rigid)[0]], 4] = -0.1  # the dyad cannot close at the fifth sample
    assert failure(plan, rest, ds, stroke) == "joint A cannot be assembled at stroke -12 mm"
    arm = compile_plan(spec_of("lifting-arm"))
    names = arm.joint_names
    rest = arm.graph.rest[:, 0] + 1j * arm.graph.rest[:, 1]
    rest[names.index("Q")] = rest[names.index("P")]  # the cylinder's barrel shrinks to nothing
    why = failure(arm, rest, np.ones((arm.n_ds, 1)), np.zeros(1))
    assert why == "linear input cylinder: its guide barrel vanishes (P and Q meet)"
