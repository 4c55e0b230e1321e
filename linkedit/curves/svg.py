"""An SVG overlay of normalized curves (plain text, no dependency).

Curves are drawn in their normalized frame (major extent 1, centroid at the origin; 3D curves
projected onto the principal plane), x right, y up, with a legend.
"""

from __future__ import annotations

import numpy as np

from linkedit.io.svg_figure import text as xml_text

PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
           "#7f7f7f")


def overlay(names: list[str], points: np.ndarray, closed: np.ndarray, *, title: str = "",
            highlight: int | None = None, labels: list[str] | None = None, size: int = 640) -> str:
    """SVG text drawing curves (C, N, D) over one another; ``highlight`` (e.g. the query) is drawn black and thick.

    ``labels`` (optional) replace the names in the legend, e.g. with distances.
    """
    xy = np.asarray(points, dtype=float)[:, :, :2]
    lo, hi = xy.reshape(-1, 2).min(axis=0), xy.reshape(-1, 2).max(axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-12))
    margin, legend_rows = 20, min(len(names), 30)
    plot = size - 2 * margin
    height = size + 16 * (legend_rows + (len(names) > legend_rows)) + (24 if title else 0)
    top = margin + (24 if title else 0)

    def coords(curve: np.ndarray) -> np.ndarray:
        return np.stack([margin + (curve[:, 0] - lo[0]) / span * plot, top + (hi[1] - curve[:, 1]) / span * plot], 1)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{height:.0f}" '
           f'viewBox="0 0 {size} {height:.0f}" font-family="sans-serif" font-size="12">',
           f'<rect width="100%" height="100%" fill="white"/>']
    if title:
        out.append(f'<text x="{margin}" y="{margin + 6}" font-size="14">{xml_text(title)}</text>')
    order = [i for i in range(len(names)) if i != highlight] + ([highlight] if highlight is not None else [])
    for i in order:
        color, width = ("black", 2.5) if i == highlight else (PALETTE[i % len(PALETTE)], 1.2)
        tag = "polygon" if closed[i] else "polyline"
        uv = coords(xy[i])
        path = " ".join(f"{a:.2f},{b:.2f}" for a, b in uv)
        out.append(f'<{tag} points="{path}" fill="none" stroke="{color}" stroke-width="{width}" '
                   f'stroke-linejoin="round"><title>{xml_text(names[i])}</title></{tag}>')
        out.append(f'<circle cx="{uv[0, 0]:.2f}" cy="{uv[0, 1]:.2f}" r="2.5" fill="{color}"/>')  # first sample
    y0 = top + plot + 16
    for row, i in enumerate(range(legend_rows)):
        color = "black" if i == highlight else PALETTE[i % len(PALETTE)]
        text = labels[i] if labels is not None else names[i]
        out.append(f'<line x1="{margin}" y1="{y0 + 16 * row - 4}" x2="{margin + 24}" y2="{y0 + 16 * row - 4}" '
                   f'stroke="{color}" stroke-width="2"/>')
        out.append(f'<text x="{margin + 30}" y="{y0 + 16 * row}">{xml_text(text)}</text>')
    if len(names) > legend_rows:
        out.append(f'<text x="{margin}" y="{y0 + 16 * legend_rows}">… and {len(names) - legend_rows} more</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"
