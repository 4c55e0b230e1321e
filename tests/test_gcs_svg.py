"""The 3D picture (``solve3d --svg``), drawn by the shared figure module: the view's projection
is exact (pixels are an equal-scale, y-flipped affine map of the projected world points), the
default view follows the mechanism (face-on to the plane it moves in, iso otherwise), nearer
strokes are darker and wider, members are labelled apart, the ground grid names its axes with
units, velocity arrows stay a tenth of the drawing, the triad and legend are there."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest

import yaml

from tests.conftest import EXAMPLES
from tests.gcs_oracles import _circles, crank_rocker
from tests.test_svg import NS, find, overlapping, parse, text_boxes

CCR = EXAMPLES / "3d" / "compound-crank-rocker.yaml"
CR = EXAMPLES / "3d" / "crank-rocker.yaml"


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    from linkedit.cli import app
    from typer.testing import CliRunner

    folder = tmp_path_factory.mktemp("gcs-svg")
    for spec in (CCR, CR):
        r = CliRunner().invoke(app, ["solve3d", str(spec), "-o", str(folder / f"{spec.stem}.h5"), "--steps", "61"])
        assert r.exit_code == 0, r.output
    return folder


def _picture(run_cli, solved, tmp_path, stem, *options):
    svg = tmp_path / f"{stem}.svg"
    r = run_cli("solve3d", "--from", solved / f"{stem}.h5", "-o", tmp_path / "x.h5", "--svg", svg, *options)
    assert r.exit_code == 0, r.output
    return parse(svg.read_text())


def _points(el) -> np.ndarray:
    return np.array([[float(c) for c in p.split(",")] for p in el.get("points").split()])


def _track(solved, stem, name) -> np.ndarray:
    with h5py.File(solved / f"{stem}.h5") as f:
        return f[f"tracks/{name}/position"][()]


def _axis_words(root) -> list[str]:
    return [t.text for t in find(root, "unit")]


@pytest.mark.parametrize("view, axes", [("xy", (0, 1)), ("xz", (0, 2)), ("yz", (1, 2))])
def test_orthographic_views_project_exactly(run_cli, solved, tmp_path, view, axes):
    root = _picture(run_cli, solved, tmp_path, "compound-crank-rocker", "--view", view)
    assert _axis_words(root) == [f"{view[0]} (m)", f"{view[1]} (m)"]
    world = _track(solved, "compound-crank-rocker", "P")[:, axes]
    px = _points(next(el for el in find(root, "track") if el.get("data-name") == "P"))
    # px = s·(x, -y) + c with one scale s > 0 for both axes (equal aspect, y up)
    A = np.column_stack([world[:, 0], -world[:, 1], np.ones(len(world))])
    sx = np.linalg.lstsq(A[:, [0, 2]], px[:, 0], rcond=None)[0]
    sy = np.linalg.lstsq(A[:, [1, 2]], px[:, 1], rcond=None)[0]
    assert sx[0] > 0 and abs(sx[0] - sy[0]) < 1e-3 * sx[0]
    fit = np.column_stack([A[:, [0, 2]] @ sx, A[:, [1, 2]] @ sy])
    assert np.abs(fit - px).max() < 0.01  # the 2-decimal rounding of the SVG coordinates


def test_default_view_is_xy_for_a_planar_mechanism_iso_otherwise(run_cli, solved, tmp_path):
    flat = _picture(run_cli, solved, tmp_path, "crank-rocker")
    assert _axis_words(flat) == ["x (m)", "y (m)"] and not find(flat, "ground-plane")
    spatial = _picture(run_cli, solved, tmp_path, "compound-crank-rocker")
    assert "view iso" in spatial.find("{http://www.w3.org/2000/svg}title").text
    assert _axis_words(spatial) == [] and len(find(spatial, "ground-plane")) >= 4
    # the ground plane lies under everything: z = the lowest z the mechanism reaches
    z = _track(solved, "compound-crank-rocker", "P")[:, 2].min()
    legend = " ".join(t.text for t in spatial.iter("{http://www.w3.org/2000/svg}text") if t.text)
    assert f"ground plane z = {z:.0f}" in legend


def test_members_labelled_triad_legend_and_arrows_a_tenth_of_the_drawing(run_cli, solved, tmp_path):
    root = _picture(run_cli, solved, tmp_path, "compound-crank-rocker", "--view", "xz", "--arrows")
    labels = {t.text for t in find(root, "member-label")}
    assert labels == {"crank", "coupler", "rocker", "spinner"}
    assert {el.get("data-name") for el in find(root, "member")} == labels
    assert [g.get("data-name") for g in find(root, "triad")[0]] == ["x", "y", "z"]
    legend = [t.text for t in find(root, "legend")[0].iter("{http://www.w3.org/2000/svg}text")]
    assert legend[:2] == ["P", "rocker_tip"] and legend[2].startswith("velocity d/dt") and "members at t = 0" in legend
    arrows = find(root, "velocity")
    assert len(arrows) == 2 * 16
    curve = _points(next(el for el in find(root, "track") if el.get("data-name") == "P"))
    frame = find(root, "axes")[0].find("{http://www.w3.org/2000/svg}rect")
    size_px = max(float(frame.get("width")), float(frame.get("height")))  # the drawing's size, pixels
    longest = max(np.hypot(float(a[0].get("x2")) - float(a[0].get("x1")), float(a[0].get("y2")) - float(a[0].get("y1")))
                  for a in arrows)
    assert longest <= 0.1 * size_px + 1 and np.ptp(curve, axis=0).max() > 5 * longest


def test_bad_view_is_an_input_error(run_cli, solved, tmp_path):
    r = run_cli("solve3d", "--from", solved / "crank-rocker.h5", "-o", tmp_path / "x.h5", "--svg", tmp_path / "x.svg",
                "--view", "top")
    assert r.exit_code == 2 and "--view" in r.output and not (tmp_path / "x.svg").exists()


def _triad_boxes(root) -> list:
    """(word, pixel box) of the triad's axis names (as :func:`text_boxes`, 11 px)."""
    out = []
    for t in find(root, "triad")[0].iter(NS + "text"):
        x, y, w = float(t.get("x")), float(t.get("y")), 0.5 * 11 * len(t.text)
        x0 = x - (w / 2 if t.get("text-anchor") == "middle" else 0.0)
        out.append((t.text, (x0, y - 0.7 * 11, x0 + w, y)))
    return out


def test_iso_picture_has_units_labels_apart_and_arrows_under_the_tracks(run_cli, solved, tmp_path):
    root = _picture(run_cli, solved, tmp_path, "compound-crank-rocker", "--arrows")
    assert not find(root, "unit")  # no axes in an isometric view: the units are on the ground plane
    words = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text") if t.text]
    assert any(w.startswith("ground plane z = ") and w.endswith(" m)") for w in words)
    ticks = [t.text for t in find(root, "ground-tick")]
    assert all(float(w) == float(w) for w in ticks)  # plain values; the grid's axes are named once, with units
    assert [t.text for t in find(root, "ground-axis")] == ["x (m)", "y (m)"]
    boxes = text_boxes(root, ("member-label", "ground-tick", "ground-axis")) + _triad_boxes(root)
    assert len(boxes) > 10 and not overlapping(boxes)
    order = [el.get("class") for el in root.iter() if el.get("class") in ("velocity", "track")]
    assert order.index("track") > max(i for i, c in enumerate(order) if c == "velocity")  # curves drawn last


def _rotated(data: dict, axis: list[float], angle_deg: float) -> dict:
    """The 3D spec ``data`` turned rigidly about the world origin (member positions and
    orientations, world points of constraints, input rotation axes)."""
    from linkedit.gcs import quaternions as quat

    q = quat.from_axis_angle(np.asarray(axis, float) / np.linalg.norm(axis), np.asarray(np.radians(angle_deg)))
    R = quat.to_matrix(q)
    for m in data["members"].values():
        o = m.get("orientation", {"axis": [0, 0, 1], "angle_deg": 0})
        m["position"] = (R @ m["position"]).tolist()
        m["orientation"] = quat.multiply(q, quat.from_axis_angle(np.asarray(o["axis"], float),
                                                                 np.asarray(np.radians(o["angle_deg"])))).tolist()
    for c in data["constraints"].values():
        c["world"] = (R @ c["world"]).tolist() if "world" in c else None
        if c["world"] is None:
            del c["world"]
    for i in data["inputs"].values():
        i["rotation"]["axis"] = (R @ i["rotation"]["axis"]).tolist()
    return data


def _tilted_crank_rocker(run_cli, tmp_path, axis, angle_deg, *options):
    """examples/3d/crank-rocker.yaml turned about ``axis``, solved over 37 steps with a picture: the
    picture's root, the rotation and the crank angles."""
    from linkedit.gcs import quaternions as quat

    data = _rotated(yaml.safe_load(CR.read_text()), axis, angle_deg)
    data["outputs"]["steps"] = 37
    spec = tmp_path / "tilted.yaml"
    spec.write_text(yaml.safe_dump(data))
    r = run_cli("solve3d", spec, "-o", tmp_path / "t.h5", "--svg", tmp_path / "t.svg", *options)
    assert r.exit_code == 0, r.output
    R = quat.to_matrix(quat.from_axis_angle(np.asarray(axis, float) / np.linalg.norm(axis),
                                            np.asarray(np.radians(angle_deg))))
    return parse((tmp_path / "t.svg").read_text()), R, np.linspace(0, 2 * np.pi, 37)


@pytest.mark.parametrize("axis, angle_deg", [([1, 1, 0], 80.0), ([1, 0, 0], 60.0), ([0.3, -1, 0.2], 35.0)])
def test_a_four_bar_in_a_tilted_plane_is_drawn_face_on(run_cli, tmp_path, axis, angle_deg):
    """The crank-rocker turned out of the xy plane (the first tilt leaves it nearly edge-on to the
    isometric view, the old default): the default picture looks along the plane's normal, so its
    tracks are the true curves to one scale — every distance between two points of the coupler
    curve and the rocker tip's arc (their closed form, turned) is the same multiple in pixels —
    with axes u, v in the spec's units and their world directions in the legend."""
    root, R, theta = _tilted_crank_rocker(run_cli, tmp_path, axis, angle_deg)
    P = crank_rocker(theta) @ R.T
    A = np.column_stack([-3 + np.cos(theta), 3 + np.sin(theta)])
    tip = np.column_stack([_circles(A, 5.0, np.array([2.0, -3.0]), 5.75, +1), np.zeros(len(theta))]) @ R.T
    tracks = {el.get("data-name"): _points(el) for el in find(root, "track")}
    world, px = np.vstack([P, tip]), np.vstack([tracks["P"], tracks["rocker_tip"]])
    assert px.shape == world[:, :2].shape
    i, j = np.triu_indices(len(world), 1)
    far = np.linalg.norm(world[i] - world[j], axis=1) > 0.5  # > 30 px: the 0.01 px rounding stays < 1e-3
    ratio = np.linalg.norm(px[i] - px[j], axis=1)[far] / np.linalg.norm(world[i] - world[j], axis=1)[far]
    assert ratio.min() > 0.999 * ratio.max()
    assert "view plane (face-on)" in root.find(NS + "title").text
    assert _axis_words(root) == ["u (m)", "v (m)"]
    legend = " ".join(t.text for t in find(root, "legend")[0].iter(NS + "text"))
    u, v = (np.array(re.search(rf"{a} = \(([^)]*)\)", legend)[1].split(","), dtype=float) for a in "uv")
    normal = R @ [0, 0, 1.0]
    assert abs(u @ normal) < 0.01 and abs(v @ normal) < 0.01 and abs(u @ v) < 0.01
    boxes = text_boxes(root, ("member-label",)) + _triad_boxes(root)
    assert len(boxes) == 6 and not overlapping(boxes)


def test_a_four_bar_turned_into_a_world_plane_gets_that_plane_s_view(run_cli, tmp_path):
    """Turned a quarter about y, the crank-rocker moves in the plane x = const: the yz view."""
    root, _, _ = _tilted_crank_rocker(run_cli, tmp_path, [0, 1, 0], 90.0)
    assert "view yz" in root.find(NS + "title").text and _axis_words(root) == ["y (m)", "z (m)"]


def _luminance(color: str) -> float:
    return sum(w * int(color[k:k + 2], 16) for w, k in zip((0.299, 0.587, 0.114), (1, 3, 5)))


def test_nearer_bars_are_darker_wider_and_drawn_over_farther_ones(run_cli, tmp_path):
    """The crank-rocker in the isometric view (looking from (−1, −1, 1), so nearer is a larger
    −x − y + z): at t = 0 the crank (from (−3, 3) to (−2, 3)) is nearer than the rocker (from
    (2, −3) to its tip, the closed form), and its bar is darker, wider and drawn later."""
    root, _, theta = _tilted_crank_rocker(run_cli, tmp_path, [0, 0, 1], 0.0, "--view", "iso")
    B = _circles(np.array([[-2.0, 3.0]]), 5.0, np.array([2.0, -3.0]), 5.75, +1)[0]
    depth = {"crank": -(-2.5 + 3.0), "rocker": -((2.0 + B[0]) / 2 + (-3.0 + B[1]) / 2)}
    assert depth["crank"] > depth["rocker"]
    bars = [el for el in find(root, "member") if el.tag == NS + "line"]
    order = [el.get("data-name") for el in bars]
    assert sorted(order) == ["crank", "rocker"] and order.index("crank") > order.index("rocker")
    el = {e.get("data-name"): e for e in bars}
    assert float(el["crank"].get("stroke-width")) > float(el["rocker"].get("stroke-width")) + 1
    assert _luminance(el["crank"].get("stroke")) < _luminance(el["rocker"].get("stroke")) - 20
    legend = [t.text for t in find(root, "legend")[0].iter(NS + "text")]
    assert "nearer: darker, wider" in legend


def test_a_label_at_the_triad_s_corner_moves_off_it():
    """A label anchored where the axes triad is drawn (the plot's lower-left corner) is placed
    clear of the triad's arrows and names (their bounding box)."""
    from linkedit.io.svg_figure import Figure

    fig = Figure(axis_names=None)
    fig.polyline(np.array([[0.0, 0.0], [10.0, 10.0]]))
    fig.triad({"x": [1.0, 0.0], "y": [0.0, 1.0]})
    root = parse(fig.render())
    triad = find(root, "triad")[0]
    centre = [(float(ln.get("x1")), float(ln.get("y1"))) for ln in triad.iter(NS + "line")][0]
    track = _points(find(root, "curve")[0])  # pixels of (0, 0) and (10, 10)
    at = (np.array(centre) - track[0]) / (track[1] - track[0]) * 10.0
    fig.annotate(at.tolist(), "corner", cls="member-label")
    root = parse(fig.render())
    (_, box), = text_boxes(root, ("member-label",))
    ends = np.array([(float(ln.get(f"x{k}")), float(ln.get(f"y{k}"))) for ln in find(root, "triad")[0].iter(NS + "line")
                     for k in "12"])
    words = np.array([b for _, b in _triad_boxes(root)])
    lo = np.minimum(ends.min(axis=0), words[:, :2].min(axis=0))
    hi = np.maximum(ends.max(axis=0), words[:, 2:].max(axis=0))
    assert box[2] < lo[0] or box[0] > hi[0] or box[3] < lo[1] or box[1] > hi[1]
