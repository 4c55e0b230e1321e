"""The symbols of a mechanism's elements, drawn in pixels: ground, motor, a slider's block, its
rail (a guide fixed to the frame) and its slot (a guide in a moving link), and a link's bar.

Each takes pixel geometry (y down; ``(F, ...)`` arrays for moving symbols) and returns one
:class:`~linkedit.io.marks.Mark`; sizes are in pixels (:data:`~linkedit.io.figure_style.BLOCK_PX`).
"""

from __future__ import annotations

import math

import numpy as np

from linkedit.io.figure_style import BLOCK_PX, FRAME_FILL, INK, PALETTE
from linkedit.io.marks import Mark, mark, path, still


def bar(q: np.ndarray, **style: object) -> Mark:
    """A straight ``line`` mark between pixel ends ``q`` ``(F, 2, 2)``."""
    m = mark("line", **style)
    m.geom = {"x1": q[:, 0, 0], "y1": q[:, 0, 1], "x2": q[:, 1, 0], "y2": q[:, 1, 1]}
    return m


def rail(ends_px: np.ndarray, side: np.ndarray, *, name: str | None, cls: str) -> Mark:
    """A hatched rail along pixel ``ends_px`` ``(2, 2)``, half a block to the world ``side`` (2,) of
    the line, hatched beyond it, reaching a block length past each end."""
    a, b, u, n = _frame(ends_px, side)
    a, b = a - u * BLOCK_PX[0] / 2 - 4 * u, b + u * BLOCK_PX[0] / 2 + 4 * u
    a, b = a + n * BLOCK_PX[1] / 2, b + n * BLOCK_PX[1] / 2
    count = max(2, int(np.hypot(*(b - a)) // 7))
    hatch = [np.array([a + (b - a) * k / count, a + (b - a) * k / count + 6 * n - 5 * u]) for k in range(count + 1)]
    return path([np.array([a, b])] + hatch, cls=cls, data_name=name, fill="none", stroke=INK,
                stroke_width="1.3", stroke_linecap="round")


def slot(q: np.ndarray, *, name: str | None, color: str, cls: str) -> Mark:
    """An opening a block wide with rounded ends, a block length past the pixel ends ``q``
    ``(F, 2, 2)`` of the travel, outlined in ``color``."""
    d = q[:, 1] - q[:, 0]
    u = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    grow = (BLOCK_PX[0] - BLOCK_PX[1]) / 2 + 2
    q = np.stack([q[:, 0] - grow * u, q[:, 1] + grow * u], axis=1)
    body = bar(q, stroke=color, stroke_width=f"{BLOCK_PX[1] + 5:g}", stroke_linecap="round", stroke_opacity=0.85)
    opening = bar(q, stroke="#ffffff", stroke_width=f"{BLOCK_PX[1] + 1:g}", stroke_linecap="round")
    return mark("g", cls=cls, data_name=name, kids=[body, opening])


def block(q: np.ndarray, d: np.ndarray, *, name: str | None, cls: str) -> Mark:
    """A slider's block at pixel centres ``q`` ``(F, 2)``, its length along the world directions
    ``d`` ``(F, 2)`` (nonzero)."""
    u = d * [1.0, -1.0] / np.hypot(d[:, 0], d[:, 1])[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)
    hl, hw = BLOCK_PX[0] / 2, BLOCK_PX[1] / 2
    corners = np.stack([q - hl * u - hw * n, q + hl * u - hw * n, q + hl * u + hw * n, q - hl * u + hw * n], 1)
    m = mark("polygon", cls=cls, data_name=name, fill=FRAME_FILL, stroke=INK, stroke_width="1.3",
             stroke_linejoin="round")
    m.geom = {"points": corners}
    return m


def ground(x: float, y: float, *, name: str | None) -> Mark:
    """The ground (frame) symbol under pixel ``(x, y)``: hatched base with a support triangle."""
    tri = still("polygon", {"points": [(x, y), (x - 8, y + 12), (x + 8, y + 12)]}, fill=FRAME_FILL)
    hatch = [np.array([(x - 11 + 5 * i, y + 12), (x - 16 + 5 * i, y + 18)]) for i in range(5)]
    base = path([np.array([(x - 14, y + 12), (x + 14, y + 12)])] + hatch, fill="none")
    return mark("g", cls="ground", data_name=name, stroke=INK, stroke_width="1.3", kids=[tri, base])


def motor(c: np.ndarray, *, ccw: bool, name: str | None) -> Mark:
    """The motor symbol at pixel ``c`` (2,): a circle with an arc arrow turning ``ccw`` or cw."""
    r, turn = 14.0, 1.0 if ccw else -1.0
    a0 = math.radians(-60.0)
    a1 = a0 + turn * math.radians(280.0)

    def at(a: float | np.ndarray) -> np.ndarray:  # visual angle, counter-clockwise on screen
        return c + r * np.stack([np.cos(a), -np.sin(a)], axis=-1)

    s, e = at(a0), at(a1)
    tangent = turn * np.array([-math.sin(a1), -math.cos(a1)])
    radial = np.array([math.cos(a1), -math.sin(a1)])
    sweep = 0 if ccw else 1
    arc = path([at(np.linspace(a0, a1, 40))], d=f"M{s[0]:.2f},{s[1]:.2f} A{r:g},{r:g} 0 1 {sweep} {e[0]:.2f},{e[1]:.2f}",
               fill="none")
    head = still("polygon", {"points": [e + 5 * tangent, e - 2 * tangent + 4 * radial, e - 2 * tangent - 4 * radial]},
                 fill=PALETTE[1], stroke="none")
    hub = still("circle", {"cx": c[0], "cy": c[1]}, r=f"{r - 6:g}", fill="none")
    return mark("g", cls="motor", data_name=name, stroke=PALETTE[1], stroke_width="1.6", kids=[hub, arc, head])


def _frame(ends_px: np.ndarray, side: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pixel ends of a segment, its unit direction and its unit normal towards world ``side``."""
    a, b = ends_px
    d = b - a
    u = d / max(float(np.hypot(*d)), 1e-9)
    n = np.array([-u[1], u[0]])
    if float(n @ (side * [1.0, -1.0])) < 0:
        n = -n
    return a, b, u, n
