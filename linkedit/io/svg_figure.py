"""A small SVG figure builder for mechanism pictures.

World coordinates (x right, y up, in the drawing's units) are mapped to SVG pixels (y down)
with one scale for both axes (equal aspect ratio). Everything drawn is recorded first; the
bounds, the scale, the axes (ticks at round numbers, unit label), the title and the legend
are laid out when :meth:`Figure.render` is called. Symbol sizes (joint circles, ground and
motor markers, bar widths) are in pixels and do not scale with the drawing.

A primitive given one pose (``(k, 2)`` points) is static; given frames (``(F, k, 2)``) it is
animated with SMIL ``<animate>`` elements (``calcMode="linear"``, ``repeatCount="indefinite"``),
which needs ``Figure(duration_s=...)``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any
from dataclasses import dataclass, field
from xml.sax.saxutils import escape, quoteattr

import numpy as np

SVG_NS = "http://www.w3.org/2000/svg"
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
           "#bcbd22", "#7f7f7f")
INK = "#2d3748"
LINK_FILL = "#8fa8d0"
PATH_GREY = "#8a939e"
ENVELOPE_GREEN = "#276749"
FAINT_OPACITY = 0.3
DASH = "6 4"
FONT = "font-family=\"Helvetica, Arial, sans-serif\""
#: a white outline under label text, so labels stay readable over links and symbols
HALO = " stroke=\"#ffffff\" stroke-width=\"3\" stroke-opacity=\"0.85\" paint-order=\"stroke\" stroke-linejoin=\"round\""

_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
_PAD_PX = 18.0          # room inside the plot area for symbols drawn around points
_MIN_PLOT_PX = 160.0    # smallest plot side, so ticks and labels fit


def text(value: object) -> str:
    """``value`` as XML character data (escaped; characters XML 1.0 forbids become U+FFFD)."""
    return escape(_NOT_XML.sub("\ufffd", str(value)))


def attr(value: object) -> str:
    """``value`` as a quoted XML attribute value."""
    return quoteattr(_NOT_XML.sub("\ufffd", str(value)))


def attrs(**kw: object) -> str:
    """``' name="value"'`` pairs; ``cls`` → ``class``, ``_`` → ``-``; ``None`` values are left out."""
    out = []
    for k, v in kw.items():
        if v is None:
            continue
        name = "class" if k == "cls" else k.replace("_", "-")
        out.append(f" {name}={attr(f'{v:.2f}' if isinstance(v, float) else v)}")
    return "".join(out)


def points_text(p: Any, decimals: int = 2) -> str:
    """``(k, 2)`` pixel points (an array or pairs) as an SVG ``points`` list ``"x,y x,y ..."``."""
    f = f"%.{decimals}f,%.{decimals}f"
    return " ".join(f % (x, y) for x, y in np.asarray(p, dtype=float).tolist())


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
        return attrs(stroke=self.color, stroke_width=float(self.width),
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


@dataclass
class _Item:
    xs: np.ndarray
    ys: np.ndarray
    draw: Callable[[View], str]


@dataclass(frozen=True)
class _Entry:
    label: str
    stroke: Stroke
    kind: str  # line | box | dot


@dataclass
class Figure:
    """Collects primitives in world coordinates and renders one SVG document.

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

    # -- primitives ------------------------------------------------------------------------

    def polyline(self, points: np.ndarray, stroke: Stroke = Stroke(), *, closed: bool = False,
                 cls: str = "curve", name: str | None = None, label: str | None = None) -> None:
        """A curve through world ``points`` ``(k, 2)``; ``closed`` joins the last point to the first."""
        p = finite(name or cls, points, (None, 2))
        tag = "polygon" if closed else "polyline"

        def draw(v: View) -> str:
            return (f"<{tag}{attrs(cls=cls, data_name=name)} points={attr(points_text(v.px(p)))}"
                    f" fill=\"none\"{stroke.svg()} stroke-linejoin=\"round\" stroke-linecap=\"round\"/>")

        self._add(p, draw)
        self._label(label, stroke, "line")

    def joints(self, points: np.ndarray, *, names: Sequence[str] | None = None, radius: float = 3.2,
               fill: str = "#ffffff", stroke: Stroke = Stroke(width=1.3), cls: str = "joint") -> None:
        """Circle markers of ``radius`` px at world ``points`` ``(n, 2)`` or frames ``(F, n, 2)``."""
        p = self._pose("joint positions", points)
        labels: list[str | None] = list(names) if names is not None else [None] * p.shape[1]
        if len(labels) != p.shape[1]:
            raise ValueError(f"{len(labels)} joint names for {p.shape[1]} points")

        def draw(v: View) -> str:
            q = v.px(p)
            out = []
            for n, name in enumerate(labels):
                head = f"<circle{attrs(cls=cls, data_name=name)} r=\"{radius:g}\" fill={attr(fill)}{stroke.svg()}"
                out.append(head + self._animated(q[:, n], ("cx", "cy"), "circle"))
            return "\n".join(out)

        self._add(p, draw)

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

            def draw(v: View) -> str:
                q = v.px(ends)
                head = (f"<line{attrs(cls=cls, data_name=name)} stroke={attr(color)} stroke-width=\"{width:g}\""
                        f" stroke-linecap=\"round\"{attrs(stroke_opacity=opacity or 0.85)}")
                return head + self._animated(q, ("x1", "y1", "x2", "y2"), "line")
        else:
            order = np.argsort(np.arctan2(first[:, 1], first[:, 0]))
            ring = p[:, order]

            def draw(v: View) -> str:
                head = (f"<polygon{attrs(cls=cls, data_name=name)} fill={attr(fill)}"
                        f"{attrs(fill_opacity=0.15 if opacity else 0.55)} stroke={attr(color)}"
                        f" stroke-width=\"2.5\" stroke-linejoin=\"round\"{attrs(stroke_opacity=opacity)}")
                return head + self._animated(v.px(ring), ("points",), "polygon")

        self._add(p, draw)

    def arrow(self, start: Sequence[float], end: Sequence[float], stroke: Stroke = Stroke(), *, cls: str = "arrow",
              name: str | None = None) -> None:
        """A straight arrow from world ``start`` to ``end`` (2,), its head (px-sized) at ``end``."""
        p = finite(name or cls, np.array([start, end], dtype=float), (2, 2))

        def draw(v: View) -> str:
            a, b = v.px(p)
            d = b - a
            length = float(np.hypot(*d))
            if length < 1e-9:
                return ""
            u = d / length
            n = np.array([-u[1], u[0]])
            head = points_text([b, b - 9 * u + 4 * n, b - 9 * u - 4 * n])
            tip = b - 8 * u
            return (f"<g{attrs(cls=cls, data_name=name)}><line x1=\"{a[0]:.2f}\" y1=\"{a[1]:.2f}\" x2=\"{tip[0]:.2f}\""
                    f" y2=\"{tip[1]:.2f}\" fill=\"none\"{stroke.svg()}/>"
                    f"<polygon points={attr(head)} fill={attr(stroke.color)} stroke=\"none\"/></g>")

        self._add(p, draw)

    def ground(self, point: Sequence[float], *, name: str | None = None) -> None:
        """The ground (frame) symbol under world ``point`` ``(2,)``: hatched base with a support triangle."""
        p = finite(f"ground {name}" if name else "ground", point, (2,))

        def draw(v: View) -> str:
            x, y = v.px(p)
            tri = points_text([(x, y), (x - 8, y + 12), (x + 8, y + 12)])
            hatch = " ".join(f"M{x - 11 + 5 * i:.2f},{y + 12:.2f} l-5,6" for i in range(5))
            return (f"<g{attrs(cls='ground', data_name=name)} stroke={attr(INK)} stroke-width=\"1.3\">"
                    f"<polygon points={attr(tri)} fill=\"#e2e8f0\"/>"
                    f"<path d=\"M{x - 14:.2f},{y + 12:.2f} h28 {hatch}\" fill=\"none\"/></g>")

        self._add(p[None], draw)

    def motor(self, pivot: Sequence[float], *, ccw: bool = True, name: str | None = None) -> None:
        """The motor symbol at world ``pivot`` ``(2,)``: a circle with an arc arrow turning ``ccw`` or cw."""
        p = finite("motor pivot", pivot, (2,))

        def draw(v: View) -> str:
            c = v.px(p)
            r, turn = 14.0, 1.0 if ccw else -1.0
            a0 = math.radians(-60.0)
            a1 = a0 + turn * math.radians(280.0)

            def at(a: float, rad: float = r) -> np.ndarray:  # visual angle, counter-clockwise on screen
                return c + rad * np.array([math.cos(a), -math.sin(a)])

            s, e = at(a0), at(a1)
            tangent = turn * np.array([-math.sin(a1), -math.cos(a1)])
            radial = np.array([math.cos(a1), -math.sin(a1)])
            head = points_text([e + 5 * tangent, e - 2 * tangent + 4 * radial, e - 2 * tangent - 4 * radial])
            sweep = 0 if ccw else 1
            return (f"<g{attrs(cls='motor', data_name=name)} stroke={attr(PALETTE[1])} stroke-width=\"1.6\">"
                    f"<circle cx=\"{c[0]:.2f}\" cy=\"{c[1]:.2f}\" r=\"{r - 6:g}\" fill=\"none\"/>"
                    f"<path d=\"M{s[0]:.2f},{s[1]:.2f} A{r:g},{r:g} 0 1 {sweep} {e[0]:.2f},{e[1]:.2f}\" fill=\"none\"/>"
                    f"<polygon points={attr(head)} fill={attr(PALETTE[1])} stroke=\"none\"/></g>")

        self._add(p[None], draw)

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

        def draw(v: View) -> str:
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
                    lines.append(f"<line data-side=\"{k}\" x1=\"{p:.2f}\" y1=\"{q:.2f}\""
                                 f" x2=\"{r:.2f}\" y2=\"{t:.2f}\"/>")
            return (f"<g{attrs(cls=cls)}><rect x=\"{a:.2f}\" y=\"{b:.2f}\""
                    f" width=\"{c - a:.2f}\" height=\"{d - b:.2f}\""
                    f" fill={attr(fill)} fill-opacity=\"0.07\" stroke=\"none\"/>"
                    f"<g fill=\"none\"{stroke.svg()}>{''.join(lines)}</g></g>")

        self._items.append(_Item(xs, ys, draw))
        self._label(label, stroke, "box")

    def annotate(self, point: Sequence[float], words: str, *, size: float = 10.0, color: str = "#4a5568",
              offset_px: tuple[float, float] = (5.0, -5.0), cls: str = "label") -> None:
        """Text ``words`` at world ``point`` ``(2,)``, shifted by ``offset_px`` (pixels, y down)."""
        p = finite("label position", point, (2,))

        def draw(v: View) -> str:
            x, y = v.px(p) + np.asarray(offset_px)
            return (f"<text{attrs(cls=cls)} x=\"{x:.2f}\" y=\"{y:.2f}\" font-size=\"{size:g}\" fill={attr(color)}"
                    f"{HALO} {FONT}>{text(words)}</text>")

        self._add(p[None], draw)

    def labels(self, points: np.ndarray, words: Sequence[str], *, size: float = 10.0, color: str = "#4a5568",
               offset_px: tuple[float, float] = (5.0, -5.0), cls: str = "joint-label") -> None:
        """Text ``words[n]`` beside world ``points`` ``(n, 2)``, or following frames ``(F, n, 2)``."""
        p = self._pose("label positions", points)
        if len(words) != p.shape[1]:
            raise ValueError(f"{len(words)} labels for {p.shape[1]} points")

        def draw(v: View) -> str:
            q = v.px(p) + np.asarray(offset_px)
            out = []
            for n, w in enumerate(words):
                rest = self._animated(q[:, n], ("x", "y"), "text")  # attributes, then "/>" or ">…</text>"
                rest = rest[:-2] + ">" if rest.endswith("/>") else rest[: -len("</text>")]
                out.append(f"<text{attrs(cls=cls, data_name=w)} font-size=\"{size:g}\" fill={attr(color)}{HALO}"
                           f" {FONT}{rest}{text(w)}</text>")
            return "\n".join(out)

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

        def draw(v: View) -> str:
            c = np.array([v.left + 14.0 + length_px, v.top + v.height - 14.0 - length_px])
            out = []
            for n, d in dirs.items():
                tip = c + length_px * np.array([d[0], -d[1]])
                if float(np.hypot(*d)) < 0.05:  # seen end-on: a dot in a ring
                    out.append(f"<g{attrs(data_name=n)}><circle cx=\"{c[0]:.2f}\" cy=\"{c[1]:.2f}\" r=\"4\" fill=\"none\"/>"
                               f"<circle cx=\"{c[0]:.2f}\" cy=\"{c[1]:.2f}\" r=\"1.2\"/>"
                               f"<text x=\"{c[0] + 6:.2f}\" y=\"{c[1] + 12:.2f}\"{HALO}>{text(n)}</text></g>")
                    continue
                u = (tip - c) / float(np.hypot(*(tip - c)))
                nrm = np.array([-u[1], u[0]])
                head = points_text([tip, tip - 7 * u + 3 * nrm, tip - 7 * u - 3 * nrm])
                at = tip + 9 * u
                out.append(f"<g{attrs(data_name=n)}><line x1=\"{c[0]:.2f}\" y1=\"{c[1]:.2f}\" x2=\"{tip[0]:.2f}\""
                           f" y2=\"{tip[1]:.2f}\"/><polygon points={attr(head)} stroke=\"none\"/>"
                           f"<text x=\"{at[0]:.2f}\" y=\"{at[1] + 4:.2f}\" text-anchor=\"middle\""
                           f"{HALO}>{text(n)}</text></g>")
            return (f"<g{attrs(cls=cls)} font-size=\"11\" fill={attr(INK)} stroke={attr(INK)} stroke-width=\"1.4\""
                    f" {FONT}>{''.join(out)}</g>")

        self._items.append(_Item(np.zeros(0), np.zeros(0), draw))

    def legend(self, label: str, stroke: Stroke = Stroke(), kind: str = "line") -> None:
        """A legend entry: a ``line`` sample, a ``box`` or a ``dot`` in ``stroke``, then ``label``."""
        if kind not in ("line", "box", "dot"):
            raise ValueError(f"legend kind must be line, box or dot, got {kind!r}")
        self._legend.append(_Entry(str(label), stroke, kind))

    # -- rendering ---------------------------------------------------------------------------

    def render(self) -> str:
        """The SVG document (UTF-8 XML text)."""
        view, width, height = self._layout()
        body = [self._axes(view)] + [it.draw(view) for it in self._items]
        if self._legend:
            body.append(self._legend_svg(view.left + view.width + 20.0, view.top))
        if self._captions:
            body.append(self._captions_svg(view.left + 6.0, view.top + 16.0))
        if self.title:
            body.append(f"<text class=\"title\" x=\"{view.left + view.width / 2:.2f}\" y=\"22\" text-anchor=\"middle\""
                        f" font-size=\"15\" font-weight=\"bold\" fill={attr(INK)} {FONT}>{text(self.title)}</text>")
        return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                f"<svg xmlns=\"{SVG_NS}\" version=\"1.1\" width=\"{width:.0f}\" height=\"{height:.0f}\""
                f" viewBox=\"0 0 {width:.0f} {height:.0f}\">\n<title>{text(self.title)}</title>\n"
                f"<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n" + "\n".join(body) + "\n</svg>\n")

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

    def _axes(self, v: View) -> str:
        x0, x1, y0, y1 = v.window
        right, bottom = v.left + v.width, v.top + v.height
        if self.axis_names is None:
            return (f"<g class=\"axes\" stroke=\"#4a5568\"><rect x=\"{v.left:.2f}\" y=\"{v.top:.2f}\""
                    f" width=\"{v.width:.2f}\" height=\"{v.height:.2f}\" fill=\"none\" stroke-width=\"1\"/></g>")
        hname, vname = self.axis_names
        grid, marks = [], []
        for axis, (lo, hi), extent in ((0, (x0, x1), v.width), (1, (y0, y1), v.height)):
            step, ticks = axis_ticks(lo, hi, extent)
            for t in ticks:
                word = text(tick_label(float(t), step))
                if axis == 0:
                    x = float(v.px(np.array([t, y0]))[0])
                    grid.append(f"M{x:.2f},{v.top:.2f}V{bottom:.2f}")
                    marks.append(f"<line x1=\"{x:.2f}\" y1=\"{bottom:.2f}\" x2=\"{x:.2f}\" y2=\"{bottom + 5:.2f}\"/>"
                                 f"<text class=\"tick\" x=\"{x:.2f}\" y=\"{bottom + 18:.2f}\" text-anchor=\"middle\""
                                 f" stroke=\"none\">{word}</text>")
                else:
                    y = float(v.px(np.array([x0, t]))[1])
                    grid.append(f"M{v.left:.2f},{y:.2f}H{right:.2f}")
                    marks.append(f"<line x1=\"{v.left - 5:.2f}\" y1=\"{y:.2f}\" x2=\"{v.left:.2f}\" y2=\"{y:.2f}\"/>"
                                 f"<text class=\"tick\" x=\"{v.left - 8:.2f}\" y=\"{y + 4:.2f}\" text-anchor=\"end\""
                                 f" stroke=\"none\">{word}</text>")
        unit = f" ({self.units})" if self.units else ""
        mid_x, mid_y = v.left + v.width / 2, v.top + v.height / 2
        return (f"<g class=\"axes\" font-size=\"11\" fill=\"#4a5568\" stroke=\"#4a5568\" {FONT}>"
                f"<path class=\"grid\" d=\"{' '.join(grid)}\" stroke=\"#edf2f7\" stroke-width=\"1\" fill=\"none\"/>"
                f"<rect x=\"{v.left:.2f}\" y=\"{v.top:.2f}\" width=\"{v.width:.2f}\" height=\"{v.height:.2f}\""
                f" fill=\"none\" stroke-width=\"1\"/>{''.join(marks)}"
                f"<text class=\"unit\" x=\"{mid_x:.2f}\" y=\"{bottom + 36:.2f}\" text-anchor=\"middle\""
                f" stroke=\"none\">{text(hname + unit)}</text>"
                f"<text class=\"unit\" x=\"16\" y=\"{mid_y:.2f}\" text-anchor=\"middle\" stroke=\"none\""
                f" transform=\"rotate(-90 16 {mid_y:.2f})\">{text(vname + unit)}</text></g>")

    def _legend_svg(self, x: float, y: float) -> str:
        rows = []
        for n, e in enumerate(self._legend):
            cy = y + 10 + 20 * n
            if e.kind == "line":
                mark = f"<line x1=\"{x:.2f}\" y1=\"{cy:.2f}\" x2=\"{x + 26:.2f}\" y2=\"{cy:.2f}\"{e.stroke.svg()}/>"
            elif e.kind == "box":
                mark = (f"<rect x=\"{x + 3:.2f}\" y=\"{cy - 6:.2f}\" width=\"20\" height=\"12\""
                        f" fill={attr(e.stroke.color)} fill-opacity=\"0.07\"{e.stroke.svg()}/>")
            else:
                mark = f"<circle cx=\"{x + 13:.2f}\" cy=\"{cy:.2f}\" r=\"3.5\" fill=\"#ffffff\"{e.stroke.svg()}/>"
            rows.append(f"{mark}<text x=\"{x + 34:.2f}\" y=\"{cy + 4:.2f}\" fill={attr(INK)}>{text(e.label)}</text>")
        return f"<g class=\"legend\" font-size=\"12\" {FONT}>{''.join(rows)}</g>"

    def _captions_svg(self, x: float, y: float) -> str:
        """One ``<text>`` per frame, each shown only during its frame (discrete ``display`` animation)."""
        words, cls = self._captions or ([], "")
        n = len(words)
        out = []
        for k, w in enumerate(words):
            a, b = k / n, (k + 1) / n
            if k == 0:
                values, times = "inline;none", f"0;{b:.6g}"
            else:
                values, times = "none;inline;none", f"0;{a:.6g};{b:.6g}"
            out.append(f"<text x=\"{x:.2f}\" y=\"{y:.2f}\" display=\"{'inline' if k == 0 else 'none'}\">{text(w)}"
                       f"<animate attributeName=\"display\" values=\"{values}\" keyTimes=\"{times}\" calcMode=\"discrete\""
                       f" dur=\"{self.duration_s:g}s\" repeatCount=\"indefinite\"/></text>")
        return (f"<g{attrs(cls=cls)} font-size=\"12\" fill={attr(INK)}{HALO} {FONT}>" + "".join(out) + "</g>")

    # -- helpers -------------------------------------------------------------------------------

    def _add(self, world: np.ndarray, draw: Callable[[View], str]) -> None:
        flat = np.asarray(world, dtype=float).reshape(-1, 2)
        self._items.append(_Item(flat[:, 0], flat[:, 1], draw))

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

    def _animated(self, q: np.ndarray, names: tuple[str, ...], tag: str) -> str:
        """Close an element whose pixel geometry is ``q`` ``(F, ...)``: attributes from frame 0 and
        one ``<animate>`` per attribute that changes between frames (one value per frame)."""
        if names == ("points",):
            start = [points_text(q[0])]
            series = [[points_text(f, 1) for f in q]]
        else:
            flat = q.reshape(q.shape[0], -1)
            start = [f"{c:.2f}" for c in flat[0]]
            series = [[f"{c:.1f}" for c in flat[:, n].tolist()] for n in range(flat.shape[1])]
        head = "".join(f" {n}=\"{s}\"" for n, s in zip(names, start))
        kids = []
        for n, values in zip(names, series):
            if len(set(values)) == 1:
                continue
            if self.cyclic:
                values = values + values[:1]
            kids.append(f"<animate attributeName=\"{n}\" dur=\"{self.duration_s:g}s\" repeatCount=\"indefinite\""
                        f" calcMode=\"linear\" values=\"{';'.join(values)}\"/>")
        return head + (">" + "".join(kids) + f"</{tag}>" if kids else "/>")
