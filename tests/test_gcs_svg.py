"""The 3D picture (``solve3d --svg``), drawn by the shared figure module: the view's projection
is exact (pixels are an equal-scale, y-flipped affine map of the projected world points), the
default view follows the mechanism (xy when it stays in a plane, iso otherwise), members are
labelled, velocity arrows stay a tenth of the drawing, the triad and legend are there."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES
from tests.test_svg import find, parse

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


def test_iso_picture_has_units_labels_apart_and_arrows_under_the_tracks(run_cli, solved, tmp_path):
    from tests.test_svg import overlapping, text_boxes

    root = _picture(run_cli, solved, tmp_path, "compound-crank-rocker", "--arrows")
    assert not find(root, "unit")  # no axes in an isometric view: the units are on the ground plane
    words = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text") if t.text]
    assert any(w.startswith("ground plane z = ") and w.endswith(" m)") for w in words)
    ticks = [t.text for t in find(root, "ground-tick")]
    assert sum(w.endswith(" m") for w in ticks) == 2  # the first of each row of grid values
    boxes = text_boxes(root, ("member-label", "ground-tick"))
    assert len(boxes) > 10 and not overlapping(boxes)
    order = [el.get("class") for el in root.iter() if el.get("class") in ("velocity", "track")]
    assert order.index("track") > max(i for i, c in enumerate(order) if c == "velocity")  # curves drawn last
