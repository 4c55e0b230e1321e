"""`linkedit edit` bad scripts: one clear line naming file, line and field; exit 2."""

from __future__ import annotations

import re

import pytest

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
