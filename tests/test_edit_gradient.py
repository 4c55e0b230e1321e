"""The edit's derivatives and forward model, checked independently.

* the forward model (positions at motor phases as a function of the rest pose) equals
  ``simulate`` of the spec with that rest pose, at random rest poses of every example and of a
  linkage with points tracked on links;
* the Jacobian (forward mode through the levels, coloured directions) and the gradient Jᵀr
  against central differences, for every objective kind, with the barrier active.
"""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.edit.feasibility import failure
from linkedit.edit.operation import build_problem
from linkedit.edit.runner import with_rest_pose
from linkedit.edit.variables import parametrize
from linkedit.planar import catalog, compile_plan
from linkedit.planar.simulate import motor_input, motor_phases, simulate
from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec

OPS = {
    "preserve+displace": {"preserve": ["{track}"], "displace": {"joint": "{joint}", "to": [1, 2], "weight": 3}},
    "displace at phase": {"displace": {"joint": "{joint}", "to": [1, 2], "at": 0.3}},
    "link point": {"displace": {"link": "{link}", "at": "{point}", "to": [1, 2], "phase": 0.4}},
    "preserve part, no timing": {"preserve": [{"track": "{track}", "phases": [0.8, 0.3], "timing": False, "weight": 2}],
                                 "displace": {"joint": "{joint}", "to": [1, 2]}},
    "preserve, no timing": {"preserve": [{"track": "{track}", "timing": False}], "displace": {"joint": "{joint}", "to": [1, 2]}},
    "envelope": {"envelope": {"xmin": "{xmin}", "ymax": "{ymax}"}},
    "retarget+drag": {"retarget": {"track": "{track}", "scale": [1.2, 0.9], "rotate_deg": 10},
                      "drag": {"track": "{track}", "at": 0.6, "by": [0.5, 1], "radius": 0.1}},
    "transform": {"transform": {"joints": "all", "scale": 0.9, "rotate_deg": 5, "translate": [0.3, 0]}},
    "follow": {"follow": [{"track": "{track}", "curve": "{curve}"}, {"track": "{track}", "curve": "{curve}", "timing": True}]},
}


def circle(cx: float, cy: float, r: float) -> list:
    return [[cx + r * np.cos(a), cy + r * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 17)[:-1]]


def with_link_track(spec: LinkageSpec, link: str, at) -> LinkageSpec:
    tracks = dict(spec.tracks) | {"marker": {"link": link, "at": list(at)}}
    return LinkageSpec.model_validate(spec.model_dump() | {"tracks": tracks})


LINKAGES = {
    "four-bar": (catalog.crank_rocker(), {"track": "coupler_point", "joint": "B", "link": "coupler", "point": [40, 20],
                                       "curve": circle(30, 50, 12)}),
    "jansen": (with_link_track(catalog.jansen_leg(), "knee", (-66, -10)),
               {"track": "foot", "joint": "C", "link": "lower", "point": [-40, -60], "curve": circle(-40, -85, 20)}),
    "strandbeest, symmetric": (catalog.strandbeest(1), {"track": "foot_0_L", "joint": "C_0_L", "link": "lower_0_L",
                                                        "point": [-40, -60], "curve": circle(-40, -85, 20)}),
}


def fill(value, names):
    if isinstance(value, dict):
        return {k: fill(v, names) for k, v in value.items()}
    if isinstance(value, list):
        return [fill(v, names) for v in value]
    if isinstance(value, str) and value.startswith("{"):
        return names[value[1:-1]]
    return value


def problem_for(spec: LinkageSpec, script: EditScript):
    from linkedit.edit.runner import _probes

    augmented, probes = _probes(spec, script)
    plan = compile_plan(augmented)
    x = plan.graph.rest.copy()
    index = {n: i for i, n in enumerate(plan.joint_names)}
    var = parametrize(plan, x, {index[n]: a for n, a in script.locked().items()}, script.motor.free_angle)
    t = motor_phases(spec, script.samples)
    probe_points = {k: int(plan.track_points[plan.track_names.index(v)]) for k, v in probes[0].items()}
    return build_problem(plan, script, script.operations[0], var, motor_input(spec.motor, t), t,
                         float(np.ptp(x, axis=0).max()), probe_points)


def assert_forward_model_equals_simulate(spec: LinkageSpec, problem, scale: float, extra=None) -> None:
    """At 3 random working rest poses (steps of ``scale`` × the size, shrinking when they do not
    work), the edit's positions, tracks and d_s equal ``simulate`` of that spec to 1e-9 of the size;
    ``extra(ev, motion)`` adds checks."""
    plan, size = problem.plan, problem.size
    rng = np.random.default_rng(3)
    tried = 0
    for n in range(40):
        v = rng.normal(scale=scale * size / (1 + n // 4), size=problem.var.n)
        ev = problem.evaluate(v)
        if not ev.works:
            continue
        tried += 1
        motion = simulate(with_rest_pose(spec, plan, problem.var.rest(v), "random"), 48)
        z = ev.z[plan.row_of[: plan.n_joints], :48].T
        assert np.abs(motion.positions[..., 0] + 1j * motion.positions[..., 1] - z).max() <= 1e-9 * size
        for track, point in zip(plan.track_names, plan.track_points):
            p = motion.tracks[track].position
            assert np.abs(p[:, 0] + 1j * p[:, 1] - ev.z[plan.row_of[point], :48]).max() <= 1e-9 * size
        if extra is not None:
            extra(ev, motion)
        assert failure(plan, ev.rest, ev.ds[:, :48], np.zeros(48)) is None
        if tried == 3:
            break
    assert tried == 3


def central_jacobian(problem, v: np.ndarray, m: int) -> np.ndarray:
    """(m, n) central differences of the residuals, steps of 1e-6 of the mechanism's size."""
    h = 1e-6 * problem.size
    numeric = np.empty((m, v.size))
    for k in range(v.size):
        e = np.zeros(v.size)
        e[k] = h
        rp, rm = problem.residuals(v + e)[1], problem.residuals(v - e)[1]
        assert rp.size == rm.size == m, "an active set changed inside the difference step"
        numeric[:, k] = (rp - rm) / (2 * h)
    return numeric


@pytest.mark.parametrize("free_angle", [False, True])
@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize("linkage", LINKAGES)
def test_jacobian_matches_central_differences(linkage, op, free_angle):
    spec, names = LINKAGES[linkage]
    x = np.array(list(spec.joints.values()))
    names = names | {"xmin": float(x[:, 0].min() + 0.2 * np.ptp(x[:, 0])),
                     "ymax": float(x[:, 1].max() - 0.2 * np.ptp(x[:, 1]))}
    script = EditScript.model_validate({"samples": 40, "singularity_epsilon": 0.5, "lock": [spec.ground[0]],
                                        "motor": {"free_angle": free_angle},
                                        "symmetric": [["_L", "_R"]] if "symmetric" in linkage else [],
                                        "operations": [fill(OPS[op], names)]})
    problem = problem_for(spec, script)
    guarded = problem.kin.guarded  # the dyads' rows of d_s
    problem.eps[guarded] = 0.6  # the barrier active on many samples
    rng = np.random.default_rng(7)
    v = rng.normal(scale=0.3, size=problem.var.n)
    ev, r, J = problem.residuals(v, jacobian=True)
    assert ev.works and J is not None
    J = J.toarray()
    assert np.count_nonzero(problem.eps[guarded][:, None] > ev.ds[guarded, :40]) > 0
    numeric = central_jacobian(problem, v, r.size)
    assert np.abs(J - numeric).max() <= 1e-6 * np.abs(numeric).max()
    g = problem.energy(v)[1]
    assert np.abs(g - numeric.T @ r).max() <= 1e-6 * np.abs(numeric.T @ r).max()


@pytest.mark.parametrize("name", ["jansen_leg", "klann_leg", "hoekens", "crank_rocker", "watt_six_bar",
                                  "stephenson_six_bar", "strandbeest3", "strandbeest10", "jansen_with_link_track",
                                  "rocker_range"])
def test_forward_model_equals_simulate_at_random_rest_poses(name):
    spec = {"strandbeest3": lambda: catalog.strandbeest(3), "strandbeest10": lambda: catalog.strandbeest(10),
            "jansen_with_link_track": lambda: with_link_track(catalog.jansen_leg(), "knee", (-66, -10)),
            "rocker_range": lambda: catalog.crank_rocker().model_copy(update={"motor": catalog.crank_rocker().motor.model_copy(
                update={"range_deg": (-30.0, 100.0)})}),
            }.get(name, getattr(catalog, name, None))()
    script = EditScript.model_validate({"samples": 48, "operations": [{"displace": {"joint": list(spec.joints)[-1], "to": [0, 0]}}],
                                        "motor": {"free_angle": True}})
    assert_forward_model_equals_simulate(spec, problem_for(spec, script), scale=0.01)
