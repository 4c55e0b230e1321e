"""Quaternions, rotation vectors and inputs: double cover, slerp, full-turn rotation inputs."""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule
from linkedit.gcs.system import WORLD, Elementary, State, System


def test_exp_log_round_trip_and_matrix():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(50, 3))
    v *= (rng.uniform(0, np.pi, 50) / np.linalg.norm(v, axis=1))[:, None]
    q = quat.exp(v)
    assert np.allclose(quat.log(q), v, atol=1e-12)
    R = quat.to_matrix(q)
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-12)
    # Rodrigues: R x = x cosθ + (k × x) sinθ + k (k·x)(1 − cosθ)
    x = rng.normal(size=(50, 3))
    th = np.linalg.norm(v, axis=1, keepdims=True)
    k = v / th
    rod = x * np.cos(th) + np.cross(k, x) * np.sin(th) + k * np.sum(k * x, axis=1, keepdims=True) * (1 - np.cos(th))
    assert np.allclose(np.einsum("nij,nj->ni", R, x), rod, atol=1e-12)
    assert np.allclose(quat.log(quat.exp(np.array([1e-10, 0, 0]))), [1e-10, 0, 0], rtol=1e-9, atol=0)


def test_q_and_minus_q_are_the_same_orientation():
    rng = np.random.default_rng(1)
    q = quat.normalize(rng.normal(size=(20, 4)))
    assert np.allclose(quat.to_matrix(q), quat.to_matrix(-q))
    assert np.allclose(quat.log(q), quat.log(-q))
    # an orientation constraint is satisfied by −q as well as by q, with zero cost
    state = State(np.zeros((1, 3)), -q[:1])
    system = System.build(["m"], state, ["o"], [Elementary("orientation", 0, 0, WORLD, rel=tuple(q[0]))])
    r = system.evaluate(state, system.step_table(np.zeros(1)), 0).r
    assert np.abs(r).max() < 1e-14
    # the orientation cost equals 4·arccos²(|Re(o1 o2⁻¹)|)
    other = quat.normalize(rng.normal(size=4))
    state = State(np.zeros((1, 3)), other[None])
    r = system.evaluate(state, system.step_table(np.zeros(1)), 0).r
    w = abs(quat.multiply(other, quat.conjugate(q[0]))[0])
    assert np.isclose(r @ r, 4 * np.arccos(min(w, 1.0)) ** 2)


def test_left_jacobian_inverse_against_finite_differences():
    rng = np.random.default_rng(2)
    for phi in (rng.normal(size=3) * 0.8, np.array([1e-6, 0, 0]), np.array([0.0, 2.5, 0.3])):
        h = 1e-6
        fd = np.column_stack([(quat.log(quat.multiply(quat.exp(d), quat.exp(phi)))
                               - quat.log(quat.multiply(quat.exp(-d), quat.exp(phi)))) / (2 * h)
                              for d in np.eye(3) * h])
        assert np.allclose(quat.left_jacobian_inverse(phi), fd, atol=1e-7)


def test_rotation_input_turns_a_full_360_degrees():
    """Angles interpolate linearly: 0 → 360° is one smooth turn, not slerp's shortest arc."""
    z = np.array([0.0, 0.0, 1.0])
    s = Schedule(mode="rotation", window=(0.0, 1.0), times=np.array([0.0, 1.0]),
                 values=np.radians([0.0, 360.0]), axis=z, base=np.array([1.0, 0, 0, 0]))
    t = np.linspace(0, 1, 361)
    q = s.evaluate(t)
    x = quat.rotate(q, np.tile([1.0, 0, 0], (t.size, 1)))
    angle = np.unwrap(np.arctan2(x[:, 1], x[:, 0]))
    assert np.allclose(angle, 2 * np.pi * t, atol=1e-12)
    # slerp between the same keyframes (as orientations) does not turn at all: 360° ≡ 0°
    flat = Schedule(mode="orientation", window=(0.0, 1.0), times=np.array([0.0, 1.0]), values=q[[0, -1]])
    assert np.allclose(np.abs(flat.evaluate(t)[:, 0]), 1.0)


def test_schedule_window_and_slerp():
    qa = np.array([1.0, 0, 0, 0])
    qb = quat.from_axis_angle(np.array([0, 1.0, 0]), np.pi / 2)
    s = Schedule(mode="orientation", window=(0.25, 0.75), times=np.array([0.25, 0.75]), values=np.stack([qa, qb]))
    t = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    assert s.active(t).tolist() == [False, True, True, True, False]
    mid = s.evaluate(np.array([0.5]))[0]
    assert np.allclose(mid, quat.from_axis_angle(np.array([0, 1.0, 0]), np.pi / 4))
    v = Schedule(mode="vector", window=(0.0, 1.0), times=np.array([0.0, 0.5, 1.0]), values=np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.0]]))
    assert np.allclose(v.evaluate(np.array([0.25, 0.75])), [[0.5, 0, 0], [1, 0.5, 0]])


def test_turned_is_a_second_order_rotation_increment():
    """q turned by v agrees with exp(v) ⊗ q up to O(|v|³), stays a unit quaternion."""
    rng = np.random.default_rng(4)
    q = quat.normalize(rng.normal(size=(20, 4)))
    direction = quat.normalize(rng.normal(size=(20, 3)))
    errors = []
    for size in (1e-2, 1e-3):
        v = size * direction
        turned = quat.turned(q, v)
        assert np.allclose(np.linalg.norm(turned, axis=1), 1.0, atol=1e-15)
        errors.append(np.abs(turned - quat.multiply(quat.exp(v), q)).max())
    assert errors[0] < 1e-6 and errors[1] < errors[0] / 500  # third order: 1000× per decade


def test_from_matrix_inverts_to_matrix_near_every_half_turn():
    """Shepperd's method: exact to rounding for random rotations and for turns of π − 1e-9 and
    π about each axis (where the trace is −1 and q's scalar part vanishes)."""
    rng = np.random.default_rng(3)
    q = quat.normalize(rng.standard_normal((500, 4)))
    axes = np.repeat(np.eye(3), 2, axis=0)
    q = np.concatenate([q, quat.from_axis_angle(axes, np.tile([np.pi - 1e-9, np.pi], 3))])
    back = quat.from_matrix(quat.to_matrix(q))
    assert np.abs(np.abs(quat.dot(back, q)) - 1.0).max() < 1e-15
    assert np.abs(quat.dot(back, back) - 1.0).max() < 1e-15
