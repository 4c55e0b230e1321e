"""The numeric engine (3D solver) agrees with the symbolic engine on every planar example."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES

planar = pytest.importorskip("linkedit.planar")

SPECS = sorted(EXAMPLES.glob("*.yaml"))


@pytest.mark.parametrize("path", SPECS, ids=[p.stem for p in SPECS])
def test_numeric_agrees_with_symbolic(path):
    from linkedit.gcs.planar_bridge import UNSUPPORTED, simulate_numeric, supported
    from linkedit.planar.simulate import motor_angles

    spec = load_model(LinkageSpec, path)
    if not supported(spec):
        pytest.skip(f"the numeric engine has no {UNSUPPORTED} (simulate --engine numeric refuses them)")
    samples = 90
    t, _ = motor_angles(spec, samples)
    try:
        plan = planar.compile_plan(spec)
        symbolic = planar.simulate(plan, samples)
    except MechanismError:
        # closed form cannot order it (e.g. a complex loop): the numeric engine solves it as far
        # as it assembles, and otherwise names the constraint and the motor angle
        try:
            numeric = simulate_numeric(spec, t)
        except MechanismError as exc:
            assert "motor angle" in str(exc) and "constraint '" in str(exc)
            return
        assert (numeric.status == 0).all()
        assert numeric.residual.max() < 1e-9
        pairs = [(a, b) for link in spec.links.values() for a in link for b in link if a < b]
        names = list(spec.joints)
        for a, b in pairs:
            i, j = names.index(a), names.index(b)
            rest = np.linalg.norm(np.subtract(spec.joints[a], spec.joints[b]))
            assert np.allclose(np.linalg.norm(numeric.positions[:, i] - numeric.positions[:, j], axis=1), rest, atol=1e-9)
        return
    numeric = simulate_numeric(spec, t)
    assert numeric.positions.shape == symbolic.positions.shape
    assert np.abs(numeric.positions - symbolic.positions).max() < 1e-8
    assert numeric.out_of_plane.max() < 1e-9
