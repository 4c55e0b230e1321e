"""An animated GIF of a planar motion, for places that do not play SMIL (needs the optional
Pillow: ``pip install linkedit[gif]``). Every frame is the animated SVG's figure
(:func:`linkedit.io.svg.animation`) painted by :mod:`linkedit.io.raster` — the same links,
sliders, labels, axes, legend and crank angle caption, antialiased — and one cycle lasts
``duration_s`` like the SVG's."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io import raster
from linkedit.io.atomic import atomic_path
from linkedit.io.formats import require
from linkedit.io.svg import animation


def frame_ms(frames: int, duration_s: float) -> list[int]:
    """Display times (ms, multiples of the GIF's 10 ms unit, at least 20) of ``frames`` frames that
    add up to ``duration_s`` (rounded to 10 ms) where that allows 20 ms a frame."""
    ends = np.round(np.arange(1, frames + 1) * duration_s * 100.0 / frames).astype(int)
    return [max(2, int(c)) * 10 for c in np.diff(np.concatenate([[0], ends]))]


def write_gif(path: str | Path, *, duration_s: float = 4.0, cyclic: bool = True, **drawing: Any) -> None:
    """Write the animation of ``drawing`` (the keyword arguments of ``motion_plot``) as a looping GIF."""
    require("gif", path)
    from PIL import Image

    images = raster.frames(animation(duration_s=duration_s, cyclic=cyclic, **drawing))
    first = images[0].quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    paletted = [first] + [im.quantize(palette=first, dither=Image.Dither.NONE) for im in images[1:]]
    with atomic_path(path) as tmp:
        paletted[0].save(tmp, format="GIF", save_all=True, append_images=paletted[1:], loop=0,
                         duration=frame_ms(len(paletted), duration_s), disposal=1, optimize=False)
