"""`linkedit plot`: kinematics against crank angle, the transmission-angle band and its worst samples;
`validate` warns when a transmission angle leaves 40°–140°."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES

NS = {"s": "http://www.w3.org/2000/svg"}


@pytest.fixture(scope="module")
def jansen_h5(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = tmp_path_factory.mktemp("plot") / "jansen.h5"
    r = CliRunner().invoke(app, ["simulate", str(EXAMPLES / "jansen.yaml"), "-o", str(out)])
    assert r.exit_code == 0, r.output
    return out


def _panel(root, name):
    return root.find(f".//s:g[@class='panel'][@data-name='{name}']", NS)


def _y_map(panel):
    """value → pixel y of a panel, from its tick labels (a linear map)."""
    ticks = [(float(t.text), float(t.get("y")) - 4) for t in panel.iterfind(".//s:text[@class='tick']", NS)
             if t.get("text-anchor") == "end"]
    (v0, y0), (v1, y1) = ticks[0], ticks[-1]
    return lambda v: y0 + (np.asarray(v) - v0) * (y1 - y0) / (v1 - v0)


def _series(panel, name):
    pts = [p for p in panel.iterfind(".//s:polyline", NS) if p.get("data-name") == name]
    return np.concatenate([np.array([[float(c) for c in xy.split(",")] for xy in p.get("points").split()]) for p in pts])


def _angle_at(p, k, i, j):
    """Angle (degrees) at joint k between k→i and k→j, (T,)."""
    u, v = p[:, i] - p[:, k], p[:, j] - p[:, k]
    cos = (u * v).sum(-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def test_transmission_band_and_worst_samples(run_cli, jansen_h5, tmp_path):
    out = tmp_path / "plot.svg"
    r = run_cli("plot", jansen_h5, "-o", out)
    assert r.exit_code == 0, r.output
    root = ET.parse(out).getroot()
    panel = _panel(root, "transmission-angle")
    y_of = _y_map(panel)
    band = panel.find(".//s:rect[@class='band']", NS)
    assert (band.get("data-lo"), band.get("data-hi")) == ("40", "140")
    assert abs(float(band.get("y")) - y_of(140)) < 0.02
    assert abs(float(band.get("y")) + float(band.get("height")) - y_of(40)) < 0.02
    with h5py.File(jansen_h5) as f:
        names = list(f["joint"].asstr()[()])
        p = f["joints/position"][()]
    O, A, B, C, D, E, F, G = range(8)
    alpha_d = _angle_at(p, D, A, B)  # D ← (A, B), computed here from the joint positions
    crank = np.arange(360.0)
    marks = {g.find("s:text", NS).text.split()[0]: (float(g.get("data-x")), float(g.get("data-y")))
             for g in panel.iterfind(".//s:g[@class='toggle']", NS)}
    t = int(np.argmax(np.abs(alpha_d - 90)))
    assert marks["D"] == pytest.approx((crank[t], alpha_d[t]), abs=1e-4)
    assert round(alpha_d[t], 1) == 8.6 and set(marks) == {"C", "D", "F"}
    line = _series(panel, "at D")
    assert np.abs(line[:, 1] - y_of(alpha_d)).max() < 0.02  # the drawn curve is the angle
    assert names == list("OABCDEFG")


def test_per_second_scales_derivatives_by_omega(run_cli, jansen_h5, tmp_path):
    a, b = tmp_path / "rad.svg", tmp_path / "sec.svg"
    assert run_cli("plot", jansen_h5, "-o", a).exit_code == 0
    assert run_cli("plot", jansen_h5, "-o", b, "--per-second", "--rpm", "60").exit_code == 0
    pa, pb = _panel(ET.parse(a).getroot(), "velocity"), _panel(ET.parse(b).getroot(), "velocity")
    assert "mm/rad" in ET.tostring(pa, encoding="unicode") and "mm/s" in ET.tostring(pb, encoding="unicode")
    ya, yb = _y_map(pa), _y_map(pb)

    def values(panel, y_of):
        px = _series(panel, "magnitude")[:, 1]
        lo, hi = y_of(0.0), y_of(1.0)
        return (px - lo) / (hi - lo)

    with h5py.File(jansen_h5) as f:
        speed = np.linalg.norm(f["tracks/foot/velocity"][()], axis=1)
    assert np.abs(values(pa, ya) - speed).max() < 0.05 * speed.max()
    assert np.abs(values(pb, yb) - 2 * np.pi * speed).max() < 0.05 * 2 * np.pi * speed.max()


def test_plot_options(run_cli, jansen_h5, tmp_path):
    r = run_cli("plot", jansen_h5, "--rpm", "60")
    assert r.exit_code == 2 and "--per-second and --rpm" in r.output
    r = run_cli("plot", jansen_h5, "--track", "hand")
    assert r.exit_code == 2 and "no track 'hand'" in r.output
    r = run_cli("plot", jansen_h5, "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and "unknown output format" in r.output
    r = run_cli("plot", jansen_h5, "--joint", "C", "-o", "-")
    assert r.exit_code == 0 and r.output.startswith("<?xml") and "C x" in r.output


def test_validate_warns_outside_40_140(run_cli):
    r = run_cli("validate", EXAMPLES / "jansen.yaml", EXAMPLES / "crank-rocker.yaml")
    assert r.exit_code == 0, r.output
    warnings = [ln for ln in r.output.splitlines() if "warning:" in ln]
    assert len(warnings) == 3  # C, D, F of Jansen; the crank-rocker stays within (worst 44.4°)
    assert "joint D leaves 40°–140°: 8.6° at motor angle 192.0°" in r.output


def test_toggle_spikes_of_a_partial_result_are_clipped_and_marked(run_cli, tmp_path):
    from tests.planar_specs import LOCKING

    spec = tmp_path / "lock.yaml"
    spec.write_text(LOCKING)
    h5, out = tmp_path / "lock.h5", tmp_path / "plot.svg"
    assert run_cli("simulate", spec, "--partial", "-o", h5).exit_code == 0
    assert run_cli("plot", h5, "-o", out).exit_code == 0
    with h5py.File(h5) as f:
        ok = f["diagnostics/assembled"][()]
        acc = f["tracks/coupler_point/acceleration"][()][ok]
    panel = _panel(ET.parse(out).getroot(), "acceleration")
    ticks = [float(t.text) for t in panel.iterfind(".//s:text[@class='tick']", NS) if t.get("text-anchor") == "end"]
    peak = np.abs(acc).max()
    assert max(np.abs(ticks)) < 0.2 * peak  # the spikes near the toggles do not set the scale
    frame = panel.find(".//s:rect", NS)
    top, bottom = float(frame.get("y")), float(frame.get("y")) + float(frame.get("height"))
    for name in ("x", "y", "magnitude"):
        line = _series(panel, name)
        assert top - 0.01 <= line[:, 1].min() and line[:, 1].max() <= bottom + 0.01  # cut at the panel's edge
    marks = [float(m.get("data-y")) for m in panel.iterfind(".//s:polygon[@class='clipped']", NS)]
    assert len(marks) >= 4 and max(np.abs(marks)) == pytest.approx(np.hypot(acc[:, 0], acc[:, 1]).max(), rel=1e-5)
    assert "spikes clipped" in "".join(panel.itertext())
    # a panel without spikes is not clipped
    assert not _panel(ET.parse(out).getroot(), "position").findall(".//s:polygon[@class='clipped']", NS)


@pytest.mark.parametrize("options", [(), ("--joint", "B"), ("--per-second", "--rpm", "30")])
def test_no_attribute_of_a_partial_result_plot_is_nan_and_lines_break_at_the_gap(run_cli, tmp_path, options):
    from tests.planar_specs import LOCKING

    spec, h5, out = tmp_path / "lock.yaml", tmp_path / "lock.h5", tmp_path / "plot.svg"
    spec.write_text(LOCKING)
    assert run_cli("simulate", spec, "--partial", "-n", "72", "-o", h5).exit_code == 0
    assert run_cli("plot", h5, "-o", out, *options).exit_code == 0
    root = ET.parse(out).getroot()
    values = [v.lower() for e in root.iter() for v in e.attrib.values()]
    assert values and not [v for v in values if "nan" in v or "inf" in v]
    # the 125°…235° gap splits every curve of the position panel into a run before and a run after it
    lines = _panel(root, "position").findall(".//s:polyline[@class='series']", NS)
    assert len(lines) == 2 * len({line.get("data-name") for line in lines})


def _values(root, panel_name, series):
    """The drawn values of one series of a panel (pixels mapped back through its ticks)."""
    panel = _panel(root, panel_name)
    y_of = _y_map(panel)
    lo, hi = y_of(0.0), y_of(1.0)
    return (_series(panel, series)[:, 1] - lo) / (hi - lo)


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_a_crank_pins_derivatives_per_second_and_jerk_follow_its_direction(run_cli, tmp_path, direction):
    """The crank pin A = 25 (cos θ, sin θ) mm at θ = ±ωt (ω = 2π/s at 60 rpm, c = ωt the crank angle
    from rest): dA/dt = ±25ω (−sin θ, cos θ), d³A/dθ³ = 25 (sin θ, −cos θ). A clockwise crank's
    velocity per second was drawn with the sign of a counter-clockwise one, and its jerk per radian
    (the difference of the accelerations over the samples) with the opposite sign."""
    spec = tmp_path / "crank.yaml"
    spec.write_text((EXAMPLES / "crank-rocker.yaml").read_text().replace(
        "motor: {joint: A, pivot: O}", f"motor: {{joint: A, pivot: O, direction: {direction}}}"))
    h5, rad, sec = tmp_path / "c.h5", tmp_path / "rad.svg", tmp_path / "sec.svg"
    assert run_cli("simulate", spec, "-o", h5, "-n", "720").exit_code == 0
    assert run_cli("plot", h5, "--joint", "A", "-o", rad).exit_code == 0
    assert run_cli("plot", h5, "--joint", "A", "--per-second", "--rpm", "60", "-o", sec).exit_code == 0
    s = 1.0 if direction == "ccw" else -1.0
    c = np.radians(np.arange(720) / 2)
    theta, w = s * c, 2 * np.pi
    velocity = s * 25 * w * np.stack([-np.sin(theta), np.cos(theta)])
    jerk = 25 * np.stack([np.sin(theta), -np.cos(theta)])
    per_sec, per_rad = ET.parse(sec).getroot(), ET.parse(rad).getroot()
    for i, axis in enumerate("xy"):
        assert np.abs(_values(per_sec, "velocity", axis) - velocity[i]).max() < 0.01 * 25 * w
        assert np.abs(_values(per_rad, "jerk", axis) - jerk[i]).max() < 0.01 * 25


def test_a_swings_jerk_is_its_derivative_and_it_has_no_rpm(run_cli, tmp_path):
    """Swinging 0° → 120° → 0° (θ = 60° (1 − cos 2πt), samples unevenly spaced in θ): the jerk is
    d acc / dθ of the crank pin, 25 (sin θ, −cos θ), away from the two turns; --rpm is refused."""
    spec = tmp_path / "swing.yaml"
    spec.write_text((EXAMPLES / "crank-rocker.yaml").read_text().replace(
        "motor: {joint: A, pivot: O}", "motor: {joint: A, pivot: O, oscillate_deg: [0, 120]}"))
    h5, rad = tmp_path / "s.h5", tmp_path / "rad.svg"
    assert run_cli("simulate", spec, "-o", h5, "-n", "720").exit_code == 0
    assert run_cli("plot", h5, "--joint", "A", "-o", rad).exit_code == 0
    theta = np.radians(60 * (1 - np.cos(2 * np.pi * np.arange(720) / 720)))
    root = ET.parse(rad).getroot()
    away = (np.arange(720) % 360 > 20) & (np.arange(720) % 360 < 340)  # away from the turns at t = 0, ½
    for i, axis in enumerate("xy"):
        want = 25 * np.stack([np.sin(theta), -np.cos(theta)])[i]
        drawn = _values(root, "jerk", axis)
        assert drawn.size == 720 - 2  # no point at the two turning samples
        kept = np.delete(np.arange(720), [0, 360])
        assert np.abs(drawn - want[kept])[away[kept]].max() < 0.01 * 25
    r = run_cli("plot", h5, "--per-second", "--rpm", "60", "-o", tmp_path / "sec.svg")
    assert r.exit_code == 2 and "oscillate_deg" in r.output and not (tmp_path / "sec.svg").exists()
