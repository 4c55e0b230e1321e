"""The edit energy's analytic gradient (reverse mode through the levels) against central differences."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.edit.objectives import build_problem
from linkedit.edit.runner import pair_lengths
from linkedit.planar import compile_plan
from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.planar_specs import FOURBAR, JANSEN

OPS = {
    "preserve+displace": {"preserve": ["{track}"], "displace": {"joint": "{joint}", "to": [1, 2]}},
    "displace at phase": {"displace": {"joint": "{joint}", "to": [1, 2], "at": 0.3}},
    "envelope": {"envelope": {"xmin": "{xmin}", "ymax": "{ymax}"}},
    "retarget+drag": {"retarget": {"track": "{track}", "scale": [1.2, 0.9], "rotate_deg": 10},
                      "drag": {"track": "{track}", "at": 0.6, "by": [0.5, 1], "radius": 0.1}},
    "transform": {"transform": {"joints": "all", "scale": 0.9, "rotate_deg": 5, "translate": [0.3, 0]}},
}
LINKAGES = {
    "four-bar": (FOURBAR, {"track": "coupler_point", "joint": "B"}),
    "jansen": (JANSEN, {"track": "foot", "joint": "C"}),
}


def fill(value, names):
    if isinstance(value, dict):
        return {k: fill(v, names) for k, v in value.items()}
    if isinstance(value, list):
        return [fill(v, names) for v in value]
    if isinstance(value, str) and value.startswith("{"):
        return names[value[1:-1]]
    return value


@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize("linkage", LINKAGES)
def test_gradient_matches_central_differences(linkage, op):
    text, names = LINKAGES[linkage]
    spec = load_model(LinkageSpec, "x.yaml", text)
    plan = compile_plan(spec)
    x = plan.graph.rest.copy()
    lo, hi = x.min(axis=0), x.max(axis=0)
    names = names | {"xmin": float(lo[0] + 0.3 * (hi[0] - lo[0])), "ymax": float(hi[1] - 0.2 * (hi[1] - lo[1]))}
    # ε large enough that the barrier is active on every dyad; lengths off their reference
    script = EditScript.model_validate({"samples": 40, "singularity_epsilon": 0.9, "lock": [plan.joint_names[0]],
                                        "weights": {"regularization": 0.5}, "operations": [fill(OPS[op], names)]})
    problem = build_problem(plan, script, script.operations[0], x, plan.geometry().rest_angle,
                            pair_lengths(plan, x) * 1.02)
    v = x[problem.free]
    e, g, f = problem.energy(v)
    assert problem.terms(f)["singularity"] > 0  # the barrier takes part
    h = 1e-6 * np.abs(x).max()
    fd = np.empty_like(v)
    for a in range(v.size):
        step = np.zeros_like(v)
        step[a] = h
        fd[a] = (problem.energy(v + step, False)[0] - problem.energy(v - step, False)[0]) / (2 * h)
    assert np.abs(g - fd).max() < 1e-6 * np.abs(fd).max()


def test_infeasible_rest_pose_has_infinite_energy():
    spec = load_model(LinkageSpec, "x.yaml", FOURBAR)
    plan = compile_plan(spec)
    script = EditScript.model_validate({"operations": [{"displace": {"joint": "B", "to": [0, 0]}}]})
    x = plan.graph.rest.copy()
    problem = build_problem(plan, script, script.operations[0], x, plan.geometry().rest_angle, pair_lengths(plan, x))
    flipped = x.copy()
    flipped[2] = [2.2, -2.1]  # B mirrored below the line A–D: the triangle's orientation flips
    assert problem.energy(flipped[problem.free])[0] == np.inf
    far = x.copy()
    far[3] = [30, 0]  # rocker pivot so far that the coupler cannot reach it
    assert problem.energy(far[problem.free])[0] == np.inf
