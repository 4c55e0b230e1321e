"""``synthesize`` against a family built to a margin below the band asked for (a complex loop's own lowest d_s)."""

from __future__ import annotations

import numpy as np

from linkedit.planar import compile_plan, simulate
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES


def test_a_complex_loop_atlas_at_the_default_band_names_the_margin_it_was_built_to(run_cli, tmp_path):
    """The complex-loop family keeps its design's own lowest d_s (0.090 < sin²20°): the default --margin 20 finds
    no linkage, and the one line says which --margin reaches the family (it said to rebuild the atlas, which
    cannot help)."""
    spec = EXAMPLES / "complex-loop.yaml"
    assert run_cli("atlas", "build", "--family", spec, "-n", "6", "-o", tmp_path / "a.h5", "-q").exit_code == 0
    curve = simulate(compile_plan(load_model(LinkageSpec, spec)), 120).tracks["body_tip"].position
    np.savetxt(tmp_path / "t.csv", curve, delimiter=",", header="x,y", comments="")
    r = run_cli("synthesize", tmp_path / "t.csv", "--atlas", tmp_path / "a.h5", "-o", tmp_path / "out")
    assert r.exit_code == 1 and len(r.output.strip().splitlines()) == 1, r.output
    assert "'complex-loop'" in r.output and "--margin 17.4 or less" in r.output and "rebuild" not in r.output
    assert not (tmp_path / "out").exists()
