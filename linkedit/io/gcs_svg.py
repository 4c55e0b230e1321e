"""The picture of a solved 3D mechanism, drawn by the shared figure module (:mod:`linkedit.io.svg_figure`).

A projection of the world onto the drawing: ``plane`` (face-on: looking along the normal of the
plane the mechanism moves in, fitted to all its points over the run), ``xy`` (top), ``xz``
(front), ``yz`` (side) — orthographic, with the figure's axes in the mechanism's units — or
``iso`` (isometric, a ground plane grid under the mechanism with its tick values and axis
names). An axes triad shows the world directions in every view. Members are drawn like planar
links (bars between consecutive points of each drawing line, plates for closed lines) at the
first step (solid, labelled; nearer strokes darker and wider, drawn over farther ones) and a few
later steps (faint); each track's curve in its colour, with optional velocity arrows scaled so
the longest is a tenth of the drawing (the curve stays visible). Labels are placed apart by the
figure (:func:`~linkedit.io.figure_layout.place_labels`). :func:`overlay` draws curves over the
mechanism (a synthesis target and candidate), face-on to the plane fitted to the curves.

Elements carry ``class`` and ``data-name``: ``member`` / ``member-pose`` (faint poses) /
``member-label`` / ``track`` / ``track-point`` / ``velocity`` / ``ground-plane`` /
``ground-tick`` / ``ground-axis`` / ``triad`` / ``curve`` (an overlay's).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.gcs import quaternions as quat
from linkedit.gcs.result import GcsResult
from linkedit.io.atomic import write_text
from linkedit.io.figure_layout import finite, nice_ticks, tick_label
from linkedit.io.figure_style import INK, PALETTE, Stroke
from linkedit.io.svg_figure import Figure

VIEWS = ("plane", "xy", "xz", "yz", "iso")
_ISO = np.array([[np.cos(np.pi / 6), -np.cos(np.pi / 6), 0.0], [np.sin(np.pi / 6), np.sin(np.pi / 6), 1.0]])
#: fixed view → (2, 3) projection matrix (world → drawing, y up) and the drawing's axis names
PROJECTIONS: dict[str, tuple[np.ndarray, tuple[str, str] | None]] = {
    "xy": (np.array([[1.0, 0, 0], [0, 1.0, 0]]), ("x", "y")),
    "xz": (np.array([[1.0, 0, 0], [0, 0, 1.0]]), ("x", "z")),
    "yz": (np.array([[0, 1.0, 0], [0, 0, 1.0]]), ("y", "z")),
    "iso": (_ISO, None),
}
#: a mechanism whose points stay within this fraction of its extent of one plane moves in that
#: plane: the default view looks at it face-on
FLAT = 0.05
#: ... and through a world view (xy, xz, yz) when the plane's normal is within this of its axis
ALIGNED_DEG = 1.0
ARROW_FRACTION = 0.1  #: the longest velocity arrow, as a fraction of the drawing's size
ARROWS_PER_TRACK = 16
POSES = 8  #: poses drawn over the run (the first solid, the others faint)
#: depth cue of the solid pose: bar width (px) and ink from the farthest to the nearest stroke
DEPTH_WIDTH = (4.0, 9.0)
DEPTH_INK = ((0xa0, 0xae, 0xc0), (0x1a, 0x20, 0x2c))


def project(p: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """World points ``(..., 3)`` → drawing coordinates ``(..., 2)`` (x right, y up) by a (2, 3) ``matrix``."""
    return np.asarray(p, dtype=float) @ matrix.T


def projection(view: str, res: GcsResult) -> tuple[np.ndarray, tuple[str, str] | None]:
    """The (2, 3) projection matrix of ``view`` and the drawing's axis names (None: no world axes)."""
    if view == "plane":
        return _face_on(_world_points(res))
    if view not in PROJECTIONS:
        raise InputError(f"unknown view {view!r} (choose from {', '.join(VIEWS)})", field="--view")
    return PROJECTIONS[view]


def default_view(res: GcsResult) -> str:
    """The view of the plane the mechanism moves in, when it is (nearly) planar — every member
    point and track over the run within :data:`FLAT` of its extent of the plane fitted to them —
    as ``xy``, ``xz`` or ``yz`` when that plane faces a world axis (within :data:`ALIGNED_DEG`),
    else ``plane`` (face-on); ``iso`` for a spatial mechanism (or one moving along a line)."""
    world = _world_points(res)
    if world.size == 0 or not np.ptp(world, axis=0).max() > 0:
        return "xy"
    axes = np.linalg.svd(world - world.mean(axis=0), full_matrices=False)[2]
    extent = np.ptp(world @ axes.T, axis=0)
    if not (extent[2] <= FLAT * extent[0] and extent[1] > FLAT * extent[0]):
        return "iso"
    facing = int(np.argmax(np.abs(axes[2])))
    if abs(axes[2, facing]) >= np.cos(np.radians(ALIGNED_DEG)):
        return ("yz", "xz", "xy")[facing]
    return "plane"


def _face_on(world: np.ndarray) -> tuple[np.ndarray, tuple[str, str]]:
    """The projection onto the plane fitted to ``world`` (n, 3) (least squares): rows u, v (in-plane
    unit vectors, u × v = n, the normal towards the viewer, its largest component positive); v is
    world z (or, for a plane near horizontal, y) projected on the plane, so up stays up."""
    n = np.linalg.svd(world - world.mean(axis=0), full_matrices=False)[2][2] if len(world) >= 3 else np.eye(3)[2]
    n = n * np.sign(n[np.argmax(np.abs(n))])
    up = next(v for v in (np.eye(3)[2], np.eye(3)[1], np.eye(3)[0]) if np.linalg.norm(v - (v @ n) * n) > 0.3)
    v = up - (up @ n) * n
    v /= np.linalg.norm(v)
    return np.array([np.cross(v, n), v]), ("u", "v")


def _toward_viewer(matrix: np.ndarray) -> np.ndarray:
    """The unit world direction (3,) towards the viewer of a projection (its rows' cross product)."""
    w = np.cross(matrix[0], matrix[1])
    return w / np.linalg.norm(w)


def _vector(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{c:.2f}".replace("-0.00", "0.00") for c in v) + ")"


def draw(path: str | Path | None, res: GcsResult, view: str | None = None, velocity: bool = False) -> str:
    """The picture's SVG text; written atomically to ``path`` if given. ``view``: one of
    :data:`VIEWS`, default :func:`default_view`; ``velocity``: draw velocity arrows on the tracks."""
    view = view or default_view(res)
    matrix, axis_names = projection(view, res)
    caption = "plane (face-on)" if view == "plane" else view
    fig = Figure(title=f"{res.name} — view {caption}, {res.t.size} steps", units=res.units, axis_names=axis_names)
    return _finish(path, _scene(fig, res, matrix, view, velocity=velocity))


@dataclass(frozen=True)
class Curve3:
    """A curve drawn over a solved mechanism (:func:`overlay`): world points ``(n, 3)``, one legend entry ``label``."""

    label: str
    points: np.ndarray
    closed: bool
    style: str = "dashed"  #: a :class:`~linkedit.io.figure_style.Stroke` style: dashed, faint, solid


def overlay(path: str | Path | None, res: GcsResult, curves: Sequence[Curve3], *, title: str,
            track_labels: Mapping[str, str] | None = None) -> str:
    """The mechanism of :func:`draw` with ``curves`` drawn over it and its tracks (each in the next colour after
    the tracks', its own legend entry), seen face-on to the plane fitted to the curves and the tracks (the view
    ``plane``: axes u, v in the mechanism's units, their world directions in the legend); ``track_labels``
    renames tracks in the legend (track name → label). Written atomically to ``path`` if given."""
    world = np.vstack([c.points for c in curves] + [tr.position for tr in res.tracks.values()])
    matrix, axis_names = _face_on(world)
    fig = Figure(title=title, units=res.units, axis_names=axis_names)
    return _finish(path, _scene(fig, res, matrix, "plane", track_labels=track_labels or {}, curves=curves))


def _finish(path: str | Path | None, fig: Figure) -> str:
    svg = fig.render()
    if path is not None:
        write_text(path, svg)
    return svg


def _scene(fig: Figure, res: GcsResult, matrix: np.ndarray, view: str, *, velocity: bool = False,
           track_labels: Mapping[str, str] | None = None, curves: Sequence[Curve3] = ()) -> Figure:
    """Draw the solved mechanism into ``fig`` through the projection ``matrix`` of ``view``: faint later
    poses, the depth-cued first pose, the tracks (legend: their names, or ``track_labels``), ``curves``
    over them, labels, the legend and the triad."""
    T = res.t.size
    frames = np.unique(np.linspace(0, T - 1, min(POSES, T)).round().astype(int))
    world = _world_points(res)
    size = float(np.ptp(project(world, matrix), axis=0).max()) if world.size else 1.0
    if view == "iso" and world.size:
        _ground_plane(fig, world, res.units)
    for k in frames[:0:-1]:  # faint poses under the first, solid one
        for name, lines in _member_lines(res, int(k)).items():
            for line in lines:
                _member(fig, name, project(line, matrix), np.allclose(line[0], line[-1]),
                        dict(name=name, style="faint", cls="member-pose", width=3.0), "member-pose")
    cue = _depth_cue(fig, res, matrix, world)
    gain = _arrows(fig, res, matrix, size) if velocity else None  # under the curves: a short track stays visible
    for n, (name, tr) in enumerate(res.tracks.items()):
        color = PALETTE[n % len(PALETTE)]
        stroke = Stroke(color, 2.2, "dashed" if n >= len(PALETTE) else "solid")
        label = (track_labels or {}).get(name, name)
        fig.polyline(project(tr.position, matrix), stroke, closed=tr.cyclic, cls="track", name=name, label=label)
        fig.joints(project(tr.position[:1], matrix), names=[name], fill=color, stroke=Stroke(color, 1.0),
                   cls="track-point")
    for k, c in enumerate(curves):
        color = PALETTE[(len(res.tracks) + k) % len(PALETTE)]
        fig.polyline(project(finite(c.label, c.points, (None, 3)), matrix), Stroke(color, 1.8, c.style),
                     closed=c.closed, cls="curve", name=c.label, label=c.label)
    if gain is not None:
        fig.legend(f"velocity d/dt × {gain:.3g} (t in [0, 1]{f'; {res.units} per unit t' if res.units else ''})",
                   Stroke(INK, 1.2))
    for name, lines in _member_lines(res, 0).items():  # the figure places the labels apart
        corners = np.vstack(lines) if lines else res.position[0, [res.member_names.index(name)]]
        fig.annotate(project(corners.mean(axis=0), matrix).tolist(), name, cls="member-label")
    R = quat.to_matrix(res.orientation[0])
    for m, name in enumerate(res.member_names):
        pts = res.points.get(name, {})
        if pts:
            local = np.array(list(pts.values()), dtype=float).reshape(-1, 3)
            fig.joints(project(res.position[0, m] + local @ R[m].T, matrix), names=[f"{name}.{p}" for p in pts])
    fig.legend("members at t = 0", Stroke(INK, 3.0))
    if cue:
        fig.legend("nearer: darker, wider", Stroke(INK, DEPTH_WIDTH[1]))
    if len(frames) > 1:
        fig.legend(f"{len(frames) - 1} later poses", Stroke(INK, 3.0, "faint"))
    if view == "plane":
        fig.legend(f"u = {_vector(matrix[0])}, v = {_vector(matrix[1])}", Stroke("#ffffff", 0.0))
    fig.triad({a: matrix[:, i].tolist() for i, a in enumerate("xyz")})
    return fig


def _member(fig: Figure, name: str, xy: np.ndarray, closed: bool, style: dict, cls: str) -> None:
    """One drawing line of a member (projected, (n, 2)): a dot, a plate (``closed``) or bars."""
    if len(xy) == 1:
        fig.joints(xy, names=[name], cls=cls)
    elif closed and len(xy) >= 3:
        fig.link(xy[:-1], **style)
    else:
        for a, b in zip(xy[:-1], xy[1:]):
            fig.link(np.array([a, b]), **style)


def _depth_cue(fig: Figure, res: GcsResult, matrix: np.ndarray, world: np.ndarray) -> bool:
    """The solid pose (t = 0), farthest stroke first, each bar or plate darker and its bars wider the
    nearer it is to the viewer (:data:`DEPTH_INK`, :data:`DEPTH_WIDTH`); True when the scene has
    depth (over 1e-6 of its size), else every stroke is drawn as the nearest."""
    toward = _toward_viewer(matrix)
    depth = world @ toward if world.size else np.zeros(1)
    lo, span = float(depth.min()), float(np.ptp(depth))
    deep = span > 1e-6 * max(float(np.ptp(world, axis=0).max()) if world.size else 0.0, 1e-300)
    pieces = []  # (depth, name, world line, closed)
    for name, lines in _member_lines(res, 0).items():
        for line in lines:
            closed = len(line) >= 3 and np.allclose(line[0], line[-1])
            if closed or len(line) == 1:
                pieces.append((float(line.mean(axis=0) @ toward), name, line, closed))
            else:
                pieces += [(float((a + b) @ toward) / 2, name, np.array([a, b]), False) for a, b in zip(line[:-1], line[1:])]
    for d, name, line, closed in sorted(pieces, key=lambda p: p[0]):
        s = (d - lo) / span if deep else 1.0
        ink = "#" + "".join(f"{round(f + s * (n - f)):02x}" for f, n in zip(*DEPTH_INK))
        width = DEPTH_WIDTH[0] + s * (DEPTH_WIDTH[1] - DEPTH_WIDTH[0])
        _member(fig, name, project(line, matrix), closed,
                dict(name=name, style="solid", cls="member", color=ink, width=round(width, 2)), "member")
    return deep


def _member_lines(res: GcsResult, k: int) -> dict[str, list[np.ndarray]]:
    """Member name → its drawing lines in world coordinates at step ``k`` (each (n, 3)); a member
    without lines: its points as one closed line (3 or more), one bar (2) or a dot (1)."""
    R = quat.to_matrix(res.orientation[k])
    out = {}
    for m, name in enumerate(res.member_names):
        pts = res.points.get(name, {})
        lines = res.lines.get(name) or ([list(pts) + list(pts)[:1]] if len(pts) >= 3 else [list(pts)] if pts else [])
        out[name] = [res.position[k, m] + np.array([pts[p] for p in line], dtype=float).reshape(-1, 3) @ R[m].T
                     for line in lines if line]
    return out


def _world_points(res: GcsResult) -> np.ndarray:
    """Every point the picture places, over all steps, ``(n, 3)``."""
    parts = [tr.position for tr in res.tracks.values()]
    for k in range(res.t.size) if res.t.size <= 2 * POSES else np.linspace(0, res.t.size - 1, 4 * POSES).astype(int):
        parts += [ln for lines in _member_lines(res, int(k)).values() for ln in lines]
    parts.append(res.position.reshape(-1, 3))
    return np.vstack(parts) if parts else np.zeros((0, 3))


def _ground_plane(fig: Figure, world: np.ndarray, units: str) -> None:
    """A grid on the plane z = lowest z under the mechanism, at round world steps, with tick values
    along two edges and the axis names (with ``units``) past their ends."""
    lo, hi = world.min(axis=0), world.max(axis=0)
    span = float(max((hi - lo)[:2].max(), 1e-12 * max(1.0, float(np.abs(world).max()))))
    lo2, hi2 = lo[:2] - 0.1 * span, hi[:2] + 0.1 * span
    step, _ = nice_ticks(0.0, span, target=5.0)
    xs = np.arange(np.floor(lo2[0] / step), np.ceil(hi2[0] / step) + 1) * step
    ys = np.arange(np.floor(lo2[1] / step), np.ceil(hi2[1] / step) + 1) * step
    z = lo[2]
    grid = Stroke("#a0aec0", 0.8)
    iso = PROJECTIONS["iso"][0]
    unit = f" ({units})" if units else ""
    for x in xs:
        fig.polyline(project(np.array([[x, ys[0], z], [x, ys[-1], z]]), iso), grid, cls="ground-plane")
        fig.annotate(project(np.array([x, ys[0], z]), iso).tolist(), tick_label(float(x), step), size=9,
                     offset_px=(-10.0, 16.0), cls="ground-tick")
    for y in ys:
        fig.polyline(project(np.array([[xs[0], y, z], [xs[-1], y, z]]), iso), grid, cls="ground-plane")
        fig.annotate(project(np.array([xs[-1], y, z]), iso).tolist(), tick_label(float(y), step), size=9,
                     offset_px=(6.0, 10.0), cls="ground-tick")
    mid = (xs[len(xs) // 2 - 1] + xs[len(xs) // 2]) / 2, (ys[len(ys) // 2 - 1] + ys[len(ys) // 2]) / 2
    fig.annotate(project(np.array([mid[0], ys[0], z]), iso).tolist(), f"x{unit}", size=10, offset_px=(0.0, 34.0),
                 cls="ground-axis")
    fig.annotate(project(np.array([xs[-1], mid[1], z]), iso).tolist(), f"y{unit}", size=10, offset_px=(22.0, 30.0),
                 cls="ground-axis")
    plain = f" {units}" if units else ""
    fig.legend(f"ground plane z = {tick_label(float(z), step)}{plain} (grid {tick_label(step, step)}{plain})", grid)


def _arrows(fig: Figure, res: GcsResult, matrix: np.ndarray, size: float) -> float | None:
    """Velocity arrows at evenly spaced steps of every track, the longest ``ARROW_FRACTION`` of ``size``;
    returns their scale (None: nothing moves)."""
    v2 = {n: project(tr.velocity, matrix) for n, tr in res.tracks.items()}  # projections are linear
    vmax = max((float(np.linalg.norm(v, axis=1).max()) for v in v2.values()), default=0.0)
    if not vmax > 0:
        return None
    gain = ARROW_FRACTION * size / vmax
    T = res.t.size
    ks = np.unique(np.linspace(0, T - 1, ARROWS_PER_TRACK, endpoint=False).round().astype(int))
    for n, (name, tr) in enumerate(res.tracks.items()):
        p, color = project(tr.position, matrix), PALETTE[n % len(PALETTE)]
        for k in ks:
            fig.arrow(p[k], p[k] + gain * v2[name][k], Stroke(color, 1.2), cls="velocity", name=name)
    return gain
