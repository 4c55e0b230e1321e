"""Charts: quantities against one shared x axis (e.g. crank angle), stacked panels, one SVG.

Unlike :class:`~linkedit.io.svg_figure.Figure` (equal aspect, world coordinates) each panel
has its own y scale. Ticks, labels, colours and the ``class``/``data-name`` attributes are the
figure modules' (:mod:`linkedit.io.figure_style`, :mod:`linkedit.io.figure_layout`). Non-finite samples break a line (never drawn
across); a value band (``band``) shades a range of y and marks (``marks``) point at samples, their
labels placed apart (:func:`~linkedit.io.figure_layout.place_labels`). Spikes (a toggle's velocity,
acceleration, jerk) do not set the y range: where the values reach :data:`SPIKE` times further
than the 2nd–98th percentiles, the range is those percentiles (plus a margin), lines are cut at
the panel's edge and each clipped run is marked there (class ``clipped``, ``data-y`` its peak).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.io.figure_layout import nice_ticks, place_labels, text_box, tick_label
from linkedit.io.figure_style import FONT, INK, PALETTE, SVG_NS
from linkedit.io.marks import attr, attrs, points_text, text

PANEL_W, PANEL_H, LEFT, GAP = 620.0, 150.0, 78.0, 46.0
SPIKE = 4.0  #: a panel's values spanning this many times their 2nd–98th percentile range are clipped


@dataclass
class Series:
    """One line: y values (T,) against the chart's x; NaN breaks it."""

    name: str
    y: np.ndarray
    color: str
    dashed: bool = False


@dataclass
class Panel:
    """One panel: a y label (with units), lines, an optional shaded band (lo, hi) and marks (x, y, label)."""

    ylabel: str
    series: list[Series] = field(default_factory=list)
    band: tuple[float, float] | None = None
    marks: list[tuple[float, float, str]] = field(default_factory=list)
    name: str = ""

    def line(self, name: str, y: np.ndarray, dashed: bool = False) -> None:
        self.series.append(Series(name, np.asarray(y, dtype=float), PALETTE[len(self.series) % len(PALETTE)], dashed))


def chart(x: np.ndarray, panels: list[Panel], *, xlabel: str, title: str = "") -> str:
    """The SVG text of ``panels`` stacked over the shared ``x`` (T,)."""
    x = np.asarray(x, dtype=float)
    xlo, xhi = float(np.nanmin(x)), float(np.nanmax(x))
    if not xhi > xlo:
        xhi = xlo + 1.0
    top0 = 40.0 if title else 14.0
    legend_w = 24.0 + 7.0 * max((len(s.name) for p in panels for s in p.series), default=0)
    width = LEFT + PANEL_W + 24.0 + legend_w
    height = top0 + len(panels) * (PANEL_H + GAP) + 10.0
    out = [f"<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>"]
    if title:
        out.append(f"<text class=\"title\" x=\"{LEFT + PANEL_W / 2:.1f}\" y=\"24\" text-anchor=\"middle\" font-size=\"15\""
                   f" font-weight=\"bold\" fill={attr(INK)} {FONT}>{text(title)}</text>")
    for n, p in enumerate(panels):
        out.append(_panel(x, (xlo, xhi), p, top0 + n * (PANEL_H + GAP), xlabel))
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            f"<svg xmlns=\"{SVG_NS}\" version=\"1.1\" width=\"{width:.0f}\" height=\"{height:.0f}\""
            f" viewBox=\"0 0 {width:.0f} {height:.0f}\">\n<title>{text(title)}</title>\n" + "\n".join(out) + "\n</svg>\n")


def _y_range(p: Panel) -> tuple[float, float, bool]:
    """The panel's y range (lo, hi) and whether spikes are clipped (see module docstring)."""
    values = np.concatenate([s.y[np.isfinite(s.y)] for s in p.series] + [np.zeros(0)])
    others = np.concatenate([np.array(p.band or (), dtype=float), np.array([m[1] for m in p.marks], dtype=float)])
    allv = np.concatenate([values, others])
    lo, hi = (float(allv.min()), float(allv.max())) if allv.size else (0.0, 1.0)
    clipped = False
    if values.size >= 20:
        q0, q1 = np.percentile(values, [2.0, 98.0])
        if q1 > q0 and hi - lo > SPIKE * (q1 - q0):
            margin = 0.5 * (q1 - q0)
            lo, hi = min([q0 - margin, *others]), max([q1 + margin, *others])
            clipped = bool(values.min() < lo or values.max() > hi)
    if hi - lo <= 1e-12 * max(1.0, abs(hi)):
        lo, hi = lo - 1.0, hi + 1.0
    pad = 0.05 * (hi - lo)
    return lo - pad, hi + pad, clipped


def _panel(x: np.ndarray, xr: tuple[float, float], p: Panel, top: float, xlabel: str) -> str:
    lo, hi, clipped = _y_range(p)
    left, bottom = LEFT, top + PANEL_H

    def px(xv: np.ndarray, yv: np.ndarray) -> np.ndarray:
        return np.stack([left + (xv - xr[0]) / (xr[1] - xr[0]) * PANEL_W, bottom - (yv - lo) / (hi - lo) * PANEL_H], -1)

    parts = [f"<g{attrs(cls='panel', data_name=p.name or p.ylabel)}>"]
    grid, marks = [], []
    xstep, xt = nice_ticks(xr[0], xr[1], 8)
    for t in xt:
        X = float(px(np.array(t), np.array(lo))[0])
        grid.append(f"M{X:.2f},{top:.2f}V{bottom:.2f}")
        marks.append(f"<text class=\"tick\" x=\"{X:.2f}\" y=\"{bottom + 15:.2f}\" text-anchor=\"middle\">"
                     f"{text(tick_label(float(t), xstep))}</text>")
    ystep, yt = nice_ticks(lo, hi, 4)
    for t in yt:
        Y = float(px(np.array(xr[0]), np.array(t))[1])
        grid.append(f"M{left:.2f},{Y:.2f}H{left + PANEL_W:.2f}")
        marks.append(f"<text class=\"tick\" x=\"{left - 6:.2f}\" y=\"{Y + 4:.2f}\" text-anchor=\"end\">"
                     f"{text(tick_label(float(t), ystep))}</text>")
    parts.append(f"<g class=\"axes\" font-size=\"11\" fill=\"#4a5568\" {FONT}>"
                 f"<path class=\"grid\" d=\"{' '.join(grid)}\" stroke=\"#edf2f7\" fill=\"none\"/>"
                 f"<rect x=\"{left:.2f}\" y=\"{top:.2f}\" width=\"{PANEL_W:.2f}\" height=\"{PANEL_H:.2f}\""
                 f" fill=\"none\" stroke=\"#4a5568\"/>{''.join(marks)}"
                 f"<text class=\"unit\" x=\"{left + PANEL_W / 2:.2f}\" y=\"{bottom + 32:.2f}\" text-anchor=\"middle\">"
                 f"{text(xlabel)}</text>"
                 f"<text class=\"unit\" x=\"14\" y=\"{top + PANEL_H / 2:.2f}\" text-anchor=\"middle\""
                 f" transform=\"rotate(-90 14 {top + PANEL_H / 2:.2f})\">{text(p.ylabel)}</text></g>")
    if p.band is not None:
        (_, y1), (_, y0) = px(np.array(xr), np.array(p.band))
        parts.append(f"<rect class=\"band\" data-lo=\"{p.band[0]:g}\" data-hi=\"{p.band[1]:g}\" x=\"{left:.2f}\""
                     f" y=\"{y0:.2f}\" width=\"{PANEL_W:.2f}\" height=\"{y1 - y0:.2f}\" fill=\"{PALETTE[2]}\""
                     f" fill-opacity=\"0.10\" stroke=\"{PALETTE[2]}\" stroke-opacity=\"0.5\" stroke-dasharray=\"4 3\"/>")
    for s in p.series:
        ok = np.isfinite(s.y) & np.isfinite(x)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            q = px(x[a:b], np.clip(s.y[a:b], lo, hi))
            dash = " stroke-dasharray=\"6 4\"" if s.dashed else ""
            parts.append(f"<polyline{attrs(cls='series', data_name=s.name)} points={attr(points_text(q))}"
                         f" fill=\"none\" stroke=\"{s.color}\" stroke-width=\"1.6\"{dash} stroke-linejoin=\"round\"/>")
            if clipped:
                parts += _clip_marks(x[a:b], s, a, b, lo, hi, px)
    if clipped:
        peak = max(float(np.nanmax(np.abs(s.y))) for s in p.series if np.isfinite(s.y).any())
        parts.append(f"<text class=\"clip-note\" x=\"{left + 6:.2f}\" y=\"{top + 13:.2f}\" font-size=\"10\""
                     f" fill=\"{INK}\" stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\" {FONT}>"
                     f"spikes clipped at the edge (▲▼), up to {peak:.3g}</text>")
    pins = sorted(p.marks, key=lambda m: -m[1])
    at = np.array([px(np.array(mx), np.array(my)) for mx, my, _ in pins]).reshape(-1, 2)
    boxes = np.array([text_box(X + 8, Y + 4, label, 10.0) for (X, Y), (_, _, label) in zip(at, pins)]).reshape(-1, 4)
    shifts, moved = place_labels(at, boxes, (left, top, left + PANEL_W, bottom), at)
    for (mx, my, label), (X, Y), s, m in zip(pins, at, shifts, moved):
        tx, ty = X + 8 + s[0], Y + 4 + s[1]
        leader = ""
        if m:
            near = np.clip([X, Y], *np.split(text_box(tx, ty, label, 10.0), 2))
            leader = (f"<line class=\"leader\" x1=\"{X:.2f}\" y1=\"{Y:.2f}\" x2=\"{near[0]:.2f}\" y2=\"{near[1]:.2f}\""
                      f" stroke=\"{PALETTE[1]}\" stroke-width=\"0.8\"/>")
        parts.append(f"<g class=\"toggle\" data-x=\"{mx:.6g}\" data-y=\"{my:.6g}\">{leader}<circle cx=\"{X:.2f}\" cy=\"{Y:.2f}\""
                     f" r=\"4\" fill=\"#ffffff\" stroke=\"{PALETTE[1]}\" stroke-width=\"1.6\"/>"
                     f"<text x=\"{tx:.2f}\" y=\"{ty:.2f}\" font-size=\"10\" fill=\"{PALETTE[1]}\""
                     f" stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\" {FONT}>{text(label)}</text></g>")
    rows = []
    for n, s in enumerate(p.series):
        y = top + 12 + 16 * n
        dash = " stroke-dasharray=\"6 4\"" if s.dashed else ""
        rows.append(f"<line x1=\"{left + PANEL_W + 12:.2f}\" y1=\"{y:.2f}\" x2=\"{left + PANEL_W + 32:.2f}\" y2=\"{y:.2f}\""
                    f" stroke=\"{s.color}\" stroke-width=\"2\"{dash}/><text x=\"{left + PANEL_W + 36:.2f}\""
                    f" y=\"{y + 4:.2f}\" fill={attr(INK)}>{text(s.name)}</text>")
    parts.append(f"<g class=\"legend\" font-size=\"11\" {FONT}>{''.join(rows)}</g></g>")
    return "".join(parts)


def _clip_marks(x: np.ndarray, s: Series, a: int, b: int, lo: float, hi: float, px) -> list[str]:
    """A triangle at the panel's edge for each run of ``s.y[a:b]`` beyond [lo, hi], at its peak."""
    y = s.y[a:b]
    out = []
    for beyond, edge, tip in ((y > hi, hi, -1.0), (y < lo, lo, 1.0)):
        runs = np.flatnonzero(np.diff(np.concatenate([[0], beyond.astype(int), [0]])))
        for r0, r1 in zip(runs[::2], runs[1::2]):
            k = r0 + int(np.argmax(np.abs(y[r0:r1])))
            X, Y = px(np.array(x[k]), np.array(edge))
            tri = points_text([(X, Y + 7 * tip), (X - 4, Y - tip), (X + 4, Y - tip)])
            out.append(f"<polygon{attrs(cls='clipped', data_name=s.name)} data-x=\"{x[k]:.6g}\" data-y=\"{y[k]:.6g}\""
                       f" points={attr(tri)} fill=\"{s.color}\" stroke=\"#ffffff\" stroke-width=\"0.8\"/>")
    return out
