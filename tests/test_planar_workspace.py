"""A reused Workspace: what it keeps between calls (compiled kernels, constants spread over the
samples, the evaluation frame) follows the geometry it is called with."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.planar import catalog
from linkedit.planar.kinematics import Workspace, evaluate, positions
from linkedit.planar.plan import compile_plan
from linkedit.planar.simulate import motor_angles


def _two_geometries():
    """Strandbeest (3 pairs) at its rest pose and with its last joint moved (other link lengths)."""
    spec = catalog.strandbeest(3)
    plan = compile_plan(spec)
    g1 = plan.geometry()
    joints = g1.rest[: plan.n_joints]  # (J,) complex, spec order
    moved = np.column_stack([joints.real, joints.imag])
    moved[-1] += 0.01 * np.abs(joints).max()
    return spec, plan, g1, plan.geometry(moved)


def test_positions_follow_each_geometry_on_one_workspace():
    spec, plan, g1, g2 = _two_geometries()
    angle = motor_angles(spec, 90)[1]
    work = Workspace(plan, angle.size)
    fresh = [positions(plan, g, angle).copy() for g in (g1, g2)]
    assert not np.allclose(fresh[0], fresh[1])
    for g, want in ((g1, fresh[0]), (g2, fresh[1]), (g1, fresh[0])):
        assert np.array_equal(positions(plan, g, angle, work), want, equal_nan=True)


def test_positions_of_a_plan_with_steps_fill_the_workspace():
    """A slider-crank (a slider step): positions with a workspace are written into it (its ``z``,
    nothing allocated per sample row), as for the batched rules, with the bits of a fresh call."""
    spec = catalog.slider_crank()
    plan = compile_plan(spec)
    assert plan.steps
    geom = plan.geometry(plan.normalized_points())
    angle = motor_angles(spec, 90)[1]
    work = Workspace(plan, angle.size)
    fresh = positions(plan, geom, angle)
    got = positions(plan, geom, angle, work)
    assert np.shares_memory(got, work.z) and np.array_equal(got, fresh, equal_nan=True)


def test_evaluate_follows_each_geometry_on_one_workspace():
    spec, plan, g1, g2 = _two_geometries()
    angle = motor_angles(spec, 90)[1]
    work = Workspace(plan, angle.size, order=2)
    fresh = [evaluate(plan, g, angle, 2) for g in (g1, g2)]
    for g, want in ((g1, fresh[0]), (g2, fresh[1]), (g1, fresh[0])):
        got = evaluate(plan, g, angle, 2, work)
        for a, b in ((got.z, want.z), (got.dz, want.dz), (got.ddz, want.ddz), (got.ds, want.ds)):
            assert np.array_equal(a, b, equal_nan=True)


def test_one_linkage_constants_are_read_only():
    """A workspace keeps constants spread over the samples per constants tuple: changing them in
    place would go unseen, so they cannot be changed."""
    _, plan, g1, _ = _two_geometries()
    kinds = {rule.kind: const for rule, const in zip(plan.rules, g1.constants)}
    lik2, ljk2, half, _ = kinds["dyad"]
    for a in (lik2, ljk2, half, kinds["rigid"][0]):
        with pytest.raises(ValueError):
            a[...] = 0.0


def test_derivative_scratch_of_a_dyad_batch_is_its_rows_and_19_arrays():
    """An order-2 workspace's rule scratch (shared by the rules, the largest batch sets it): a
    dyad batch forms z_k − z_i and its rates in its own rows of the stacked orders, so beside
    them it holds z_i and e with their derivatives (2 × 3 complex; g = z_k − z_j where e was),
    w and then ġ (complex), d², 1/d², B², A, B: 19 real (R, T) arrays, where it held 31 (the
    offsets, the rates' products and g apart)."""
    spec = catalog.strandbeest(10)
    plan = compile_plan(spec)
    angle = motor_angles(spec, 360)[1]
    work = Workspace(plan, angle.size, order=2)
    rows = max(r.batch_rows() for r in plan.rules if r.kind == "dyad")
    pool = work.pair.base
    assert pool is not None and all(np.shares_memory(a, pool) for a in (work.e, work.w))
    assert pool.nbytes <= 19 * rows * angle.size * 8 + 64 * 16
    s = evaluate(plan, plan.geometry(), angle, 2, work)
    fresh = evaluate(plan, plan.geometry(), angle, 2)
    for a, b in ((s.z, fresh.z), (s.dz, fresh.dz), (s.ddz, fresh.ddz), (s.ds, fresh.ds)):
        assert np.array_equal(a, b)
