"""Charts: quantities against one shared x axis (e.g. crank angle), stacked panels, one SVG.

Unlike :class:`~linkedit.io.svg_figure.Figure` (equal aspect, world coordinates) each panel
has its own y scale. Ticks, labels, colours and the ``class``/``data-name`` attributes are the
figure module's (:mod:`linkedit.io.svg_figure`). Non-finite samples break a line (never drawn
across); a value band (``band``) shades a range of y and marks (``marks``) point at samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.io.svg_figure import FONT, INK, PALETTE, SVG_NS, attr, attrs, nice_ticks, points_text, text, tick_label

PANEL_W, PANEL_H, LEFT, GAP = 620.0, 150.0, 78.0, 46.0


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


def _panel(x: np.ndarray, xr: tuple[float, float], p: Panel, top: float, xlabel: str) -> str:
    ys = [s.y[np.isfinite(s.y)] for s in p.series] + [np.array(p.band or (), dtype=float)]
    ys += [np.array([m[1] for m in p.marks])]
    allv = np.concatenate(ys) if ys else np.zeros(0)
    lo, hi = (float(allv.min()), float(allv.max())) if allv.size else (0.0, 1.0)
    if hi - lo <= 1e-12 * max(1.0, abs(hi)):
        lo, hi = lo - 1.0, hi + 1.0
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
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
            q = px(x[a:b], s.y[a:b])
            dash = " stroke-dasharray=\"6 4\"" if s.dashed else ""
            parts.append(f"<polyline{attrs(cls='series', data_name=s.name)} points={attr(points_text(q))}"
                         f" fill=\"none\" stroke=\"{s.color}\" stroke-width=\"1.6\"{dash} stroke-linejoin=\"round\"/>")
    placed: list[float] = []  # label baselines, kept 12 px apart so near marks stay readable
    for mx, my, label in sorted(p.marks, key=lambda m: -m[1]):
        X, Y = px(np.array(mx), np.array(my))
        ly = float(Y) + 4
        while any(abs(ly - q) < 12 for q in placed):
            ly -= 12
        placed.append(ly)
        parts.append(f"<g class=\"toggle\" data-x=\"{mx:.6g}\" data-y=\"{my:.6g}\"><circle cx=\"{X:.2f}\" cy=\"{Y:.2f}\""
                     f" r=\"4\" fill=\"#ffffff\" stroke=\"{PALETTE[1]}\" stroke-width=\"1.6\"/>"
                     f"<text x=\"{X + 8:.2f}\" y=\"{ly:.2f}\" font-size=\"10\" fill=\"{PALETTE[1]}\""
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
