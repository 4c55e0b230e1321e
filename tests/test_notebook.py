"""The notebook API: le.simulate / le.load / Motion's SVG, DataFrame and xarray views; le.edit,
le.solve3d, le.features."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import linkedit as le
from tests.conftest import EXAMPLES


def test_simulate_load_round_trip(run_cli, tmp_path):
    m = le.simulate(EXAMPLES / "jansen.yaml", 72)
    assert isinstance(m, le.Motion) and m.tracks["foot"].position.shape == (72, 2)
    out = tmp_path / "j.h5"
    assert run_cli("simulate", EXAMPLES / "jansen.yaml", "-o", out, "-n", "72").exit_code == 0
    back = le.load(out)
    assert isinstance(back, le.Motion) and back.plan.spec == m.plan.spec
    for name in ("t", "motor_angle", "positions", "velocity", "acceleration", "singularity", "transmission"):
        assert np.array_equal(getattr(back, name), getattr(m, name)), name
    assert np.array_equal(back.tracks["foot"].velocity, m.tracks["foot"].velocity)


def test_length_given_spec_and_repr_svg():
    m = le.simulate(EXAMPLES / "lengths" / "jansen.yaml", 24)
    root = ET.fromstring(m._repr_svg_().split("?>", 1)[1])
    assert root.tag.endswith("svg") and root.findall(".//{http://www.w3.org/2000/svg}polygon")


def test_dataframe_and_xarray(tmp_path, run_cli):
    pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    m = le.simulate(EXAMPLES / "crank-rocker.yaml", 30)
    df = m.to_dataframe()
    assert df.shape == (30, 1 + 4 * (len(m.plan.joint_names) + len(m.tracks)))
    assert np.array_equal(df["B_x"].to_numpy(), m.positions[:, m.plan.joint_names.index("B"), 0])
    ds = m.to_xarray()
    assert ds["position"].dims == ("t", "joint", "xy")
    assert float(ds["position"].sel(joint="B", xy="y")[5]) == m.positions[5, m.plan.joint_names.index("B"), 1]
    assert isinstance(ds, xr.Dataset)


def test_features_edit_and_solve3d(tmp_path, run_cli):
    out = tmp_path / "j.h5"
    assert run_cli("simulate", EXAMPLES / "jansen.yaml", "-o", out, "-n", "90").exit_code == 0
    table = le.features(f"{out}:foot", EXAMPLES / "curves" / "foot-paths.yaml")
    assert len(table) >= 2
    result = le.solve3d(EXAMPLES / "3d" / "compound-crank-rocker.yaml", steps=8)
    assert result.position.shape[0] == 8


def svg_root(text: str) -> ET.Element:
    root = ET.fromstring(text.split("?>", 1)[-1])
    assert root.tag.endswith("svg")
    return root


def test_results_print_one_line_and_draw_themselves():
    """A cell showing a result prints a summary line (it printed 134 KB for an edit, 28 KB for a 3D
    run), and Jupyter draws the picture the CLI writes (``_repr_svg_``)."""
    m = le.simulate(EXAMPLES / "jansen.yaml", 72)
    e = le.edit(EXAMPLES / "jansen.yaml", EXAMPLES / "edits" / "jansen-move-knee.yaml")
    s = le.solve3d(EXAMPLES / "3d" / "crank-rocker.yaml", steps=19)
    for result, words in ((m, ("jansen-leg", "72 samples")), (e, ("operation", "goal")), (s, ("19 steps", "converged 19"))):
        text = repr(result)
        assert len(text) < 200 and "\n" not in text and "array" not in text, text
        assert all(w in text for w in words), text
        assert svg_root(result._repr_svg_()).findall(".//{http://www.w3.org/2000/svg}path"), type(result)


def test_edit_from_a_notebook(run_cli, tmp_path):
    import yaml

    import linkedit.edit.runner  # noqa: F401  (the subpackage linkedit.edit, loaded: le.edit still edits)

    script = EXAMPLES / "edits" / "jansen-move-knee.yaml"
    result = le.edit(EXAMPLES / "jansen.yaml", script)
    assert run_cli("edit", EXAMPLES / "jansen.yaml", script, "-o", tmp_path).exit_code == 0
    cli = yaml.safe_load(next(tmp_path.glob("*-edited.yaml")).read_text())["joints"]
    assert {n: list(p) for n, p in result.edited.joints.items()} == {n: list(p) for n, p in cli.items()}


def test_import_linkedit_is_light():
    code = "import sys, linkedit; print('numpy' in sys.modules, 'scipy' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.split() == ["False", "False"]
