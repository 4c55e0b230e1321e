"""Sliders in the pictures: every prismatic pair is drawn as a rail on the frame or a slot in its
guide link, with a block on the sliding joint, oriented along the guide, in the still picture,
in every frame of the animation (SVG and GIF) and as a slot outline in DXF (issue 25, item 1)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
import yaml

from linkedit.io.svg import MAX_FRAMES
from linkedit.io.figure_style import BLOCK_PX
from tests.conftest import EXAMPLES
from tests.test_svg import NS, find, joint_pixels

SLIDER_EXAMPLES = ["slider-crank", "quick-return", "scotch-yoke", "inverted-slider-crank", "two-slots", "lifting-arm",
                   "stephenson-slider"]


def _spec(stem):
    return yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())


def _points(text):
    return np.array([[float(c) for c in p.split(",")] for p in text.split()])


def _series(el):
    return {a.get("attributeName"): a.get("values").split(";") for a in el.iter(NS + "animate")}


def _simulate(run_cli, tmp_path, stem, *more):
    out = tmp_path / f"{stem}.svg"
    r = run_cli("simulate", EXAMPLES / f"{stem}.yaml", "-o", tmp_path / f"{stem}.h5", "--svg", out, "-n", "90", *more)
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / f"{stem}.h5") as f:
        names = list(f["joint"].asstr()[()])
        positions = f["joints/position"][()]
    return ET.parse(out).getroot(), names, positions


def fit_map(world, px):
    """px = (ax + s·x, ay − s·y) (equal aspect, y flipped), fitted; works when the joints are on one line."""
    A = np.column_stack([np.r_[world[:, 0], -world[:, 1]], np.r_[np.ones(len(world)), np.zeros(len(world))],
                         np.r_[np.zeros(len(world)), np.ones(len(world))]])
    (s, ax, ay), *_ = np.linalg.lstsq(A, np.r_[px[:, 0], px[:, 1]], rcond=None)
    return ax, s, ay, -s


def _guide_of(root, name):
    """The slider's guide: ('slot', ends (2, 2) px) or ('rail', its line (2, 2) px)."""
    slots = [g for g in find(root, "slot") if g.get("data-name") == name]
    rails = [g for g in find(root, "rail") if g.get("data-name") == name]
    assert len(slots) + len(rails) == 1, (name, len(slots), len(rails))
    if slots:
        line = slots[0].find(NS + "line")
        return "slot", slots[0], np.array([[float(line.get(k)) for k in ("x1", "y1")], [float(line.get(k)) for k in ("x2", "y2")]])
    first = rails[0].get("d").split("M")[1]  # the rail's line, then its hatching
    return "rail", rails[0], _points(first.replace(" L", " "))


def _turned(spec, guide, names, pose):
    """How far (degrees) the guide link has turned from the spec's rest pose to ``pose`` (a swing
    range starts away from rest)."""
    if guide == "ground":
        return 0.0
    a, b = spec["links"][guide][:2]
    rest = np.subtract(spec["joints"][b], spec["joints"][a])
    now = pose[names.index(b)] - pose[names.index(a)]
    return float(np.degrees(np.arctan2(now[1], now[0]) - np.arctan2(rest[1], rest[0])))


def _off_line(p, ends):
    """Signed distance of pixel point p from the line through ends, and its position along it (0..1 inside)."""
    d = ends[1] - ends[0]
    u = d / np.hypot(*d)
    q = p - ends[0]
    return float(u[0] * q[1] - u[1] * q[0]), float(q @ d / (d @ d))


@pytest.mark.parametrize("stem", SLIDER_EXAMPLES)
def test_every_slider_is_a_block_on_its_guide_at_rest(run_cli, tmp_path, stem):
    root, names, positions = _simulate(run_cli, tmp_path, stem)
    spec = _spec(stem)
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(positions[0], np.array([px[n] for n in names]))
    blocks = {b.get("data-name"): b for b in find(root, "block")}
    assert set(blocks) == set(spec["sliders"])
    for name, s in spec["sliders"].items():
        joint = s.get("joint") or spec["links"][s["link"]][0]
        world = positions[0, names.index(joint)]
        corners = _points(blocks[name].get("points"))
        centre = corners.mean(axis=0)
        # the block sits on the sliding joint, its long side along the slider's direction (spec angle, y up)
        assert centre == pytest.approx([ax + sx * world[0], ay + sy * world[1]], abs=0.02)
        long_side = corners[1] - corners[0]
        assert np.hypot(*long_side) == pytest.approx(BLOCK_PX[0], abs=0.02)
        angle = np.degrees(np.arctan2(-long_side[1], long_side[0])) - _turned(spec, s["guide"], names, positions[0])
        assert (angle - s["angle_deg"] + 90) % 180 - 90 == pytest.approx(0, abs=0.05)
        kind, el, ends = _guide_of(root, name)
        fixed = s["guide"] == "ground" or set(spec["links"][s["guide"]]) <= set(spec["ground"])
        assert kind == ("rail" if fixed else "slot")
        off, along = _off_line(centre, ends)
        if kind == "slot":  # on the slot's centre line, inside it
            assert abs(off) < 0.03 and -1e-3 <= along <= 1 + 1e-3
        else:  # resting on the rail: half a block beside its line
            assert abs(abs(off) - BLOCK_PX[1] / 2) < 0.03 and 0 < along < 1


@pytest.mark.parametrize("stem", ["scotch-yoke", "quick-return", "inverted-slider-crank", "two-slots"])
def test_blocks_ride_their_slots_in_every_animation_frame(run_cli, tmp_path, stem):
    root, names, positions = _simulate(run_cli, tmp_path, stem, "--animate")
    spec = _spec(stem)
    px = joint_pixels(root)
    ax, sx, ay, sy = fit_map(positions[0], np.array([px[n] for n in names]))
    frames = min(90, MAX_FRAMES)
    for name, s in spec["sliders"].items():
        joint = s.get("joint") or spec["links"][s["link"]][0]
        (block,) = [b for b in find(root, "block") if b.get("data-name") == name]
        centres = np.array([_points(v).mean(axis=0) for v in _series(block)["points"]])
        cyclic = "range_deg" not in spec["motor"]
        assert len(centres) == frames + cyclic  # a full cycle: frame 0 again at the end
        world = positions[:frames, names.index(joint)]
        np.testing.assert_allclose(centres[:frames], np.column_stack([ax + sx * world[:, 0], ay + sy * world[:, 1]]), atol=0.1)
        kind, el, ends = _guide_of(root, name)
        if kind == "rail":
            continue  # the rail stands still; the block's centre follows the joint (checked above)
        line = el.find(NS + "line")
        moving = _series(line)
        coords = {k: np.array(moving[k], float) if k in moving else np.full(frames, float(line.get(k)))
                  for k in ("x1", "y1", "x2", "y2")}
        assert moving, f"the slot of {name} does not move with its link"
        for k in range(frames):
            e = np.array([[coords["x1"][k], coords["y1"][k]], [coords["x2"][k], coords["y2"][k]]])
            off, along = _off_line(centres[k], e)
            assert abs(off) < 0.15 and -0.01 <= along <= 1.01, (name, k, off, along)


def test_a_slot_outline_is_on_its_guide_layer_in_dxf(run_cli, tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    out = tmp_path / "yoke.dxf"
    assert run_cli("simulate", EXAMPLES / "scotch-yoke.yaml", "-o", out).exit_code == 0
    doc = ezdxf.readfile(out)
    outlines = {e.dxf.layer: np.array(list(e.get_points("xyb"))) for e in doc.modelspace().query("LWPOLYLINE")
                if e.closed}
    hole = next(c.dxf.radius for c in doc.modelspace().query("CIRCLE"))
    # A (crank 20) in the yoke's vertical slot at x = 20: y = 20 sin θ spans [-20, 20]
    slot = outlines["LINK-yoke"]
    assert sorted(set(np.round(slot[:, 0], 9))) == pytest.approx([20 - hole, 20 + hole])
    assert sorted(set(np.round(slot[:, 1], 9))) == pytest.approx([-20, 20])
    assert sorted(np.abs(slot[:, 2])) == [0, 0, 1, 1]  # two half circles
    # the yoke slides on the frame: Y1 = 50 − 20 + 20 cos θ spans [10, 50] on y = 0
    rail = outlines["FRAME"]
    assert sorted(set(np.round(rail[:, 0], 9))) == pytest.approx([10, 50])
    assert sorted(set(np.round(rail[:, 1], 9))) == pytest.approx([-hole, hole])


def test_a_dxf_slot_on_a_moving_guide_is_cut_in_its_link_at_the_rest_pose(run_cli, tmp_path):
    """DXF draws the links at the rest pose; a slotted rocker's slot must lie along that rocker. With a sweep
    that starts away from the rest pose (range_deg [60, 150]) the slot was drawn where the rocker is at the
    sweep's start (80° instead of its rest 63.4°), off the part it is cut in."""
    ezdxf = pytest.importorskip("ezdxf")
    spec, out = tmp_path / "qr.yaml", tmp_path / "qr.dxf"
    doc = yaml.safe_load((EXAMPLES / "quick-return.yaml").read_text())
    doc["motor"]["range_deg"] = [60, 150]
    spec.write_text(yaml.safe_dump(doc))
    assert run_cli("simulate", spec, "-o", out, "-n", "91").exit_code == 0
    (slot,) = [np.array(list(e.get_points("xyb"))) for e in ezdxf.readfile(out).modelspace().query("LWPOLYLINE")
               if e.closed and e.dxf.layer == "LINK-rocker"]
    ends = (slot[[0, 1], :2] + slot[[3, 2], :2]) / 2  # the slot's centre line (O2, the first ground joint, at 0)
    # the crank pin A = O + 15 (cos θ, sin θ), O = (0, 30), slides in the rocker at |A| from its pivot O2:
    # 45 at θ = 90°, 39.7 at θ = 150° and 15√5 = 33.5 at rest (θ = 0), where the linkage is assembled
    reach = [15 * 5**0.5, 45.0]
    rest = np.arctan2(2, 1)  # the rocker O2 → C at rest
    assert np.abs(np.arctan2(ends[:, 1], ends[:, 0]) - rest).max() < 1e-12
    assert np.hypot(*ends.T) == pytest.approx(reach, rel=1e-12)


def test_a_dxf_slot_off_its_link_is_joined_to_it_by_an_arm(run_cli, tmp_path):
    """The Scotch yoke's slot (x = 20) lies off the yoke's bar Y1-Y2 (x 50…90): the pictures join them with an
    arm, the DXF left the slot floating apart from its part; its layer now has the arm's centre line too."""
    ezdxf = pytest.importorskip("ezdxf")
    out = tmp_path / "yoke.dxf"
    assert run_cli("simulate", EXAMPLES / "scotch-yoke.yaml", "-o", out, "-n", "36").exit_code == 0
    lines = sorted(tuple(map(tuple, np.round([p[:2] for p in e.get_points()], 9)))
                   for e in ezdxf.readfile(out).modelspace().query("LWPOLYLINE") if e.dxf.layer == "LINK-yoke" and not e.closed)
    assert lines == [((20, 0), (50, 0)), ((50, 0), (90, 0))]  # the arm, the bar
