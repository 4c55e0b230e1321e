"""`linkedit edit` bad scripts: one clear line naming file, line and field; exit 2."""

from __future__ import annotations

import re

import pytest

from tests.conftest import EXAMPLES
from tests.planar_specs import FOURBAR

SCRIPT = """\
samples: 40
lock: [O]
weights: {edit: 1.0, singularity: 1.0, regularization: 0.01}
operations:
  - name: move
    preserve: [tip]
    displace: {joint: B, to: [2.0, 2.3]}
"""

BAD = [
    ("unknown joint", lambda s: s.replace("joint: B", "joint: Z"), r"^s\.yaml:7: operations\[0\]\.displace\.joint: unknown joint 'Z'"),
    ("unknown track", lambda s: s.replace("preserve: [tip]", "preserve: [toe]"), r"^s\.yaml:6: operations\[0\]\.preserve\[0\]: unknown track 'toe'"),
    ("xmin > xmax", lambda s: s + "    envelope: {xmin: 3, xmax: 1}\n", r"^s\.yaml:8: operations\[0\]\.envelope: xmin \(3\.0\) must be less than xmax"),
    ("negative weight", lambda s: s.replace("singularity: 1.0", "singularity: -1"), r"^s\.yaml:3: weights\.singularity: .*greater than or equal to 0"),
    ("phase outside [0,1)", lambda s: s.replace("to: [2.0, 2.3]}", "to: [2.0, 2.3], at: 1.5}"), r"^s\.yaml:7: operations\[0\]\.displace\.at: .*less than 1"),
    ("locked joint displaced", lambda s: s.replace("lock: [O]", "lock: [O, B]"), r"^s\.yaml:7: operations\[0\]\.displace\.joint: joint 'B' is locked"),
    ("no goal", lambda s: s.replace("    displace: {joint: B, to: [2.0, 2.3]}\n", ""), r"^s\.yaml:5: operations\[0\]: an operation needs a goal"),
    ("unknown key", lambda s: s.replace("preserve:", "preserv:"), r"^s\.yaml:6: operations\[0\]\.preserv: unknown field"),
    ("phases between samples", lambda s: s.replace("preserve: [tip]", "preserve: [{track: tip, phases: [0.51, 0.52]}]"), r"^s\.yaml:6: operations\[0\]\.preserve\[0\]\.phases: \[0\.51, 0\.52\] hold none of the 40 samples"),
    ("transform of no joints", lambda s: s + "    transform: {joints: [], scale: 0.9}\n", r"^s\.yaml:8: operations\[0\]\.transform\.joints: name at least one joint, or all"),
]


@pytest.mark.parametrize("case,mutate,pattern", BAD, ids=[b[0] for b in BAD])
def test_bad_script_one_line_exit_2(run_cli, tmp_path, monkeypatch, case, mutate, pattern):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "l.yaml").write_text(FOURBAR)
    (tmp_path / "s.yaml").write_text(mutate(SCRIPT))
    r = run_cli("edit", "l.yaml", "s.yaml", "-o", "out")
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.output
    assert re.search(pattern, lines[0].removeprefix("linkedit: error: ")), lines[0]
    assert not (tmp_path / "out").exists()


def test_script_without_linkage_needs_one(run_cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text(SCRIPT)
    r = run_cli("edit", "s.yaml")
    assert r.exit_code == 2 and "no linkage" in r.output


@pytest.mark.parametrize("operation, field", [
    ("displace: {joint: B, to: [63, 68]}", "displace.to"),
    ("drag: {track: coupler_point, at: 0.3, by: [0, 10], radius: 0.1}", "drag.by"),
    ("envelope: {ymax: 55}", "envelope"),  # a box 0.055 m above would hold nothing back: exit 0, nothing done
    ("follow: {track: coupler_point, curve: [[20, 40], [30, 50], [25, 60]], timing: false}", "follow.curve[0]"),
])
def test_a_script_in_mm_on_a_spec_in_m_is_refused_naming_the_units(run_cli, tmp_path, operation, field):
    """The crank-rocker in m (0.075 m across) and a script written for it in mm: the displacement was
    run (exit 1, 'goal not met: 92.6 m'; exit 0 with --best-effort and a distorted linkage written)."""
    from tests.conftest import EXAMPLES

    text = (EXAMPLES / "crank-rocker.yaml").read_text().replace("units: mm", "units: m")
    spec = tmp_path / "m.yaml"
    spec.write_text(re.sub(r"-?\d+(\.\d+)?(?=[,\]])", lambda m: repr(float(m.group()) / 1000), text))
    script = tmp_path / "mm.yaml"
    script.write_text(f"lock: [O, D]\noperations:\n  - {operation}\n")
    r = run_cli("edit", spec, script, "-o", tmp_path / "out", "--best-effort")
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert f"mm.yaml:3: operations[0].{field}:" in line and "the spec is in m; is the script in other units?" in line
    assert "× the linkage's size (0.075 m)" in line and not (tmp_path / "out").exists()
    scaled = script.read_text().replace("[63, 68]", "[0.063, 0.068]")  # the same in m: accepted
    if scaled != script.read_text():
        script.write_text(scaled)
        assert run_cli("edit", spec, script, "-o", tmp_path / "out", "--best-effort").exit_code == 0


@pytest.mark.parametrize("out", ["-", "knee.h5", "knee.YAML"])
def test_edit_output_is_a_folder_not_stdout_or_a_file(run_cli, tmp_path, monkeypatch, out):
    """``edit`` writes three files into the folder ``-o``: ``-o -`` (standard output elsewhere) made a folder
    named ``-``, and ``-o knee.h5`` a folder named ``knee.h5``, both exit 0. Now one line, exit 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    r = run_cli("edit", EXAMPLES / "edits" / "jansen-move-knee.yaml", "-o", out)
    assert r.exit_code == 2 and "--output" in r.output and "folder" in r.output, r.output
    assert list(tmp_path.iterdir()) == []
