"""Every analytic Jacobian of the 3D solver against central finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.gcs.kernels import Custom
from linkedit.gcs.system import WORLD, Elementary, State, System


def _random_state(rng, M):
    return State(rng.normal(size=(M, 3)), quat.normalize(rng.normal(size=(M, 4))))


def _fd_jacobian(system, state, table, h=1e-6):
    N = system.n_unknowns
    J = np.zeros((system.n_rows, N))
    for i in range(N):
        d = np.zeros(N)
        d[i] = h
        J[:, i] = (system.evaluate(state.moved(d), table, 0).r - system.evaluate(state.moved(-d), table, 0).r) / (2 * h)
    return J


def _unit(rng):
    return tuple(quat.normalize(rng.normal(size=3)))


def _elementary(kind, rng, b):
    v = lambda: tuple(rng.normal(size=3))  # noqa: E731
    if kind == "location":
        return Elementary("location", 0, 0, b, sa=v(), sb=v())
    if kind == "orientation":
        return Elementary("orientation", 0, 0, b, rel=tuple(quat.normalize(rng.normal(size=4))))
    if kind in ("axis", "parallel"):
        return Elementary(kind, 0, 0, b, sa=_unit(rng), sb=_unit(rng))
    if kind == "distance":
        return Elementary("distance", 0, 0, b, sa=v(), sb=v(), value=float(rng.uniform(0.1, 3.0)))
    if kind == "angle":
        return Elementary("angle", 0, 0, b, sa=_unit(rng), sb=_unit(rng), value=float(rng.uniform(0.1, 3.0)))
    return Elementary(kind, 0, 0, b, sa=v(), sb=v(), nb=_unit(rng))  # plane, line


KINDS = ["location", "orientation", "axis", "plane", "line", "distance", "angle", "parallel"]


@pytest.mark.parametrize("relative", [False, True], ids=["fixed", "relative"])
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", range(4))
def test_jacobian_matches_finite_differences(kind, relative, seed):
    rng = np.random.default_rng(seed)
    state = _random_state(rng, 2)
    system = System.build(["a", "b"], state, ["c"], [_elementary(kind, rng, 1 if relative else WORLD)])
    table = system.step_table(np.zeros(1))
    J = system.dense_jacobian(system.evaluate(state, table, 0, jacobian=True))
    fd = _fd_jacobian(system, state, table)
    assert np.abs(J - fd).max() < 1e-7 * max(1.0, np.abs(J).max())
    if not relative:
        assert np.all(J[:, 6:] == 0)  # member b is not involved


def test_axis_jacobian_near_alignment_and_large_angles():
    """The axis residual θ·n uses series near θ = 0; check there and at obtuse angles."""
    rng = np.random.default_rng(7)
    for angle in (1e-6, 1e-4, 0.5, 2.0, 3.0):
        ua = np.array([0.0, 0.0, 1.0])
        axis = _unit(rng)
        ub = quat.rotate(quat.from_axis_angle(np.cross(ua, axis) / np.linalg.norm(np.cross(ua, axis)), angle), ua)
        state = State(np.zeros((1, 3)), np.array([[1.0, 0, 0, 0]]))
        system = System.build(["a"], state, ["c"], [Elementary("axis", 0, 0, WORLD, sa=tuple(ua), sb=tuple(ub))])
        table = system.step_table(np.zeros(1))
        ev = system.evaluate(state, table, 0, jacobian=True)
        assert np.isclose(np.linalg.norm(ev.r), angle, rtol=1e-9)  # |r| is the angle: cost = arccos²
        fd = _fd_jacobian(system, state, table, h=1e-7 if angle < 1e-3 else 1e-6)
        assert np.abs(system.dense_jacobian(ev) - fd).max() < 1e-6


def test_custom_constraint_finite_difference_jacobian():
    """A custom residual without its own Jacobian gets central differences; with one, it is used."""
    def distance(P, Q, t):
        return np.array([np.sum((P[0] - P[1]) ** 2) - 4.0])

    def distance_jac(P, Q, t):
        d = P[0] - P[1]
        return np.concatenate([2 * d, np.zeros(3), -2 * d, np.zeros(3)])[None, :]

    rng = np.random.default_rng(3)
    state = _random_state(rng, 2)
    for jac in (None, distance_jac):
        system = System.build(["a", "b"], state, ["c"], [], [Custom(0, (0, 1), distance, 1, jac)])
        table = system.step_table(np.zeros(1))
        J = system.dense_jacobian(system.evaluate(state, table, 0, jacobian=True))
        assert np.abs(J - _fd_jacobian(system, state, table)).max() < 1e-6


def test_normal_equations_match_dense_products():
    """JᵀJ and Jᵀr assembled from the groups (dense and sparse plans) equal the dense products."""
    from linkedit.gcs import linalg

    rng = np.random.default_rng(11)
    M = 4
    state = _random_state(rng, M)
    elems = [_elementary(k, rng, WORLD) for k in ("location", "axis")]
    elems += [Elementary(k, 0, a, b, **p) for k, a, b, p in [
        ("location", 0, 1, dict(sa=(1, 0, 0), sb=(0, 1, 0))), ("axis", 1, 2, dict(sa=_unit(rng), sb=_unit(rng))),
        ("orientation", 2, 3, dict(rel=(1, 0, 0, 0))), ("plane", 3, 0, dict(sa=(0, 0, 1), sb=(1, 1, 1), nb=_unit(rng)))]]
    system = System.build(list("abcd"), state, ["c"], elems)
    table = system.step_table(np.zeros(1))
    ev = system.evaluate(state, table, 0, jacobian=True)
    J = system.dense_jacobian(ev)
    for sparse_above in (1000, 1):
        old = linalg.SPARSE_ABOVE
        linalg.SPARSE_ABOVE = sparse_above
        try:
            ne = linalg.NormalEquations(system.groups, M, system.n_rows)
        finally:
            linalg.SPARSE_ABOVE = old
        lin = ne.linearize(ev.jac)
        assert np.allclose(lin.gradient(ev.r), J.T @ ev.r, atol=1e-12)
        g = rng.normal(size=6 * M)
        x = ne.factor(lin.data, 0.0, 1e-3).solve(g)
        assert np.allclose((J.T @ J + 1e-3 * np.eye(6 * M)) @ x, g, atol=1e-9)


def test_sparse_factorization_reuses_its_ordering_and_reorders_for_new_nonzeros():
    """A kept ordering gives the same solutions; a pattern with new nonzeros gets a new ordering."""
    from linkedit.gcs import linalg

    rng = np.random.default_rng(5)
    M = 4
    planar = State(np.column_stack([rng.normal(size=(M, 2)), np.zeros(M)]),
                   quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), rng.uniform(0, 6, M)))
    z = (0.0, 0.0, 1.0)
    elems = [Elementary(k, 0, a, b, sa=sa, sb=sb) for a, b in [(0, WORLD), (0, 1), (1, 2), (2, 3), (3, WORLD)]
             for k, sa, sb in [("location", (1.0, 0.0, 0.0), (0.0, 0.5, 0.0)), ("axis", z, z)]]
    system = System.build(list("abcd"), planar, ["c"], elems)
    table = system.step_table(np.zeros(1))
    old = linalg.SPARSE_ABOVE
    linalg.SPARSE_ABOVE = 1
    try:
        ne = linalg.NormalEquations(system.groups, M, system.n_rows)
    finally:
        linalg.SPARSE_ABOVE = old
    spatial = State(planar.position + rng.normal(size=(M, 3)) * 0.1, quat.normalize(rng.normal(size=(M, 4))))
    orderings = []
    for state in (planar, planar.moved(0.01 * np.tile([1.0, 1.0, 0.0, 0.0, 0.0, 1.0], M)), spatial):
        ev = system.evaluate(state, table, 0, jacobian=True)
        J = system.dense_jacobian(ev)
        g = rng.normal(size=6 * M)
        x = ne.factor(ne.linearize(ev.jac).data, 0.0, 1e-3).solve(g)
        assert np.allclose((J.T @ J + 1e-3 * np.eye(6 * M)) @ x, g, atol=1e-9)
        orderings.append(ne.ordering)
    # the planar pattern (in-plane and out-of-plane unknowns decoupled) is kept for the second
    # planar state; the spatial state couples them: a new ordering
    assert orderings[1] is orderings[0] and orderings[2] is not orderings[1]
    assert orderings[2].pattern.sum() > orderings[0].pattern.sum()


def test_input_outside_its_window_adds_nothing_and_driven_points_follow_their_schedule():
    from linkedit.gcs.inputs import Schedule

    rng = np.random.default_rng(9)
    state = _random_state(rng, 1)
    schedule = Schedule(mode="vector", window=(0.25, 0.75), times=np.array([0.25, 0.75]),
                        values=np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.0]]))
    elems = [Elementary("axis", 0, 0, WORLD, sa=(0.0, 0.0, 1.0), sb=(0.0, 0.0, 1.0)),
             Elementary("location", 1, 0, WORLD, sa=(1.0, 0.0, 0.0), sb=(0.0, 0.0, 0.0), schedule=schedule)]
    system = System.build(["m"], state, ["pin axis", "drive"], elems)
    t = np.array([0.0, 0.5, 1.0])
    table = system.step_table(t)
    tip = state.position[0] + quat.rotate(state.orientation[0], np.array([1.0, 0.0, 0.0]))
    drive = system.row_owner == 1
    for k in range(3):
        ev = system.evaluate(state, table, k, jacobian=True)
        J = system.dense_jacobian(ev)
        if k == 1:
            assert np.allclose(ev.r[drive], tip - [0.5, 1.0, 0.0], atol=1e-14)
            assert np.abs(J[drive]).max() > 0.5
        else:
            assert np.all(ev.r[drive] == 0.0) and np.all(J[drive] == 0.0)
        assert np.abs(ev.r[~drive]).max() > 1e-3  # the axis constraint is always active


def test_axis_residual_is_finite_for_exactly_opposite_axes():
    import numpy as np

    from linkedit.gcs.constraints import axis

    wa = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    wb = -wa
    out = np.empty((2, 3))
    jac = axis(wa, wb, out, jacobian=True)
    assert np.isfinite(out).all() and np.isfinite(jac).all()
    assert np.allclose(np.linalg.norm(out, axis=1), np.pi)  # cost arccos²(−1) = π²
    assert np.allclose((out * wa).sum(axis=1), 0.0)  # a rotation about an axis ⊥ a
