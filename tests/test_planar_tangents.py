"""Rest-pose tangents of the new rules (sliders, linear input, numeric groups) against central differences."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.planar import catalog, simulate
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import order_joints
from linkedit.planar.rules import compile_steps
from linkedit.spec.linkage import LinkageSpec
from tests.test_planar_sliders import piston_driven


def moved(spec: LinkageSpec, drest: np.ndarray, h: float) -> LinkageSpec:
    data = spec.model_dump()
    data["joints"] = {n: (x + h * d.real, y + h * d.imag) for (n, (x, y)), d in zip(spec.joints.items(), drest)}
    return LinkageSpec.model_validate(data)


def complex_positions(spec: LinkageSpec, samples: int) -> np.ndarray:
    p = simulate(spec, samples).positions
    return (p[..., 0] + 1j * p[..., 1]).T  # (J, T)


@pytest.mark.parametrize("build", [catalog.slider_crank, catalog.quick_return, catalog.complex_loop,
                                   catalog.lifting_arm, catalog.stephenson_slider, catalog.scotch_yoke,
                                   catalog.inverted_slider_crank, piston_driven], ids=lambda b: b.__name__)
def test_rest_tangent_of_every_new_rule_matches_central_differences(build):
    spec = build()
    graph = LinkageGraph.from_spec(spec)
    ordering = order_joints(graph)
    initial = set(graph.ground) | ({graph.motor} if graph.pivot >= 0 else set())
    steps = compile_steps(graph, ordering.steps, initial, {r.k: r.level for r in ordering.rules})
    assert steps
    rng = np.random.default_rng(7)
    size = np.abs(graph.rest).max()
    drest = size * (rng.normal(size=(graph.n_joints, 3)) + 1j * rng.normal(size=(graph.n_joints, 3)))  # 3 directions at once
    h = 1e-7
    samples = 24
    z = complex_positions(spec, samples)
    dz = np.stack([(complex_positions(moved(spec, d, h), samples) - complex_positions(moved(spec, d, -h), samples)) / (2 * h)
                   for d in drest.T], axis=1)  # (J, C, T)
    for step in steps:
        got = step.rest_tangent(graph, z, dz, drest)
        for c in range(drest.shape[1]):
            want = dz[step.joints, c]
            assert np.abs(got[:, c] - want).max() <= 1e-5 * np.abs(want).max(), (step.kind, step.name, c)
            # all directions at once give each one's tangent as along it alone, bit for bit (edit's steps)
            alone = step.rest_tangent(graph, z, dz[:, c:c + 1], drest[:, c:c + 1])
            assert np.array_equal(got[:, c:c + 1], alone), (step.kind, step.name, c)
