"""Every example in examples/ simulated over full cycles: invariants, known poses, derivatives."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from linkedit.errors import MechanismError
from linkedit.planar import Motion, catalog, compile_plan, simulate
from linkedit.planar.catalog.four_bars import HOEKENS_STRAIGHT
from linkedit.planar.catalog.legs import KLANN
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES


def _full_turn(e: catalog.Example) -> bool:
    m = e.build().motor
    return not m.linear and m.range_deg is None and m.oscillate_deg is None


MOVING = [e.file for e in catalog.EXAMPLES if e.simulates and _full_turn(e)]  # full turns


def load(file: str) -> LinkageSpec:
    return load_model(LinkageSpec, EXAMPLES / file)


def size(spec: LinkageSpec) -> float:
    """The linkage's size: the largest side of its rest-pose bounding box."""
    return float(np.ptp(np.array(list(spec.joints.values())), axis=0).max())


@functools.cache
def cycle(file: str) -> Motion:
    """One full cycle of an example at 360 samples (simulated once per test session)."""
    return simulate(load(file), 360)


@pytest.mark.parametrize("file", MOVING)
def test_full_cycle_keeps_every_link_rigid(file):
    m = cycle(file)
    assert m.t.size == 360 and m.assembled.all()
    p = m.positions
    assert np.isfinite(p).all()
    rest = m.plan.graph.rest
    pairs = m.plan.pairs
    assert len(pairs) == sum(len(j) * (len(j) - 1) // 2 for j in m.plan.spec.links.values())
    now = np.linalg.norm(p[:, pairs[:, 0]] - p[:, pairs[:, 1]], axis=-1)
    then = np.linalg.norm(rest[pairs[:, 0]] - rest[pairs[:, 1]], axis=-1)
    assert np.abs(now - then).max() <= 1e-9 * size(m.plan.spec)
    # ground joints stay put; the crank pin turns at its rest radius, one full turn
    g = list(m.plan.graph.ground)
    assert np.abs(p[:, g] - rest[g]).max() == 0.0
    arm = p[:, m.plan.graph.motor] - p[:, m.plan.graph.pivot]
    turned = np.unwrap(np.arctan2(arm[:, 1], arm[:, 0]))
    assert turned[-1] - turned[0] == pytest.approx(2 * np.pi * 359 / 360, abs=1e-9)


@pytest.mark.parametrize("file", MOVING)
def test_triangle_orientations_never_change(file):
    m = cycle(file)
    assert (m.orientation == m.plan.table.orientation[None, :]).all()
    assert (m.plan.table.orientation[~m.plan.table.rigid] != 0).all()


@pytest.mark.parametrize("file", MOVING)
def test_tracks_are_finite_and_follow_their_joints(file):
    m = cycle(file)
    spec = m.plan.spec
    assert set(m.tracks) == set(spec.tracks)
    for name, track in spec.tracks.items():
        pos = m.tracks[name].position
        assert pos.shape == (360, 2) and np.isfinite(pos).all()
        if hasattr(track, "joint"):
            assert np.array_equal(pos, m.positions[:, m.plan.joint_names.index(track.joint)])


def test_jansen_poses_at_0_and_90_degrees():
    m = simulate(load("jansen.yaml"), 4)
    assert np.allclose(m.motor_angle, np.radians([0, 90, 180, 270]))
    assert np.allclose(m.t, [0, 0.25, 0.5, 0.75])
    names = m.plan.joint_names
    rest = {"O": (0, 0), "A": (15, 0), "B": (-38, -7.8), "C": (-24.0135, 31.2721), "D": (-26.9521, -45.5152),
            "E": (-74.7944, 8.1432), "F": (-59.2315, -28.0529), "G": (-43.1601, -91.7569)}
    for name, xy in rest.items():
        assert np.abs(m.positions[0, names.index(name)] - xy).max() <= 1e-3, name
    assert np.abs(m.positions[1, names.index("A")] - (0, 15)).max() <= 1e-12
    assert np.abs(m.positions[1, names.index("G")] - (-7.6891, -90.3894)).max() <= 1e-3
    assert np.abs(m.tracks["foot"].position[1] - (-7.6891, -90.3894)).max() <= 1e-3


def test_hoekens_tracer_is_straight_over_the_half_cycle_from_90_to_270_degrees():
    m = cycle("hoekens.yaml")
    tracer = m.tracks["tracer"].position
    lo, hi = HOEKENS_STRAIGHT
    straight = (m.t >= lo) & (m.t <= hi)
    assert straight.sum() == 181
    # the best-fit line through the straight half, and the distances from it
    pts = tracer[straight]
    centre = pts.mean(axis=0)
    _, _, axes = np.linalg.svd(pts - centre)
    off = (pts - centre) @ axes[1]
    assert np.ptp(off) <= 0.01  # the tracer stays within a band 0.01 wide
    assert abs(axes[0][1]) < 1e-3  # the line is horizontal (parallel to the ground link O-D)
    assert np.ptp(pts @ axes[0]) > 3.9  # over a stroke of about 4 (twice the ground link)
    other = tracer[~straight]
    assert np.ptp((other - centre) @ axes[1]) > 0.5  # the other half lifts off the line


def test_strandbeest_feet_are_evenly_phased_and_mirrored():
    for file, pairs in (("strandbeest-3.yaml", 3), ("strandbeest-10.yaml", 10)):
        m = simulate(load(file), 360)
        names = m.plan.joint_names
        pins = m.positions[:, [names.index(f"A_{p}") for p in range(pairs)]]
        angle = np.arctan2(pins[..., 1], pins[..., 0])
        step = np.angle(np.exp(1j * (angle - angle[:, :1])))  # pin p relative to pin 0
        expected = np.angle(np.exp(2j * np.pi * np.arange(pairs) / pairs))
        assert np.abs(np.angle(np.exp(1j * (step - expected)))).max() < 1e-12
        shift = 360 // pairs
        foot0 = m.tracks["foot_0_L"].position
        for p in range(pairs):
            # leg p is leg 0 ahead by p/pairs of a turn
            assert np.abs(m.tracks[f"foot_{p}_L"].position - np.roll(foot0, -p * shift, axis=0)).max() < 1e-9
        # the right leg at crank angle θ is the left leg at 180° − θ, mirrored about x = 0
        right = m.tracks["foot_0_R"].position
        mirrored = foot0[(180 - np.arange(360)) % 360] * (-1, 1)
        assert np.abs(right - mirrored).max() < 1e-9


def test_klann_foot_walks_a_flat_stride():
    foot = cycle("klann.yaml").tracks["foot"].position
    low = foot[:, 1] < foot[:, 1].min() + 5.0  # within 5 mm of the lowest point
    stride = np.ptp(foot[low, 0])
    assert stride > 3.5 * KLANN["crank"]  # a long flat stride, about 4 crank lengths
    assert np.ptp(foot[:, 1]) > 1.5 * KLANN["crank"]  # the foot lifts on the way back


@pytest.mark.parametrize("file", ["crank-rocker.yaml", "watt-six-bar.yaml", "stephenson-six-bar.yaml",
                                  "klann.yaml"])
def test_transmission_angles_are_reasonable(file):
    m = cycle(file)
    dyads = ~m.plan.table.rigid
    mu = np.degrees(m.transmission[:, dyads])
    assert np.minimum(mu, 180 - mu).min() >= 30.0


def test_six_bar_outputs_swing():
    for file in ("watt-six-bar.yaml", "stephenson-six-bar.yaml"):
        m = simulate(load(file), 360)
        names = m.plan.joint_names
        arm = m.positions[:, names.index("E")] - m.positions[:, names.index("F")]
        swing = np.degrees(np.ptp(np.unwrap(np.arctan2(arm[:, 1], arm[:, 0]))))
        assert 40.0 < swing < 90.0, file


def central_differences(p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """d/dθ and d²/dθ² of a cyclic (T, ...) sampling with step h by central differences."""
    ahead, behind = np.roll(p, -1, axis=0), np.roll(p, 1, axis=0)
    return (ahead - behind) / (2 * h), (ahead - 2 * p + behind) / h**2


@pytest.mark.parametrize("file", MOVING)
def test_velocity_and_acceleration_match_central_differences(file):
    """Analytic derivatives in the motor angle against differences at θ ± h, h = 0.1°."""
    samples = 3600
    m = simulate(load(file), samples)
    h = 2 * np.pi / samples
    scale = size(m.plan.spec)
    fd_v, fd_a = central_differences(m.positions, h)
    # truncation error of the differences: about h²/6·|x'''| and h²/12·|x''''|
    assert np.abs(m.velocity - fd_v).max() <= 2e-5 * max(np.abs(m.velocity).max(), scale)
    assert np.abs(m.acceleration - fd_a).max() <= 2e-4 * max(np.abs(m.acceleration).max(), scale)
    for name, track in m.tracks.items():
        fd_v, fd_a = central_differences(track.position, h)
        assert np.abs(track.velocity - fd_v).max() <= 2e-5 * max(np.abs(track.velocity).max(), scale), name
        assert np.abs(track.acceleration - fd_a).max() <= 2e-4 * max(np.abs(track.acceleration).max(), scale), name
