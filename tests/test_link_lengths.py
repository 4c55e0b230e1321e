"""Links given by length: closed-form assembly of the rest pose, `linkedit assemble`, errors."""

from __future__ import annotations

import math
import re

import h5py
import numpy as np
import pytest
import yaml

from tests.conftest import EXAMPLES

LENGTHS = EXAMPLES / "lengths" / "jansen.yaml"
#: Jansen's holy numbers (mm), the link lengths the assembled pose must reproduce
HOLY = {("O", "A"): 15, ("A", "C"): 50, ("A", "D"): 61.9, ("B", "C"): 41.5, ("B", "E"): 40.1, ("C", "E"): 55.8,
        ("B", "D"): 39.3, ("E", "F"): 39.4, ("D", "F"): 36.7, ("D", "G"): 49, ("F", "G"): 65.7}


def _cross(p, q, r):
    return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])


def test_length_given_jansen_assembles_to_the_holy_number_rest_pose(run_cli, tmp_path):
    out = tmp_path / "posed.yaml"
    r = run_cli("assemble", LENGTHS, "-o", out)
    assert r.exit_code == 0, r.output
    posed = yaml.safe_load(out.read_text())
    j = {n: tuple(v) for n, v in posed["joints"].items()}
    for (a, b), length in HOLY.items():
        assert abs(math.dist(j[a], j[b]) - length) < 1e-9, (a, b)
    assert j["O"] == (0, 0) and j["B"] == (-38, -7.8) and j["A"] == (15, 0)
    # the branches the file asks for: C right of A→B, D left of it, E left of B→C, G left of D→F
    assert _cross(j["A"], j["B"], j["C"]) < 0 < _cross(j["A"], j["B"], j["D"])
    assert _cross(j["B"], j["C"], j["E"]) > 0 and _cross(j["D"], j["F"], j["G"]) > 0
    exact = yaml.safe_load((EXAMPLES / "jansen.yaml").read_text())["joints"]
    for n, p in exact.items():
        assert math.dist(p, j[n]) < 1e-9, n
    assert posed["links"]["upper"] == ["B", "C", "E"]


def test_length_given_spec_simulates_like_the_coordinate_spec(run_cli, tmp_path):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    assert run_cli("simulate", LENGTHS, "-o", a, "-n", "120").exit_code == 0
    assert run_cli("simulate", EXAMPLES / "jansen.yaml", "-o", b, "-n", "120").exit_code == 0
    with h5py.File(a) as fa, h5py.File(b) as fb:
        assert np.abs(fa["joints/position"][()] - fb["joints/position"][()]).max() < 1e-9
        assert fa.attrs["spec"] == LENGTHS.read_text()


def test_posed_yaml_reloads_to_the_same_doubles(run_cli, tmp_path):
    out = tmp_path / "posed.yaml"
    assert run_cli("assemble", LENGTHS, "-o", out).exit_code == 0
    again = tmp_path / "again.yaml"
    assert run_cli("assemble", out, "-o", again).exit_code == 0  # a posed spec passes through unchanged
    from linkedit.spec import load_model
    from linkedit.spec.linkage import LinkageSpec

    assert load_model(LinkageSpec, out).joints == load_model(LinkageSpec, LENGTHS).joints
    assert load_model(LinkageSpec, again).joints == load_model(LinkageSpec, out).joints


def test_near_picks_the_nearer_branch_and_branch_mirrors(tmp_path):
    from linkedit.spec import load_model
    from linkedit.spec.linkage import LinkageSpec

    text = LENGTHS.read_text()
    near = text.replace("C: {from: [A, B], branch: cw}", "C: {near: [-20, 30]}")
    mirror = text.replace("C: {from: [A, B], branch: cw}", "C: {from: [A, B], branch: ccw}") \
                 .replace("E: {from: [B, C], branch: ccw}", "E: {near: [-60, -80]}")
    base = load_model(LinkageSpec, LENGTHS).joints
    (tmp_path / "n.yaml").write_text(near)
    (tmp_path / "m.yaml").write_text(mirror)
    assert math.dist(load_model(LinkageSpec, tmp_path / "n.yaml").joints["C"], base["C"]) < 1e-12
    c = load_model(LinkageSpec, tmp_path / "m.yaml").joints["C"]
    assert c[1] < 0 and _cross((15, 0), (-38, -7.8), c) > 0


def test_brace_length_is_the_rest_pose_distance():
    j = yaml.safe_load((EXAMPLES / "jansen.yaml").read_text())["joints"]
    assert abs(math.dist(j['E'], j['G']) - 104.78910576) < 1e-8


@pytest.mark.parametrize("old, new, pattern", [
    ("rocker: {joints: [B, D], length: 39.3}", "rocker: {joints: [B, D], length: 39.3}\n  extra: {joints: [D, B], length: 40}",
     r":\d+: links\.extra: conflicting lengths: D-B is 40 here but 39\.3 on link rocker"),
    ("knee: {joints: [E, F], length: 39.4}", "knee: {joints: [E, F], length: 39.4}\n  brace: {joints: [E, G], length: 80}",
     r":\d+: links\.brace: conflicting lengths: E-G is 80 but .* make it 104\.7891057"),  # |EG| in jansen.yaml
    ("knee: {joints: [E, F], length: 39.4}", "knee: {joints: [E, F], length: 3}",
     r":\d+: joints\.F: cannot be assembled: F-\w = [\d.]+ and F-\w = [\d.]+ cannot close a triangle"),
    ("G: {from: [D, F], branch: ccw}", "G: {from: [D, F]}", r":\d+: joints\.G: from two joints needs branch"),
    ("lengths: [36.7, 49, 65.7]", "lengths: [36.7, 49]", r":\d+: links\.lower: lengths needs 3 values"),
    ("crank: {joints: [O, A], length: 15}", "crank: {joints: [O, A], length: -15}", r":\d+: links\.crank(\.length)?: "),
    ("crank: {joints: [O, A], length: 15}", "crank: {joints: [O, O], length: 15}",
     r":\d+: links\.crank: a joint is listed twice"),  # was 'joints.A.from: no link gives the length O-A'
    ("F: {near: [-59, -28]}", "F: {near: [-59, -28]}\n  H: {near: [0, 9]}",
     r":\d+: joints\.H: joint 'H' cannot be placed"),
])
def test_bad_lengths_one_line_exit_2(run_cli, tmp_path, old, new, pattern):
    text = LENGTHS.read_text()
    assert old in text
    spec = tmp_path / "bad.yaml"
    spec.write_text(text.replace(old, new))
    for command in ("assemble", "simulate"):
        r = run_cli(command, spec, "-o", tmp_path / ("x.yaml" if command == "assemble" else "x.h5"))
        assert r.exit_code == 2, r.output
        assert re.search(pattern, r.output), r.output
        assert len(r.output.strip().splitlines()) == 1


SLIDER = """name: slider
units: mm
joints:
  A: [0, 0]
  L1: [-10, -5]
  L2: [40, 3]
  B: {from: [A], angle_deg: 90}
  P: {line: [L1, L2], near: NEAR}
ground: [A, L1, L2]
links:
  crank: {joints: [A, B], length: 10}
  rod: {joints: [B, P], length: 30}
sliders:
  P: {joint: P, guide: ground, angle_deg: 9.090276920822323}
motor: {joint: B, pivot: A}
"""


@pytest.mark.parametrize("near, sign", [("[30, 0]", 1), ("[-30, 0]", -1)])
def test_line_places_a_joint_on_a_line_at_its_length(tmp_path, near, sign):
    """``{line: [L1, L2], near: …}``: on the line L1-L2 at the rod's 30 from B = (0, 10), the crossing nearer
    ``near``: foot F of the perpendicular from B plus or minus √(30² − |BF|²) along the line."""
    from linkedit.spec import load_model
    from linkedit.spec.linkage import LinkageSpec

    (tmp_path / "s.yaml").write_text(SLIDER.replace("NEAR", near))
    p = load_model(LinkageSpec, tmp_path / "s.yaml").joints["P"]
    u = complex(50, 8) / abs(complex(50, 8))
    foot = -10 - 5j + u * ((10j - (-10 - 5j)) * u.conjugate()).real
    want = foot + sign * u * math.sqrt(900 - abs(10j - foot) ** 2)
    assert abs(complex(*p) - want) < 1e-12


@pytest.mark.parametrize("old, new, pattern", [
    ("P: {line: [L1, L2], near: NEAR}", "P: {line: [L1, L2]}", r":\d+: joints\.P: line: \[P, Q\] needs near"),
    ("P: {line: [L1, L2], near: NEAR}", "P: {line: [L1, L1], near: [30, 0]}",
     r":\d+: joints\.P\.line: the line it slides on has no direction"),
    ("L1: [-10, -5]\n  L2: [40, 3]", "L1: [-10, 70]\n  L2: [40, 70]",  # 60 above B
     r":\d+: joints\.P: cannot be assembled: P-B = 30 cannot reach the line it slides on \(60 from B\)"),
])
def test_bad_line_one_line_exit_2(run_cli, tmp_path, old, new, pattern):
    (tmp_path / "bad.yaml").write_text(SLIDER.replace(old, new).replace("NEAR", "[30, 0]"))
    r = run_cli("simulate", tmp_path / "bad.yaml", "-o", tmp_path / "x.h5")
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(pattern, r.output), r.output


FOURBAR = """name: fourbar
units: mm
joints:
  O: [X0, Y0]
  B: [X1, Y0]
  A: {from: [O], angle_deg: 60}
  C: {from: [A, B], branch: ccw}
ground: [O, B]
links:
  frame: {joints: [O, B], length: FRAME}
  crank: {joints: [O, A], length: 10}
  coupler: {joints: [A, C], length: 35}
  rocker: {joints: [B, C], length: 30}
motor: {joint: A, pivot: O}
"""


def _fourbar(tmp_path, x0: float, frame: str, x1: float | None = None, y0: str | None = None):
    text = (FOURBAR.replace("X0", repr(x0)).replace("X1", repr(x0 + 40 if x1 is None else x1))
            .replace("Y0", y0 or repr(x0)).replace("FRAME", frame))
    (tmp_path / "f.yaml").write_text(text)
    return tmp_path / "f.yaml"


@pytest.mark.parametrize("offset", [0.0, 1e7])
def test_a_conflicting_length_is_refused_however_far_the_linkage_lies_from_the_origin(run_cli, tmp_path, offset):
    """The frame O-B is 40 by its positions; a length of 40.01 (2.5e-4 of it) contradicts them, 14,000 km
    from the origin as at it (the check was relative to the distance from the origin: 0.014 there)."""
    r = run_cli("validate", _fourbar(tmp_path, offset, "40.01"))
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(r"f\.yaml:10: links\.frame: conflicting lengths: B-O is 40\.01 but .* make it 40\b", r.output), r.output
    r = run_cli("validate", _fourbar(tmp_path, offset, "40"))
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("y0", ["true", "false"])
def test_a_boolean_coordinate_is_refused_in_a_length_given_spec(run_cli, tmp_path, y0):
    """``[40, true]`` is not [40, 1] (YAML reads true as a boolean): refused as in a coordinate spec."""
    r = run_cli("validate", _fourbar(tmp_path, 0.0, "40", y0=y0))
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(r"f\.yaml:4: joints\.O\[1\]: ", r.output), r.output


def test_a_conflicting_length_is_said_with_the_digits_that_differ(run_cli, tmp_path):
    """40.000001 against 40 was said as "B-O is 40 but … make it 40"."""
    r = run_cli("validate", _fourbar(tmp_path, 0.0, "40.000001"))
    assert r.exit_code == 2, r.output
    assert "B-O is 40.000001 but the other lengths and positions make it 40\n" in r.output, r.output


@pytest.mark.parametrize("old, new, pattern", [
    ("A: {from: [O], angle_deg: 60}", "A: {from: [Z], angle_deg: 60}", r"f\.yaml:6: joints\.A\.from\[0\]: 'Z' is an unknown joint"),
    ("C: {from: [A, B], branch: ccw}", "C: {from: [A, C], branch: ccw}", r"f\.yaml:7: joints\.C\.from\[1\]: 'C' is the joint itself"),
    ("C: {from: [A, B], branch: ccw}", "C: {line: [O, b], near: [30, 0]}", r"f\.yaml:7: joints\.C\.line\[1\]: 'b' is an unknown joint"),
])
def test_a_placement_naming_an_unknown_joint_says_so(run_cli, tmp_path, old, new, pattern):
    """A misspelt joint in ``from``/``line`` was 'cannot be placed: it needs links with lengths to two placed joints'."""
    spec = _fourbar(tmp_path, 0.0, "40")
    spec.write_text(spec.read_text().replace(old, new))
    r = run_cli("validate", spec)
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(pattern, r.output), r.output


@pytest.mark.parametrize("angle, ok", [("9.090276920822323", True), ("189.09027692082232", True), ("10", False),
                                       ("0", False)])
def test_a_slot_not_along_the_line_its_joint_is_placed_on_is_refused(run_cli, tmp_path, angle, ok):
    """P is placed on the line L1-L2 (atan(8/50) = 9.0903°); a slider slot at 10° moved it along another line
    than the one it was placed on (exit 0)."""
    text = SLIDER.replace("NEAR", "[30, 0]").replace("angle_deg: 9.090276920822323", f"angle_deg: {angle}")
    (tmp_path / "s.yaml").write_text(text)
    r = run_cli("validate", tmp_path / "s.yaml")
    if ok:
        assert r.exit_code == 0, r.output
        return
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(r"s\.yaml:14: sliders\.P\.angle_deg: the slot points at [\d.]+° but joint 'P' is placed on the "
                     r"line L1-L2 \(9\.09027692082°", r.output), r.output


@pytest.mark.parametrize("scale", [1e-200, 1e-160, 1e160, 1e200])
def test_length_given_specs_assemble_at_any_magnitude_a_double_holds(tmp_path, scale):
    """The four-bar and the line-placed slider scaled by 1e±200 assemble to their rest poses scaled (the
    squares of the lengths under- or overflowed: 'conflicting lengths … make it 0', 'cannot close a
    triangle'), as their coordinate specs load and simulate at that scale."""
    from linkedit.spec import load_model
    from linkedit.spec.linkage import LinkageSpec

    def scaled(text: str) -> str:
        return re.sub(r"(?<=[\[ ])(?<!angle_deg: )-?\d+(\.\d+)?(?=[,\]}\n])", lambda m: repr(float(m.group(0)) * scale), text)

    for text in (FOURBAR.replace("X0", "0").replace("X1", "40").replace("Y0", "0").replace("FRAME", "40"),
                 SLIDER.replace("NEAR", "[30, 0]")):
        (tmp_path / "a.yaml").write_text(text)
        (tmp_path / "b.yaml").write_text(scaled(text))
        want = load_model(LinkageSpec, tmp_path / "a.yaml").joints
        got = load_model(LinkageSpec, tmp_path / "b.yaml").joints
        for n, p in want.items():
            assert math.dist(p, (got[n][0] / scale, got[n][1] / scale)) < 1e-12, n
