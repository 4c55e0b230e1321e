"""A figure's frames as raster images: the marks of :class:`~linkedit.io.svg_figure.Figure` (the same
ones its SVG is written from, :mod:`linkedit.io.marks`) painted with Pillow's ``ImageDraw``.

Painted at :data:`SUPERSAMPLE` times the size and reduced (box filter), so edges are antialiased.
Text uses Pillow's built-in scalable font. What does not move is painted once and copied into
every frame. Needs the optional Pillow (``pip install linkedit[gif]``): imported by the caller.
"""

from __future__ import annotations

import re
from functools import lru_cache
from typing import Any

import numpy as np

from linkedit.io.marks import Mark
from linkedit.io.svg_figure import Figure

SUPERSAMPLE = 2
_ROTATE = re.compile(r"rotate\(([-\d.]+) ([-\d.]+) ([-\d.]+)\)")
_ANCHOR = {"start": "ls", "middle": "ms", "end": "rs"}
_INHERITED = ("stroke", "stroke-width", "stroke-opacity", "stroke-dasharray", "stroke-linecap", "fill", "fill-opacity",
              "font-size", "font-weight", "text-anchor", "paint-order")


def frames(fig: Figure) -> list[Any]:
    """The figure's animation frames (one for a still figure) as RGB ``PIL.Image`` images, in pixels
    of the SVG's size."""
    from PIL import Image

    width, height, marks = fig.marks()
    n = max((m.n_frames for m in marks), default=1)
    moving = [i for i, m in enumerate(marks) if m.n_frames > 1]
    first, last = (moving[0], moving[-1] + 1) if moving else (len(marks), len(marks))
    size = (int(width) * SUPERSAMPLE, int(height) * SUPERSAMPLE)
    base = Image.new("RGB", size, "white")
    for m in marks[:first]:
        _paint(base, m, 0, {})
    top = Image.new("RGBA", size, (255, 255, 255, 0))  # what is still over the moving marks (legend, title)
    for m in marks[last:]:
        _paint(top, m, 0, {})
    box = top.getbbox()
    patch = top.crop(box) if box else None
    out = []
    for k in range(n):
        img = base.copy()
        for m in marks[first:last]:
            _paint(img, m, k, {})
        if patch is not None and box is not None:
            img.paste(patch, box[:2], patch)
        out.append(img.reduce(SUPERSAMPLE))
    return out


def _paint(img: Any, m: Mark, k: int, inherited: dict[str, str]) -> None:
    """Paint mark ``m`` at frame ``k`` onto ``img`` (supersampled pixels)."""
    from PIL import ImageDraw

    if m.frame is not None and m.frame != k:
        return
    style = {**inherited, **{a: v for a, v in m.style.items() if a in _INHERITED or a == "transform"}}
    if m.tag == "g":
        for kid in m.kids:
            _paint(img, kid, k, {a: v for a, v in style.items() if a != "transform"})
        return
    draw = ImageDraw.Draw(img, "RGBA")
    s = SUPERSAMPLE
    stroke = _color(style.get("stroke", "none"), style.get("stroke-opacity"))
    fill = _color(style.get("fill", "#000000"), style.get("fill-opacity"))
    width = float(style.get("stroke-width", "1")) * s
    if m.tag == "text":
        _text(img, m, k, style)
        return
    if m.tag == "circle":
        x, y, r = float(m.at("cx", k)) * s, float(m.at("cy", k)) * s, float(m.style["r"]) * s
        if fill:
            draw.ellipse([x - r, y - r, x + r, y + r], fill=fill)
        if stroke:
            lw = max(1, round(width))
            draw.ellipse([x - r - lw / 2, y - r - lw / 2, x + r + lw / 2, y + r + lw / 2], outline=stroke, width=lw)
        return
    if m.tag == "rect":
        if "x" not in m.geom:
            return  # the background
        x, y, w, h = (float(m.at(a, k)) * s for a in ("x", "y", "width", "height"))
        if fill:
            draw.rectangle([x, y, x + w, y + h], fill=fill)
        if stroke:
            _stroke(draw, np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h], [x, y]]), stroke, width, style)
        return
    if m.tag == "line":
        lines = [np.array([[m.at("x1", k), m.at("y1", k)], [m.at("x2", k), m.at("y2", k)]], dtype=float) * s]
    elif m.tag == "path":
        lines = [p * s for p in m.subpaths]
    else:
        lines = [m.at("points", k) * s]
    if m.tag == "polygon":
        if fill:
            draw.polygon([tuple(p) for p in lines[0].tolist()], fill=fill)
        lines = [np.vstack([lines[0], lines[0][:1]])]
    if stroke:
        for line in lines:
            _stroke(draw, line, stroke, width, style)


def _stroke(draw: Any, line: np.ndarray, color: tuple[int, ...], width: float, style: dict[str, str]) -> None:
    """A polyline ``(k, 2)`` in ``color``, ``width`` px, dashed and round-capped as ``style`` says."""
    w = max(1, round(width))
    pieces = [line]
    if style.get("stroke-dasharray"):
        on, off = (float(v) * SUPERSAMPLE for v in style["stroke-dasharray"].split()[:2])
        pieces = _dashes(line, on, off)
    for p in pieces:
        if len(p) < 2:
            continue
        draw.line([tuple(q) for q in p.tolist()], fill=color, width=w, joint="curve")
        if style.get("stroke-linecap") == "round" and w > 2:
            for x, y in (p[0], p[-1]):
                draw.ellipse([x - w / 2, y - w / 2, x + w / 2, y + w / 2], fill=color)


def _dashes(line: np.ndarray, on: float, off: float) -> list[np.ndarray]:
    """The dashes (each ``(k, 2)``) of a polyline drawn with dash length ``on`` and gap ``off``."""
    seg = np.hypot(*np.diff(line, axis=0).T)
    at = np.concatenate([[0.0], np.cumsum(seg)])
    out = []
    for start in np.arange(0.0, at[-1], on + off):
        stop = min(start + on, at[-1])
        inside = (at > start) & (at < stop)
        ends = [np.array([np.interp(t, at, line[:, 0]), np.interp(t, at, line[:, 1])]) for t in (start, stop)]
        out.append(np.vstack([ends[0], line[inside], ends[1]]))
    return out


def _text(img: Any, m: Mark, k: int, style: dict[str, str]) -> None:
    from PIL import Image, ImageDraw

    s = SUPERSAMPLE
    size = float(style.get("font-size", "12"))
    font = _font(round(size * s))
    x, y = float(m.at("x", k)) * s, float(m.at("y", k)) * s
    fill = _color(style.get("fill", "#000000"), None) or (0, 0, 0, 255)
    kw: dict[str, Any] = {"anchor": _ANCHOR[style.get("text-anchor", "start")], "fill": fill}
    if style.get("paint-order") == "stroke" and _color(style.get("stroke", "none"), None):
        kw.update(stroke_width=round(float(style.get("stroke-width", "1")) * s / 2), stroke_fill=_color(style["stroke"], None))
    elif style.get("font-weight") == "bold":
        kw.update(stroke_width=max(1, s // 2), stroke_fill=fill)
    turn = _ROTATE.fullmatch(style.get("transform", ""))
    if turn is None:
        ImageDraw.Draw(img, "RGBA").text((x, y), m.words, font=font, **kw)
        return
    angle, cx, cy = (float(v) for v in turn.groups())
    layer = Image.new("RGBA", img.size, (255, 255, 255, 0))
    ImageDraw.Draw(layer).text((x, y), m.words, font=font, **kw)
    img.paste(layer.rotate(-angle, center=(cx * s, cy * s)), (0, 0), layer.rotate(-angle, center=(cx * s, cy * s)))


@lru_cache(maxsize=16)
def _font(px: int) -> Any:
    from PIL import ImageFont

    return ImageFont.load_default(size=px)


def _color(value: str, opacity: str | None) -> tuple[int, ...] | None:
    """``#rrggbb`` (and an opacity) → RGBA; ``none`` → None."""
    if value == "none":
        return None
    if not re.fullmatch(r"#[0-9a-fA-F]{6}", value):
        raise ValueError(f"cannot paint colour {value!r}")
    alpha = round(255 * float(opacity)) if opacity is not None else 255
    return tuple(int(value[i:i + 2], 16) for i in (1, 3, 5)) + (alpha,)
