"""Solver behaviour: velocities, under- and over-constrained systems, stored-state tracking, slsqp-fd."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.diagnostics import redundant_constraints, run_diagnostics
from linkedit.gcs.mechanism import solve_spec
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.continuation import Solver
from linkedit.gcs.outputs import velocity
from linkedit.gcs.solve import solve_run
from linkedit.gcs.tolerances import CONVERGED, INCONSISTENT, SLSQP_TOL, Options
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_model, load_yaml, validate
from tests.conftest import EXAMPLES

CRANK_ROCKER = EXAMPLES / "3d" / "crank-rocker.yaml"


def _spec(changes: dict | None = None, drop: tuple = ()) -> MechanismSpec:
    data, _ = load_yaml(CRANK_ROCKER)
    for path in drop:
        del data[path[0]][path[1]]
    for key, value in (changes or {}).items():
        data[key] = {**data.get(key, {}), **value} if isinstance(value, dict) and key != "outputs" else value
    return validate(MechanismSpec, data, file="test")


def test_velocity_of_a_point_on_a_uniformly_rotating_member_is_r_omega():
    spec = _spec({"outputs": {"steps": 361, "tracks": {"tip": {"member": "crank", "point": [1.0, 0.0, 0.0]},
                                                        "half": {"member": "crank", "point": [0.5, 0.0, 0.0]}}}})
    res = solve_spec(spec, rank=False)
    omega = 2 * np.pi  # one turn per unit time
    for name, r in (("tip", 1.0), ("half", 0.5)):
        v = res.tracks[name].velocity
        assert res.tracks[name].cyclic
        assert np.allclose(np.linalg.norm(v, axis=1), r * omega, rtol=1e-3)
        # tangential: perpendicular to the arm, counter-clockwise
        arm = res.tracks[name].position - [-3.0, 3.0, 0.0]
        assert np.abs(np.sum(arm * v, axis=1)).max() < 1e-3 * r * r * omega
        assert (np.cross(arm, v)[:, 2] > 0).all()


def test_parabola_velocity_is_exact_for_quadratics_on_uneven_steps():
    t = np.array([0.0, 0.1, 0.35, 0.4, 0.8, 1.0])
    p = np.column_stack([3 * t**2 - t + 2, -t**2, t])
    v = velocity(t, p, cyclic=False)
    assert np.allclose(v, np.column_stack([6 * t - 1, -2 * t, np.ones_like(t)]), atol=1e-12)


def test_tracking_from_stored_states_equals_re_solving():
    res = solve_spec(_spec(), rank=False)
    added = res.add_track("new", "coupler", np.array([1.0, -2.0, 0.5]))
    again = solve_spec(_spec({"outputs": {"steps": 361, "tracks": {
        "new": {"member": "coupler", "point": [1.0, -2.0, 0.5]}}}}), rank=False)
    assert np.allclose(added.position, again.tracks["new"].position, atol=1e-12)
    assert np.allclose(added.velocity, again.tracks["new"].velocity, atol=1e-9)


def test_over_constrained_inconsistent_spec_names_the_constraints():
    # pin the rocker tip to a world point it cannot reach while the crank turns
    spec = _spec({"constraints": {"stuck": {"type": "location", "member": "rocker", "point": "tip",
                                            "world": [2.0, 2.75, 0.0]}}})
    res = solve_spec(spec, steps=5)
    d = res.diagnostics
    assert (d.status == INCONSISTENT).any()
    k = int(np.flatnonzero(d.status == INCONSISTENT)[0])
    assert "stuck" in d.unsatisfied[k]
    assert d.residual[k] > 1e-3
    # worst first: the listed names follow the costs, the largest first
    costs = [d.costs[k, res.constraint_names.index(n)] for n in d.unsatisfied[k]]
    assert len(costs) >= 2 and costs == sorted(costs, reverse=True)
    assert d.unsatisfied[k][0] == res.constraint_names[int(np.argmax(d.costs[k]))]


def test_under_constrained_member_stays_where_it_was():
    """A coupler held only at one end keeps its orientation; the dof count says 3 are free."""
    spec = _spec(drop=(("constraints", "coupler_rocker"),))
    res = solve_spec(spec, steps=37)
    assert (res.diagnostics.status == 0).all()
    # coupler: ball-like freedom about the crank tip (pin axis) → 1 rotation left, and the rocker 1
    assert (res.diagnostics.dof == 2).all()
    m = res.member_names.index("coupler")
    q0 = res.orientation[0, m]
    drift = [np.linalg.norm(quat.log(quat.multiply(q, quat.conjugate(q0)))) for q in res.orientation[:, m]]
    # it turns only as the crank drags it (the pin axis), never about x or y
    axes = [quat.log(quat.multiply(q, quat.conjugate(q0))) for q in res.orientation[:, m]]
    assert np.abs(np.array(axes)[:, :2]).max() < 1e-9
    assert max(drift) < 2 * np.pi


def test_redundant_constraint_is_named():
    spec = _spec({"constraints": {"again": {"type": "pin", "member": "rocker", "point": "pivot",
                                            "world": [2, -3, 0]}}})
    system, _ = compile_mechanism(spec)
    t = np.linspace(0, 1, 5)
    table = system.step_table(t)
    run = solve_run(system, t, table=table)
    names = redundant_constraints(system, run.state(0), table, 0)
    assert "again" in names and "rocker_pivot" in names and "drive" not in names
    diag = run_diagnostics(system, run, table)
    assert (diag.redundant == 5 + 5).all()
    assert {"again", "rocker_pivot"} <= set(diag.redundant_names)


def test_slsqp_fd_option_reduces_the_cost():
    spec = load_model(MechanismSpec, CRANK_ROCKER)
    system, _ = compile_mechanism(spec)
    table = system.step_table(np.zeros(1))
    r0 = system.evaluate(system.rest, table, 0).r
    state, r, info = Solver(system, Options(solver="slsqp-fd")).solve(system.rest, table, 0)
    assert r @ r < 1e-8 * (r0 @ r0)
    _, r_lm, info_lm = Solver(system).solve(system.rest, table, 0)
    assert info_lm.status == 0 and np.abs(r_lm).max() < 1e-12
    # judged by its own tolerance: SLSQP's success and a scaled residual ≤ SLSQP_TOL
    assert info.status == CONVERGED
    assert np.max(np.abs(r) * system.row_scale) <= SLSQP_TOL


def test_slsqp_fd_reports_an_inconsistent_spec_as_inconsistent():
    spec = _spec({"constraints": {"stuck": {"type": "location", "member": "rocker", "point": "tip",
                                            "world": [2.0, 2.75, 0.0]}}})
    system, _ = compile_mechanism(spec)
    table = system.step_table(np.full(1, 0.25))
    _, r, info = Solver(system, Options(solver="slsqp-fd")).solve(system.rest, table, 0)
    assert info.status == INCONSISTENT
    assert np.max(np.abs(r) * system.row_scale) > SLSQP_TOL


def test_an_unknown_solver_option_is_refused_by_name():
    """``Options(solver=…)`` names the solvers there are (it used to run ``lm`` for any name)."""
    with pytest.raises(ValueError, match=r"Options.solver: 'newton' is not a solver; use one of 'lm', 'slsqp-fd'"):
        Options(solver="newton")
