"""``linkedit synthesize --motion``: a four-bar whose coupler passes through prescribed poses."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import yaml


def coupler_poses(O: complex, D: complex, a: float, b: float, c: float, uv: complex, crank_deg: np.ndarray):
    """Reference: coupler point A + uv·(B − A) and coupler angle arg(B − A) (degrees) of the four-bar
    with pivots O, D, crank a, coupler b, rocker c, B left of A→D (two circles intersected)."""
    pin = O + a * np.exp(1j * np.radians(crank_deg))
    gap = D - pin
    dist = np.abs(gap)
    along = (b * b - c * c + dist * dist) / (2 * dist)
    tip = pin + (along + 1j * np.sqrt(b * b - along * along)) * gap / dist
    return pin + uv * (tip - pin), np.degrees(np.angle(tip - pin))


def write_poses(path, points, angles, header="x, y, angle_deg") -> None:
    path.write_text(header + "\n" + "".join(f"{float(z.real)!r}, {float(z.imag)!r}, {float(a)!r}\n"
                                             for z, a in zip(points, angles)))


def simulated_poses(run_cli, spec, turns_deg, offset_deg, tmp_path,
                    coupler: tuple[str, str] = ("A", "B")) -> tuple[np.ndarray, np.ndarray]:
    """The coupler point and angle (degrees: the angle of ``coupler``'s first joint → second plus
    ``offset_deg``) of `linkedit simulate` at the crank (motor) turns from rest the report names: each turn
    is the end of a sweep [0, turn] simulated with 2 samples."""
    data = yaml.safe_load(spec.read_text())
    points, angles = [], []
    for k, turn in enumerate(turns_deg):
        data["motor"]["range_deg"] = [0.0, abs(turn) if turn else 1.0]
        (tmp_path / f"at{k}.yaml").write_text(yaml.safe_dump(data))
        sim = run_cli("simulate", tmp_path / f"at{k}.yaml", "-n", "2", "-o", tmp_path / f"at{k}.h5")
        assert sim.exit_code == 0, sim.output
        with h5py.File(tmp_path / f"at{k}.h5") as f:
            names = [n.decode() if isinstance(n, bytes) else n for n in f["joint"][()]]
            p = f["joints/position"][()]
            track = f["tracks/target/position"][()]
        z = p[:, :, 0] + 1j * p[:, :, 1]
        s = 1 if turn else 0  # the sweep's end, or the rest pose
        points.append(complex(*track[s]))
        tail, head = (names.index(joint) for joint in coupler)
        angles.append(np.degrees(np.angle(z[s, head] - z[s, tail])) + offset_deg)
    return np.array(points), np.array(angles)


def check_poses(run_cli, out, points, angles, tmp_path, tolerance: float, angle_tolerance: float | None = None) -> dict:
    """The report's errors are within ``tolerance`` (of the size) and ``angle_tolerance`` (degrees,
    default ``tolerance``), and `linkedit simulate` of result.yaml at the report's crank angles
    passes through the poses as closely."""
    angle_tolerance = tolerance if angle_tolerance is None else angle_tolerance
    report = json.loads((out / "report.json").read_text())
    size = np.abs(points[:, None] - points[None, :]).max()
    assert report["poses"]["size"] == pytest.approx(size)
    assert report["error"]["position"]["max"] <= tolerance and report["error"]["angle_deg"]["max"] <= angle_tolerance
    turns = [p["motor_turn_deg"] for p in report["points"]]
    assert turns[0] == 0 and np.all(np.diff(turns) * np.sign(turns[-1]) > 0)  # in order, one way
    got, angle = simulated_poses(run_cli, out / "result.yaml", turns, report["coupler_angle_offset_deg"], tmp_path)
    assert np.abs(got - points).max() <= tolerance * size
    assert np.abs((angle - angles + 180) % 360 - 180).max() <= angle_tolerance
    assert 20 <= report["transmission_deg"]["min"] and report["transmission_deg"]["max"] <= 160
    return report


def test_poses_of_a_known_four_bar_are_recovered(run_cli, tmp_path):
    """Seven poses of a crank-rocker's coupler (crank 30°…150°): its pivots and link lengths come
    back to 1e-6 of the size, and the written linkage passes through the poses."""
    O, D = 10 + 20j, 50 + 20j
    points, angles = coupler_poses(O, D, 15, 40, 35, 0.5 + 0.8j, np.linspace(30, 150, 7))
    write_poses(tmp_path / "poses.csv", points, angles)
    out = tmp_path / "mo"
    result = run_cli("synthesize", "--motion", tmp_path / "poses.csv", "-o", out)
    assert result.exit_code == 0, result.output
    report = check_poses(run_cli, out, points, angles, tmp_path, 1e-6)
    size = report["poses"]["size"]
    spec = yaml.safe_load((out / "result.yaml").read_text())
    joints = {k: complex(*v) for k, v in spec["joints"].items()}
    assert abs(joints["O"] - O) <= 1e-6 * size and abs(joints["D"] - D) <= 1e-6 * size
    np.testing.assert_allclose([report["linkage"][k] for k in ("crank", "coupler", "rocker", "ground")],
                               [15, 40, 35, 40], rtol=0, atol=1e-6 * size)
    np.testing.assert_allclose([p["motor_turn_deg"] for p in report["points"]], np.arange(0, 121, 20), atol=1e-6)
    assert not report["note"] and spec["motor"]["range_deg"] == pytest.approx([0, 120])
    with h5py.File(out / "result.h5") as f:
        assert f["tracks/target/position"].shape == (361, 2)


FIVE = (np.array([0, 10 + 5j, 20 + 8j, 30 + 7j, 40 + 2j]), np.array([0, 10, 25, 35, 40]))


def test_five_poses_are_interpolated_exactly(run_cli, tmp_path):
    """Five poses no known four-bar was sampled from: a Burmester pair through all of them."""
    points, angles = FIVE
    write_poses(tmp_path / "five.csv", points, angles, header="x (cm), y (cm), angle_deg")
    out = tmp_path / "mo"
    result = run_cli("synthesize", "--motion", tmp_path / "five.csv", "-o", out, "--json")
    assert result.exit_code == 0, result.output
    done = json.loads(result.stdout)["result"]
    assert done["mode"] == "motion" and done["family"] == "four-bar"
    report = check_poses(run_cli, out, points, angles, tmp_path, 1e-6)
    assert report["linkage"]["units"] == "cm" and yaml.safe_load((out / "result.yaml").read_text())["units"] == "cm"
    assert report["note"] == ""  # a compact linkage: no note


@pytest.mark.parametrize("count", [3, 4])
def test_three_and_four_poses_are_met_exactly(run_cli, tmp_path, count):
    points, angles = FIVE[0][:count], FIVE[1][:count]
    write_poses(tmp_path / "p.csv", points, angles)
    result = run_cli("synthesize", "--motion", tmp_path / "p.csv", "-o", tmp_path / "mo")
    assert result.exit_code == 0, result.output
    check_poses(run_cli, tmp_path / "mo", points, angles, tmp_path, 1e-6)


def test_poses_in_the_order_of_t(run_cli, tmp_path):
    """A t column orders the poses: the same five, shuffled, with their times."""
    points, angles = FIVE
    order = [3, 0, 4, 1, 2]
    (tmp_path / "t.csv").write_text("t, x, y, angle_deg\n" + "".join(
        f"{k}, {points[k].real}, {points[k].imag}, {angles[k]}\n" for k in order))
    result = run_cli("synthesize", "--motion", tmp_path / "t.csv", "-o", tmp_path / "mo")
    assert result.exit_code == 0, result.output
    report = check_poses(run_cli, tmp_path / "mo", points, angles, tmp_path, 1e-6)
    assert [p["line"] for p in report["points"]] == [3, 5, 6, 2, 4]


SPIN = (np.arange(4) + 0j, np.array([0, 170, 340, 150]))  # the coupler spinning while its point creeps


def test_poses_no_four_bar_meets_get_the_best_and_a_note(run_cli, tmp_path):
    write_poses(tmp_path / "spin.csv", *SPIN)
    result = run_cli("synthesize", "--motion", tmp_path / "spin.csv", "-o", tmp_path / "mo")
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "mo" / "report.json").read_text())
    assert "no four-bar found passes the poses within 0.5 % of their size and 0.5°" in report["note"]
    assert "note:" in result.output
    err = report["error"]
    assert err["position"]["max"] > 0.005 or err["angle_deg"]["max"] > 0.5
    assert max(p["position_error"] for p in report["points"]) == pytest.approx(err["position"]["max"])
    assert max(abs(p["angle_error_deg"]) for p in report["points"]) == pytest.approx(err["angle_deg"]["max"])
    assert 20 <= report["transmission_deg"]["min"]


def test_poses_no_working_four_bar_passes_exit_1(run_cli, tmp_path):
    """The same poses with the transmission angle held within [60°, 120°]: one line, exit 1."""
    write_poses(tmp_path / "spin.csv", *SPIN)
    result = run_cli("synthesize", "--motion", tmp_path / "spin.csv", "-o", tmp_path / "mo", "--margin", "60")
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "makes a four-bar that passes the 4 poses in order" in lines[0]
    size = np.abs(SPIN[0][:, None] - SPIN[0][None, :]).max()
    assert f"every joint within {20 * size:.4g} mm of the poses' centre" in lines[0], lines[0]
    assert not (tmp_path / "mo").exists()


def test_moving_pivots_three_sizes_out_are_found(run_cli, tmp_path):
    """Five poses of a four-bar whose coupler point lies far from its coupler (moving pivots 3.2 sizes out,
    beyond the first grid's ±2): met exactly (it was exit 1: no pair of the dyads found)."""
    points, angles = coupler_poses(0j, 40 + 0j, 15, 45, 35, 0.5 - 1.2j, np.linspace(30, 90, 5))
    size = np.abs(points[:, None] - points[None, :]).max()
    pin = 15 * np.exp(1j * np.radians(30))
    assert 3 < min(abs(pin - points[0]), abs(pin + 45 * np.exp(1j * np.radians(angles[0])) - points[0])) / size
    write_poses(tmp_path / "far.csv", points, angles)
    result = run_cli("synthesize", "--motion", tmp_path / "far.csv", "-o", tmp_path / "mo")
    assert result.exit_code == 0, result.output
    assert not check_poses(run_cli, tmp_path / "mo", points, angles, tmp_path, 1e-6)["note"]


def test_a_translation_along_a_line_is_met_closely(run_cli, tmp_path):
    """A coupler translating along a straight line (every circle point at infinity): least squares
    through 12 poses with long links, within the tolerance — and a note that says how long: its longest link
    (read from result.yaml) over the poses' size, the coupler's turn 0° (it said nothing of a 1 km linkage
    for 100 mm of poses)."""
    points = np.linspace(0, 100, 12) + 0j
    write_poses(tmp_path / "line.csv", points, np.zeros(12))
    result = run_cli("synthesize", "--motion", tmp_path / "line.csv", "-o", tmp_path / "mo")
    assert result.exit_code == 0, result.output
    report = check_poses(run_cli, tmp_path / "mo", points, np.zeros(12), tmp_path, 0.005, 0.5)
    joints = {k: complex(*v) for k, v in yaml.safe_load((tmp_path / "mo" / "result.yaml").read_text())["joints"].items()}
    links = [abs(joints[a] - joints[b]) for a, b in (("O", "D"), ("O", "A"), ("A", "B"), ("B", "D"))]
    times = max(links) / report["poses"]["size"]
    assert times > 1000 and report["note"] == (
        f"its longest link is {times:,.0f}× the poses' size ({max(links):.4g} mm): the coupler turns only 0° over the "
        "poses, so its pivots lie far out; poses that turn the coupler more give a compact linkage")
    assert f"note: its longest link is {times:,.0f}×" in result.output


@pytest.mark.parametrize("text, message", [
    ("", "has no data"),
    ("x,y\n0,0\n1,1\n2,0\n", ":1: the header must name x, y, angle_deg once each"),
    ("x,y,angle_deg\n0,0,0\n1,1,10\n", "2 data rows; at least 3"),
    ("x,y,angle_deg\n0,0,0\n1,one,10\n2,0,20\n", ":3: y: not a number: 'one'"),
    ("x,y,angle_deg\n0,0,0\n1,1,nan\n2,0,20\n", ":3: angle_deg: not a finite number"),
    ("x,y,angle_deg\n5,5,0\n5,5,10\n5,5,20\n", "x: every pose has the same position"),
    ("x (mm),y (in),angle_deg\n0,0,0\n1,1,10\n2,0,20\n", ":1: y: x and y are in different units (in, mm)"),
    ("x,y,angle_deg (rad)\n0,0,0\n1,1,0.1\n2,0,0.2\n", ":1: angle_deg: angle_deg is in degrees, the header gives it "
                                                       "in 'rad'"),
])
def test_bad_poses_exit_2_with_one_line(run_cli, tmp_path, text, message):
    """One line naming the file, the line and the column; a header's unit that contradicts its column (angles in
    rad) is refused, not read as degrees."""
    (tmp_path / "bad.csv").write_text(text)
    result = run_cli("synthesize", "--motion", tmp_path / "bad.csv", "-o", tmp_path / "out")
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "bad.csv" in lines[0], lines
    assert not (tmp_path / "out").exists()
