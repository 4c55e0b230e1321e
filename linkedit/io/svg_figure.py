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

from linkedit.io import symbols
from linkedit.io.figure_layout import View, axis_ticks, finite, link_outline, place_labels, text_box, tick_label
from linkedit.io.figure_style import (ENVELOPE_GREEN, FAINT_OPACITY, FONT_ATTRS, HALO_ATTRS, INK, LINK_FILL, SVG_NS,
                                      Stroke)
from linkedit.io.marks import Mark, mark, path, still, svg, text

_PAD_PX = 18.0          # room inside the plot area for symbols drawn around points
_MIN_PLOT_PX = 160.0    # smallest plot side, so ticks and labels fit


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
        order = link_outline(p[0])
        if len(order) == 2:
            ends = p[:, order]

            def draw(v: View) -> Mark:
                return symbols.bar(v.px(ends), cls=cls, data_name=name, stroke=color, stroke_width=f"{width:g}",
                            stroke_linecap="round", stroke_opacity=opacity or 0.85)
        else:
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

        self._add(e, lambda v: symbols.rail(v.px(e), s, name=name, cls=cls))

    def slot(self, ends: np.ndarray, *, name: str | None = None, color: str = INK, cls: str = "slot") -> None:
        """A slot in a moving link: an opening a block (:data:`BLOCK_PX`) wide with rounded ends, a
        block length past the world ``ends`` ``(2, 2)`` or frames ``(F, 2, 2)`` of the travel, outlined
        in the link's colour."""
        e = self._pose(f"slot {name}" if name else "slot", ends)
        if e.shape[1] != 2:
            raise ValueError(f"slot {name}: expected 2 ends, got {e.shape[1]}")

        self._add(e.reshape(-1, 2), lambda v: symbols.slot(v.px(e), name=name, color=color, cls=cls))

    def block(self, centre: np.ndarray, direction: np.ndarray, *, name: str | None = None,
              cls: str = "block") -> None:
        """A slider's block, :data:`BLOCK_PX` in size, at world ``centre`` ``(2,)`` or frames ``(F, 2)``,
        its length along ``direction`` (same shape; any length)."""
        c = self._pose(f"block {name}" if name else "block", np.asarray(centre, dtype=float)[..., None, :])[:, 0]
        d = finite(f"block {name} direction", direction, c.shape if np.ndim(direction) == 2 else (2,))
        d = np.broadcast_to(d, c.shape)
        if np.any(np.hypot(d[:, 0], d[:, 1]) == 0):
            raise ValueError(f"block {name}: zero direction")

        self._add(c, lambda v: symbols.block(v.px(c), d, name=name, cls=cls))

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

        self._add(p[None], lambda v: symbols.ground(*v.px(p), name=name), p[None])

    def motor(self, pivot: Sequence[float], *, ccw: bool = True, name: str | None = None) -> None:
        """The motor symbol at world ``pivot`` ``(2,)``: a circle with an arc arrow turning ``ccw`` or cw."""
        p = finite("motor pivot", pivot, (2,))

        self._add(p[None], lambda v: symbols.motor(v.px(p), ccw=ccw, name=name), p[None])

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
            t = still("text", {"x": x, "y": y}, cls=cls, font_size=f"{size:g}", fill=color, **HALO_ATTRS, **FONT_ATTRS)
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
                t = mark("text", cls=cls, data_name=w, font_size=f"{size:g}", fill=color, **HALO_ATTRS, **FONT_ATTRS)
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
                    word = still("text", {"x": c[0] + 6, "y": c[1] + 12}, **HALO_ATTRS)
                    word.words = n
                    out.append(mark("g", data_name=n, kids=[
                        still("circle", {"cx": c[0], "cy": c[1]}, r="4", fill="none"),
                        still("circle", {"cx": c[0], "cy": c[1]}, r="1.2"), word]))
                    continue
                u = (tip - c) / float(np.hypot(*(tip - c)))
                nrm = np.array([-u[1], u[0]])
                at = tip + 9 * u
                word = still("text", {"x": at[0], "y": at[1] + 4}, text_anchor="middle", **HALO_ATTRS)
                word.words = n
                out.append(mark("g", data_name=n, kids=[
                    still("line", dict(zip(("x1", "y1", "x2", "y2"), [*c, *tip]))),
                    still("polygon", {"points": [tip, tip - 7 * u + 3 * nrm, tip - 7 * u - 3 * nrm]}, stroke="none"),
                    word]))
            return mark("g", cls=cls, font_size="11", fill=INK, stroke=INK, stroke_width="1.4", **FONT_ATTRS, kids=out)

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
                      font_size="15", font_weight="bold", fill=INK, **FONT_ATTRS)
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
        return mark("g", cls="axes", font_size="11", fill="#4a5568", stroke="#4a5568", **FONT_ATTRS,
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
        return mark("g", cls="legend", font_size="12", **FONT_ATTRS, kids=rows)

    def _caption_marks(self, x: float, y: float) -> Mark:
        """One text per frame, each shown only during its frame."""
        words, cls = self._captions or ([], "")
        out = []
        for k, w in enumerate(words):
            t = still("text", {"x": x, "y": y})
            t.words, t.frame, t.frames = w, k, len(words)
            out.append(t)
        return mark("g", cls=cls, font_size="12", fill=INK, **HALO_ATTRS, **FONT_ATTRS, kids=out)

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

