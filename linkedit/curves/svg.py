"""An SVG overlay of normalized curves, drawn by the shared figure module (:mod:`linkedit.io.svg_figure`).

Curves are drawn in their normalized frame (major extent 1, centroid at the origin; 3D curves
projected onto the principal plane), x right, y up, with axes, a legend and a dot at each
curve's first sample. Elements carry ``class="curve"`` (the highlighted one also ``query``),
``class="start"`` and ``data-name``.
"""

from __future__ import annotations

import numpy as np

from linkedit.io.figure_style import INK, PALETTE, Stroke
from linkedit.io.svg_figure import Figure

MAX_LEGEND = 30  # legend rows at most; the rest are summarized in one row


def overlay(names: list[str], points: np.ndarray, closed: np.ndarray, *, title: str = "",
            highlight: int | None = None, labels: list[str] | None = None, size: int = 640) -> str:
    """SVG text drawing curves (C, N, D) over one another; ``highlight`` (e.g. the query) is drawn dark and thick.

    ``labels`` (optional) replace the names in the legend, e.g. with distances.
    """
    xy = np.asarray(points, dtype=float)[:, :, :2]
    fig = Figure(title=title, units="major extent", size_px=float(size))
    order = [i for i in range(len(names)) if i != highlight] + ([highlight] if highlight is not None else [])
    for i in order:
        if i == highlight:
            stroke, cls = Stroke(INK, 2.5), "curve query"
        else:
            stroke = Stroke(PALETTE[i % len(PALETTE)], 1.2, "dashed" if i >= len(PALETTE) else "solid")
            cls = "curve"
        label = (labels[i] if labels is not None else names[i]) if i < MAX_LEGEND else None
        fig.polyline(xy[i], stroke, closed=bool(closed[i]), cls=cls, name=names[i], label=label)
        fig.joints(xy[i, :1], radius=2.5, fill=stroke.color, stroke=Stroke(stroke.color, 1.0), cls="start")
    if len(names) > MAX_LEGEND:
        fig.legend(f"… and {len(names) - MAX_LEGEND} more", Stroke("#ffffff", 0.1))
    return fig.render()
