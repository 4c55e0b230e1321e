"""`linkedit import`: pyslvs/PMKS expressions and projects, pylinkage JSON → specs that simulate to
the trajectory computed here independently (circle intersections continued sample by sample)."""

from __future__ import annotations

import json
import math
import re
import time

import h5py
import numpy as np
import pytest
import yaml

from tests.conftest import EXAMPLES, ROOT


def _circles(p, rp, q, rq, previous):
    """The intersection of two circles nearest ``previous`` (how pyslvs and pylinkage follow a branch)."""
    d = q - p
    dist = abs(d)
    along = (rp * rp - rq * rq + dist * dist) / (2 * dist)
    across = math.sqrt(rp * rp - along * along)
    a, b = p + d / dist * complex(along, across), p + d / dist * complex(along, -across)
    return a if abs(a - previous) <= abs(b - previous) else b


def _reference(rest: dict[str, complex], pivot: str, crank: str, chain: list[tuple[str, str, str]],
               samples: int) -> dict[str, np.ndarray]:
    """Positions (T,) complex of every joint for a ccw crank turn; ``chain``: (joint, from, from)."""
    r = abs(rest[crank] - rest[pivot])
    theta0 = math.atan2((rest[crank] - rest[pivot]).imag, (rest[crank] - rest[pivot]).real)
    lengths = {(k, a): abs(rest[k] - rest[a]) for k, i, j in chain for a in (i, j)}
    now = dict(rest)
    out = {n: np.empty(samples, complex) for n in rest}
    for s in range(samples):
        now[crank] = rest[pivot] + r * complex(math.cos(theta0 + 2 * math.pi * s / samples),
                                               math.sin(theta0 + 2 * math.pi * s / samples))
        for k, i, j in chain:
            now[k] = _circles(now[i], lengths[(k, i)], now[j], lengths[(k, j)], now[k])
        for n in rest:
            out[n][s] = now[n]
    return out


def _simulated(run_cli, spec, tmp_path, samples):
    out = tmp_path / "sim.h5"
    r = run_cli("simulate", spec, "-o", out, "-n", str(samples))
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        names = f["joint"].asstr()[()]
        pos = f["joints/position"][()]
    return {n: pos[:, i, 0] + 1j * pos[:, i, 1] for i, n in enumerate(names)}


FOURBAR = ("M[J[R, color[Green], P[0.0, 0.0], L[ground, L1]], J[R, color[Green], P[12.92, 32.53], L[L1, L2]],"
           " J[R, color[Blue], P[73.28, 67.97], L[L2, L3]], J[R, color[Green], P[33.3, 66.95], L[L2]],"
           " J[R, color[Green], P[73.28, 0.0], L[ground, L3]]]")


def test_pyslvs_four_bar_expression(run_cli, tmp_path):
    spec = tmp_path / "fourbar.yaml"
    r = run_cli("import", FOURBAR, "--from", "pyslvs", "-o", spec)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(spec.read_text())
    assert doc["ground"] == ["P0", "P4"] and doc["motor"] == {"joint": "P1", "pivot": "P0"}
    assert doc["links"]["L2"] == ["P1", "P2", "P3"] and "P3" in doc["tracks"]
    got = _simulated(run_cli, spec, tmp_path, 180)
    rest = {"P0": 0j, "P1": 12.92 + 32.53j, "P2": 73.28 + 67.97j, "P3": 33.3 + 66.95j, "P4": 73.28 + 0j}
    ref = _reference(rest, "P0", "P1", [("P2", "P1", "P4"), ("P3", "P1", "P2")], 180)
    for n in rest:
        assert np.abs(got[n] - ref[n]).max() < 1e-9, n


def _jansen_expression() -> str:
    doc = yaml.safe_load((EXAMPLES / "jansen.yaml").read_text())
    on = {n: [lk for lk, members in doc["links"].items() if n in members] for n in doc["joints"]}
    parts = []
    for n, (x, y) in doc["joints"].items():
        links = (["ground"] if n in doc["ground"] else []) + on[n]
        parts.append(f"J[R, color[Green], P[{x!r}, {y!r}], L[{', '.join(links)}]]")
    return "M[\n  " + ",\n  ".join(parts) + "\n]"


def test_pyslvs_jansen_project_yaml(run_cli, tmp_path):
    project = tmp_path / "jansen.pyslvs"
    project.write_text(yaml.safe_dump({"pyslvs_ver": "21.12.0", "mechanism": _jansen_expression(),
                                       "links": {"ground": "White"}, "input": [[0, 1]]}))
    spec = tmp_path / "jansen.yaml"
    r = run_cli("import", project, "-o", spec, "--name", "jansen")
    assert r.exit_code == 0, r.output
    got = _simulated(run_cli, spec, tmp_path, 360)
    names = "OABCDEFG"
    exact = yaml.safe_load((EXAMPLES / "jansen.yaml").read_text())["joints"]
    rest = {f"P{i}": complex(*exact[n]) for i, n in enumerate(names)}
    # C, D from A and B; E from B, C; F from E, D; G from D, F
    chain = [("P3", "P1", "P2"), ("P4", "P1", "P2"), ("P5", "P2", "P3"), ("P6", "P5", "P4"), ("P7", "P4", "P6")]
    ref = _reference(rest, "P0", "P1", chain, 360)
    for n in rest:
        assert np.abs(got[n] - ref[n]).max() < 1e-9, n


def test_pyslvs_input_option_picks_the_motor(run_cli, tmp_path):
    spec = tmp_path / "s.yaml"
    r = run_cli("import", FOURBAR, "--input", "4,2", "-o", spec)
    assert r.exit_code == 0, r.output
    assert yaml.safe_load(spec.read_text())["motor"] == {"joint": "P2", "pivot": "P4"}


def _pylinkage_four_bar() -> list[dict]:
    """A Grashof crank-rocker as pylinkage 0.x saves it: crank B about A, pin C at 2.5 from B and 2 from D."""
    return [
        {"type": "Static", "name": "A", "x": 0.0, "y": 0.0},
        {"type": "Crank", "name": "B", "x": 0.0, "y": 1.0, "joint0": {"ref": "A"}, "distance": 1.0, "angle": 0.31},
        {"type": "Static", "name": "D", "x": 3.0, "y": 0.0},
        {"type": "Revolute", "name": "C", "x": 3.0, "y": 2.0, "joint0": {"ref": "B"}, "joint1": {"ref": "D"},
         "distance0": 2.5, "distance1": 2.0}]


def _imported(run_cli, tmp_path, data: dict, samples: int) -> dict:
    """``linkedit import`` of pylinkage JSON ``data`` (exit 0), simulated at ``samples``: each joint's positions."""
    src, spec = tmp_path / "pylinkage.json", tmp_path / "imported.yaml"
    src.write_text(json.dumps(data))
    r = run_cli("import", src, "-o", spec)
    assert r.exit_code == 0, r.output
    return _simulated(run_cli, spec, tmp_path, samples)


def test_pylinkage_json_four_bar(run_cli, tmp_path):
    data = {"name": "four-bar", "joints": _pylinkage_four_bar(), "solve_order": ["A", "B", "D", "C"]}
    got = _imported(run_cli, tmp_path, data, 120)
    # rest pose: C at exactly 2.5 from B and 2 from D, on the side of the saved (3, 2)
    c = _circles(1j, 2.5, 3 + 0j, 2.0, 3 + 2j)
    assert abs(got["C"][0] - c) < 1e-12
    ref = _reference({"A": 0j, "B": 1j, "D": 3 + 0j, "C": c}, "A", "B", [("C", "B", "D")], 120)
    for n in "ABCD":
        assert np.abs(got[n] - ref[n]).max() < 1e-9, n


@pytest.mark.parametrize("saved, angle", [(None, 0.5), ([5.0, 5.0], 0.5), ([5.0, 5.0], -0.7), ([5.0, 5.0], math.pi)],
                         ids=["no-xy", "stale-xy", "cw", "on-the-line"])
def test_pylinkage_json_fixed_joint_follows_its_distance_and_angle(run_cli, tmp_path, saved, angle):
    """A 0.x ``Fixed`` joint sits at ``distance`` from joint0, ``angle`` radians from the direction joint0 →
    joint1 (pylinkage's own rule); its x, y are only a cache, left null before a first simulation or
    saved from another pose. It was placed at its x, y: (0, 0) for null (refused as coinciding with A),
    the stale point (exit 0, 4.3 off)."""
    xy = {"x": saved[0], "y": saved[1]} if saved else {"x": None, "y": None}
    data = {"name": "four-bar", "joints": [*_pylinkage_four_bar(), {
        "type": "Fixed", "name": "E", **xy, "joint0": {"ref": "B"}, "joint1": {"ref": "C"}, "distance": 1.0,
        "angle": angle}]}
    got = _imported(run_cli, tmp_path, data, 120)
    ref = _reference({"A": 0j, "B": 1j, "D": 3 + 0j, "C": _circles(1j, 2.5, 3 + 0j, 2.0, 3 + 2j)}, "A", "B",
                     [("C", "B", "D")], 120)
    e = ref["B"] + (ref["C"] - ref["B"]) / np.abs(ref["C"] - ref["B"]) * np.exp(1j * angle)
    assert np.abs(got["E"] - e).max() < 1e-9


@pytest.mark.parametrize("source, pattern", [
    ("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]], J[P, A[30], P[1, 0], L[L1]]]",
     r"<expression>:1: column 80: joint P2 \(P\): a slider needs its slot link and a pinned link"),
    ("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]],\n J[RP, P[3, 0], L[ground, L2]]]",
     r"<expression>:2: column 2: joint P2 \(RP\): a slider needs its slot angle"),
    ("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]], J[P, A[0], P[3, 0], L[ground, L2, L3]]]",
     r"<expression>:1: column 79: joint P2 \(P\): a prismatic P joint imports with one moving pin link, not L2, L3"),
    ("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0 L[L1]]]", r"expected ',' or '\]'"),
    ("M[J[R, P[0, 0], L[ground]], J[R, P[1, 0], L[L1]]]", r"no revolute pair on a ground link"),
    ("M[", r"column 3: the expression ends too early"),  # the parser read past its end: StopIteration
    ("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1", r"ends too early|ends before its closing"),
])
def test_bad_sources_one_line_exit_2(run_cli, tmp_path, source, pattern):
    r = run_cli("import", source, "-o", tmp_path / "x.yaml")
    assert r.exit_code == 2, r.output
    assert len(r.output.strip().splitlines()) == 1 and re.search(pattern, r.output), r.output
    assert not (tmp_path / "x.yaml").exists()


# Offset slider-crank (crank r, rod l, slider line y = e); the slider joint B = P2.
R_, L_, E_ = 20.0, 70.0, 12.0
XB0 = R_ + math.sqrt(L_**2 - E_**2)


def _motor_angle(run_cli, spec, tmp_path, samples):
    got = _simulated(run_cli, spec, tmp_path, samples)
    with h5py.File(tmp_path / "sim.h5") as f:
        return got, f["motor_angle"][()]


@pytest.mark.parametrize("expression", [
    # RP: the rod L2 turns on the slider block pinned at B, which slides on the frame's horizontal slot
    f"M[J[R, P[0, 0], L[ground, L1]], J[R, P[{R_!r}, 0], L[L1, L2]], J[RP, A[0], P[{XB0!r}, {E_!r}], L[ground, L2]]]",
    # P: the block L3 slides on the frame without turning; the rod pinned to it at B; P3 a corner of the block
    f"M[J[R, P[0, 0], L[ground, L1]], J[R, P[{R_!r}, 0], L[L1, L2]], J[R, P[{XB0!r}, {E_!r}], L[L2, L3]],"
    f" J[P, A[0], P[{XB0 + 10!r}, {E_ - 5!r}], L[ground, L3]]]",
])
def test_pyslvs_slider_crank_follows_the_closed_form(run_cli, tmp_path, expression):
    spec = tmp_path / "slider.yaml"
    r = run_cli("import", expression, "-o", spec)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(spec.read_text())
    assert doc["motor"] == {"joint": "P1", "pivot": "P0"} and len(doc["sliders"]) == 1
    got, theta = _motor_angle(run_cli, spec, tmp_path, 144)
    assert np.allclose(theta, 2 * np.pi * np.arange(144) / 144, rtol=0, atol=1e-12)
    x_b = R_ * np.cos(theta) + np.sqrt(L_**2 - (R_ * np.sin(theta) - E_) ** 2)  # the textbook closed form
    assert np.abs(got["P2"] - (x_b + 1j * E_)).max() < 1e-9 * L_
    if "P3" in got:  # the block's corner moves with B, without turning
        assert np.abs(got["P3"] - got["P2"] - (10 - 5j)).max() < 1e-9 * L_


def test_pyslvs_inverted_slider_crank_follows_the_closed_form(run_cli, tmp_path):
    """pyslvs' "three bar" crank slider: the arm L2 turns about the crank pin A and slides through the
    ground pivot Q (an RP joint whose slot is on the arm); X is the arm's tip."""
    a0, q = complex(20.0, 0.0), complex(60.0, 0.0)
    u0 = (q - a0) / abs(q - a0)
    x0 = a0 + 75.0 * u0 * complex(math.cos(0.3), math.sin(0.3))  # a tip off the slot line
    angle = math.degrees(math.atan2(u0.imag, u0.real))
    expression = (f"M[J[R, P[0, 0], L[ground, L1]], J[R, P[{a0.real!r}, 0], L[L1, L2]],"
                  f" J[RP, A[{angle!r}], P[{q.real!r}, {q.imag!r}], L[L2, ground]],"
                  f" J[R, P[{x0.real!r}, {x0.imag!r}], L[L2]]]")
    spec = tmp_path / "inverted.yaml"
    r = run_cli("import", expression, "-o", spec)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(spec.read_text())
    assert doc["sliders"] == {"S2": {"joint": "P2", "guide": "L2", "angle_deg": angle}} and "P2" in doc["ground"]
    got, theta = _motor_angle(run_cli, spec, tmp_path, 144)
    a = 20.0 * np.exp(1j * theta)
    turn = (q - a) / np.abs(q - a) / u0  # the arm points from A through Q: its rotation from rest
    assert np.abs(got["P1"] - a).max() < 1e-9 * 75
    assert np.abs(got["P3"] - (a + (x0 - a0) * turn)).max() < 1e-9 * 75


# --- pylinkage ≥ 1.0 files, written by pylinkage 1.3.0 itself (tests/data/pylinkage/, with its trajectories) ---

PYLINKAGE = ROOT / "tests" / "data" / "pylinkage"


@pytest.mark.parametrize("name, form", [(n, f) for n in ("fourbar", "slider-crank", "six-bar") for f in ("mechanism", "graph")]
                         + [("fourbar-midrun", "mechanism"), ("arc-fourbar", "mechanism")])
def test_pylinkage_files_simulate_to_pylinkages_own_trajectories(run_cli, tmp_path, name, form):
    """``mechanism_to_json`` and ``graph_to_json`` (+ its Dimensions) files, imported and simulated with the
    samples the import sets (one per pylinkage step of a turn): sample k is pylinkage's step k, to 1e-9 of
    the linkage's size. ``fourbar-midrun`` was saved after 10 steps, away from its initial angle;
    ``arc-fourbar``'s crank swings 30° → 110° (an arc_driver): its forward sweep, both ends sampled."""
    extra = ["--dimensions", PYLINKAGE / f"{name}.dimensions.json"] if form == "graph" else []
    spec = tmp_path / "imported.yaml"
    r = run_cli("import", PYLINKAGE / f"{name}.{form}.json", *extra, "-o", spec)
    assert r.exit_code == 0, r.output
    reference = np.load(PYLINKAGE / f"{name}.trajectory.npz")
    steps = reference["position"].shape[0]
    out = tmp_path / "sim.h5"
    r = run_cli("simulate", spec, "-o", out)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        joints = list(f["joint"].asstr()[()])
        position = f["joints/position"][()]
    assert position.shape[0] == steps + (name == "arc-fourbar")
    got = np.roll(position, -1, axis=0)[:steps, [joints.index(j) for j in reference["joint"]]]  # step k ↔ sample k mod steps
    size = np.ptp(reference["position"].reshape(-1, 2), axis=0).max()
    assert np.abs(got - reference["position"]).max() <= 1e-9 * size


@pytest.mark.parametrize("name", ["linear-slider-crank", "prismatic-coupler-slot"])
def test_pylinkage_0x_prismatic_joints_simulate_to_pylinkages_own_trajectories(run_cli, tmp_path, name):
    """pylinkage 0.x ``Linear`` / ``Prismatic`` joints (at ``revolute_radius`` from joint0, on the line through
    joint1 and joint2) were refused; they are sliders: on the frame when both line joints are ``Static``
    (``linear-slider-crank``: a rod from the crank pin B, 3 long, to P on the frame line L1-L2, a rocker C hung
    from P), on the link carrying both otherwise (``prismatic-coupler-slot``: a four-bar turning cw whose
    coupler B-C carries a slot, P on it 1.2 from the frame joint E). Both files and their trajectories were
    written by pylinkage 0.8.0 (``pip install pylinkage==0.8.0``): the joints built with
    ``pylinkage.joints`` (``Crank(angle=±2π/90)``, ``Linear``/``Prismatic(joint0, joint1, joint2,
    revolute_radius)``), ``Linkage(joints, order)`` saved with ``linkage.serialization.save_to_json``, then
    ``numpy.savez_compressed(joint=names, position=list(linkage.step(iterations=90)))``: step k, the pose after
    k crank steps, is linkedit's sample k mod 90, to 1e-9 of the linkage's size."""
    spec = tmp_path / "imported.yaml"
    r = run_cli("import", PYLINKAGE / f"{name}.legacy.json", "-o", spec)
    assert r.exit_code == 0, r.output
    reference = np.load(PYLINKAGE / f"{name}.trajectory.npz")
    steps = reference["position"].shape[0]
    out = tmp_path / "sim.h5"
    r = run_cli("simulate", spec, "-o", out, "-n", str(steps))
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        joints = list(f["joint"].asstr()[()])
        position = f["joints/position"][()]
    got = np.roll(position, -1, axis=0)[:, [joints.index(j) for j in reference["joint"]]]
    size = np.ptp(reference["position"].reshape(-1, 2), axis=0).max()
    assert np.abs(got - reference["position"]).max() <= 1e-9 * size
    assert np.ptp(reference["position"][:, list(reference["joint"]).index("P")], axis=0).max() > 0.1 * size  # P slides


def test_pylinkage_graph_needs_its_dimensions(run_cli, tmp_path):
    r = run_cli("import", PYLINKAGE / "fourbar.graph.json", "-o", tmp_path / "x.yaml")
    assert r.exit_code == 2 and "give its Dimensions" in r.output and "--dimensions" in r.output, r.output
    r = run_cli("import", PYLINKAGE / "fourbar.mechanism.json", "--dimensions", PYLINKAGE / "fourbar.dimensions.json",
                "-o", tmp_path / "x.yaml")
    assert r.exit_code == 2 and "--dimensions: --dimensions goes with a pylinkage graph" in r.output, r.output
    dims = json.loads((PYLINKAGE / "six-bar.dimensions.json").read_text())
    dims["edge_distances"]["edge_8"] = 3.5  # the rod: 3 long in the positions
    (tmp_path / "dims.json").write_text(json.dumps(dims, indent=2))
    r = run_cli("import", PYLINKAGE / "six-bar.graph.json", "--dimensions", tmp_path / "dims.json", "-o", tmp_path / "x.yaml")
    line = next(n for n, text in enumerate((tmp_path / "dims.json").read_text().splitlines(), 1) if '"edge_8"' in text)
    assert r.exit_code == 2 and f"dims.json:{line - 9}: edge_distances.edge_8: 3.5 but the positions" in r.output, r.output
    assert not (tmp_path / "x.yaml").exists()


# --- malformed inputs: one line naming the file and line (or the expression's column), exit 2, nothing written ---

FOURBAR_JOINTS = [
    {"type": "Static", "name": "A", "x": 0.0, "y": 0.0},
    {"type": "Crank", "name": "B", "x": 0.0, "y": 1.0, "joint0": {"ref": "A"}, "distance": 1.0, "angle": 0.31},
    {"type": "Static", "name": "D", "x": 3.0, "y": 0.0},
    {"type": "Revolute", "name": "C", "x": 3.0, "y": 2.0, "joint0": {"ref": "B"}, "joint1": {"ref": "D"},
     "distance0": 2.5, "distance1": 2.0}]


def _legacy(joint: int, key: str, value=...) -> str:
    """The 0.x four-bar, one joint per line, with one field changed (``...``: removed)."""
    joints = [dict(j) for j in FOURBAR_JOINTS]
    if value is ...:
        del joints[joint][key]
    else:
        joints[joint][key] = value
    return '{"joints": [\n' + ",\n".join(json.dumps(j) for j in joints) + "\n]}"


def _mechanism(change) -> str:
    data = json.loads((PYLINKAGE / "fourbar.mechanism.json").read_text())
    change(data)
    return json.dumps(data, indent=2)


def _prismatic(key: str, value=...) -> str:
    """pylinkage's 0.x slider-crank (``linear-slider-crank.legacy.json``) with one field of its Linear joint P
    (``joints[4]``, line 33) changed (``...``: removed)."""
    data = json.loads((PYLINKAGE / "linear-slider-crank.legacy.json").read_text())
    if value is ...:
        del data["joints"][4][key]
    else:
        data["joints"][4][key] = value
    return json.dumps(data, indent=2)


PROJECT = "pyslvs_ver: 21.12.0\nmechanism: 'M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]]]'\n"
MALFORMED = [
    # (file name or None for an expression on the command line, its text, the line, the message)
    (None, "M[J[P, A[], P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]]]", 1,
     r"column 8: joint P0: A\[degrees\] takes one number, got 0 values"),
    (None, "M[J[P, A[x], P[0, 0], L[ground, L1]]]", 1, r"column 10: joint P0: A\[degrees\] takes one number, got the name 'x'"),
    (None, "M[J[R, P[(0, 1), 0], L[ground, L1]]]", 1, r"column 10: joint P0: P\[x, y\] takes two numbers, got \(…\)"),
    (None, "M[J[(R), P[0, 0], L[ground, L1]]]", 1, r"column 5: joint P0: the joint type is R, P or RP"),
    (None, "M[J[R, P[0, 0], L[ground, (L1)]]]", 1, r"column 27: joint P0: L\[…\] lists link names, got \(…\)"),
    (None, "M[J[R, P[0, 1e999], L[ground, L1]]]", 1, r"column 13: joint P0: P\[x, y\] takes two numbers, got a number out of range"),
    (None, "M[" + "(" * 5000 + ")" * 5000 + "]", 1, r"column 18: nested more than 16 levels deep"),
    (None, "M[" + "A[" * 5000 + "]" * 5000 + "]", 1, r"column 34: nested more than 16 levels deep"),
    (None, "M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0 L[L1]]]", 1, r"column 45: expected ',' or '\]'"),
    (None, "M[J[R, P[0, 0], L[ground, L1]]] x", 1, r"column 33: text after the end of M\[…\]"),
    (None, "M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]], J[R, P[1, 0], L[L2, ground]]", 1,
     r"column 87: the expression ends before its closing '\]'"),
    ("m.expr", "M[\n  J[R, P[0, 0], L[ground, L1]],\n  J[R, P[1, 0], L[L1, L2]] ;\n]", 3, r"column 28: unexpected character ';'"),
    ("p.pyslvs", PROJECT.replace("[1, 0]", "[1, (0)]"), 2, r"mechanism: character 43 of the expression: joint P1: P\[x, y\]"),
    ("p.pyslvs", PROJECT + "input: abc\n", 3, r"input: must be a list of \[pivot, joint\] point index pairs"),
    ("p.pyslvs", PROJECT + "input: 5\n", 3, r"input: must be a list"),
    ("p.pyslvs", PROJECT + "input: {a: 1}\n", 3, r"input: must be a list"),
    ("p.pyslvs", PROJECT + "input:\n- [[0, 1]]\n", 4, r"input\[0\]: an input is \[pivot, joint\], two point indices"),
    ("p.pyslvs", PROJECT + "input:\n- [0]\n", 4, r"input\[0\]: an input is \[pivot, joint\]"),
    ("p.pyslvs", PROJECT + "input:\n- [0, true]\n", 4, r"input\[0\]: an input is \[pivot, joint\]"),
    ("p.pyslvs", PROJECT + "input: &a [*a]\n", 3, r"an alias refers to itself"),
    ("p.pyslvs", PROJECT + "input: " + "[" * 100 + "]" * 100 + "\n", 3, r"nested more than 64 levels deep"),
    ("old.json", _legacy(1, "distance"), 3, r"joints\[1\]\.distance: required field is missing"),
    ("old.json", _legacy(3, "distance0"), 5, r"joints\[3\]\.distance0: required field is missing"),
    ("old.json", _legacy(3, "distance1", "2.0"), 5, r"joints\[3\]\.distance1: expected a finite number, got \"2.0\""),
    ("old.json", _legacy(3, "x", [1, 2]), 5, r"joints\[3\]\.x: expected a finite number, got \[1, 2\]"),
    ("old.json", _legacy(1, "angle", True), 3, r"joints\[1\]\.angle: expected a finite number, got true"),
    ("old.json", _legacy(3, "joint1", {"ref": "Q"}), 5, r"joints\[3\]\.joint1: joint 'C' \(Revolute\) needs joint1"),
    ("old.json", _legacy(0, "name", [1]), 2, r"joints\[0\]\.name: expected a name"),
    ("old.json", _legacy(3, "distance0", 7).replace(": 7", ": " + "9" * 5000), 5, r"a number of more than 4300 digits"),
    ("old.json", '{"joints":\n' + "[" * 100000 + "]" * 100000 + "}", 2, r"nested more than 64 levels deep"),
    ("old.json", _legacy(3, "x", 1.0).replace('"x": 1.0', '"x": 1.0, "x": 2.0'), 5, r"duplicate key 'x'"),
    ("old.json", '{"joints": [\n{"type": "Static",\n"x": 0.0 "y": 1}]}', 3, r"malformed JSON: Expecting ',' delimiter"),
    ("old.json", _legacy(2, "x", 1e200), 4, r"joints\[2\]\.x: beyond 1e\+150: too large to assemble from lengths"),
    ("new.json", _mechanism(lambda d: next(j for j in d["joints"] if j["id"] == "crank.motor_ground.A").update(
        position=[1e308, 0.0])), 1,  # the crank's pivot, far away
     r"saved away from its initial_angle, with coordinates beyond 1e\+150"),
    ("old.json", _prismatic("joint2", {"ref": "B"}), 33,  # a line through a frame point and the crank pin
     r"joints\[4\]: joint 'P' \(Linear\): its line through 'L1' and 'B' is fixed neither to the frame nor to one link"),
    ("old.json", _prismatic("joint2", {"ref": "L1"}), 33, r"joints\[4\]: joint 'P' \(Linear\): joint1 and joint2 must be two other"),
    ("old.json", _prismatic("revolute_radius"), 33, r"joints\[4\]\.revolute_radius: required field is missing"),
    ("old.json", _prismatic("revolute_radius", 0.5), None,
     r"joints\.P: cannot be assembled: P-B = 0\.5 cannot reach the line it slides on \(1\.32317 from B\)"),  # |BL1 × L1L2| / |L1L2|
    ("new.json", _mechanism(lambda d: d["joints"][1].update(position=["0.9", 0.3])), 12,
     r"joints\[1\]\.position\[0\]: expected a finite number, got \"0.9\""),
    ("new.json", _mechanism(lambda d: d["links"][1].update(joints=["crank.motor_ground.A", "nowhere"])), 46,
     r"links\[1\]\.joints: unknown joint 'nowhere'"),
    ("new.json", _mechanism(lambda d: d["links"][1].update(angular_velocity=0)), 46, r"angular_velocity is 0"),
    ("new.json", _mechanism(lambda d: d["links"][1].update(type="link")), 1, r"links: 0 driver links"),
    ("new.json", _mechanism(lambda d: d["joints"].append({"id": "T", "type": "tracker", "position": [0, 0],
                                                           "ref_joint1_id": "crank.motor_ground.A",
                                                           "ref_joint2_id": "ground.D_rocker.1"})), 36,
     r"joints\[4\]: tracker 'T': no link carries both"),
]


@pytest.mark.parametrize("file, text, line, message", MALFORMED, ids=[f"{n}-{c[0] or 'expression'}" for n, c in enumerate(MALFORMED)])
def test_malformed_sources_one_line_exit_2(run_cli, tmp_path, file, text, line, message):
    source = text if file is None else tmp_path / file
    if file is not None:
        source.write_text(text)
    r = run_cli("import", source, "-o", tmp_path / "x.yaml")
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1, r.output
    where = "<expression>" if file is None else str(source)
    located = re.escape(where) + (f":{line}: " if line else ": ")
    assert re.search(located + ".*" + message, r.output), r.output
    assert not (tmp_path / "x.yaml").exists()


def test_the_expression_reader_takes_time_linear_in_its_length():
    """32,000 joints (1.7 MB) were minutes of tokenizing (a quadratic scan) and 16 MiB never ended; now about
    1.5 s on an idle core (the bound leaves room for a loaded CI machine, far below the quadratic scan's time)."""
    from linkedit.interop.pyslvs import parse_expression

    parts = ["J[R, color[Green], P[0.0, 0.0], L[ground, L0]]"]
    parts += [f"J[R, color[Green], P[{i * 1.5}, {i % 7 * 0.25}], L[L{i - 1}, L{i}]]" for i in range(1, 32_000)]
    start = time.perf_counter()
    joints = parse_expression("M[" + ",\n".join(parts) + "]")
    assert len(joints) == 32_000 and joints[-1].position == (31_999 * 1.5, 31_999 % 7 * 0.25)
    assert time.perf_counter() - start < 30


def _actuator_files(tmp_path, driver_angle: dict) -> tuple:
    """A pylinkage ``LinearActuator`` (anchor O, direction 0.5 rad, stroke 2, here extended 1) driving a dyad to
    G2, as ``graph_to_json`` and ``Dimensions.to_dict()`` write it, ``driver_angle`` its ``driver_angles`` entry:
    the graph, the dimensions and C's rest position."""
    direction = complex(math.cos(0.5), math.sin(0.5))
    o, g2, a = 0j, 3 + 0j, 1.0 * direction
    c = _circles(a, 2.0, g2, 2.5, 3 + 3j)  # the dyad's upper branch
    graph = {"name": "lin", "nodes": [
        {"id": "O", "role": "GROUND", "joint_type": "REVOLUTE", "name": "O"},
        {"id": "G2", "role": "GROUND", "joint_type": "REVOLUTE", "name": "G2"},
        {"id": "A", "role": "DRIVER", "joint_type": "PRISMATIC", "name": "A"},
        {"id": "C", "role": "DRIVEN", "joint_type": "REVOLUTE", "name": "C"}],
        "edges": [{"id": "e0", "source": "O", "target": "A"}, {"id": "e1", "source": "A", "target": "C"},
                  {"id": "e2", "source": "G2", "target": "C"}], "hyperedges": []}
    dims = {"node_positions": {n: [p.real, p.imag] for n, p in (("O", o), ("G2", g2), ("A", a), ("C", c))},
            "driver_angles": {"A": driver_angle},
            "edge_distances": {"e0": 2.0, "e1": 2.0, "e2": 2.5}, "hyperedge_constraints": {}, "name": "lin"}
    (tmp_path / "g.json").write_text(json.dumps(graph, indent=2))
    (tmp_path / "d.json").write_text(json.dumps(dims, indent=2))
    return tmp_path / "g.json", tmp_path / "d.json", c


def test_pylinkage_graph_with_a_linear_actuator_follows_its_stroke(run_cli, tmp_path):
    """A pylinkage ``LinearActuator`` (speed 0.1) imports as a linear input over the whole stroke (extension
    0 … 2, one sample per pylinkage step), not as a refused slider nor a crank: the pin follows
    A(e) = O + e (cos 0.5, sin 0.5)."""
    graph, dims, c = _actuator_files(tmp_path, {"angular_velocity": 0.1, "initial_angle": 0.5})
    direction, g2 = complex(math.cos(0.5), math.sin(0.5)), 3 + 0j
    spec = tmp_path / "lin.yaml"
    r = run_cli("import", graph, "--dimensions", dims, "-o", spec)
    assert r.exit_code == 0, r.output
    got = _simulated(run_cli, spec, tmp_path, 21)
    e = np.linspace(0.0, 2.0, 21)
    assert np.abs(got["A"] - e * direction).max() <= 1e-12
    now, want = c, []
    for pin in e * direction:
        now = _circles(pin, 2.0, g2, 2.5, now)
        want.append(now)
    assert np.abs(got["C"] - np.array(want)).max() <= 1e-12
    assert yaml.safe_load(spec.read_text())["samples"] == 21  # 2 / 0.1 steps, both ends


@pytest.mark.parametrize("speed, message", [
    (0, "linear actuator 'A': speed 0 never moves"),
    (-0.1, r"linear actuator 'A': speed -0.1 is negative \(a speed, units per step; initial_angle gives the direction\)"),
    (..., "required field is missing"),  # pylinkage's DriverAngle.from_dict needs it too
    (math.nan, "expected a finite number, got nan"),
])
def test_pylinkage_linear_actuator_that_never_moves_is_refused(run_cli, tmp_path, speed, message):
    """pylinkage's actuator speed is a magnitude (units per step): at 0 the actuator stands still, below 0 it
    jitters between extension 0 and |speed|. Both imported with exit 0 as a sweep of the whole stroke (speed 0
    also without samples); now one line naming the field, exit 2, nothing written."""
    graph, dims, _ = _actuator_files(tmp_path, {"initial_angle": 0.5} if speed is ... else
                                     {"angular_velocity": speed, "initial_angle": 0.5})
    r = run_cli("import", graph, "--dimensions", dims, "-o", tmp_path / "x.yaml")
    line = next(n for n, text in enumerate(dims.read_text().splitlines(), 1) if '"A": {' in text and n > 10)
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert re.search(re.escape(f"{dims}:{line}: driver_angles.A.angular_velocity: ") + message, r.output), r.output
    assert not (tmp_path / "x.yaml").exists()


@pytest.mark.parametrize("expression, rocker", [
    # a Scotch yoke: the crank pin P1 turns in the yoke's vertical slot (RP), the yoke slides on the frame (P)
    ("M[J[R, P[0, 0], L[ground, L1]], J[RP, A[90], P[20, 0], L[yoke, L1]], J[P, A[0], P[50, 0], L[ground, yoke]],"
     " J[R, P[90, 0], L[yoke]]]", None),
    # a Whitworth quick-return: the crank pin P1 slides in the arm P2-P3, which turns fully about P2 = (0, 15)
    (f"M[J[R, P[0, 0], L[ground, L1]], J[RP, A[{math.degrees(math.atan2(-15, 40))!r}], P[40, 0], L[L2, L1]],"
     " J[R, P[0, 15], L[ground, L2]], J[R, P[0, -30], L[L2]]]", 15j),
])
def test_pyslvs_default_motor_drives_a_crank_whose_pin_slides_in_a_slot(run_cli, tmp_path, expression, rocker):
    """The default input is the first ground revolute joint and the first joint pinned to its link (P0, P1),
    also when that joint's pin runs in a slot (a Scotch yoke's or a quick-return's crank pin)."""
    spec = tmp_path / "crank.yaml"
    r = run_cli("import", expression, "-o", spec)
    assert r.exit_code == 0, r.output
    assert yaml.safe_load(spec.read_text())["motor"] == {"joint": "P1", "pivot": "P0"}
    got, theta = _motor_angle(run_cli, spec, tmp_path, 72)
    r0 = abs(got["P1"][0])
    assert np.abs(got["P1"] - r0 * np.exp(1j * theta)).max() < 1e-9 * r0
    if rocker is None:  # the yoke moves by 20 cos θ
        assert np.abs(got["P3"] - (70 + 20 * np.cos(theta))).max() < 1e-9 * 90
    else:  # the arm turns with the line from its pivot to the crank pin
        u = (got["P1"] - rocker) / np.abs(got["P1"] - rocker)
        assert np.abs(got["P3"] - (rocker + (-30j - rocker) * u / u[0])).max() < 1e-9 * 90


def test_pyslvs_comments_are_read_as_pyslvs_reads_them(run_cli, tmp_path):
    """pyslvs' grammar has line comments ``# …`` and block comments ``#[ … #]`` (to the end of the line of the
    closing ``#]``). Only line comments were stripped: a joint commented out by a block over several lines was
    imported (exit 0, one joint too many, the later ones renumbered)."""
    spec = tmp_path / "fourbar.yaml"
    commented = FOURBAR.replace(" J[R, color[Blue]", "  # the coupler's far end\n #[ an old coupler point:\n"
                                                     " J[R, P[40, 60], L[L2]],\n #] closed here, J[R, P[9, 9], L[x]],\n"
                                                     " J[R, color[Blue]")
    r = run_cli("import", commented, "-o", spec)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(spec.read_text())
    assert doc["joints"] == {"P0": [0, 0], "P1": [12.92, 32.53], "P2": [73.28, 67.97], "P3": [33.3, 66.95], "P4": [73.28, 0]}
    r = run_cli("import", "M[#[ a\n#] J[R],\n  J[R, P[0, 0], L[ground, L1]], J[X]]", "-o", spec)
    assert r.exit_code == 2 and "<expression>:3: column 35: joint P1: the joint type is R, P or RP" in r.output, r.output


# pyslvs' "Slider lifter": the RP joint P0 slides on the frame's x axis, P2 joins the links L1 (about the ground
# pivot P1) and L2 (carried by P0); its input pair (0, 0) is a slider input: P0 pushed along its slot
SLIDER_LIFTER = ("M[J[RP, A[0.0], P[0.0, 0.0], L[ground, L2]], J[R, P[50.0, 0.0], L[ground, L1]],"
                 " J[R, P[25.0, 27.0], L[L1, L2]], J[R, P[1.0, 54.0], L[L1]], J[R, P[50.0, 53.0], L[L2]]]")


def test_pyslvs_slider_input_is_a_linear_input_over_the_stroke_given(run_cli, tmp_path):
    """An input pair (n, n) is pyslvs' slider input. It was refused as a motor 'pivot not a ground joint';
    with --stroke it is a linear input, P0 at x = s, and P2 where its two links meet (the rest branch)."""
    spec = tmp_path / "lifter.yaml"
    r = run_cli("import", SLIDER_LIFTER, "--input", "0,0", "-o", spec)
    assert r.exit_code == 2 and "--stroke" in r.output and "slider input" in r.output, r.output
    assert not spec.exists()
    r = run_cli("import", SLIDER_LIFTER, "--input", "0,0", "--stroke", "0,20", "-o", spec)
    assert r.exit_code == 0, r.output
    assert yaml.safe_load(spec.read_text())["motor"] == {"slider": "S0", "stroke": [0, 20]}
    got = _simulated(run_cli, spec, tmp_path, 41)
    s = np.linspace(0, 20, 41)
    assert np.abs(got["P0"] - s).max() < 1e-12 * 50
    p1, r1, r0 = 50 + 0j, abs(25 + 27j - 50), abs(25 + 27j)  # P2 on circles about P1 and about P0
    d = p1 - s
    a = (r0**2 - r1**2 + np.abs(d) ** 2) / (2 * np.abs(d))
    p2 = s + d / np.abs(d) * (a + 1j * np.sqrt(r0**2 - a**2))  # the upper crossing, as at rest
    assert np.abs(got["P2"] - p2).max() < 1e-9 * 50
    r = run_cli("import", SLIDER_LIFTER, "--input", "1,2", "--stroke", "0,20", "-o", spec)
    assert r.exit_code == 2 and "--stroke" in r.output, r.output


def test_pyslvs_slot_joints_added_for_drawing_are_not_tracked(run_cli, tmp_path):
    """pyslvs' 'Inverted slider': the block L2 slides (P joint) in the slot of L3, which has no other joint than
    its pivot, so linkedit adds P3_slot on the slot line to carry it. That made-up joint was tracked like a
    coupler point (a curve in every picture); the tracks are the source's points only (P3, the block's)."""
    spec = tmp_path / "inverted.yaml"
    r = run_cli("import", "M[J[R, P[0, 0], L[ground, L1]], J[R, P[56, 0], L[ground, L3]], J[R, P[7, 25], L[L1, L2]],"
                " J[P, A[0.0], P[59, 41], L[L3, L2]]]", "--input", "0,2", "-o", spec)
    assert r.exit_code == 0, r.output
    doc = yaml.safe_load(spec.read_text())
    assert doc["links"]["L3"] == ["P1", "P3_slot"] and doc["tracks"] == {"P3": {"joint": "P3"}}
