"""Diagnostics: block-wise rank and null space against the dense definitions, where the rank is
evaluated (and recorded), custom constraints that misbehave, and results that would hold NaN/inf."""

from __future__ import annotations

import json

import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.gcs import diagnostics as diag
from linkedit.gcs import linalg
from linkedit.gcs.members import compile_mechanism
from linkedit.io.gcs_hdf5 import read_result, write_result
from linkedit.gcs.solve import solve_run
from linkedit.gcs.tolerances import CONVERGED, RANK_TOL
from linkedit.gcs.kernels import Custom
from linkedit.gcs.system import State, System
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_model
from tests.test_gcs_solver import _spec


def _dense_rank(J: np.ndarray) -> int:
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > RANK_TOL * s[0])) if s.size and s[0] > 0 else 0


@pytest.mark.parametrize("whole", [linalg.WHOLE_SVD, 0])  # small matrices whole, or block by block
def test_block_rank_equals_the_dense_rank(monkeypatch, whole):
    monkeypatch.setattr(linalg, "WHOLE_SVD", whole)
    rng = np.random.default_rng(4)
    for _ in range(20):
        # a random matrix with decoupled blocks, dependent rows, zero rows and zero columns, shuffled
        blocks = []
        for _ in range(rng.integers(1, 4)):
            r, c, k = rng.integers(1, 8), rng.integers(1, 8), rng.integers(1, 6)
            blocks.append(rng.normal(size=(r, k)) @ rng.normal(size=(k, c)) * 10.0 ** rng.integers(-3, 3))
        R, N = sum(b.shape[0] for b in blocks) + 2, sum(b.shape[1] for b in blocks) + 1
        J = np.zeros((R, N))
        i = j = 0
        for b in blocks:
            J[i:i + b.shape[0], j:j + b.shape[1]] = b
            i, j = i + b.shape[0], j + b.shape[1]
        J = J[rng.permutation(R)][:, rng.permutation(N)]
        assert diag.jacobian_rank(J) == _dense_rank(J)
        Y = diag.left_null_space(J)
        assert Y.shape == (R, R - _dense_rank(J))
        assert np.allclose(Y.T @ Y, np.eye(Y.shape[1]), atol=1e-12)
        assert np.abs(Y.T @ J).max(initial=0.0) < 1e-9 * np.abs(J).max()
    assert diag.jacobian_rank(np.zeros((3, 4))) == 0


@pytest.mark.parametrize("name", ["crank-rocker", "spherical-four-bar", "six-bar"])
def test_example_jacobian_ranks_equal_the_dense_rank(name):
    from tests.conftest import EXAMPLES

    system, _ = compile_mechanism(load_model(MechanismSpec, EXAMPLES / "3d" / f"{name}.yaml"))
    t = np.linspace(0, 1, 7)
    table = system.step_table(t)
    run = solve_run(system, t, table=table)
    for k in range(t.size):
        J = diag.scaled_jacobian(system, run.state(k), table, k)
        assert diag.jacobian_rank(J) == _dense_rank(J)


def test_redundant_constraints_match_the_definition():
    """Named redundant ⇔ removing the constraint's rows leaves the (dense) rank unchanged."""
    spec = _spec({"constraints": {"again": {"type": "pin", "member": "rocker", "point": "pivot",
                                            "world": [2, -3, 0]},
                                  "tip_height": {"type": "on_plane", "member": "crank", "point": "tip",
                                                 "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}}}})
    system, _ = compile_mechanism(spec)
    t = np.linspace(0, 1, 3)
    table = system.step_table(t)
    run = solve_run(system, t, table=table)
    J = diag.scaled_jacobian(system, run.state(1), table, 1)
    full = _dense_rank(J)
    expected = [n for c, n in enumerate(system.constraint_names)
                if (system.row_owner == c).any() and _dense_rank(J[system.row_owner != c]) == full]
    assert diag.redundant_constraints(system, run.state(1), table, 1) == expected
    assert {"again", "rocker_pivot", "tip_height"} <= set(expected)


def _strandbeest(pairs: int) -> System:
    from linkedit.gcs.planar_bridge import planar_model
    from linkedit.planar import catalog

    return planar_model(catalog.strandbeest(pairs)).system


def test_rank_is_evaluated_periodically_and_where_the_status_changes():
    system = _strandbeest(3)
    t = np.arange(360) / 360
    table = system.step_table(t)
    run = solve_run(system, t, table=table)
    run.status[[100, 101, 250]] = [1, 1, 2]  # as if those steps had failed
    d = diag.run_diagnostics(system, run, table)
    ev = d.dof_evaluated
    assert ev[0] and ev[[100, 101, 102, 250, 251]].all()  # failed steps and the steps after them
    assert 10 < ev.sum() < 360  # a large system: not every step
    gaps = np.diff(np.flatnonzero(ev))
    assert gaps.max() == int(np.ceil(360 / (diag.RANK_BUDGET // (333 * 222 * 222 + diag.RANK_OVERHEAD))))
    for k in np.flatnonzero(ev)[::7]:  # evaluated steps hold their own rank
        J = diag.scaled_jacobian(system, run.state(k), table, k)
        assert d.dof[k] == system.n_unknowns - _dense_rank(J)
    last = np.maximum.accumulate(np.where(ev, np.arange(360), 0))
    assert (d.dof == d.dof[last]).all() and (d.redundant == d.redundant[last]).all()  # carried, not invented


def test_small_systems_evaluate_the_rank_at_every_step():
    system, _ = compile_mechanism(_spec())
    t = np.linspace(0, 1, 50)
    table = system.step_table(t)
    d = diag.run_diagnostics(system, solve_run(system, t, table=table), table)
    assert d.dof_evaluated.all() and (d.dof == 0).all()


def test_dof_evaluated_is_stored_and_read_back(tmp_path):
    import h5py

    from linkedit.gcs.mechanism import solve_spec

    res = solve_spec(_spec(), steps=9)
    write_result(tmp_path / "r.h5", res)
    with h5py.File(tmp_path / "r.h5") as f:
        ds = f["diagnostics/dof_evaluated"]
        assert ds.dtype == bool and ds.shape == (9,) and ds[()].all() and "description" in ds.attrs
    assert (read_result(tmp_path / "r.h5").diagnostics.dof_evaluated == res.diagnostics.dof_evaluated).all()


# ---- custom constraints that misbehave ---------------------------------------------------------

def _custom_system(fn, jac=None) -> System:
    """A member held at the origin by a custom 3-row residual (its position)."""
    rest = State(np.array([[0.1, 0.2, 0.3]]), np.array([[1.0, 0.0, 0.0, 0.0]]))
    return System.build(["m"], rest, ["holder"], [], [Custom(owner=0, members=(0,), fn=fn, size=3, jac=jac)])


@pytest.mark.parametrize("fn, message", [
    (lambda P, Q, t: 1 / 0, "ZeroDivisionError"),
    (lambda P, Q, t: np.array([np.nan, 0.0, 0.0]), "non-finite"),
    (lambda P, Q, t: np.array([0.0, np.inf, 0.0]), "non-finite"),
    (lambda P, Q, t: P[0, :2], "returned 2 values, expected 3"),
    (lambda P, Q, t: "abc", "failed: ValueError"),
])
def test_a_misbehaving_custom_constraint_is_a_mechanism_error_naming_it(fn, message):
    system = _custom_system(fn)
    t = np.linspace(0, 1, 3)
    with pytest.raises(MechanismError) as err:
        solve_run(system, t)
    text = str(err.value)
    assert "'holder'" in text and "t = 0.0000" in text and message in text and "\n" not in text


def test_a_custom_jacobian_of_the_wrong_size_is_a_mechanism_error():
    system = _custom_system(lambda P, Q, t: P[0].copy(), jac=lambda P, Q, t: np.eye(3))
    with pytest.raises(MechanismError, match=r"'holder'.*Jacobian.*returned 9 values, expected 3 x 6"):
        solve_run(system, np.linspace(0, 1, 3))


def test_a_well_behaved_custom_constraint_still_solves():
    system = _custom_system(lambda P, Q, t: P[0] - [1.0, 2.0, 3.0 * t])
    run = solve_run(system, np.linspace(0, 1, 3))
    assert (run.status == CONVERGED).all()
    assert np.allclose(run.position[:, 0], [[1, 2, 0], [1, 2, 1.5], [1, 2, 3]], atol=1e-12)


# ---- no NaN or inf in results -----------------------------------------------------------------

def test_an_overflowing_solve_is_refused_and_the_summary_is_json(tmp_path):
    from linkedit.gcs.mechanism import solve_spec

    far = _spec({"constraints": {"far": {"type": "location", "member": "rocker", "point": "tip",
                                         "world": [1e200, 2.75, 0.0]}}})
    with pytest.raises(MechanismError, match=r"step 0 \(t = 0.0000\).*far"):
        solve_spec(far, steps=3)
    # a result that holds inf anyway (built by a library user) is not written, and summarizes as JSON
    res = solve_spec(_spec(), steps=5)
    res.diagnostics.residual[2] = np.inf
    res.tracks["P"].position[1, 0] = np.nan
    summary = json.loads(json.dumps(res.summary(), allow_nan=False))
    assert summary["max_residual"] is None and summary["tracks"]["P"]["min"][0] is None
    with pytest.raises(MechanismError, match=r"residual is not finite at step 2"):
        write_result(tmp_path / "x.h5", res)
    assert not (tmp_path / "x.h5").exists()
