"""SVG pictures: valid XML, geometry inside the viewBox, y flipped, equal aspect, ticks at the
right places, SMIL animation following the motion, every link and track present, no NaN."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from linkedit.io.svg import MAX_FRAMES, animated_motion, edit_overlay, motion_plot
from linkedit.io.figure_layout import nice_ticks, tick_label
from linkedit.io.figure_style import Stroke
from linkedit.io.svg_figure import Figure
from tests.conftest import ROOT

NS = "{http://www.w3.org/2000/svg}"


def crank_rocker(samples: int = 90, *, reverse: bool = False) -> dict:
    """A Grashof crank-rocker (crank 1, coupler 3, rocker 2.5, ground 3) with a coupler point P."""
    t = np.arange(samples) / samples
    phi = (-1 if reverse else 1) * 2 * np.pi * t
    O, B = np.zeros((samples, 2)), np.tile([3.0, 0.0], (samples, 1))
    A = np.column_stack([np.cos(phi), np.sin(phi)])
    d = B - A
    dist = np.linalg.norm(d, axis=1)
    a = (3.0**2 - 2.5**2 + dist**2) / (2 * dist)
    h = np.sqrt(3.0**2 - a**2)
    u = d / dist[:, None]
    C = A + a[:, None] * u + h[:, None] * np.column_stack([-u[:, 1], u[:, 0]])  # upper branch
    P = A + 0.5 * (C - A) + 1.2 * np.column_stack([-(C - A)[:, 1], (C - A)[:, 0]]) / 3.0
    return dict(joint_names=["O", "A", "C", "B", "P"], positions=np.stack([O, A, C, B, P], axis=1),
                links={"crank": [0, 1], "coupler": [1, 2, 4], "rocker": [3, 2]}, ground=[0, 3], motor=(1, 0),
                tracks={"tracer": P.copy(), "mid <A&C>": (A + C) / 2}, units="m", title="crank-rocker")


def parse(svg: str) -> ET.Element:
    root = ET.fromstring(svg.encode("utf-8"))
    assert root.tag == NS + "svg"
    return root


def classes(el: ET.Element) -> list[str]:
    return (el.get("class") or "").split()


def find(root: ET.Element, cls: str) -> list[ET.Element]:
    return [el for el in root.iter() if cls in classes(el)]


def drawn_points(root: ET.Element) -> np.ndarray:
    """Every coordinate pair of lines, circles, polylines, polygons, rects, texts and animations."""
    pts = []
    for el in root.iter():
        tag = el.tag.removeprefix(NS)
        if tag in ("polyline", "polygon"):
            pts += [tuple(map(float, p.split(","))) for p in el.get("points").split()]
        elif tag == "line":
            pts += [(float(el.get("x1")), float(el.get("y1"))), (float(el.get("x2")), float(el.get("y2")))]
        elif tag == "circle":
            pts.append((float(el.get("cx")), float(el.get("cy"))))
        elif tag == "rect" and el.get("x") is not None:
            x, y, w, h = (float(el.get(k)) for k in ("x", "y", "width", "height"))
            pts += [(x, y), (x + w, y + h)]
        elif tag == "text" and el.get("x") is not None:
            pts.append((float(el.get("x")), float(el.get("y"))))
        elif tag == "animate":
            name = el.get("attributeName")
            values = el.get("values").split(";")
            if name == "points":
                pts += [tuple(map(float, p.split(","))) for v in values for p in v.split()]
            elif name in ("cx", "x1", "x2", "x"):
                pts += [(float(v), 1.0) for v in values]
            elif name != "display":  # per-frame captions switch display on and off
                pts += [(1.0, float(v)) for v in values]
    return np.array(pts)


def viewbox(root: ET.Element) -> tuple[float, float, float, float]:
    x, y, w, h = map(float, root.get("viewBox").split())
    assert (float(root.get("width")), float(root.get("height"))) == (w, h)
    return x, y, w, h


def joint_pixels(root: ET.Element, also: str = "joint") -> dict[str, tuple[float, float]]:
    """Joint marker centres by joint name (markers whose classes include ``joint`` and ``also``)."""
    return {el.get("data-name"): (float(el.get("cx")), float(el.get("cy"))) for el in find(root, "joint")
            if also in classes(el)}


def fit_map(world: np.ndarray, px: np.ndarray) -> tuple[float, float, float, float]:
    """Least-squares px = ax + sx·x, py = ay + sy·y; returns (ax, sx, ay, sy)."""
    (sx, ax), *_ = np.linalg.lstsq(np.column_stack([world[:, 0], np.ones(len(world))]), px[:, 0], rcond=None)
    (sy, ay), *_ = np.linalg.lstsq(np.column_stack([world[:, 1], np.ones(len(world))]), px[:, 1], rcond=None)
    return ax, sx, ay, sy


# -- the motion plot ---------------------------------------------------------------------------


def test_motion_plot_is_xml_with_everything_inside_the_viewbox(tmp_path):
    kw = crank_rocker()
    svg = motion_plot(tmp_path / "plot.svg", **kw)
    assert (tmp_path / "plot.svg").read_text(encoding="utf-8") == svg
    assert [p.name for p in tmp_path.iterdir()] == ["plot.svg"]  # no temporary left behind
    root = parse(svg)
    x0, y0, w, h = viewbox(root)
    pts = drawn_points(root)
    assert len(pts) > 4 * 90  # two tracks and two joint paths at least
    assert np.all(pts >= [x0, y0]) and np.all(pts <= [x0 + w, y0 + h])
    assert "nan" not in svg.lower() and "inf" not in svg.lower()


def test_y_axis_is_flipped_and_aspect_is_equal():
    kw = crank_rocker()
    root = parse(motion_plot(None, **kw))
    px = joint_pixels(root)
    world = kw["positions"][0]
    pix = np.array([px[n] for n in kw["joint_names"]])
    ax, sx, ay, sy = fit_map(world, pix)
    assert sx > 0 and sy < 0
    assert sx == pytest.approx(-sy, rel=1e-4)  # one scale for both axes
    np.testing.assert_allclose(pix, np.column_stack([ax + sx * world[:, 0], ay + sy * world[:, 1]]), atol=0.01)
    c, a = px["C"], px["A"]  # at rest C is above A: drawn higher (smaller SVG y)
    assert world[2, 1] > world[1, 1] and c[1] < a[1]


def test_figure_draws_larger_y_higher():
    fig = Figure()
    fig.polyline(np.array([[0.0, 0.0], [0.0, 10.0], [5.0, 10.0]]), cls="probe")
    (el,) = find(parse(fig.render()), "probe")
    p = [tuple(map(float, q.split(","))) for q in el.get("points").split()]
    assert p[1][1] < p[0][1] and p[1][0] == p[0][0]
    assert p[2][0] > p[1][0] and p[2][1] == p[1][1]
    assert p[0][1] - p[1][1] == pytest.approx(2 * (p[2][0] - p[1][0]), abs=0.02)


def test_every_link_track_and_joint_appears_with_its_shape():
    kw = crank_rocker()
    root = parse(motion_plot(None, **kw))
    links = {el.get("data-name"): el.tag.removeprefix(NS) for el in find(root, "link")}
    assert links == {"crank": "line", "rocker": "line", "coupler": "polygon"}
    assert {el.get("data-name") for el in find(root, "track")} == {"tracer", "mid <A&C>"}
    assert set(joint_pixels(root)) == set(kw["joint_names"])
    assert {el.get("data-name") for el in find(root, "ground")} == {"O", "B"}
    assert [el.get("data-name") for el in find(root, "motor")] == ["A"]
    # moving joints that are not tracks get a faint path; the ground joints don't move
    assert {el.get("data-name") for el in find(root, "joint-path")} == {"A", "C"}
    legend = [t.text for t in find(root, "legend")[0].iter(NS + "text")]
    assert legend == ["joint paths", "tracer", "mid <A&C>"]
    colors = {el.get("data-name"): el.get("stroke") for el in find(root, "track")}
    assert len(set(colors.values())) == 2


def test_track_curve_is_the_track_in_pixels():
    kw = crank_rocker(60)
    root = parse(motion_plot(None, **kw))
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(kw["positions"][0], np.array([px[n] for n in kw["joint_names"]]))
    (el,) = [e for e in find(root, "track") if e.get("data-name") == "tracer"]
    assert el.tag == NS + "polygon"  # one full cycle: a closed curve
    got = np.array([tuple(map(float, q.split(","))) for q in el.get("points").split()])
    P = kw["tracks"]["tracer"]
    np.testing.assert_allclose(got, np.column_stack([ax + sx * P[:, 0], ay + sy * P[:, 1]]), atol=0.02)


def test_axes_ticks_are_round_numbers_at_their_world_positions():
    kw = crank_rocker()
    root = parse(motion_plot(None, **kw))
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(kw["positions"][0], np.array([px[n] for n in kw["joint_names"]]))
    ticks = find(root, "tick")
    xs = [(float(t.text), float(t.get("x"))) for t in ticks if t.get("text-anchor") == "middle"]
    ys = [(float(t.text), float(t.get("y")) - 4) for t in ticks if t.get("text-anchor") == "end"]
    assert len(xs) >= 3 and len(ys) >= 3
    for value, x in xs:
        assert x == pytest.approx(ax + sx * value, abs=0.02)
    for value, y in ys:
        assert y == pytest.approx(ay + sy * value, abs=0.02)
    steps = {round(b - a, 9) for (a, _), (b, _) in zip(xs, xs[1:])}
    assert len(steps) == 1
    assert {u.text for u in find(root, "unit")} == {"x (m)", "y (m)"}
    assert find(root, "title")[0].text == "crank-rocker"


@given(st.floats(-1e6, 1e6), st.floats(1e-6, 1e6), st.floats(2, 12))
def test_nice_ticks_are_round_and_inside(lo, span, target):
    hi = lo + span
    step, ticks = nice_ticks(lo, hi, target)
    mantissa = step / 10 ** math.floor(math.log10(step) + 1e-12)
    assert min(abs(mantissa - m) for m in (1, 2, 2.5, 5, 10)) < 1e-9
    assert step >= span / target * (1 - 1e-9)
    assert len(ticks) >= 1 and len(ticks) <= target + 2
    assert np.all(ticks >= lo - 1e-9 * step) and np.all(ticks <= hi + 1e-9 * step)
    np.testing.assert_allclose(ticks / step, np.round(ticks / step), atol=1e-6)
    for t in ticks:
        assert float(tick_label(float(t), step)) == pytest.approx(t, abs=1e-6 * step + 1e-12 * abs(t))


def test_tick_labels():
    assert [tick_label(v, 0.25) for v in (-0.5, 0.0, 0.25)] == ["-0.50", "0", "0.25"]
    assert [tick_label(v, 2.5) for v in (5.0, 7.5)] == ["5.0", "7.5"]
    assert [tick_label(v, 20.0) for v in (-40.0, -0.0)] == ["-40", "0"]


def test_motor_arrow_follows_the_turning_direction():
    def sweep(reverse: bool) -> str:
        (motor,) = find(parse(motion_plot(None, **crank_rocker(reverse=reverse))), "motor")
        (arc,) = motor.iter(NS + "path")
        return re.search(r"A[\d.]+,[\d.]+ 0 1 ([01])", arc.get("d")).group(1)

    assert sweep(False) == "0"  # counter-clockwise in the world = counter-clockwise on screen
    assert sweep(True) == "1"


def test_collinear_ternary_link_is_a_bar_between_its_outer_joints():
    fig = Figure()
    fig.link(np.array([[0.0, 0.0], [2.0, 1.0], [1.0, 0.5]]), name="coupler")
    fig.joints(np.array([[0.0, 0.0], [2.0, 1.0]]), names=["a", "b"])
    root = parse(fig.render())
    (bar,) = find(root, "link")
    px = joint_pixels(root)
    assert bar.tag == NS + "line" and bar.get("stroke-linecap") == "round"
    ends = {(float(bar.get("x1")), float(bar.get("y1"))), (float(bar.get("x2")), float(bar.get("y2")))}
    assert ends == {px["a"], px["b"]}


# -- the animation -----------------------------------------------------------------------------


def motion_animates(root):
    """The <animate> elements that move the drawing (the per-frame captions switch display instead)."""
    captions = {id(a) for g in root.iter() if g.get("class") == "frame-caption" for a in g.iter(NS + "animate")}
    return [a for a in root.iter(NS + "animate") if id(a) not in captions]


@pytest.mark.parametrize("samples, frames", [(360, MAX_FRAMES), (50, 50), (MAX_FRAMES + 1, MAX_FRAMES)])
def test_animation_values_follow_the_subsampled_motion(samples, frames):
    kw = crank_rocker(samples)
    svg = animated_motion(None, **kw, duration_s=3.0)
    root = parse(svg)
    x0, y0, w, h = viewbox(root)
    pts = drawn_points(root)
    assert np.all(pts >= [x0, y0]) and np.all(pts <= [x0 + w, y0 + h])
    animates = motion_animates(root)
    assert animates
    for a in animates:
        assert (a.get("dur"), a.get("repeatCount"), a.get("calcMode")) == ("3s", "indefinite", "linear")
        assert len(a.get("values").split(";")) == frames + 1  # closes the loop with frame 0
    idx = np.round(np.linspace(0, samples, frames, endpoint=False)).astype(int)
    assert len(set(idx)) == frames
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(kw["positions"][0], np.array([px[n] for n in kw["joint_names"]]))
    for el in find(root, "joint"):
        j = kw["joint_names"].index(el.get("data-name"))
        series = {a.get("attributeName"): np.array(a.get("values").split(";"), float) for a in el}
        if j in (0, 3):  # ground joints stand still: no animation
            assert series == {}
            continue
        world = kw["positions"][idx, j]
        np.testing.assert_allclose(series["cx"][:-1], ax + sx * world[:, 0], atol=0.06)
        np.testing.assert_allclose(series["cy"][:-1], ay + sy * world[:, 1], atol=0.06)
        assert (series["cx"][-1], series["cy"][-1]) == (series["cx"][0], series["cy"][0])
    (coupler,) = [e for e in find(root, "link") if e.get("data-name") == "coupler"]
    (anim,) = coupler.iter(NS + "animate")
    assert anim.get("attributeName") == "points"
    assert all(len(v.split()) == 3 for v in anim.get("values").split(";"))
    for name in ("crank", "rocker"):
        (bar,) = [e for e in find(root, "link") if e.get("data-name") == name]
        assert {a.get("attributeName") for a in bar} <= {"x1", "y1", "x2", "y2"} and len(list(bar)) == 2
    assert {el.get("data-name") for el in find(root, "track")} == {"tracer", "mid <A&C>"}
    assert len(find(root, "track-point")) == 2 and all(len(list(e)) == 2 for e in find(root, "track-point"))


def test_animation_not_cyclic_has_one_value_per_frame():
    root = parse(animated_motion(None, **crank_rocker(30), cyclic=False))
    assert {len(a.get("values").split(";")) for a in motion_animates(root)} == {30}
    assert all(e.tag == NS + "polyline" for e in find(root, "track"))


def test_animation_size_does_not_grow_with_samples():
    def animation_chars(samples: int) -> int:
        root = parse(animated_motion(None, **crank_rocker(samples)))
        return sum(len(a.get("values")) for a in motion_animates(root))

    assert animation_chars(3600) == pytest.approx(animation_chars(240), rel=0.05)


# -- the edit overlay --------------------------------------------------------------------------


def test_edit_overlay_draws_before_after_targets_and_envelope(tmp_path):
    before = crank_rocker()
    after = dict(before, positions=before["positions"] * 0.8,
                 tracks={k: v * 0.8 for k, v in before["tracks"].items()})
    target = before["tracks"]["tracer"] * [1.1, 1.0]
    svg = edit_overlay(tmp_path / "edit.svg", before=before, after=after,
                       targets={"retarget tracer": target, "other": target + 0.1},
                       envelope=(-1.2, None, None, 2.5), units="m", title="edit <1> & 'two'")
    assert (tmp_path / "edit.svg").read_text(encoding="utf-8") == svg
    root = parse(svg)
    x0, y0, w, h = viewbox(root)
    pts = drawn_points(root)
    assert np.all(pts >= [x0, y0]) and np.all(pts <= [x0 + w, y0 + h])
    assert find(root, "title")[0].text == "edit <1> & 'two'"
    for which, style in (("before", "faint"), ("after", "solid")):
        links = [e for e in find(root, "link") if which in classes(e)]
        tracks = [e for e in find(root, "track") if which in classes(e)]
        assert {e.get("data-name") for e in links} == {"crank", "coupler", "rocker"}
        assert {e.get("data-name") for e in tracks} == {"tracer", "mid <A&C>"}
        faint = [e.get("stroke-opacity") is not None for e in tracks]
        assert all(faint) if style == "faint" else not any(faint)
    targets = {e.get("data-name"): e for e in find(root, "target")}
    assert set(targets) == {"retarget tracer", "other"}
    assert all(e.get("stroke-dasharray") for e in targets.values())
    tracer = [e for e in find(root, "track") if e.get("data-name") == "tracer" and "after" in classes(e)][0]
    assert targets["retarget tracer"].get("stroke") == tracer.get("stroke")
    assert targets["other"].get("stroke") not in {e.get("stroke") for e in find(root, "track")}
    # envelope: xmin and ymax drawn where they are, open sides reach the plot frame
    px = joint_pixels(root, "after")
    ax, sx, ay, sy = fit_map(after["positions"][0], np.array([px[n] for n in after["joint_names"]]))
    (env,) = find(root, "envelope")
    sides = {ln.get("data-side"): ln for ln in env.iter(NS + "line")}
    assert set(sides) == {"xmin", "ymax"}
    assert float(sides["xmin"].get("x1")) == pytest.approx(ax + sx * -1.2, abs=0.02)
    assert float(sides["ymax"].get("y1")) == pytest.approx(ay + sy * 2.5, abs=0.02)
    (shade,) = env.iter(NS + "rect")
    frame = [e for e in find(root, "axes")[0] if e.tag == NS + "rect"][0]
    right = float(frame.get("x")) + float(frame.get("width"))
    bottom = float(frame.get("y")) + float(frame.get("height"))
    assert float(shade.get("x")) + float(shade.get("width")) == pytest.approx(right, abs=0.02)
    assert float(shade.get("y")) + float(shade.get("height")) == pytest.approx(bottom, abs=0.02)
    legend = [t.text for t in find(root, "legend")[0].iter(NS + "text")]
    assert legend[-4:] == ["before", "after", "target", "envelope"]


def test_edit_overlay_accepts_the_motion_plot_keywords_and_no_envelope():
    before = crank_rocker()
    root = parse(edit_overlay(None, before=before, after=before, targets={}, envelope=None))
    assert not find(root, "envelope") and not find(root, "target")
    with pytest.raises(ValueError, match="after: unknown keys"):
        edit_overlay(None, before=before, after=dict(before, colour="red"), targets={}, envelope=None)


# -- bad input ---------------------------------------------------------------------------------


@pytest.mark.parametrize("spoil, message", [
    (lambda kw: kw["positions"].__setitem__((3, 2, 0), np.nan), "positions: contains NaN"),
    (lambda kw: kw["tracks"]["tracer"].__setitem__((0, 1), np.inf), "track tracer: contains NaN"),
    (lambda kw: kw.update(positions=kw["positions"][:, :4]), "positions: expected an array of shape"),
    (lambda kw: kw["tracks"].update(tracer=kw["tracks"]["tracer"][:10]), "track tracer: expected"),
    (lambda kw: kw["links"].update(crank=[0, 7]), "link crank: joint index 7 out of range"),
    (lambda kw: kw["links"].update(crank=[0]), "link crank: needs at least 2 joints"),
    (lambda kw: kw.update(motor=(1, -1)), "motor pivot: joint index -1"),
    (lambda kw: kw.update(ground=[0.5]), "ground: joint index 0.5"),
])
def test_bad_input_raises_value_error(spoil, message):
    for draw in (motion_plot, animated_motion):
        kw = crank_rocker(20)
        spoil(kw)
        with pytest.raises(ValueError, match=message):
            draw(None, **kw)


def test_non_finite_overlay_inputs_raise(tmp_path):
    kw = crank_rocker(20)
    bad = dict(kw, positions=np.where(np.arange(5)[None, :, None] == 2, -np.inf, kw["positions"]))
    with pytest.raises(ValueError, match="after: positions"):
        edit_overlay(tmp_path / "x.svg", before=kw, after=bad, targets={}, envelope=None)
    with pytest.raises(ValueError, match="target foot"):
        edit_overlay(tmp_path / "x.svg", before=kw, after=kw, targets={"foot": np.full((4, 2), np.nan)},
                     envelope=None)
    with pytest.raises(ValueError, match="box xmax: not finite"):
        edit_overlay(tmp_path / "x.svg", before=kw, after=kw, targets={}, envelope=(0, math.inf, None, None))
    with pytest.raises(ValueError, match="xmin 2 > xmax 1"):
        edit_overlay(tmp_path / "x.svg", before=kw, after=kw, targets={}, envelope=(2, 1, None, None))
    with pytest.raises(ValueError, match="duration_s"):
        animated_motion(None, **kw, duration_s=float("nan"))
    assert not list(tmp_path.iterdir())  # nothing written


def test_names_are_escaped():
    kw = crank_rocker(20)
    kw["joint_names"] = ['O"', "A<", "C&", "B'", "P\x01>"]
    kw["links"] = {"a<b>&'\"": [0, 1], "coupler": [1, 2, 4], "rocker": [3, 2]}
    root = parse(motion_plot(None, **dict(kw, title="</svg> & <script>")))
    assert set(joint_pixels(root)) == {'O"', "A<", "C&", "B'", "P\ufffd>"}
    assert "a<b>&'\"" in {e.get("data-name") for e in find(root, "link")}
    assert find(root, "title")[0].text == "</svg> & <script>"


def test_degenerate_drawings_still_have_a_sensible_view():
    fig = Figure(units="mm")
    fig.polyline(np.array([[5.0, 2.0], [5.0, 2.0]]), cls="dot")  # a single point
    root = parse(fig.render())
    _, _, w, h = viewbox(root)
    assert 100 < w < 2000 and 100 < h < 2000
    fig = Figure()
    fig.polyline(np.array([[0.0, 1.0], [1000.0, 1.0]]), Stroke(style="dashed"), cls="flat")  # no height
    root = parse(fig.render())
    assert len(find(root, "tick")) >= 4
    fig = Figure()
    fig.polyline(np.array([[0.0, 76654.0], [1e-5, 76654.00001]]), cls="far")  # long tick labels
    root = parse(fig.render())
    for t in find(root, "tick"):
        if t.get("text-anchor") == "end":  # y labels end left of the axis and leave room for the unit
            assert len(t.text) > 10 and float(t.get("x")) - 6.5 * len(t.text) >= 24


# -- a real renderer, when one is installed ----------------------------------------------------


@pytest.mark.skipif(shutil.which("chromium") is None, reason="headless chromium not installed")
def test_chromium_renders_the_plot(tmp_path):
    blank = Figure()
    blank.polyline(np.array([[0.0, 0.0], [1.0, 1.0]]), Stroke(color="#ffffff", width=0.1))
    sizes = {}
    for name, svg in (("blank", blank.render()), ("plot", motion_plot(None, **crank_rocker()))):
        (tmp_path / f"{name}.svg").write_text(svg, encoding="utf-8")
        root = parse(svg)
        subprocess.run(["chromium", "--headless", "--disable-gpu", "--no-sandbox",
                        f"--screenshot={tmp_path / name}.png",
                        f"--window-size={root.get('width')},{root.get('height')}",
                        (tmp_path / f"{name}.svg").as_uri()], check=True, capture_output=True, timeout=60)
        sizes[name] = (tmp_path / f"{name}.png").stat().st_size
    assert sizes["plot"] > 3 * sizes["blank"]


# -- pictures that tell the truth (issue 11) ----------------------------------------------------


def _lines(root, cls):
    out = []
    for el in root.iter():
        if (el.get("class") or "").split()[:1] == [cls] and el.get("points"):
            out.append(np.array([[float(v) for v in xy.split(",")] for xy in el.get("points").split()]))
    return out


def test_partial_plot_breaks_curves_and_marks_the_lockup(run_cli, tmp_path):
    from tests.planar_specs import LOCKING

    spec = tmp_path / "lock.yaml"
    spec.write_text(LOCKING)
    pic = tmp_path / "lock.svg"
    assert run_cli("simulate", spec, "--partial", "-o", tmp_path / "l.h5", "--svg", pic).exit_code == 0
    root = ET.parse(pic).getroot()
    tip = [el for el in root.iter() if el.get("class") == "track" and el.get("data-name") == "tip"]
    assert len(tip) == 1 and tip[0].tag.endswith("polyline")  # broken at the lock-up only (through the rest pose), not closed
    pieces = _lines(root, "track")
    steps = np.concatenate([np.linalg.norm(np.diff(p, axis=0), axis=1) for p in pieces])
    assert steps.max() < 10 * np.median(steps)  # no straight line across the locked gap
    labels = [el.text for el in root.iter() if el.get("class") == "lockup-label"]
    assert any("locks at" in w for w in labels) and any("free again" in w for w in labels)
    # the point tracked on the coupler is a corner of the coupler's plate
    coupler = next(el for el in root.iter() if el.get("class") == "link" and el.get("data-name") == "coupler")
    assert coupler.tag.endswith("polygon") and len(coupler.get("points").split()) == 3


def test_eleventh_track_differs_from_the_first_and_labels_have_a_halo():
    kw = crank_rocker()
    pos = kw["positions"]
    kw["tracks"] = {f"t{n}": pos[:, 3] + n for n in range(11)}
    root = parse(motion_plot(None, **kw))
    style = {el.get("data-name"): (el.get("stroke"), el.get("stroke-dasharray"))
             for el in root.iter() if el.get("class") == "track"}
    assert style["t10"] != style["t0"]
    label = next(el for el in root.iter() if el.get("class") == "joint-label")
    assert label.get("stroke") == "#ffffff" and label.get("paint-order") == "stroke"


def test_animation_shows_crank_angle_and_moving_joint_labels(run_cli, tmp_path):
    pic = tmp_path / "a.svg"
    assert run_cli("simulate", ROOT / "examples" / "jansen.yaml", "--svg", pic, "--animate", "-n", "72",
                   "-o", tmp_path / "a.h5").exit_code == 0
    root = ET.parse(pic).getroot()
    captions = [el for el in root.iter() if el.get("class") == "frame-caption"][0]
    words = [t.text for t in captions if t.tag.endswith("text")]
    assert words[0] == "crank 0°" and words[18] == "crank 90°" and len(words) == 72
    label = next(el for el in root.iter() if el.get("class") == "joint-label" and el.get("data-name") == "G")
    assert "".join(label.itertext()) == "G" and {a.get("attributeName") for a in label} == {"x", "y"}


def test_animation_as_gif(run_cli, tmp_path):
    Image = pytest.importorskip("PIL.Image")
    gif = tmp_path / "a.gif"
    r = run_cli("simulate", ROOT / "examples" / "jansen.yaml", "--svg", gif, "--animate", "-n", "60",
                "-o", tmp_path / "a.h5")
    assert r.exit_code == 0, r.output
    im = Image.open(gif)
    assert im.format == "GIF" and im.n_frames == 60 and im.info["loop"] == 0
    r = run_cli("simulate", ROOT / "examples" / "jansen.yaml", "--svg", tmp_path / "b.gif", "-o", tmp_path / "b.h5")
    assert r.exit_code == 2 and "add --animate" in r.output


def test_edit_overlay_draws_displace_targets_at_the_edited_rest_pose(run_cli, tmp_path):
    import yaml

    r = run_cli("edit", ROOT / "examples" / "edits" / "jansen-move-knee.yaml", "-o", tmp_path)
    assert r.exit_code == 0, r.output
    root = ET.parse(next(tmp_path.glob("*.svg"))).getroot()
    edited = yaml.safe_load(next(tmp_path.glob("*-edited.yaml")).read_text())["joints"]
    names = list(edited)
    px = joint_pixels(root, "after")
    world = np.array([edited[n] for n in names], dtype=float)
    ax, sx, ay, sy = fit_map(world, np.array([px[n] for n in names]))
    # the "after" linkage is drawn at the edited YAML's rest pose, joint for joint
    residual = np.abs(np.array([px[n] for n in names]) - np.column_stack([ax + sx * world[:, 0], ay + sy * world[:, 1]]))
    assert residual.max() < 0.02
    (target,) = [el for el in root.iter() if el.get("class") == "displace-target"]
    assert (float(target.get("cx")), float(target.get("cy"))) == pytest.approx((ax + sx * -20, ay + sy * 36), abs=0.02)
    (arrow,) = [el for el in root.iter() if el.get("class") == "displace"]
    line = arrow.find(NS + "line")
    original = yaml.safe_load((ROOT / "examples" / "jansen.yaml").read_text())["joints"]["C"]
    assert (float(line.get("x1")), float(line.get("y1"))) == pytest.approx(
        (ax + sx * original[0], ay + sy * original[1]), abs=0.02)


# -- labels placed apart (issue 25, item 3) --------------------------------------------------------


def text_boxes(root, classes_):
    """(words, pixel box) of the texts of ``classes_``: width 0.5 em a character (narrower than any
    sans-serif's average), 0.7 em tall above the baseline."""
    out = []
    for t in root.iter(NS + "text"):
        if t.get("class") in classes_ and t.get("x") is not None:
            x, y, size = float(t.get("x")), float(t.get("y")), float(t.get("font-size") or 10)
            w = 0.5 * size * len(t.text or "")
            x0 = x - {"start": 0.0, "middle": w / 2, "end": w}[t.get("text-anchor", "start")]
            out.append((t.text, (x0, y - 0.7 * size, x0 + w, y)))
    return out


def overlapping(boxes):
    return [(a, b) for n, (a, p) in enumerate(boxes) for b, q in boxes[n + 1:]
            if p[0] < q[2] and q[0] < p[2] and p[1] < q[3] and q[1] < p[3]]


def test_lockup_labels_at_neighbouring_samples_do_not_overlap():
    kw = crank_rocker(90)
    notes = [(40, "locks at 160.0° (C)"), (40, "free again after 161.0°"), (41, "locks at 164.0° (C)")]
    root = parse(motion_plot(None, **kw, notes=notes))
    boxes = text_boxes(root, ("lockup-label", "joint-label"))
    assert len(boxes) == 3 + 5 and not overlapping(boxes)
    # a label moved off its place has a leader line from its marker
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(kw["positions"][0], np.array([px[n] for n in kw["joint_names"]]))
    starts = np.array([(float(ln.get("x1")), float(ln.get("y1"))) for ln in find(root, "leader")])
    tracer = kw["tracks"]["tracer"][[40, 41]]
    anchors = np.vstack([np.column_stack([ax + sx * tracer[:, 0], ay + sy * tracer[:, 1]]), list(px.values())])
    assert len(starts) >= 1
    assert all(np.hypot(*(anchors - q).T).min() < 0.05 for q in starts)


def test_a_partial_cycle_curve_runs_through_the_rest_pose(run_cli, tmp_path):
    """A full turn that locks away from the rest pose (--partial): the track is one polyline from where
    the linkage frees, through the rest pose, to where it locks. It was two pieces, the stretch from
    the last sample to the rest pose left out."""
    import h5py

    from tests.planar_specs import LOCKING

    spec = tmp_path / "lock.yaml"
    spec.write_text(LOCKING)
    out, svg = tmp_path / "lock.h5", tmp_path / "lock.svg"
    assert run_cli("simulate", spec, "-o", out, "--svg", svg, "-n", "36", "--partial").exit_code == 0
    with h5py.File(out) as f:
        ok = f["diagnostics/assembled"][()]
        tip = f["tracks/tip/position"][()]
    assert ok[0] and ok[-1] and not ok.all()
    root = parse(svg.read_text())
    (el,) = [e for e in find(root, "track") if e.get("data-name") == "tip"]
    assert el.tag == NS + "polyline"
    got = np.array([tuple(map(float, q.split(","))) for q in el.get("points").split()])
    freed = int(np.flatnonzero(~ok)[-1]) + 1
    world = np.roll(tip, -freed, axis=0)[:int(ok.sum())]  # freed … last sample, rest pose … locked
    ax, sx, ay, sy = fit_map(world, got)
    np.testing.assert_allclose(got, np.column_stack([ax + sx * world[:, 0], ay + sy * world[:, 1]]), atol=0.02)


def test_animate_with_the_result_on_stdout_needs_a_picture_path(run_cli, tmp_path, monkeypatch):
    """``-o - --animate`` without ``--svg``: the animation goes next to the result, which has no file; it was
    dropped without a word (exit 0, no animation). Now one line, exit 2, before anything is written."""
    monkeypatch.chdir(tmp_path)
    r = run_cli("simulate", ROOT / "examples" / "crank-rocker.yaml", "-o", "-", "--animate", "-n", "8")
    assert r.exit_code == 2 and "--animate: " in r.output and "--svg" in r.output, r.output
    assert list(tmp_path.iterdir()) == []


def test_animation_of_a_linear_input_shows_the_stroke(run_cli, tmp_path):
    """A cylinder-driven linkage's animation showed no input at all (a crank's shows its angle): each frame now
    says the stroke from rest, in the spec's units, as the CSV's stroke column."""
    pic = tmp_path / "a.svg"
    assert run_cli("simulate", ROOT / "examples" / "lifting-arm.yaml", "--svg", pic, "--animate", "-n", "11",
                   "-o", tmp_path / "a.h5").exit_code == 0
    captions = [el for el in ET.parse(pic).getroot().iter() if el.get("class") == "frame-caption"]
    assert captions, "no caption"
    words = [t.text for t in captions[0] if t.tag.endswith("text")]
    assert words == [f"stroke {2.5 * k:g} mm" for k in range(11)]  # stroke [0, 25]
