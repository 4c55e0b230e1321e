"""pylinkage's numba solver, on linkages rebuilt from linkedit's plans, traces the same joints as
linkedit's closed form (an independent implementation: a check of both, and of the side-by-side
bench's premise). Skipped where pylinkage is not installed (the optional ``bench`` extra)."""

import numpy as np
import pytest

from linkedit.planar import catalog, peer
from linkedit.planar.plan import compile_plan
from linkedit.planar.simulate import simulate

pytest.importorskip("pylinkage")


@pytest.mark.parametrize("make", [catalog.crank_rocker, catalog.jansen_leg, lambda: catalog.strandbeest(2)])
def test_pylinkage_traces_the_same_joints(make):
    plan = compile_plan(make())
    assert peer.dyadic(plan)
    linkage, joints = peer.build(plan, 90)
    theirs = linkage.step_fast(iterations=90)  # row t is linkedit's sample t + 1
    ours = np.roll(simulate(plan, 90).positions[:, joints], -1, axis=0)
    assert np.max(np.abs(theirs - ours)) <= 1e-9 * plan.scale


def test_a_mechanism_saved_by_pylinkage_moves_as_in_pylinkage(run_cli, tmp_path):
    """pylinkage builds and saves a Jansen leg (``mechanism_to_json``); ``linkedit import`` then
    ``simulate`` writes a CSV whose joints follow pylinkage's own ``Mechanism.step`` at every sample."""
    import h5py
    from pylinkage.dyads._conversion import to_mechanism
    from pylinkage.mechanism.serialization import mechanism_to_json

    plan = compile_plan(catalog.jansen_leg())
    mechanism = to_mechanism(peer.build(plan, 72)[0])
    mechanism_to_json(mechanism, tmp_path / "leg.json")
    names = [j.id for j in mechanism.joints]
    theirs = np.array(list(mechanism.step()))  # (72, J, 2): row t is sample t + 1
    assert run_cli("import", tmp_path / "leg.json", "-o", tmp_path / "leg.yaml").exit_code == 0
    assert run_cli("simulate", tmp_path / "leg.yaml", "-o", tmp_path / "leg.h5").exit_code == 0
    with h5py.File(tmp_path / "leg.h5") as f:
        written = [n.decode() for n in f["joint"][()]]
        pos = f["joints/position"][()]
    ours = np.roll(pos[:, [written.index(n) for n in names]], -1, axis=0)
    assert ours.shape == theirs.shape
    assert np.max(np.abs(ours - theirs)) <= 1e-9 * plan.scale
