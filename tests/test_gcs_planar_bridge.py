"""Planar linkages through the 3D solver, checked against closed-form four-bar poses."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.gcs.planar_bridge import planar_model, simulate_numeric
from linkedit.spec.linkage import LinkageSpec


def four_bar(direction="ccw", range_deg=None, ground=4.0, crank=1.0, coupler=3.5, rocker=3.0):
    """O(0,0)–A crank, A–B coupler, B–C rocker, C(ground,0); B above the ground line at rest."""
    A = (crank, 0.0)
    d = np.hypot(ground - crank, 0.0)
    x = (d * d + coupler**2 - rocker**2) / (2 * d)
    B = (crank + x, float(np.sqrt(coupler**2 - x * x)))
    motor = {"joint": "A", "pivot": "O", "direction": direction}
    if range_deg:
        motor["range_deg"] = range_deg
    return LinkageSpec.model_validate({
        "name": "four-bar", "units": "mm", "joints": {"O": (0, 0), "A": A, "B": B, "C": (ground, 0)},
        "ground": ["O", "C"], "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["B", "C"]},
        "motor": motor, "tracks": {"mid": {"link": "coupler", "at": (A[0] + 0.5, A[1] + 1.0)}}})


def closed_form_B(angle, ground=4.0, crank=1.0, coupler=3.5, rocker=3.0):
    """B for crank angle(s), on the branch above the line A–C (the rest branch)."""
    A = crank * np.column_stack([np.cos(angle), np.sin(angle)])
    C = np.array([ground, 0.0])
    v = C - A
    d = np.linalg.norm(v, axis=1, keepdims=True)
    x = (d * d + coupler**2 - rocker**2) / (2 * d)
    h = np.sqrt(coupler**2 - x * x)
    u = v / d
    n = np.column_stack([-u[:, 1], u[:, 0]])
    return A + x * u + h * n


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_four_bar_matches_closed_form(direction):
    spec = four_bar(direction)
    t = np.arange(120) / 120
    m = simulate_numeric(spec, t)
    sign = 1 if direction == "ccw" else -1
    assert np.allclose(m.motor_angle, sign * 2 * np.pi * t)
    B = m.positions[:, list(spec.joints).index("B")]
    assert np.abs(B - closed_form_B(m.motor_angle)).max() < 1e-9
    assert (m.status == 0).all() and m.residual.max() < 1e-9 and m.out_of_plane.max() == 0.0
    # the link-attached track keeps its place on the coupler
    A = m.positions[:, 1]
    assert np.allclose(np.linalg.norm(m.tracks[:, 0] - A, axis=1), np.hypot(0.5, 1.0), atol=1e-9)


def test_range_sweep_and_model_layout():
    spec = four_bar(range_deg=(-30.0, 60.0))
    model = planar_model(spec)
    assert model.system.member_names == ["crank", "coupler", "rocker"]
    # two ground pins, one shared joint each for A and B, and the motor
    assert len(model.system.constraint_names) == 5
    t = np.linspace(0, 1, 31)
    m = simulate_numeric(spec, t, model=model)
    assert np.allclose(np.degrees(m.motor_angle[[0, -1]]), [-30.0, 60.0])
    assert np.abs(m.positions[:, 2] - closed_form_B(m.motor_angle)).max() < 1e-9


def test_linkage_that_cannot_turn_names_constraint_and_angle():
    spec = four_bar(crank=2.5, coupler=3.0, rocker=3.0)  # a triple-rocker: the crank cannot go round
    with pytest.raises(MechanismError, match=r"motor angle -?\d+\.\d°.*constraint '"):
        simulate_numeric(spec, np.arange(72) / 72)


def test_simulate_engine_numeric_writes_a_planar_result(run_cli, tmp_path):
    import h5py
    import yaml

    spec = four_bar()
    path = tmp_path / "fb.yaml"
    path.write_text(yaml.safe_dump(spec.model_dump(mode="json", exclude_none=True)))
    for engine in ("numeric", "symbolic"):
        r = run_cli("simulate", path, "--engine", engine, "-n", "72", "-o", tmp_path / f"{engine}.h5")
        assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "numeric.h5") as a, h5py.File(tmp_path / "symbolic.h5") as b:
        assert a.attrs["engine"] == "numeric"
        assert np.abs(a["joints/position"][()] - b["joints/position"][()]).max() < 1e-8
        v, w = a["joints/velocity"][()], b["joints/velocity"][()]
        assert np.abs(v - w).max() < 1e-2 * np.abs(w).max()  # parabola differences vs closed form


def test_coarse_sampling_stays_on_the_branch():
    """15° samples would let continuation jump to another assembly; the refined solve does not."""
    import numpy as np

    from linkedit.gcs.planar_bridge import refined_phases, simulate_numeric
    from linkedit.planar import catalog, simulate

    fine, keep = refined_phases(np.arange(24) / 24, 360.0)
    assert np.allclose(fine[keep], np.arange(24) / 24) and np.diff(fine).max() * 360 <= 1.0 + 1e-9
    spec = catalog.strandbeest(3)
    numeric = simulate_numeric(spec, np.arange(24) / 24)
    assert np.abs(numeric.positions - simulate(spec, 24).positions).max() < 1e-8
