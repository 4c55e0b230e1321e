"""Lock-up intervals are reported where the linkage stops and starts assembling, not at the samples.

References are closed forms: the offset slider-crank (crank r = 20, rod l = 25, offset e = 12,
``examples/invalid/locking-slider-crank.yaml``) cannot reach its slot for r sin θ − e < −l, θ in
(180° + asin(13/20), 360° − asin(13/20)) = (220.54°, 319.46°); the four-bar ``LOCKING`` (crank 1.9,
ground 3, coupler + rocker c) for |A − D| > c, cos θ < (1.9² + 3² − c²) / (2·1.9·3).
"""

from __future__ import annotations

import dataclasses
import re

import h5py
import numpy as np
import pytest

from linkedit.planar import simulate
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES, report_of
from tests.planar_specs import LOCKING

SLIDER = EXAMPLES / "invalid" / "locking-slider-crank.yaml"
SLIDER_EDGE = np.degrees(np.arcsin(13.0 / 20.0))  # 40.54°: the lock-up is 180° + edge … 360° − edge
COUPLER_ROCKER = np.hypot(0.3, 2.1) + np.hypot(0.8, 2.1)
FOUR_BAR_EDGE = np.degrees(np.arccos((1.9**2 + 3.0**2 - COUPLER_ROCKER**2) / (2 * 1.9 * 3.0)))  # 124.60°


def test_a_coarse_partial_simulation_reports_the_exact_lock_up_everywhere_it_is_shown(run_cli, tmp_path):
    """-n 8 samples the crank every 45°: the run of failing samples is 225°…315°, and that was
    reported (text, HDF5, SVG) as the lock-up, though the slider fails from 220.5° to 319.5°."""
    h5, pic = tmp_path / "s.h5", tmp_path / "s.svg"
    r = run_cli("simulate", SLIDER, "-n", "8", "--partial", "-o", h5, "--svg", pic)
    assert r.exit_code == 0, r.output
    want = f"motor angles {180 + SLIDER_EDGE:.1f}°…{360 - SLIDER_EDGE:.1f}°: slider piston"
    assert want == "motor angles 220.5°…319.5°: slider piston"
    assert want in r.output, r.output
    with h5py.File(h5) as f:
        assert want in f["diagnostics"].attrs["lockups"]
        assert f["diagnostics/assembled"][()].tolist() == [True] * 5 + [False] * 3  # 225°, 270°, 315°
    svg = pic.read_text()
    assert "locks at 220.5°" in svg and "free again after 319.5°" in svg
    assert "locking-slider-crank (5 of 8 samples assembled)" in svg  # was "(5 samples)", as if 5 were asked
    r = run_cli("simulate", SLIDER, "-n", "8", "-o", tmp_path / "x.h5")
    assert r.exit_code == 1 and want in r.output, r.output
    r = run_cli("validate", SLIDER, "-n", "8")
    assert r.exit_code == 1 and want in r.output, r.output


@pytest.mark.parametrize("samples", [5, 8, 37, 360])
def test_lock_up_boundaries_match_the_closed_form_at_any_sampling(samples):
    slider = simulate(load_model(LinkageSpec, SLIDER), samples, partial=True)
    four_bar = simulate(load_model(LinkageSpec, "locking.yaml", LOCKING), samples, partial=True)
    (s,), (f,) = slider.lockups, four_bar.lockups
    assert abs(s.start_deg - (180 + SLIDER_EDGE)) < 1e-9 and abs(s.end_deg - (360 - SLIDER_EDGE)) < 1e-9
    assert abs(f.start_deg - FOUR_BAR_EDGE) < 1e-9 and abs(f.end_deg - (360 - FOUR_BAR_EDGE)) < 1e-9
    assert s.exact and f.exact and "within" not in s.describe()


def test_a_sweep_that_starts_locked_reports_its_start_and_the_exact_end():
    """A sweep 230° → 300° starts inside the lock-up: the run starts at the sweep's start."""
    text = SLIDER.read_text().replace("motor: {joint: A, pivot: O}", "motor: {joint: A, pivot: O, range_deg: [180, 340]}")
    m = simulate(load_model(LinkageSpec, "sweep.yaml", text), 9, partial=True)
    (lk,) = m.lockups
    assert abs(lk.start_deg - (180 + SLIDER_EDGE)) < 1e-9 and abs(lk.end_deg - (360 - SLIDER_EDGE)) < 1e-9
    text = text.replace("range_deg: [180, 340]", "range_deg: [230, 340]")
    m = simulate(load_model(LinkageSpec, "sweep.yaml", text), 9, partial=True)
    (lk,) = m.lockups
    assert lk.start_deg == pytest.approx(230.0, abs=1e-12) and abs(lk.end_deg - (360 - SLIDER_EDGE)) < 1e-9


def test_a_swing_reports_where_it_locks_and_its_exact_turn(run_cli, tmp_path):
    """Swinging 0° → 250° → 0° in 9 samples (turning back between two of them): locked past 220.5°
    out to 250° and back."""
    path = tmp_path / "swing.yaml"
    path.write_text(SLIDER.read_text().replace("motor: {joint: A, pivot: O}",
                                               "motor: {joint: A, pivot: O, oscillate_deg: [0, 250]}"))
    r = run_cli("simulate", path, "-n", "9", "--partial", "-o", tmp_path / "w.h5")
    assert r.exit_code == 0, r.output
    found = re.search(r"motor angles ([\d.]+)°…([\d.]+)°…([\d.]+)°: slider piston", r.output)
    assert found, r.output
    assert [float(g) for g in found.groups()] == [round(180 + SLIDER_EDGE, 1), 250.0, round(180 + SLIDER_EDGE, 1)]


@pytest.mark.parametrize(("sweep", "locks", "frees"), [("[180, 340]", True, True), ("[230, 340]", False, True),
                                                      ("[180, 300]", True, False)])
def test_a_sweeps_picture_marks_only_the_edges_inside_it(run_cli, tmp_path, sweep, locks, frees):
    """A sweep that starts locked does not lock there, and one locked to its end never frees: the picture
    said "free again after 300.0°" at the rest pose for a sweep locked from 220.5° to its end."""
    path, pic = tmp_path / "sweep.yaml", tmp_path / "s.svg"
    path.write_text(SLIDER.read_text().replace("motor: {joint: A, pivot: O}",
                                               f"motor: {{joint: A, pivot: O, range_deg: {sweep}}}"))
    assert run_cli("simulate", path, "-n", "9", "--partial", "-o", tmp_path / "s.h5", "--svg", pic).exit_code == 0
    svg = pic.read_text()
    assert ("locks at 220.5° (B)" in svg) is locks and ("locks" in svg) is locks
    assert ("free again after 319.5°" in svg) is frees and ("free again" in svg) is frees


def test_a_clockwise_crank_reports_its_lock_up_in_its_own_angles():
    text = SLIDER.read_text().replace("motor: {joint: A, pivot: O}", "motor: {joint: A, pivot: O, direction: cw}")
    (lk,) = simulate(load_model(LinkageSpec, "cw.yaml", text), 8, partial=True).lockups
    assert abs(lk.start_deg + SLIDER_EDGE) < 1e-9 and abs(lk.end_deg + (180 - SLIDER_EDGE)) < 1e-9


def test_the_picture_marks_the_samples_next_to_each_lock_up():
    """Locked samples (-n 8: 225°, 270°, 315°): the marks are on the assembled samples either side,
    180° and 0°. A lock-up between samples (the four-bar NARROW, 166.8°…193.2°, -n 7 every 51.4°):
    on the samples nearest to its ends, 154.3° and 205.7° (the first mark was a sample early, 102.9°)."""
    from linkedit.io.planar_svg import drawing
    from tests.test_planar_scale import NARROW

    slider = drawing(simulate(load_model(LinkageSpec, SLIDER), 8, partial=True))
    assert slider["notes"] == [(4, "locks at 220.5° (B)"), (0, "free again after 319.5°")]
    narrow = drawing(simulate(load_model(LinkageSpec, "narrow.yaml", NARROW), 7, partial=True))
    assert narrow["notes"] == [(3, "locks at 166.8° (B)"), (4, "free again after 193.2°")]


def test_a_lock_up_past_0_degrees_is_written_between_0_and_360(run_cli, tmp_path):
    """LOCKING turned by 180° (its rest crank at 180°) locks for 180° + 124.60° … 180° + 235.40°: that
    was written "304.6°…415.4°"; a designer reads 304.6°…55.4°, through 0°. The numbers (--json, HDF5)
    keep running on from the rest angle, as ``/motor_angle`` does (304.6…415.4, start < end)."""
    turned = LOCKING.replace("A: [1.9, 0]", "A: [-1.9, 0]").replace("B: [2.2, 2.1]", "B: [-2.2, -2.1]") \
        .replace("D: [3, 0]", "D: [-3, 0]")
    spec = tmp_path / "turned.yaml"
    spec.write_text(turned)
    start, end = 180 + FOUR_BAR_EDGE, 180 + 360 - FOUR_BAR_EDGE
    want = f"motor angles {start:.1f}°…{end - 360:.1f}° (through 0°): joint B cannot be placed"
    assert want == "motor angles 304.6°…55.4° (through 0°): joint B cannot be placed"
    r = run_cli("simulate", spec, "--partial", "-n", "36", "-o", tmp_path / "t.h5", "--json")
    assert r.exit_code == 0, r.output
    (result,) = report_of(r)
    assert want in result["lockups"][0], result["lockups"]
    (record,) = result["lockup_intervals"]
    assert abs(record["start"] - start) < 1e-9 and abs(record["end"] - end) < 1e-9
    with h5py.File(tmp_path / "t.h5") as f:
        assert want in f["diagnostics"].attrs["lockups"]
    r = run_cli("validate", spec, "-n", "36")
    assert r.exit_code == 1 and want in r.output and "415.4" not in r.output, r.output
    pic = tmp_path / "t.svg"
    assert run_cli("simulate", spec, "--partial", "-n", "36", "-o", tmp_path / "u.h5", "--svg", pic).exit_code == 0
    assert "free again after 55.4°" in pic.read_text()


def test_motor_angles_in_words_are_reduced_and_a_wrap_is_said():
    from linkedit.planar.diagnostics import degrees_text

    assert [degrees_text(v) for v in (460.9, -40.5, 359.96, -0.01, 0.0, 720.0)] == \
        ["100.9°", "319.5°", "0.0°", "0.0°", "0.0°", "0.0°"]
    (lk,) = simulate(load_model(LinkageSpec, SLIDER), 8, partial=True).lockups
    cw = dataclasses.replace(lk, start_deg=-lk.start_deg, end_deg=-lk.end_deg)  # turning the other way
    assert "motor angles 139.5°…40.5°: slider" in cw.describe()
    ends = dataclasses.replace(lk, start_deg=300.0, end_deg=360.0, exact=False)  # ending at 0°: not through it
    assert "within 300.0°…0.0° (the assembled samples either side;" in ends.describe()
    swing = dataclasses.replace(lk, start_deg=350.0, turn_deg=370.0, end_deg=350.0, exact=False)
    assert "within 350.0°…10.0°…350.0° (through 0°; the assembled samples" in swing.describe()
