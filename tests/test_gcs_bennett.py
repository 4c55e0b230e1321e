"""examples/3d/bennett.yaml, an over-constrained spatial 4R, against its closed form (Bennett's
input–output relation and the Denavit–Hartenberg chain it closes) at ×1, ×1000 and ×1e-3."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.mechanism import solve_spec
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from tests import gcs_oracles as oracle
from tests.conftest import EXAMPLES

A1, A2 = 2.0, 1.0  #: link lengths (common normals)
ALPHA1, ALPHA2 = np.radians(90.0), np.radians(30.0)  #: twists


def _dh(theta: float, a: float, alpha: float) -> np.ndarray:
    """Rz(θ) · Tx(a) · Rx(α), (4, 4)."""
    c, s, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[c, -s * ca, s * sa, a * c], [s, c * ca, -c * sa, a * s], [0, sa, ca, 0], [0, 0, 0, 1.0]])


def _frames(theta1: float) -> list[np.ndarray]:
    """World frames (4, 4) of link1, link2, link3 at crank angle θ1: θ2 from Bennett's relation
    tan(θ1/2) tan(θ2/2) = sin((α2+α1)/2) / sin((α2−α1)/2), θ3 = −θ1, θ4 = −θ2."""
    K = np.sin((ALPHA2 + ALPHA1) / 2) / np.sin((ALPHA2 - ALPHA1) / 2)
    theta2 = 2 * np.arctan(K / np.tan(theta1 / 2))
    rz = lambda t: _dh(t, 0.0, 0.0)  # noqa: E731
    F1 = rz(theta1)
    F2 = F1 @ _dh(0.0, A1, ALPHA1) @ rz(theta2)
    F3 = F2 @ _dh(0.0, A2, ALPHA2) @ rz(-theta1)
    closure = F3 @ _dh(0.0, A1, ALPHA1) @ rz(-theta2) @ _dh(0.0, A2, ALPHA2)
    assert np.abs(closure - np.eye(4)).max() < 1e-12  # the loop closes: the relation is right
    return [F1, F2, F3]


def test_the_example_meets_bennetts_conditions():
    """Opposite links equal and a1 / sin α1 = a2 / sin α2, measured from the spec's joints."""
    spec = load_yaml(EXAMPLES / "3d" / "bennett.yaml")[0]
    j = spec["joints"]
    at = {n: np.array(j[n]["at"], dtype=float) for n in "ABCD"}
    axis = {n: np.array(j[n]["axis"], dtype=float) / np.linalg.norm(j[n]["axis"]) for n in "ABCD"}
    links = [("A", "B"), ("B", "C"), ("C", "D"), ("D", "A")]
    length = [np.linalg.norm(at[q] - at[p]) for p, q in links]  # joints sit on the common normals
    twist = [np.arccos(np.clip(abs(axis[p] @ axis[q]), 0, 1)) for p, q in links]
    for (p, q), n in zip(links, length):
        d = (at[q] - at[p]) / n
        assert abs(d @ axis[p]) < 1e-15 and abs(d @ axis[q]) < 1e-15  # ⊥ both axes
    assert np.isclose(length[0], length[2], rtol=1e-15) and np.isclose(length[1], length[3], rtol=1e-15)
    assert np.isclose(twist[0], twist[2], rtol=1e-15) and np.isclose(twist[1], twist[3], rtol=1e-15)
    assert np.isclose(length[0] / np.sin(twist[0]), length[1] / np.sin(twist[1]), rtol=1e-15)


@pytest.mark.parametrize("s", [1.0, 1e3, 1e-3])
def test_bennett_follows_its_closed_form_at_any_scale(s):
    data = oracle.scaled_spec(load_yaml(EXAMPLES / "3d" / "bennett.yaml")[0], s)
    res = solve_spec(validate(MechanismSpec, data, file="bennett"), steps=61, rank=False)
    assert (res.diagnostics.status == 0).all()
    size = s * np.sqrt(3.0**2 + 3.0**2 + 2.0**2)  # ≥ the linkage's extent
    theta1 = np.radians(90.0 - 60.0 + 300.0 * res.t)
    for k, th in enumerate(theta1):
        for m, F in enumerate(_frames(th)):
            assert np.abs(res.position[k, m] - s * F[:3, 3]).max() < 1e-9 * size
            assert np.abs(quat.to_matrix(res.orientation[k, m]) - F[:3, :3]).max() < 1e-9
    want = np.array([s * (F[:3, :3] @ [0.5, 0.3, 0.0] + F[:3, 3]) for F in (_frames(th)[1] for th in theta1)])
    assert np.abs(res.tracks["P"].position - want).max() < 1e-9 * size
