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


# A four-bar that cannot turn its crank fully (crank 3, coupler 2, rocker 2.5, ground 4): the
# crank tip reaches the rocker's reach only while |A - D| <= 2 + 2.5, i.e. cos θ >= 0.1979, θ <= 78.58°.
# It starts at θ = 40° and turns 5° per step (73 steps): step 7 (75°) assembles, step 8 (80°) cannot.
NON_GRASHOF = """\
name: short-crank
units: m
shapes:
  crank: {points: {O: [0, 0, 0], A: [2.298133329356934, 1.9283628290596178, 0]}}
  coupler: {points: {A: [2.298133329356934, 1.9283628290596178, 0], B: [4.2175026795770805, 2.490520544861413, 0]}}
  rocker: {points: {D: [4, 0, 0], B: [4.2175026795770805, 2.490520544861413, 0]}}
members: {crank: {shape: crank}, coupler: {shape: coupler}, rocker: {shape: rocker}}
joints:
  O: {type: revolute, members: [crank, world], at: [0, 0, 0], axis: [0, 0, 1]}
  A: {type: revolute, members: [coupler, crank], at: [2.298133329356934, 1.9283628290596178, 0], axis: [0, 0, 1]}
  B: {type: revolute, members: [rocker, coupler], at: [4.2175026795770805, 2.490520544861413, 0], axis: [0, 0, 1]}
  D: {type: revolute, members: [rocker, world], at: [4, 0, 0], axis: [0, 0, 1]}
inputs:
  drive: {type: orientation, member: crank, rotation: {axis: [0, 0, 1], angles_deg: [0, 360]}}
outputs: {steps: 73}
"""


def test_solve3d_that_cannot_assemble_raises_naming_the_step_unless_partial(tmp_path):
    """``le.solve3d`` returned the unassembled least-squares poses of steps 8..72 as a Solution, without
    a word (the CLI exits 1 there); like ``le.simulate`` it raises unless asked for a partial result."""
    from linkedit.errors import MechanismError

    spec = tmp_path / "short-crank.yaml"
    spec.write_text(NON_GRASHOF)
    with pytest.raises(MechanismError, match=r"short-crank: inconsistent at step 8 \(t = 0\.1111\)"):
        le.solve3d(spec)
    partial = le.solve3d(spec, partial=True)
    status = partial.diagnostics.status
    reach = np.cos(np.radians(40 + 5 * np.arange(73))) >= (3**2 + 4**2 - 4.5**2) / (2 * 3 * 4)
    assert np.array_equal(status == 0, reach)  # steps 8..48 fail, the crank is back in reach from 49 (285°)
    assert np.isfinite(partial.position).all()


@pytest.mark.parametrize("call", [
    lambda: le.simulate(EXAMPLES / "crank-rocker.yaml", 0),       # was the default 360 samples
    lambda: le.simulate(EXAMPLES / "crank-rocker.yaml", -5),      # was a Motion of 0 samples
    lambda: le.simulate(EXAMPLES / "crank-rocker.yaml", 2.5),     # was 3 samples
    lambda: le.solve3d(EXAMPLES / "3d" / "crank-rocker.yaml", steps=0),    # was the spec's 361
    lambda: le.solve3d(EXAMPLES / "3d" / "crank-rocker.yaml", steps=4.5),
    lambda: le.features(EXAMPLES / "curves" / "foot-paths.yaml", samples=1),    # was length 0.0 for every curve
    lambda: le.features(EXAMPLES / "curves" / "foot-paths.yaml", samples=0),    # was the default
    lambda: le.features(EXAMPLES / "curves" / "foot-paths.yaml", harmonics=-1),  # was numpy's "negative dimensions"
    lambda: le.features(),                                                       # was KeyError 'pop from an empty set'
], ids=["simulate-0", "simulate-negative", "simulate-fraction", "solve3d-0", "solve3d-fraction",
        "features-1-sample", "features-0-samples", "features-negative-harmonics", "features-none"])
def test_counts_out_of_range_are_input_errors(call):
    """A count the CLI refuses (``--samples 0``, ``--steps 0``, ``-n 1``, ``--harmonics -1``) is a
    clear InputError from the library too, naming the argument, not a default or a wrong answer."""
    from linkedit.errors import InputError

    with pytest.raises(InputError, match=r"samples|steps|harmonics|curve"):
        call()


def test_a_path_argument_that_is_not_a_path_is_a_type_error():
    """``le.simulate(42)`` read (and closed) file descriptor 42 ('Bad file descriptor' at best)."""
    for call in (lambda: le.simulate(42), lambda: le.solve3d(7), lambda: le.edit(EXAMPLES / "jansen.yaml", 3)):
        with pytest.raises(TypeError, match="path"):
            call()


def test_a_solution_written_from_a_notebook_records_its_spec(tmp_path):
    """Every result file records the spec it came from: a ``le.solve3d`` Solution written with
    ``linkedit.io.gcs_hdf5.write_result`` had ``spec = ''`` (from a path and from a loaded spec)."""
    import h5py
    import yaml

    from linkedit.io.gcs_hdf5 import write_result
    from linkedit.spec.mechanism3d import MechanismSpec
    from linkedit.spec.yamlload import load_model, validate

    path = EXAMPLES / "3d" / "rssr.yaml"
    model = load_model(MechanismSpec, path)
    for given, out in ((path, tmp_path / "a.h5"), (model, tmp_path / "b.h5")):
        write_result(out, le.solve3d(given, steps=5))
        with h5py.File(out) as f:
            text = f.attrs["spec"]
        assert validate(MechanismSpec, yaml.safe_load(text), file=str(out)) == model
    with h5py.File(tmp_path / "a.h5") as f:
        assert f.attrs["spec"] == path.read_text(encoding="utf-8")


def test_xarray_of_a_linear_input_is_its_stroke_in_length_units():
    """A cylinder-driven linkage's to_xarray() called its stroke (0..25 mm) ``motor_angle`` in rad and
    its velocities mm/rad; the HDF5 file and CSV have ``stroke`` in mm and velocities per mm."""
    pytest.importorskip("xarray")
    m = le.simulate(EXAMPLES / "lifting-arm.yaml", 5)
    ds = m.to_xarray()
    assert "motor_angle" not in ds and ds["stroke"].attrs["units"] == "mm"
    assert np.allclose(ds["stroke"].values, [0, 6.25, 12.5, 18.75, 25])  # motor: stroke [0, 25], 5 samples
    assert ds["velocity"].attrs["units"] == "mm/mm" and ds["acceleration"].attrs["units"] == "mm/mm**2"
    rotary = le.simulate(EXAMPLES / "crank-rocker.yaml", 4).to_xarray()
    assert rotary["motor_angle"].attrs["units"] == "rad" and rotary["velocity"].attrs["units"] == "mm/rad"


def test_load_reads_the_slider_and_group_singularities_back(run_cli, tmp_path):
    """le.load left out the file's /diagnostics/step_singularity, so a slider-crank read back lost
    its slider's d_s: no ``min d_s`` in its summary, and rule_ds() all 1 where the slider's rod
    comes nearest the slot normal (d_s 0.791 at 36 samples)."""
    for spec in ("slider-crank.yaml", "complex-loop.yaml"):
        out = tmp_path / spec.replace(".yaml", ".h5")
        assert run_cli("simulate", EXAMPLES / spec, "-o", out, "-n", "36", "-q").exit_code == 0
        m, back = le.simulate(EXAMPLES / spec, 36), le.load(out)
        assert m.step_singularity is not None and np.array_equal(back.step_singularity, m.step_singularity)
        assert repr(back) == repr(m) and back.summary() == m.summary()


def test_load_of_a_partial_result_keeps_its_lock_ups(run_cli, tmp_path):
    """The locking slider-crank (crank 20, rod 25, offset 12) cannot close where 20 sin θ < −13:
    θ in (180° + asin(13/20), 360° − asin(13/20)), piston B to blame. ``le.load`` of its
    ``--partial`` result gives that lock-up back, as ``le.simulate`` had it."""
    spec, out = EXAMPLES / "invalid" / "locking-slider-crank.yaml", tmp_path / "lock.h5"
    assert run_cli("simulate", spec, "-o", out, "-n", "72", "--partial").exit_code == 0
    back, m = le.load(out), le.simulate(spec, 72, partial=True)
    assert back.lockups == m.lockups and len(back.lockups) == 1
    lk = back.lockups[0]
    edge = np.degrees(np.arcsin(13 / 20))
    assert abs(lk.start_deg - (180 + edge)) < 1e-6 and abs(lk.end_deg - (360 - edge)) < 1e-6
    assert lk.joint == "B" and lk.unit == "°"
    assert "1 lock-up(s)" in repr(back) and back.summary()["lockups"] == m.summary()["lockups"]


@pytest.mark.parametrize("bad", ["not json", '[{"start": 1}]', "[5]"])
def test_load_refuses_a_damaged_lockup_list_in_one_line(run_cli, tmp_path, bad):
    """A result whose ``lockup_intervals`` attribute is not the list simulate wrote is an InputError naming it."""
    import h5py

    from linkedit.errors import InputError

    out = tmp_path / "lock.h5"
    spec = EXAMPLES / "invalid" / "locking-slider-crank.yaml"
    assert run_cli("simulate", spec, "-o", out, "-n", "12", "--partial").exit_code == 0
    with h5py.File(out, "a") as f:
        f["diagnostics"].attrs["lockup_intervals"] = bad
    with pytest.raises(InputError, match="lockup_intervals"):
        le.load(out)
