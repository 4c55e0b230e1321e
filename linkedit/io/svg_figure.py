"""The figure model of every mechanism picture: drawn to SVG, and frame by frame to raster (GIF).

World coordinates (x right, y up, in the drawing's units) are mapped to pixels (y down) with
one scale for both axes (equal aspect ratio). Everything drawn is recorded first; the bounds,
the scale, the axes (ticks at round numbers, unit label), the title, the legend and the
placement of labels (so they do not overlap) are laid out when the figure's marks
(:mod:`linkedit.io.marks`) are made: :meth:`Figure.render` writes them as SVG,
:func:`linkedit.io.raster.frames` paints them. Symbol sizes (joint circles, ground, motor and
slider symbols, bar widths) are in pixels and do not scale with the drawing.

A primitive given one pose (``(k, 2)`` points) is still; given frames (``(F, k, 2)``) it moves:
in SVG with SMIL ``<animate>`` elements (``calcMode="linear"``, ``repeatCount="indefinite"``),
which needs ``Figure(duration_s=...)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from linkedit.io.marks import Mark, attr, attrs, mark, path, points_text, still, svg, text

__all__ = ["Figure", "Stroke", "View", "attr", "attrs", "points_text", "text", "place_labels", "nice_ticks",
           "tick_label", "finite"]

SVG_NS = "http://www.w3.org/2000/svg"
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
           "#bcbd22", "#7f7f7f")
INK = "#2d3748"
LINK_FILL = "#8fa8d0"
FRAME_FILL = "#e2e8f0"
PATH_GREY = "#8a939e"
ENVELOPE_GREEN = "#276749"
FAINT_OPACITY = 0.3
DASH = "6 4"
FONT = "font-family=\"Helvetica, Arial, sans-serif\""
_FONT = {"font-family": "Helvetica, Arial, sans-serif"}
#: a white outline under label text, so labels stay readable over links and symbols
HALO = " stroke=\"#ffffff\" stroke-width=\"3\" stroke-opacity=\"0.85\" paint-order=\"stroke\" stroke-linejoin=\"round\""
_HALO = {"stroke": "#ffffff", "stroke-width": "3", "stroke-opacity": "0.85", "paint-order": "stroke",
         "stroke-linejoin": "round"}
#: a slider's block (length along its guide, height across) and its guide's opening, px
BLOCK_PX = (20.0, 10.0)

_PAD_PX = 18.0          # room inside the plot area for symbols drawn around points
_MIN_PLOT_PX = 160.0    # smallest plot side, so ticks and labels fit
_CHAR_EM = 0.6          # width of a character of the label font, in font sizes (generous)


def finite(name: str, a: object, shape: tuple[int | None, ...]) -> np.ndarray:
    """``a`` as a float array of ``shape`` (``None`` = any length); ValueError if not finite."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name}: expected an array of shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def nice_ticks(lo: float, hi: float, target: float = 6.0) -> tuple[float, np.ndarray]:
    """Round tick step (1, 2, 2.5 or 5 × 10^k) and the ticks ``k·step`` inside ``[lo, hi]``."""
    span = hi - lo
    if not span > 0:
        raise ValueError(f"tick range must have hi > lo, got [{lo}, {hi}]")
    raw = span / max(target, 1.0)
    magnitude = 10.0 ** math.floor(math.log10(raw))
    step = next(m * magnitude for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * magnitude >= raw * (1 - 1e-12))
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    # a tick within rounding of an end is that end (k·step may land a few ulps outside [lo, hi])
    return step, np.clip(np.arange(first, last + 1) * step, lo, hi)


def axis_ticks(lo: float, hi: float, extent_px: float) -> tuple[float, np.ndarray]:
    """Ticks for an axis ``extent_px`` pixels long: about one per 90 px (see :func:`nice_ticks`)."""
    return nice_ticks(lo, hi, target=max(2.0, extent_px / 90.0))


def tick_label(value: float, step: float) -> str:
    """A tick value with just the decimals its step needs (``0.25``, ``2.5``, ``40``), never ``-0``."""
    mantissa = step / 10.0 ** math.floor(math.log10(step) + 1e-12)
    decimals = max(0, -math.floor(math.log10(step) + 1e-12) + (1 if abs(mantissa - 2.5) < 1e-9 else 0))
    out = f"{value:.{decimals}f}"
    return "0" if float(out) == 0 else out


def text_box(x: float, y: float, words: str, size: float, anchor: str = "start") -> np.ndarray:
    """Pixel box ``(x0, y0, x1, y1)`` a label of ``size`` px with its baseline at ``(x, y)`` covers (an
    upper bound of its width: :data:`_CHAR_EM` per character)."""
    w = _CHAR_EM * size * len(words)
    x0 = x - {"start": 0.0, "middle": w / 2, "end": w}[anchor]
    return np.array([x0, y - 0.8 * size, x0 + w, y + 0.25 * size])


def place_labels(anchors: np.ndarray, boxes: np.ndarray, area: Sequence[float],
                 avoid: np.ndarray = np.zeros((0, 2))) -> tuple[np.ndarray, np.ndarray]:
    """Greedy label placement, in pixels: label n's ``boxes[n]`` (x0, y0, x1, y1) at its preferred
    place, or the first place on rings around ``anchors[n]`` (2,) where it overlaps no label placed
    before it, covers no point of ``avoid`` (m, 2) and stays inside ``area`` (x0, y0, x1, y1).

    Returns the shift of each box (n, 2) and whether it moved off its preferred place (n,): such a
    label gets a leader line to its anchor. A label with no free place keeps its preferred one.
    """
    placed: list[np.ndarray] = []
    shifts, moved = np.zeros((len(anchors), 2)), np.zeros(len(anchors), dtype=bool)
    angles = np.radians([45, 0, 90, 135, 180, 270, 315, 225, 22.5, 67.5, 112.5, 157.5, 202.5, 247.5, 292.5, 337.5])
    for n, (a, box) in enumerate(zip(np.asarray(anchors, float), np.asarray(boxes, float))):
        half = (box[2:] - box[:2]) / 2
        centre = (box[:2] + box[2:]) / 2
        tries = [np.zeros(2)] + [a + np.array([math.cos(t) * (half[0] + r), -math.sin(t) * (half[1] + r)]) - centre
                                 for r in (4.0, 12.0, 22.0, 34.0, 48.0, 64.0) for t in angles]
        for k, s in enumerate(tries):
            b = box + np.r_[s, s]
            inside = b[0] >= area[0] and b[1] >= area[1] and b[2] <= area[2] and b[3] <= area[3]
            free = not any(b[0] < q[2] + 1 and q[0] < b[2] + 1 and b[1] < q[3] + 1 and q[1] < b[3] + 1 for q in placed)
            clear = not np.any((avoid[:, 0] > b[0] - 2) & (avoid[:, 0] < b[2] + 2)
                               & (avoid[:, 1] > b[1] - 2) & (avoid[:, 1] < b[3] + 2)) if len(avoid) else True
            if inside and free and clear:
                shifts[n], moved[n] = s, k > 0
                break
        placed.append(box + np.r_[shifts[n], shifts[n]])
    return shifts, moved


@dataclass(frozen=True)
class Stroke:
    """Line style: ``color``, ``width`` in px, ``style`` solid | faint (translucent) | dashed."""

    color: str = INK
    width: float = 1.5
    style: str = "solid"

    def __post_init__(self) -> None:
        if self.style not in ("solid", "faint", "dashed"):
            raise ValueError(f"stroke style must be solid, faint or dashed, got {self.style!r}")

    def svg(self) -> str:
        return attrs(**self.kw())

    def kw(self) -> dict[str, object]:
        """The stroke's presentation attributes, as :func:`~linkedit.io.marks.mark` keywords."""
        return dict(stroke=self.color, stroke_width=float(self.width),
                    stroke_dasharray=DASH if self.style == "dashed" else None,
                    stroke_opacity=FAINT_OPACITY if self.style == "faint" else None)


@dataclass(frozen=True)
class View:
    """The world → pixel map: window lower-left ``(x0, y0)``, ``scale`` px per unit, plot area."""

    x0: float
    y0: float
    scale: float
    left: float
    top: float
    width: float
    height: float

    def px(self, p: np.ndarray) -> np.ndarray:
        """World points ``(..., 2)`` → pixel points ``(..., 2)`` (y flipped)."""
        p = np.asarray(p, dtype=float)
        x = self.left + (p[..., 0] - self.x0) * self.scale
        y = self.top + self.height - (p[..., 1] - self.y0) * self.scale
        return np.stack([x, y], axis=-1)

    @property
    def window(self) -> tuple[float, float, float, float]:
        """World ``(xmin, xmax, ymin, ymax)`` of the plot area."""
        return (self.x0, self.x0 + self.width / self.scale, self.y0, self.y0 + self.height / self.scale)

    @property
    def area(self) -> tuple[float, float, float, float]:
        """Pixel ``(x0, y0, x1, y1)`` of the plot area."""
        return (self.left, self.top, self.left + self.width, self.top + self.height)


@dataclass
class _Item:
    xs: np.ndarray
    ys: np.ndarray
    draw: Callable[[View], Mark | list[Mark]]
    #: world points (k, 2) of still symbols that labels should not cover
    marks_at: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


@dataclass
class _Label:
    point: np.ndarray
    words: str
    size: float
    color: str
    offset_px: tuple[float, float]
    cls: str


@dataclass(frozen=True)
class _Entry:
    label: str
    stroke: Stroke
    kind: str  # line | box | dot


@dataclass
class Figure:
    """Collects primitives in world coordinates; renders one SVG document or raster frames.

    ``size_px``: length of the longer side of the plot area; ``duration_s``: cycle time of the
    animated primitives; ``cyclic``: the last animation frame returns to the first;
    ``axis_names``: the horizontal and vertical axes' names (``("x", "z")`` for a side view of a
    3D mechanism), or None for a projection without world axes (an isometric view: the plot
    area is framed, without ticks; a :meth:`triad` shows the directions).
    """

    title: str = ""
    units: str = ""
    size_px: float = 640.0
    duration_s: float | None = None
    cyclic: bool = True
    axis_names: tuple[str, str] | None = ("x", "y")
    _items: list[_Item] = field(default_factory=list, repr=False)
    _legend: list[_Entry] = field(default_factory=list, repr=False)
    _captions: tuple[list[str], str] | None = field(default=None, repr=False)
    _labels: list[_Label] = field(default_factory=list, repr=False)
    _placed: dict[int, tuple[float, float, bool]] = field(default_factory=dict, repr=False)
    _triad_px: float | None = field(default=None, repr=False)  #: the triad's arrow length, px (labels keep off it)

    # -- primitives ------------------------------------------------------------------------

    def polyline(self, points: np.ndarray, stroke: Stroke = Stroke(), *, closed: bool = False,
                 cls: str = "curve", name: str | None = None, label: str | None = None) -> None:
        """A curve through world ``points`` ``(k, 2)``; ``closed`` joins the last point to the first."""
        p = finite(name or cls, points, (None, 2))

        def draw(v: View) -> Mark:
            return still("polygon" if closed else "polyline", {"points": v.px(p)}, cls=cls, data_name=name,
                         fill="none", **stroke.kw(), stroke_linejoin="round", stroke_linecap="round")

        self._add(p, draw)
        self._label(label, stroke, "line")

    def joints(self, points: np.ndarray, *, names: Sequence[str] | None = None, radius: float = 3.2,
               fill: str = "#ffffff", stroke: Stroke = Stroke(width=1.3), cls: str = "joint") -> None:
        """Circle markers of ``radius`` px at world ``points`` ``(n, 2)`` or frames ``(F, n, 2)``."""
        p = self._pose("joint positions", points)
        labels: list[str | None] = list(names) if names is not None else [None] * p.shape[1]
        if len(labels) != p.shape[1]:
            raise ValueError(f"{len(labels)} joint names for {p.shape[1]} points")

        def draw(v: View) -> list[Mark]:
            q = v.px(p)
            out = []
            for n, name in enumerate(labels):
                m = mark("circle", cls=cls, data_name=name, r=f"{radius:g}", fill=fill, **stroke.kw())
                m.geom = {"cx": q[:, n, 0], "cy": q[:, n, 1]}
                out.append(m)
            return out

        self._add(p, draw, p[0] if p.shape[0] == 1 else None)

    def link(self, points: np.ndarray, *, name: str | None = None, style: str = "solid", width: float = 7.0,
             color: str = INK, fill: str = LINK_FILL, cls: str = "link") -> None:
        """A rigid link through its joints: world ``(k, 2)`` or frames ``(F, k, 2)``, k ≥ 2.

        Two joints, or joints on one line: a thick bar (``width`` px) with rounded ends between
        the outermost joints. Three or more: a translucent polygon around the joints (ordered by
        angle about their centroid in the first frame).
        """
        p = self._pose(f"link {name}" if name else "link", points)
        if p.shape[1] < 2:
            raise ValueError(f"link {name}: needs at least 2 joints, got {p.shape[1]}")
        if style not in ("solid", "faint"):
            raise ValueError(f"link style must be solid or faint, got {style!r}")
        opacity = FAINT_OPACITY if style == "faint" else None
        first = p[0] - p[0].mean(axis=0)
        _, sv, vt = np.linalg.svd(first)
        if p.shape[1] == 2 or sv[1] <= 1e-9 * sv[0]:
            along = first @ vt[0]
            ends = p if p.shape[1] == 2 else p[:, [int(np.argmin(along)), int(np.argmax(along))]]

            def draw(v: View) -> Mark:
                return _bar(v.px(ends), cls=cls, data_name=name, stroke=color, stroke_width=f"{width:g}",
                            stroke_linecap="round", stroke_opacity=opacity or 0.85)
        else:
            order = np.argsort(np.arctan2(first[:, 1], first[:, 0]))
            ring = p[:, order]

            def draw(v: View) -> Mark:
                m = mark("polygon", cls=cls, data_name=name, fill=fill, fill_opacity=0.15 if opacity else 0.55,
                         stroke=color, stroke_width="2.5", stroke_linejoin="round", stroke_opacity=opacity)
                m.geom = {"points": v.px(ring)}
                return m

        self._add(p, draw)

    def rail(self, ends: np.ndarray, side: Sequence[float] | np.ndarray, *, name: str | None = None, cls: str = "rail") -> None:
        """A guide fixed to the frame: a hatched rail along world ``ends`` ``(2, 2)``, drawn half a
        block (:data:`BLOCK_PX`) to the ``side`` (2,) of the line, hatched beyond it, reaching a
        block length past each end."""
        e = finite(f"rail {name}" if name else "rail", ends, (2, 2))
        s = finite("rail side", side, (2,))

        def draw(v: View) -> Mark:
            a, b, u, n = _frame_px(v, e, s)
            a, b = a - u * BLOCK_PX[0] / 2 - 4 * u, b + u * BLOCK_PX[0] / 2 + 4 * u
            a, b = a + n * BLOCK_PX[1] / 2, b + n * BLOCK_PX[1] / 2
            count = max(2, int(np.hypot(*(b - a)) // 7))
            hatch = [np.array([a + (b - a) * k / count, a + (b - a) * k / count + 6 * n - 5 * u]) for k in range(count + 1)]
            return path([np.array([a, b])] + hatch, cls=cls, data_name=name, fill="none", stroke=INK,
                        stroke_width="1.3", stroke_linecap="round")

        self._add(e, draw)

    def slot(self, ends: np.ndarray, *, name: str | None = None, color: str = INK, cls: str = "slot") -> None:
        """A slot in a moving link: an opening a block (:data:`BLOCK_PX`) wide with rounded ends, a
        block length past the world ``ends`` ``(2, 2)`` or frames ``(F, 2, 2)`` of the travel, outlined
        in the link's colour."""
        e = self._pose(f"slot {name}" if name else "slot", ends)
        if e.shape[1] != 2:
            raise ValueError(f"slot {name}: expected 2 ends, got {e.shape[1]}")

        def draw(v: View) -> Mark:
            q = v.px(e)
            d = q[:, 1] - q[:, 0]
            u = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
            grow = (BLOCK_PX[0] - BLOCK_PX[1]) / 2 + 2
            q = np.stack([q[:, 0] - grow * u, q[:, 1] + grow * u], axis=1)
            body = _bar(q, stroke=color, stroke_width=f"{BLOCK_PX[1] + 5:g}", stroke_linecap="round",
                        stroke_opacity=0.85)
            opening = _bar(q, stroke="#ffffff", stroke_width=f"{BLOCK_PX[1] + 1:g}", stroke_linecap="round")
            return mark("g", cls=cls, data_name=name, kids=[body, opening])

        self._add(e.reshape(-1, 2), draw)

    def block(self, centre: np.ndarray, direction: np.ndarray, *, name: str | None = None,
              cls: str = "block") -> None:
        """A slider's block, :data:`BLOCK_PX` in size, at world ``centre`` ``(2,)`` or frames ``(F, 2)``,
        its length along ``direction`` (same shape; any length)."""
        c = self._pose(f"block {name}" if name else "block", np.asarray(centre, dtype=float)[..., None, :])[:, 0]
        d = finite(f"block {name} direction", direction, c.shape if np.ndim(direction) == 2 else (2,))
        d = np.broadcast_to(d, c.shape)
        if np.any(np.hypot(d[:, 0], d[:, 1]) == 0):
            raise ValueError(f"block {name}: zero direction")

        def draw(v: View) -> Mark:
            q = v.px(c)
            u = d * [1.0, -1.0] / np.hypot(d[:, 0], d[:, 1])[:, None]
            n = np.stack([-u[:, 1], u[:, 0]], axis=1)
            hl, hw = BLOCK_PX[0] / 2, BLOCK_PX[1] / 2
            corners = np.stack([q - hl * u - hw * n, q + hl * u - hw * n, q + hl * u + hw * n, q - hl * u + hw * n], 1)
            m = mark("polygon", cls=cls, data_name=name, fill=FRAME_FILL, stroke=INK, stroke_width="1.3",
                     stroke_linejoin="round")
            m.geom = {"points": corners}
            return m

        self._add(c, draw)

    def arrow(self, start: Sequence[float], end: Sequence[float], stroke: Stroke = Stroke(), *, cls: str = "arrow",
              name: str | None = None) -> None:
        """A straight arrow from world ``start`` to ``end`` (2,), its head (px-sized) at ``end``."""
        p = finite(name or cls, np.array([start, end], dtype=float), (2, 2))

        def draw(v: View) -> list[Mark]:
            a, b = v.px(p)
            d = b - a
            length = float(np.hypot(*d))
            if length < 1e-9:
                return []
            u = d / length
            n = np.array([-u[1], u[0]])
            shaft = still("line", dict(zip(("x1", "y1", "x2", "y2"), [*a, *(b - 8 * u)])), fill="none", **stroke.kw())
            head = still("polygon", {"points": [b, b - 9 * u + 4 * n, b - 9 * u - 4 * n]}, fill=stroke.color,
                         stroke="none")
            return [mark("g", cls=cls, data_name=name, kids=[shaft, head])]

        self._add(p, draw)

    def ground(self, point: Sequence[float], *, name: str | None = None) -> None:
        """The ground (frame) symbol under world ``point`` ``(2,)``: hatched base with a support triangle."""
        p = finite(f"ground {name}" if name else "ground", point, (2,))

        def draw(v: View) -> Mark:
            x, y = v.px(p)
            tri = still("polygon", {"points": [(x, y), (x - 8, y + 12), (x + 8, y + 12)]}, fill=FRAME_FILL)
            hatch = [np.array([(x - 11 + 5 * i, y + 12), (x - 16 + 5 * i, y + 18)]) for i in range(5)]
            base = path([np.array([(x - 14, y + 12), (x + 14, y + 12)])] + hatch, fill="none")
            return mark("g", cls="ground", data_name=name, stroke=INK, stroke_width="1.3", kids=[tri, base])

        self._add(p[None], draw, p[None])

    def motor(self, pivot: Sequence[float], *, ccw: bool = True, name: str | None = None) -> None:
        """The motor symbol at world ``pivot`` ``(2,)``: a circle with an arc arrow turning ``ccw`` or cw."""
        p = finite("motor pivot", pivot, (2,))

        def draw(v: View) -> Mark:
            c = v.px(p)
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

        self._add(p[None], draw, p[None])

    def box(self, xmin: float | None, xmax: float | None, ymin: float | None, ymax: float | None, *,
            stroke: Stroke = Stroke(ENVELOPE_GREEN, 1.8, "dashed"), fill: str = ENVELOPE_GREEN, cls: str = "envelope",
            label: str | None = None) -> None:
        """A world box; a side given as ``None`` is open and extends to the plot bounds.

        The region is shaded lightly; only the given (closed) sides are stroked.
        """
        sides = {"xmin": xmin, "xmax": xmax, "ymin": ymin, "ymax": ymax}
        for k, s in sides.items():
            if s is not None and not math.isfinite(s):
                raise ValueError(f"box {k}: not finite ({s})")
        for lo, hi in (("xmin", "xmax"), ("ymin", "ymax")):
            a, b = sides[lo], sides[hi]
            if a is not None and b is not None and a > b:
                raise ValueError(f"box: {lo} {a} > {hi} {b}")
        xs = np.array([s for s in (xmin, xmax) if s is not None], dtype=float)
        ys = np.array([s for s in (ymin, ymax) if s is not None], dtype=float)

        def draw(v: View) -> Mark:
            wx0, wx1, wy0, wy1 = v.window
            x0, x1 = (wx0 if xmin is None else xmin), (wx1 if xmax is None else xmax)
            y0, y1 = (wy0 if ymin is None else ymin), (wy1 if ymax is None else ymax)
            (a, b), (c, d) = v.px(np.array([[x0, y1], [x1, y0]]))
            edges = {"xmin": [[x0, y0], [x0, y1]], "xmax": [[x1, y0], [x1, y1]],
                     "ymin": [[x0, y0], [x1, y0]], "ymax": [[x0, y1], [x1, y1]]}
            lines = []
            for k, s in sides.items():
                if s is not None:
                    (p, q), (r, t) = v.px(np.array(edges[k]))
                    lines.append(still("line", {"x1": p, "y1": q, "x2": r, "y2": t}, data_side=k))
            shade = still("rect", {"x": a, "y": b, "width": c - a, "height": d - b}, fill=fill, fill_opacity="0.07",
                          stroke="none")
            return mark("g", cls=cls, kids=[shade, mark("g", fill="none", **stroke.kw(), kids=lines)])

        self._items.append(_Item(xs, ys, draw))
        self._label(label, stroke, "box")

    def annotate(self, point: Sequence[float], words: str, *, size: float = 10.0, color: str = "#4a5568",
                 offset_px: tuple[float, float] = (5.0, -5.0), cls: str = "label") -> None:
        """Text ``words`` at world ``point`` ``(2,)``, its baseline start shifted by ``offset_px``
        (pixels, y down) — or, where that would overlap another label or cover a symbol, the
        nearest free place around the point, with a leader line to it (see :func:`place_labels`)."""
        p = finite("label position", point, (2,))
        label = _Label(p, str(words), float(size), color, (float(offset_px[0]), float(offset_px[1])), cls)
        self._labels.append(label)

        def draw(v: View) -> list[Mark]:
            x, y, moved = self._placed[id(label)]
            out = []
            if moved:
                a = v.px(p)
                box = text_box(x, y, label.words, size)
                near = np.clip(a, box[:2], box[2:])
                out.append(still("line", dict(zip(("x1", "y1", "x2", "y2"), [*a, *near])), cls="leader",
                                 stroke=color, stroke_width="0.8", stroke_opacity="0.7"))
            t = still("text", {"x": x, "y": y}, cls=cls, font_size=f"{size:g}", fill=color, **_HALO, **_FONT)
            t.words = label.words
            return out + [t]

        self._add(p[None], draw)

    def labels(self, points: np.ndarray, words: Sequence[str], *, size: float = 10.0, color: str = "#4a5568",
               offset_px: tuple[float, float] = (5.0, -5.0), cls: str = "joint-label") -> None:
        """Text ``words[n]`` beside world ``points`` ``(n, 2)``, or following frames ``(F, n, 2)``."""
        p = self._pose("label positions", points)
        if len(words) != p.shape[1]:
            raise ValueError(f"{len(words)} labels for {p.shape[1]} points")

        def draw(v: View) -> list[Mark]:
            q = v.px(p) + np.asarray(offset_px)
            out = []
            for n, w in enumerate(words):
                t = mark("text", cls=cls, data_name=w, font_size=f"{size:g}", fill=color, **_HALO, **_FONT)
                t.geom, t.words = {"x": q[:, n, 0], "y": q[:, n, 1]}, str(w)
                out.append(t)
            return out

        self._add(p, draw)

    def frame_caption(self, captions: Sequence[str], *, cls: str = "frame-caption") -> None:
        """One caption per animation frame (e.g. the crank angle), shown above the plot as the frames play."""
        n = len(captions)
        if n == 0 or self.duration_s is None:
            raise ValueError("frame captions need frames and an animated figure (duration_s)")
        self._captions = (list(captions), cls)

    def triad(self, directions: Mapping[str, Sequence[float]], *, length_px: float = 30.0, cls: str = "triad") -> None:
        """Axis arrows in the plot's lower-left corner: name → the world axis's direction on the drawing
        ``(2,)`` (x right, y up; its length, at most 1, is the foreshortening: 0 is an axis seen end-on,
        drawn as a dot)."""
        dirs = {str(n): finite(f"triad {n}", d, (2,)) for n, d in directions.items()}
        self._triad_px = length_px

        def draw(v: View) -> Mark:
            c = np.array([v.left + 14.0 + length_px, v.top + v.height - 14.0 - length_px])
            out = []
            for n, d in dirs.items():
                tip = c + length_px * np.array([d[0], -d[1]])
                if float(np.hypot(*d)) < 0.05:  # seen end-on: a dot in a ring
                    word = still("text", {"x": c[0] + 6, "y": c[1] + 12}, **_HALO)
                    word.words = n
                    out.append(mark("g", data_name=n, kids=[
                        still("circle", {"cx": c[0], "cy": c[1]}, r="4", fill="none"),
                        still("circle", {"cx": c[0], "cy": c[1]}, r="1.2"), word]))
                    continue
                u = (tip - c) / float(np.hypot(*(tip - c)))
                nrm = np.array([-u[1], u[0]])
                at = tip + 9 * u
                word = still("text", {"x": at[0], "y": at[1] + 4}, text_anchor="middle", **_HALO)
                word.words = n
                out.append(mark("g", data_name=n, kids=[
                    still("line", dict(zip(("x1", "y1", "x2", "y2"), [*c, *tip]))),
                    still("polygon", {"points": [tip, tip - 7 * u + 3 * nrm, tip - 7 * u - 3 * nrm]}, stroke="none"),
                    word]))
            return mark("g", cls=cls, font_size="11", fill=INK, stroke=INK, stroke_width="1.4", **_FONT, kids=out)

        self._items.append(_Item(np.zeros(0), np.zeros(0), draw))

    def legend(self, label: str, stroke: Stroke = Stroke(), kind: str = "line") -> None:
        """A legend entry: a ``line`` sample, a ``box`` or a ``dot`` in ``stroke``, then ``label``."""
        if kind not in ("line", "box", "dot"):
            raise ValueError(f"legend kind must be line, box or dot, got {kind!r}")
        self._legend.append(_Entry(str(label), stroke, kind))

    # -- rendering ---------------------------------------------------------------------------

    def render(self) -> str:
        """The SVG document (UTF-8 XML text)."""
        width, height, marks = self.marks()
        body = "\n".join(svg(m, self.duration_s, self.cyclic) for m in marks)
        return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                f"<svg xmlns=\"{SVG_NS}\" version=\"1.1\" width=\"{width:.0f}\" height=\"{height:.0f}\""
                f" viewBox=\"0 0 {width:.0f} {height:.0f}\">\n<title>{text(self.title)}</title>\n"
                f"<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n{body}\n</svg>\n")

    def marks(self) -> tuple[float, float, list[Mark]]:
        """The picture's width and height (px) and its marks, bottom first (see :mod:`linkedit.io.marks`)."""
        view, width, height = self._layout()
        self._place(view)
        out = [self._axes(view)]
        for it in self._items:
            drawn = it.draw(view)
            out += drawn if isinstance(drawn, list) else [drawn]
        if self._legend:
            out.append(self._legend_marks(view.left + view.width + 20.0, view.top))
        if self._captions:
            out.append(self._caption_marks(view.left + 6.0, view.top + 16.0))
        if self.title:
            t = still("text", {"x": view.left + view.width / 2, "y": 22.0}, cls="title", text_anchor="middle",
                      font_size="15", font_weight="bold", fill=INK, **_FONT)
            t.words = self.title
            out.append(t)
        return width, height, out

    def _place(self, v: View) -> None:
        """Where each :meth:`annotate` label goes: baseline start (x, y) and whether it moved (px)."""
        anchors = np.array([v.px(lb.point) for lb in self._labels]).reshape(-1, 2)
        boxes = np.array([text_box(float(a[0] + lb.offset_px[0]), float(a[1] + lb.offset_px[1]), lb.words, lb.size)
                          for a, lb in zip(anchors, self._labels)])
        avoid = np.concatenate([v.px(it.marks_at) for it in self._items] + [anchors, self._triad_area(v)])
        shifts, moved = place_labels(anchors, boxes.reshape(-1, 4), v.area, avoid)
        self._placed = {id(lb): (float(a[0] + lb.offset_px[0] + s[0]), float(a[1] + lb.offset_px[1] + s[1]), bool(m))
                        for lb, a, s, m in zip(self._labels, anchors, shifts, moved)}

    def _triad_area(self, v: View) -> np.ndarray:
        """Points (k, 2) every 6 px over the corner the triad and its axis names take (none without a triad)."""
        if self._triad_px is None:
            return np.zeros((0, 2))
        side = 2 * self._triad_px + 34.0
        xs, ys = np.meshgrid(np.arange(0.0, side + 6, 6), np.arange(0.0, side + 6, 6))
        return np.column_stack([v.left + xs.ravel(), v.top + v.height - ys.ravel()])

    def _layout(self) -> tuple[View, float, float]:
        xs = np.concatenate([it.xs for it in self._items] + [np.zeros(0)])
        ys = np.concatenate([it.ys for it in self._items] + [np.zeros(0)])
        lo = np.array([xs.min() if xs.size else 0.0, ys.min() if ys.size else 0.0])
        hi = np.array([xs.max() if xs.size else 1.0, ys.max() if ys.size else 1.0])
        span = hi - lo
        least = max(0.1 * span.max(), 1e-9 * max(1.0, float(np.abs(np.r_[lo, hi]).max())))
        if span.max() == 0:
            least = max(1.0, 1e-6 * float(np.abs(np.r_[lo, hi]).max()))
        grow = np.maximum(least - span, 0.0)
        lo, span = lo - grow / 2, span + grow
        scale = (self.size_px - 2 * _PAD_PX) / span.max()
        size = np.maximum(span * scale + 2 * _PAD_PX, _MIN_PLOT_PX)
        origin = lo - (size - span * scale) / 2 / scale
        ystep, yticks = axis_ticks(float(origin[1]), float(origin[1] + size[1] / scale), float(size[1]))
        widest = max((len(tick_label(float(t), ystep)) for t in yticks), default=0)
        left, top = max(64.0, 34.0 + 6.5 * widest), 36.0 if self.title else 14.0
        view = View(float(origin[0]), float(origin[1]), float(scale), left, top, float(size[0]), float(size[1]))
        legend_w = (40.0 + 6.5 * max((len(e.label) for e in self._legend), default=0)) if self._legend else 0.0
        width = left + size[0] + 16.0 + legend_w
        height = max(top + size[1] + 48.0, top + 20.0 * len(self._legend) + 16.0)
        return view, float(math.ceil(width)), float(math.ceil(height))

    def _axes(self, v: View) -> Mark:
        x0, x1, y0, y1 = v.window
        right, bottom = v.left + v.width, v.top + v.height
        frame = still("rect", {"x": v.left, "y": v.top, "width": v.width, "height": v.height}, fill="none",
                      stroke_width="1")
        if self.axis_names is None:
            return mark("g", cls="axes", stroke="#4a5568", kids=[frame])
        hname, vname = self.axis_names
        grid: list[np.ndarray] = []
        marks = [frame]
        for axis, (lo, hi), extent in ((0, (x0, x1), v.width), (1, (y0, y1), v.height)):
            step, ticks = axis_ticks(lo, hi, extent)
            for t in ticks:
                if axis == 0:
                    x = float(v.px(np.array([t, y0]))[0])
                    grid.append(np.array([(x, v.top), (x, bottom)]))
                    line, at, anchor = [x, bottom, x, bottom + 5], (x, bottom + 18), "middle"
                else:
                    y = float(v.px(np.array([x0, t]))[1])
                    grid.append(np.array([(v.left, y), (right, y)]))
                    line, at, anchor = [v.left - 5, y, v.left, y], (v.left - 8, y + 4), "end"
                word = still("text", {"x": at[0], "y": at[1]}, cls="tick", text_anchor=anchor, stroke="none")
                word.words = tick_label(float(t), step)
                marks += [still("line", dict(zip(("x1", "y1", "x2", "y2"), line))), word]
        unit = f" ({self.units})" if self.units else ""
        mid_x, mid_y = v.left + v.width / 2, v.top + v.height / 2
        h = still("text", {"x": mid_x, "y": bottom + 36}, cls="unit", text_anchor="middle", stroke="none")
        vt = still("text", {"x": 16.0, "y": mid_y}, cls="unit", text_anchor="middle", stroke="none",
                   transform=f"rotate(-90 16 {mid_y:.2f})")
        h.words, vt.words = hname + unit, vname + unit
        return mark("g", cls="axes", font_size="11", fill="#4a5568", stroke="#4a5568", **_FONT,
                    kids=[path(grid, cls="grid", stroke="#edf2f7", stroke_width="1", fill="none")] + marks + [h, vt])

    def _legend_marks(self, x: float, y: float) -> Mark:
        rows = []
        for n, e in enumerate(self._legend):
            cy = y + 10 + 20 * n
            if e.kind == "line":
                rows.append(still("line", {"x1": x, "y1": cy, "x2": x + 26, "y2": cy}, **e.stroke.kw()))
            elif e.kind == "box":
                rows.append(still("rect", {"x": x + 3, "y": cy - 6, "width": 20.0, "height": 12.0},
                                  fill=e.stroke.color, fill_opacity="0.07", **e.stroke.kw()))
            else:
                rows.append(still("circle", {"cx": x + 13, "cy": cy}, r="3.5", fill="#ffffff", **e.stroke.kw()))
            word = still("text", {"x": x + 34, "y": cy + 4}, fill=INK)
            word.words = e.label
            rows.append(word)
        return mark("g", cls="legend", font_size="12", **_FONT, kids=rows)

    def _caption_marks(self, x: float, y: float) -> Mark:
        """One text per frame, each shown only during its frame."""
        words, cls = self._captions or ([], "")
        out = []
        for k, w in enumerate(words):
            t = still("text", {"x": x, "y": y})
            t.words, t.frame, t.frames = w, k, len(words)
            out.append(t)
        return mark("g", cls=cls, font_size="12", fill=INK, **_HALO, **_FONT, kids=out)

    # -- helpers -------------------------------------------------------------------------------

    def _add(self, world: np.ndarray, draw: Callable[[View], Mark | list[Mark]],
             marks_at: np.ndarray | None = None) -> None:
        flat = np.asarray(world, dtype=float).reshape(-1, 2)
        self._items.append(_Item(flat[:, 0], flat[:, 1], draw,
                                 np.zeros((0, 2)) if marks_at is None else np.asarray(marks_at, float).reshape(-1, 2)))

    def _label(self, label: str | None, stroke: Stroke, kind: str) -> None:
        if label is not None:
            self.legend(label, stroke, kind)

    def _pose(self, name: str, points: np.ndarray) -> np.ndarray:
        """Points ``(k, 2)`` → ``(1, k, 2)``; frames ``(F, k, 2)`` kept (animation needs ``duration_s``)."""
        p = np.asarray(points, dtype=float)
        if p.ndim == 2:
            return finite(name, p, (None, 2))[None]
        p = finite(name, p, (None, None, 2))
        if p.shape[0] == 0:
            raise ValueError(f"{name}: no frames")
        if p.shape[0] > 1 and self.duration_s is None:
            raise ValueError(f"{name}: frames given but the figure has no duration_s (not animated)")
        return p


def _bar(q: np.ndarray, **style: object) -> Mark:
    """A straight ``line`` mark between pixel ends ``q`` ``(F, 2, 2)``."""
    m = mark("line", **style)
    m.geom = {"x1": q[:, 0, 0], "y1": q[:, 0, 1], "x2": q[:, 1, 0], "y2": q[:, 1, 1]}
    return m


def _frame_px(v: View, ends: np.ndarray, side: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pixel ends of a world segment, its unit direction and its unit normal towards world ``side``."""
    a, b = v.px(ends)
    d = b - a
    u = d / max(float(np.hypot(*d)), 1e-9)
    n = np.array([-u[1], u[0]])
    if float(n @ (side * [1.0, -1.0])) < 0:
        n = -n
    return a, b, u, n
