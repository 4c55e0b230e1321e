"""The picture of a solved 3D mechanism, drawn by the shared figure module (:mod:`linkedit.io.svg_figure`).

A projection of the world onto the drawing: ``xy`` (top), ``xz`` (front), ``yz`` (side) —
orthographic, with the figure's axes in the mechanism's units — or ``iso`` (isometric, a ground
plane grid under the mechanism with its tick values). An axes triad shows the world directions
in every view. Members are drawn like planar links (bars between consecutive points of each
drawing line, plates for closed lines) at the first step (solid, labelled) and a few later
steps (faint); each track's curve in its colour, with optional velocity arrows scaled so the
longest is a tenth of the drawing (the curve stays visible).

Elements carry ``class`` and ``data-name``: ``member`` / ``member-pose`` (faint poses) /
``member-label`` / ``track`` / ``track-point`` / ``velocity`` / ``ground-plane`` / ``triad``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.gcs import quaternions as quat
from linkedit.gcs.result import GcsResult
from linkedit.io.atomic import write_text
from linkedit.io.svg_figure import INK, PALETTE, Figure, Stroke, nice_ticks, tick_label

VIEWS = ("xy", "xz", "yz", "iso")
_ISO = np.array([[np.cos(np.pi / 6), -np.cos(np.pi / 6), 0.0], [np.sin(np.pi / 6), np.sin(np.pi / 6), 1.0]])
#: view → (2, 3) projection matrix (world → drawing, y up) and the drawing's axis names
PROJECTIONS: dict[str, tuple[np.ndarray, tuple[str, str] | None]] = {
    "xy": (np.array([[1.0, 0, 0], [0, 1.0, 0]]), ("x", "y")),
    "xz": (np.array([[1.0, 0, 0], [0, 0, 1.0]]), ("x", "z")),
    "yz": (np.array([[0, 1.0, 0], [0, 0, 1.0]]), ("y", "z")),
    "iso": (_ISO, None),
}
ARROW_FRACTION = 0.1  #: the longest velocity arrow, as a fraction of the drawing's size
ARROWS_PER_TRACK = 16
POSES = 8  #: poses drawn over the run (the first solid, the others faint)


def project(p: np.ndarray, view: str) -> np.ndarray:
    """World points ``(..., 3)`` → drawing coordinates ``(..., 2)`` (x right, y up)."""
    if view not in PROJECTIONS:
        raise InputError(f"unknown view {view!r} (choose from {', '.join(VIEWS)})", field="--view")
    return np.asarray(p, dtype=float) @ PROJECTIONS[view][0].T


def default_view(res: GcsResult) -> str:
    """``xy`` for a mechanism that stays in a plane z = const (every member point and track over
    the run, to 1e-9 of its size), ``iso`` otherwise."""
    world = _world_points(res)
    size = float(np.ptp(world, axis=0).max()) if world.size else 0.0
    flat = world.size == 0 or float(np.ptp(world[:, 2])) <= 1e-9 * max(size, 1e-300)
    return "xy" if flat else "iso"


def draw(path: str | Path | None, res: GcsResult, view: str | None = None, velocity: bool = False) -> str:
    """The picture's SVG text; written atomically to ``path`` if given. ``view``: one of
    :data:`VIEWS`, default :func:`default_view`; ``velocity``: draw velocity arrows on the tracks."""
    view = view or default_view(res)
    project(np.zeros(3), view)  # checks the name
    T = res.t.size
    frames = np.unique(np.linspace(0, T - 1, min(POSES, T)).round().astype(int))
    fig = Figure(title=f"{res.name} — view {view}, {T} steps", units=res.units, axis_names=PROJECTIONS[view][1])
    world = _world_points(res)
    size = float(np.ptp(project(world, view), axis=0).max()) if world.size else 1.0
    if view == "iso" and world.size:
        _ground_plane(fig, world, res.units)
    for k in frames[::-1]:  # faint poses under the first, solid one
        first = k == frames[0]
        for name, lines in _member_lines(res, int(k)).items():
            for line in lines:
                xy = project(line, view)
                if len(xy) == 1:
                    fig.joints(xy, names=[name], cls="member" if first else "member-pose")
                    continue
                closed = len(xy) >= 3 and np.allclose(line[0], line[-1])
                style = dict(name=name, style="solid", cls="member") if first else \
                    dict(name=name, style="faint", cls="member-pose", width=3.0)
                if closed:
                    fig.link(xy[:-1], **style)  # type: ignore[arg-type]
                else:
                    for a, b in zip(xy[:-1], xy[1:]):
                        fig.link(np.array([a, b]), **style)  # type: ignore[arg-type]
    gain = _arrows(fig, res, view, size) if velocity else None  # under the curves: a short track stays visible
    for n, (name, tr) in enumerate(res.tracks.items()):
        color = PALETTE[n % len(PALETTE)]
        stroke = Stroke(color, 2.2, "dashed" if n >= len(PALETTE) else "solid")
        fig.polyline(project(tr.position, view), stroke, closed=tr.cyclic, cls="track", name=name, label=name)
        fig.joints(project(tr.position[:1], view), names=[name], fill=color, stroke=Stroke(color, 1.0),
                   cls="track-point")
    if gain is not None:
        fig.legend(f"velocity d/dt × {gain:.3g} (t in [0, 1]{f'; {res.units} per unit t' if res.units else ''})",
                   Stroke(INK, 1.2))
    for name, lines in _member_lines(res, 0).items():  # the figure places the labels apart
        corners = np.vstack(lines) if lines else res.position[0, [res.member_names.index(name)]]
        fig.annotate(project(corners.mean(axis=0), view).tolist(), name, cls="member-label")
    R = quat.to_matrix(res.orientation[0])
    for m, name in enumerate(res.member_names):
        pts = res.points.get(name, {})
        if pts:
            local = np.array(list(pts.values()), dtype=float).reshape(-1, 3)
            fig.joints(project(res.position[0, m] + local @ R[m].T, view), names=[f"{name}.{p}" for p in pts])
    fig.legend("members at t = 0", Stroke(INK, 3.0))
    if len(frames) > 1:
        fig.legend(f"{len(frames) - 1} later poses", Stroke(INK, 3.0, "faint"))
    fig.triad({a: PROJECTIONS[view][0][:, i].tolist() for i, a in enumerate("xyz")})
    svg = fig.render()
    if path is not None:
        write_text(path, svg)
    return svg


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
    (the first of each row with ``units``)."""
    lo, hi = world.min(axis=0), world.max(axis=0)
    span = float(max((hi - lo)[:2].max(), 1e-12 * max(1.0, float(np.abs(world).max()))))
    lo2, hi2 = lo[:2] - 0.1 * span, hi[:2] + 0.1 * span
    step, _ = nice_ticks(0.0, span, target=5.0)
    xs = np.arange(np.floor(lo2[0] / step), np.ceil(hi2[0] / step) + 1) * step
    ys = np.arange(np.floor(lo2[1] / step), np.ceil(hi2[1] / step) + 1) * step
    z = lo[2]
    grid = Stroke("#a0aec0", 0.8)
    unit = f" {units}" if units else ""
    for n, x in enumerate(xs):
        fig.polyline(project(np.array([[x, ys[0], z], [x, ys[-1], z]]), "iso"), grid, cls="ground-plane")
        fig.annotate(project(np.array([x, ys[0], z]), "iso").tolist(), f"x {tick_label(float(x), step)}{unit}" if n == 0
                     else tick_label(float(x), step), size=9, offset_px=(-10.0, 16.0), cls="ground-tick")
    for n, y in enumerate(ys):
        fig.polyline(project(np.array([[xs[0], y, z], [xs[-1], y, z]]), "iso"), grid, cls="ground-plane")
        fig.annotate(project(np.array([xs[-1], y, z]), "iso").tolist(), f"y {tick_label(float(y), step)}{unit}" if n == 0
                     else tick_label(float(y), step), size=9, offset_px=(6.0, 10.0), cls="ground-tick")
    fig.legend(f"ground plane z = {tick_label(float(z), step)}{unit} (grid {tick_label(step, step)}{unit})", grid)


def _arrows(fig: Figure, res: GcsResult, view: str, size: float) -> float | None:
    """Velocity arrows at evenly spaced steps of every track, the longest ``ARROW_FRACTION`` of ``size``;
    returns their scale (None: nothing moves)."""
    v2 = {n: project(tr.velocity, view) for n, tr in res.tracks.items()}  # projections are linear
    vmax = max((float(np.linalg.norm(v, axis=1).max()) for v in v2.values()), default=0.0)
    if not vmax > 0:
        return None
    gain = ARROW_FRACTION * size / vmax
    T = res.t.size
    ks = np.unique(np.linspace(0, T - 1, ARROWS_PER_TRACK, endpoint=False).round().astype(int))
    for n, (name, tr) in enumerate(res.tracks.items()):
        p, color = project(tr.position, view), PALETTE[n % len(PALETTE)]
        for k in ks:
            fig.arrow(p[k], p[k] + gain * v2[name][k], Stroke(color, 1.2), cls="velocity", name=name)
    return gain
