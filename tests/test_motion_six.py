"""``linkedit synthesize --motion POSES.csv --family six-bar``: a Watt II six-bar meeting timed poses."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import yaml

from tests.test_synthesis_motion import simulated_poses


def third(a: np.ndarray, d: complex, la: float, ld: float) -> np.ndarray:
    """Reference: the point at distance la from a and ld from d, left of a→d (law of cosines)."""
    gap = d - a
    dist = np.abs(gap)
    along = (la * la - ld * ld + dist * dist) / (2 * dist)
    return a + (along + 1j * np.sqrt(la * la - along * along)) * gap / dist


def watt_poses(t: np.ndarray, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Coupler point and coupler-2 angle (degrees) of a known Watt II six-bar at motor phases t: crank
    O1-A1 (12) at 0.8 rad + 2π·t, coupler 38, rocker D1-B1 (25) rigid with the arm D1-A2 (15, 1.2 rad
    ahead of it), coupler A2-B2 (45) with the point at A2 + (0.4 + 0.6i)(B2 − A2), rocker D2-B2 (35)."""
    O1, D1, D2 = 0j, 40 + 5j, 80 + 20j
    A1 = O1 + 12 * np.exp(1j * (0.8 + 2 * np.pi * np.asarray(t)))
    B1 = third(A1, D1, 38, 25)
    A2 = D1 + 15 * np.exp(1j * (np.angle(B1 - D1) + 1.2))
    B2 = third(A2, D2, 45, 35)
    return scale * (A2 + (0.4 + 0.6j) * (B2 - A2)), np.degrees(np.angle(B2 - A2))


def write(path, t, points, angles, header="x (mm), y (mm), angle_deg, t") -> None:
    path.write_text(header + "\n" + "".join(f"{float(z.real)!r}, {float(z.imag)!r}, {float(a)!r}, {float(s)!r}\n"
                                             for z, a, s in zip(points, angles, t)))


def simulated(run_cli, out, turns_deg, tmp_path) -> tuple[np.ndarray, np.ndarray]:
    """Coupler point and coupler-2 angle (degrees) of `linkedit simulate` of out/result.yaml at motor turns
    from rest (degrees)."""
    offset = json.loads((out / "report.json").read_text())["coupler_angle_offset_deg"]
    return simulated_poses(run_cli, out / "result.yaml", turns_deg, offset, tmp_path, coupler=("A2", "B2"))


def angle_gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180) % 360 - 180)


T5 = np.array([0.0, 0.1, 0.2, 0.3, 0.4])


@pytest.mark.parametrize("scale, unit", [(1.0, "mm"), (1e-3, "m")])
def test_five_timed_poses_of_a_known_six_bar_are_met_exactly(run_cli, tmp_path, scale, unit):
    """Five poses at motor phases t of a known six-bar: the written six-bar, simulated, passes each pose at
    the motor angle 360°·t prescribes (1e-6 of the size, 1e-6 rad), and meets it best there (timing 1e-6 rad)."""
    points, angles = watt_poses(T5, scale)
    write(tmp_path / "timed.csv", T5 + 0.25, points, angles, f"x ({unit}), y ({unit}), angle_deg, t")
    out = tmp_path / "six"
    result = run_cli("synthesize", "--motion", tmp_path / "timed.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    size = np.abs(points[:, None] - points[None, :]).max()
    assert report["family"] == "six-bar" and report["linkage"]["units"] == unit and not report["note"]
    assert report["error"]["position"]["max"] <= 1e-6 and np.radians(report["error"]["angle_deg"]["max"]) <= 1e-6
    assert np.radians(report["error"]["timing_deg"]["max"]) <= 1e-6
    turns = [p["motor_turn_deg"] for p in report["points"]]
    np.testing.assert_allclose(turns, 360 * T5, atol=1e-9)
    np.testing.assert_allclose([p["achieved_motor_turn_deg"] for p in report["points"]], 360 * T5,
                               atol=np.degrees(1e-6))
    got, angle = simulated(run_cli, out, turns, tmp_path)
    assert np.abs(got - points).max() <= 1e-6 * size
    assert np.radians(angle_gap(angle, angles).max()) <= 1e-6
    for low, high in report["transmission_deg"]["stages"]:
        assert 20 <= low <= high <= 160
    spec = yaml.safe_load((out / "result.yaml").read_text())
    assert spec["ground"] == ["O1", "D1", "D2"] and spec["links"]["ternary"] == ["D1", "B1", "A2"]
    assert spec["motor"]["range_deg"] == pytest.approx([0, 144])
    with h5py.File(out / "result.h5") as f:
        assert f["tracks/target/position"].shape == (361, 2)


def test_seven_timed_poses_are_met_in_the_least_squares_sense(run_cli, tmp_path):
    """Seven poses of the six-bar with their times moved (up to 0.01 turn): no six-bar is exact; the report's
    errors are those of the written six-bar simulated at the prescribed motor angles, and each pose is met
    at least as closely at the motor turn the report says it is met best."""
    t = np.array([0, 0.07, 0.15, 0.26, 0.33, 0.4, 0.45])
    points, angles = watt_poses(t)
    moved = t + np.array([0, 0.004, -0.006, 0.003, 0.008, -0.004, 0.005])
    write(tmp_path / "seven.csv", moved, points, angles)
    out = tmp_path / "six"
    result = run_cli("synthesize", "--motion", tmp_path / "seven.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    size = report["poses"]["size"]
    got, angle = simulated(run_cli, out, [p["motor_turn_deg"] for p in report["points"]], tmp_path)
    np.testing.assert_allclose(np.abs(got - points) / size, [p["position_error"] for p in report["points"]],
                               atol=1e-9)
    np.testing.assert_allclose(angle_gap(angle, angles), [abs(p["angle_error_deg"]) for p in report["points"]],
                               atol=1e-7)
    best, best_angle = simulated(run_cli, out, [p["achieved_motor_turn_deg"] for p in report["points"]], tmp_path)
    cost = (np.abs(got - points) / size) ** 2 + np.radians(angle_gap(angle, angles)) ** 2
    assert np.all((np.abs(best - points) / size) ** 2 + np.radians(angle_gap(best_angle, angles)) ** 2
                  <= cost + 1e-12)
    timing = [p["achieved_motor_turn_deg"] - p["motor_turn_deg"] for p in report["points"]]
    assert report["error"]["timing_deg"]["max"] == pytest.approx(np.abs(timing).max())
    assert 0 < report["error"]["timing_deg"]["max"] < 5 and report["error"]["position"]["max"] < 0.05


def swinging_poses(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coupler point and coupler-2 angle (degrees) of a Watt II six-bar whose ternary link swings back
    between poses: crank O1-A1 (10) at 0.3 rad + 2π·t, coupler 40, rocker D1-B1 (25) rigid with the arm
    D1-A2 (20, 100° ahead of it), coupler A2-B2 (45) with the point at A2 + (0.5 + 0.4i)(B2 − A2), rocker
    D2-B2 (30). Over t = 0 … 0.4 the ternary link turns −0.7°, then +40° (law of cosines)."""
    O1, D1, D2 = 0j, 35 + 5j, 60 + 40j
    A1 = O1 + 10 * np.exp(1j * (0.3 + 2 * np.pi * np.asarray(t)))
    B1 = third(A1, D1, 40, 25)
    A2 = D1 + 20 * np.exp(1j * (np.angle(B1 - D1) + np.radians(100)))
    B2 = third(A2, D2, 45, 30)
    return A2 + (0.5 + 0.4j) * (B2 - A2), np.degrees(np.angle(B2 - A2))


def test_a_ternary_link_swinging_back_between_poses_is_found(run_cli, tmp_path):
    """Five timed poses of a six-bar whose stage-2 crank (the ternary link, a rocker) turns back between
    poses 1 and 2: met exactly (it was 'no Watt II six-bar found', exit 1, when stage 2's crank had to
    turn one way through the poses), and `linkedit simulate` passes each at its motor angle."""
    points, angles = swinging_poses(T5)
    rocker = np.angle(third(10 * np.exp(1j * (0.3 + 2 * np.pi * T5)), 35 + 5j, 40, 25) - (35 + 5j))
    assert np.diff(rocker)[0] < 0 < np.diff(rocker)[1:].min()  # the premise: the ternary link swings back
    write(tmp_path / "swing.csv", T5, points, angles)
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "swing.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert not report["note"] and report["error"]["position"]["max"] <= 1e-6
    assert np.radians(max(report["error"]["angle_deg"]["max"], report["error"]["timing_deg"]["max"])) <= 1e-6
    got, angle = simulated(run_cli, out, [float(v) for v in 360 * T5], tmp_path)
    assert np.abs(got - points).max() <= 1e-6 * np.abs(points[:, None] - points[None, :]).max()
    assert np.radians(angle_gap(angle, angles).max()) <= 1e-6


def test_a_pose_passed_twice_is_timed_at_the_nearest_pass(run_cli, tmp_path):
    """Timed poses over most of a turn of the swinging six-bar: its ternary link swings out and back, so the
    coupler passes a pose on the way back at a second motor turn too (the same ternary angle: the same pose,
    exactly). Every pose is met exactly at its prescribed turn, so the timing is 0 and there is no note (it
    was 75°: the best of the whole sweep was the other pass)."""
    t = np.array([0.05, 0.3, 0.5, 0.7, 0.9])
    points, angles = swinging_poses(t)
    write(tmp_path / "twice.csv", t, points, angles)
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "twice.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["error"]["position"]["max"] <= 1e-6 and np.radians(report["error"]["angle_deg"]["max"]) <= 1e-6
    assert np.radians(report["error"]["timing_deg"]["max"]) <= 1e-6 and not report["note"]
    np.testing.assert_allclose([p["achieved_motor_turn_deg"] for p in report["points"]], 360 * (t - t[0]),
                               atol=np.degrees(1e-6))


def test_a_small_motion_of_a_large_six_bar_is_found(run_cli, tmp_path):
    """Five timed poses 0.2 mm apart (t = 0 … 0.04) of the 45 mm six-bar: its joints lie 50–76 pose sizes out
    (it was exit 1: every joint had to lie within 20 sizes); found, the written six-bar simulated passes the
    poses at their motor angles within the tolerance."""
    t = np.linspace(0, 0.04, 5)
    points, angles = watt_poses(t)
    size = np.abs(points[:, None] - points[None, :]).max()
    assert abs(80 + 20j - points.mean()) / size > 70
    write(tmp_path / "small.csv", t, points, angles)
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "small.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert not report["note"]
    got, angle = simulated(run_cli, out, [float(v) for v in 360 * t], tmp_path)
    assert np.abs(got - points).max() <= 0.005 * size and angle_gap(angle, angles).max() <= 0.5


def test_a_timing_no_six_bar_meets_is_written_with_a_note(run_cli, tmp_path):
    """Poses 2 and 3 swapped in time: the best six-bar found is written, exit 0, with a note giving its errors,
    those of the written six-bar simulated at the prescribed motor angles."""
    points, angles = watt_poses(T5)
    times = np.array([0.0, 0.2, 0.1, 0.3, 0.4])
    write(tmp_path / "swapped.csv", times, points, angles)
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "swapped.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    worst = report["error"]["position"]["max"]
    assert worst > 0.005 and report["note"].startswith("no six-bar found passes the poses at their times")
    assert f"off by {100 * worst:.3g} %" in report["note"]
    order = np.argsort(times)
    got, _ = simulated(run_cli, out, [p["motor_turn_deg"] for p in report["points"]], tmp_path)
    size = report["poses"]["size"]
    assert np.abs(got - points[order]).max() / size == pytest.approx(worst, rel=1e-9)


@pytest.mark.parametrize("times, message", [
    (None, "bad.csv:1: t: --family six-bar meets the motor's timing: give a t column"),
    ([0, 0.1, 0.1, 0.3, 0.4], ":4: t: t 0.1 is given twice (line 3 too)"),
    ([0, 0.3, 0.6, 0.9, 1.0], "bad.csv:6: t: the times span 1, one motor turn or more"),
    ([1.0, 0.3, 0.6, 0.9, 0.0], "bad.csv:2: t: the times span 1, one motor turn or more"),
    ((T5, "t (s)"), "bad.csv:1: t: t is the motor's phase (one turn = 1), the header gives it in 's'"),
    ((T5, "t (deg)"), "bad.csv:1: t: t is the motor's phase (one turn = 1), the header gives it in 'deg'"),
])
def test_bad_timing_exit_2_with_one_line(run_cli, tmp_path, times, message):
    """Each message names the file, the line (the header's for a missing t or a t in a unit, the latest
    time's for a span of a turn or more) and the column. A t in seconds or degrees is refused, not read as
    motor turns."""
    points, angles = watt_poses(T5)
    if times is None:
        (tmp_path / "bad.csv").write_text("x, y, angle_deg\n" + "".join(
            f"{float(z.real)!r}, {float(z.imag)!r}, {float(a)!r}\n" for z, a in zip(points, angles)))
    elif isinstance(times, tuple):
        write(tmp_path / "bad.csv", times[0], points, angles, f"x (mm), y (mm), angle_deg, {times[1]}")
    else:
        write(tmp_path / "bad.csv", times, points, angles)
    result = run_cli("synthesize", "--motion", tmp_path / "bad.csv", "--family", "six-bar", "-o", tmp_path / "o")
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "bad.csv" in lines[0], lines
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("column", ["t (turn)", "t (turns)"])
def test_a_t_header_in_turns_is_accepted(run_cli, tmp_path, column):
    """t given in turns (its unit): read as the motor's phase, the poses met exactly."""
    points, angles = watt_poses(T5)
    write(tmp_path / "turns.csv", T5, points, angles, f"x (mm), y (mm), angle_deg, {column}")
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "turns.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    np.testing.assert_allclose([p["motor_turn_deg"] for p in report["points"]], 360 * T5, atol=1e-9)


def test_unknown_motion_family_exit_2(run_cli, tmp_path):
    points, angles = watt_poses(T5)
    write(tmp_path / "p.csv", T5, points, angles)
    result = run_cli("synthesize", "--motion", tmp_path / "p.csv", "--family", "eight-bar", "-o", tmp_path / "o")
    assert result.exit_code == 2 and "unknown family 'eight-bar' for --motion" in result.output
    assert not (tmp_path / "o").exists()


def test_a_stage_one_turning_against_its_crank_is_mirrored(run_cli, tmp_path, monkeypatch):
    """Stage 1 fitted with its rocker turning against its crank (forced here): its frame is mirrored, the motor
    turns clockwise, and the written six-bar still meets every pose at its time."""
    from linkedit.synthesis import function

    fit = function.fit
    monkeypatch.setattr(function, "fit", lambda *args, **kw: fit(*args, **(kw | {"sense": -1.0})))
    points, angles = watt_poses(T5)
    write(tmp_path / "timed.csv", T5, points, angles)
    out = tmp_path / "six"
    result = run_cli("synthesize", "--motion", tmp_path / "timed.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    spec = yaml.safe_load((out / "result.yaml").read_text())
    assert report["motor_direction"] == "cw" and spec["motor"]["direction"] == "cw"
    got, angle = simulated(run_cli, out, [p["motor_turn_deg"] for p in report["points"]], tmp_path)
    assert np.abs(got - points).max() <= 1e-6 * report["poses"]["size"]
    assert np.radians(angle_gap(angle, angles).max()) <= 1e-6


def test_the_bench_held_out_six_bar_is_met_to_rounding(run_cli, tmp_path):
    """The bench's held-out Watt II (:func:`linkedit.synthesis.bench_motion.six_bar`), 5 timed poses over 150° of
    motor turn, its ternary link turning back (−10°, then back up to +26°): stage 2's root is ill-conditioned (its
    rocker dyad), where Levenberg–Marquardt's damped steps crawl (it stopped 1.35e-8 of the size off). Met to
    1e-12 of the size and 1e-10 rad at the prescribed motor angles, by `linkedit simulate` of result.yaml too,
    and timed to 1e-10 rad."""
    from linkedit.synthesis.bench_motion import SWEEP_DEG, poses, six_bar
    from linkedit.synthesis.generate import at_inputs

    known = six_bar()
    O1, A1, D1 = (complex(*known.joints[k]) for k in ("O1", "A1", "D1"))
    at = at_inputs(known, np.angle(A1 - O1) + np.radians(np.linspace(0, SWEEP_DEG, 5)))
    assert np.diff(np.angle(at["B1"] - D1))[0] < -0.1 < 0.1 < np.diff(np.angle(at["B1"] - D1))[2:].min()  # swings
    (tmp_path / "held.csv").write_text(poses("six-bar", 5, False))
    rows = np.loadtxt(tmp_path / "held.csv", delimiter=",", skiprows=1)
    points, angles = rows[:, 0] + 1j * rows[:, 1], rows[:, 2]
    out = tmp_path / "o"
    result = run_cli("synthesize", "--motion", tmp_path / "held.csv", "--family", "six-bar", "-o", out)
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert not report["note"] and report["error"]["position"]["max"] <= 1e-12, report["error"]
    assert np.radians(report["error"]["angle_deg"]["max"]) <= 1e-10, report["error"]
    assert np.radians(report["error"]["timing_deg"]["max"]) <= 1e-10, report["error"]
    got, angle = simulated(run_cli, out, [p["motor_turn_deg"] for p in report["points"]], tmp_path)
    size = np.abs(points[:, None] - points[None, :]).max()
    assert np.abs(got - points).max() <= 1e-12 * size
    assert np.radians(angle_gap(angle, angles).max()) <= 1e-10
