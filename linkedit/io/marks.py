"""What a figure draws, in pixels: one tree of marks that every picture backend reads.

A :class:`Mark` is one element (``line``, ``polyline``, ``polygon``, ``circle``, ``rect``,
``path``, ``text`` or a group ``g``) with its presentation attributes (SVG names: ``stroke``,
``fill``, ``stroke-width``…, inherited by a group's marks) and its geometry per animation
frame: ``(F,)`` values per coordinate attribute (``cx``, ``x1``…) or ``(F, k, 2)`` ``points``;
F = 1 is still. :func:`svg` writes a mark as SVG (moving coordinates as SMIL ``<animate>``);
:mod:`linkedit.io.raster` paints one frame of the same marks into an image.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np

_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def text(value: object) -> str:
    """``value`` as XML character data (escaped; characters XML 1.0 forbids become U+FFFD)."""
    return escape(_NOT_XML.sub("\ufffd", str(value)))


def attr(value: object) -> str:
    """``value`` as a quoted XML attribute value."""
    return quoteattr(_NOT_XML.sub("\ufffd", str(value)))


def attrs(**kw: object) -> str:
    """``' name="value"'`` pairs; ``cls`` → ``class``, ``_`` → ``-``; ``None`` values are left out."""
    return "".join(f" {k}={attr(v)}" for k, v in svg_names(kw).items())


def svg_names(kw: dict[str, object]) -> dict[str, str]:
    """Keyword names → SVG attribute names (``cls`` → ``class``, ``_`` → ``-``), values as text
    (floats with 2 decimals); ``None`` values are left out."""
    out = {}
    for k, v in kw.items():
        if v is not None:
            out["class" if k == "cls" else k.replace("_", "-")] = f"{v:.2f}" if isinstance(v, float) else str(v)
    return out


def points_text(p: object, decimals: int = 2) -> str:
    """``(k, 2)`` pixel points (an array or pairs) as an SVG ``points`` list ``"x,y x,y ..."``."""
    f = f"%.{decimals}f,%.{decimals}f"
    return " ".join(f % (x, y) for x, y in np.asarray(p, dtype=float).tolist())


@dataclass
class Mark:
    """One drawn element in pixels (see module docstring).

    ``geom``: coordinate attribute → ``(F,)`` values, or ``points`` → ``(F, k, 2)``; ``words``: a
    text's characters; ``subpaths``: a path's pieces ``(k, 2)`` (what is painted) and ``d``: its SVG
    path data (the same shape, e.g. with exact arcs); ``frame``/``frames``: shown only during
    frame ``frame`` of ``frames`` (a per-frame caption), ``frame`` None: always.
    """

    tag: str
    style: dict[str, str] = field(default_factory=dict)
    geom: dict[str, np.ndarray] = field(default_factory=dict)
    kids: list[Mark] = field(default_factory=list)
    words: str = ""
    subpaths: tuple[np.ndarray, ...] = ()
    d: str = ""
    frame: int | None = None
    frames: int = 0

    @property
    def n_frames(self) -> int:
        """Frames this mark and its marks move over (1: still)."""
        own = max((g.shape[0] for g in self.geom.values()), default=1)
        return max([own, self.frames] + [k.n_frames for k in self.kids])

    def at(self, name: str, frame: int) -> np.ndarray:
        """Geometry ``name`` at ``frame`` (a still mark has one frame)."""
        g = self.geom[name]
        return g[min(frame, g.shape[0] - 1)]


def mark(tag: str, **style: Any) -> Mark:
    """A mark with presentation attributes given as keywords (``cls``, ``data_name``, ``stroke_width``…);
    ``kids``: a group's marks, ``words``: a text's."""
    kids, words = style.pop("kids", None) or [], str(style.pop("words", ""))
    return Mark(tag, svg_names(style), kids=kids, words=words)


def still(tag: str, geom: dict[str, object], **style: Any) -> Mark:
    """A mark that does not move: ``geom`` coordinate attribute → value (``points``: ``(k, 2)``)."""
    m = mark(tag, **style)
    m.geom = {k: np.asarray(v, dtype=float)[None] for k, v in geom.items()}
    return m


def path(subpaths: list[np.ndarray], *, d: str = "", **style: Any) -> Mark:
    """A still path through the pixel polylines ``subpaths`` (each ``(k, 2)``); ``d`` overrides its SVG data."""
    m = mark("path", **style)
    m.subpaths = tuple(np.asarray(s, dtype=float) for s in subpaths)
    m.d = d or " ".join("M" + " L".join(f"{x:.2f},{y:.2f}" for x, y in s.tolist()) for s in m.subpaths)
    return m


def svg(m: Mark, duration_s: float | None = None, cyclic: bool = True) -> str:
    """The SVG text of mark ``m``: still coordinates with 2 decimals; a coordinate that changes
    between frames gets an ``<animate>`` with one value per frame (1 decimal; frame 0 again at the
    end when ``cyclic``) over ``duration_s``."""
    head = "".join(f" {k}={attr(v)}" for k, v in m.style.items() if k != "d")
    kids: list[str] = []
    for name, g in m.geom.items():
        if name == "points":
            head += f" points={attr(points_text(g[0]))}"
            series = [points_text(f, 1) for f in g]
        else:
            head += f" {name}=\"{g[0]:.2f}\""
            series = [f"{c:.1f}" for c in g.tolist()]
        values: list[str]
        if len(set(series)) > 1:
            values = series + series[:1] if cyclic else series
            kids.append(f"<animate attributeName=\"{name}\" dur=\"{duration_s:g}s\" repeatCount=\"indefinite\""
                        f" calcMode=\"linear\" values=\"{';'.join(values)}\"/>")
    if m.tag == "path":
        head = f" d={attr(m.d)}" + head
    if m.frame is not None:  # a caption's words come first (a reader takes the element's text)
        a, b = m.frame / m.frames, (m.frame + 1) / m.frames
        shown, times = ("inline;none", f"0;{b:.6g}") if m.frame == 0 else ("none;inline;none", f"0;{a:.6g};{b:.6g}")
        head += f" display=\"{'inline' if m.frame == 0 else 'none'}\""
        kids.insert(0, text(m.words))
        kids.append(f"<animate attributeName=\"display\" values=\"{shown}\" keyTimes=\"{times}\" calcMode=\"discrete\""
                    f" dur=\"{duration_s:g}s\" repeatCount=\"indefinite\"/>")
    kids += [svg(k, duration_s, cyclic) for k in m.kids]
    if m.words and m.frame is None:
        kids.append(text(m.words))
    return f"<{m.tag}{head}>{''.join(kids)}</{m.tag}>" if kids else f"<{m.tag}{head}/>"
