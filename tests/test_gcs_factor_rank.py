"""The rank the solver reads from its factorization (no SVD per step) is the SVD's rank, and the
diagnostics built on it are the ones an SVD at every step gives."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import diagnostics as diag
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.solve import solve_run
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES


@pytest.mark.parametrize("name", ["crank-rocker", "rssr", "spatial-slider-crank", "spherical-four-bar"])
def test_factorization_rank_is_the_svd_rank_at_every_step(name):
    system, _ = compile_mechanism(load_model(MechanismSpec, EXAMPLES / "3d" / f"{name}.yaml"))
    t = np.linspace(0.0, 1.0, 73)
    table = system.step_table(t)
    run = solve_run(system, t, table=table)
    assert (run.status == 0).all() and (run.rank >= 0).all()
    svd = [diag.jacobian_rank(diag.scaled_jacobian(system, run.state(k), table, k)) for k in range(t.size)]
    assert (run.rank == svd).all()
    d = diag.run_diagnostics(system, run, table)
    assert (d.dof == system.n_unknowns - np.array(svd)).all()
