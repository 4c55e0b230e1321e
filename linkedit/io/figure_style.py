"""The look shared by every picture: colours, fonts, line styles and symbol sizes (px)."""

from __future__ import annotations

from dataclasses import dataclass

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
FONT_ATTRS = {"font-family": "Helvetica, Arial, sans-serif"}
#: a white outline under label text (mark keywords), so labels stay readable over links and symbols
HALO_ATTRS = {"stroke": "#ffffff", "stroke-width": "3", "stroke-opacity": "0.85", "paint-order": "stroke",
              "stroke-linejoin": "round"}
#: a slider's block (length along its guide, height across) and its guide's opening, px
BLOCK_PX = (20.0, 10.0)


@dataclass(frozen=True)
class Stroke:
    """Line style: ``color``, ``width`` in px, ``style`` solid | faint (translucent) | dashed."""

    color: str = INK
    width: float = 1.5
    style: str = "solid"

    def __post_init__(self) -> None:
        if self.style not in ("solid", "faint", "dashed"):
            raise ValueError(f"stroke style must be solid, faint or dashed, got {self.style!r}")

    def kw(self) -> dict[str, object]:
        """The stroke's presentation attributes, as :func:`~linkedit.io.marks.mark` keywords."""
        return dict(stroke=self.color, stroke_width=float(self.width),
                    stroke_dasharray=DASH if self.style == "dashed" else None,
                    stroke_opacity=FAINT_OPACITY if self.style == "faint" else None)

