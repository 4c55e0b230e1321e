"""An animated GIF of a planar motion, for places that do not play SMIL (needs the optional
Pillow: ``pip install linkedit[gif]``). The same content as the animated SVG, drawn with
Pillow's raster primitives: track curves, joint paths, links (bars, translucent plates),
joints, ground joints, the crank angle of each frame."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io.atomic import atomic_path
from linkedit.io.formats import require
from linkedit.io.svg import MAX_FRAMES, Drawing
from linkedit.io.svg_figure import INK, PALETTE, PATH_GREY

SIZE_PX = 560
MARGIN_PX = 24


def _rgb(color: str) -> tuple[int, int, int]:
    return tuple(int(color[i:i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


def write_gif(path: str | Path, *, duration_s: float = 4.0, cyclic: bool = True, **drawing: Any) -> None:
    """Write the animation of ``drawing`` (the keyword arguments of ``motion_plot``) as a looping GIF."""
    require("gif", path)
    from PIL import Image, ImageDraw

    d = Drawing.check(drawing["joint_names"], drawing["positions"], drawing["links"], drawing["ground"],
                      drawing["motor"], drawing["tracks"], drawing.get("breaks", ()))
    T = d.positions.shape[0]
    frames = np.arange(T) if T <= MAX_FRAMES else np.round(np.linspace(0, T, MAX_FRAMES, endpoint=False)).astype(int)
    pts = np.concatenate([d.positions.reshape(-1, 2)] + [c for c in d.tracks.values()])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    scale = (SIZE_PX - 2 * MARGIN_PX) / max(float((hi - lo).max()), 1e-12)
    w, h = (np.ceil((hi - lo) * scale) + 2 * MARGIN_PX).astype(int)

    def px(p: np.ndarray) -> list[tuple[float, float]]:
        q = np.asarray(p, dtype=float).reshape(-1, 2)
        return [(float(MARGIN_PX + (x - lo[0]) * scale), float(h - MARGIN_PX - (y - lo[1]) * scale)) for x, y in q]

    base = Image.new("RGB", (int(w), int(h)), "white")
    draw = ImageDraw.Draw(base)
    for j in range(d.positions.shape[1]):
        for piece in d.pieces(d.positions[:, j]):
            if len(piece) > 1:
                draw.line(px(piece), fill=_rgb("#d5d9de"), width=1)
    for n, curve in enumerate(d.tracks.values()):
        for piece in d.pieces(curve):
            if len(piece) > 1:
                draw.line(px(piece), fill=_rgb(PALETTE[n % len(PALETTE)]), width=2)
    images = []
    rest = d.positions[0]
    motor = d.motor
    turn = None
    if motor is not None:
        r = d.positions[frames, motor[0]] - d.positions[frames, motor[1]]
        turn = np.degrees(np.unwrap(np.arctan2(r[:, 1], r[:, 0])))
    for k, f in enumerate(frames):
        img = base.copy()
        layer = Image.new("RGBA", img.size, (0, 0, 0, 0))
        dl = ImageDraw.Draw(layer)
        pose = d.positions[f]
        for members in d.links.values():
            if len(members) > 2:
                dl.polygon(px(pose[members][_ring(pose[members])]), fill=(143, 168, 208, 140), outline=_rgb(INK))
        img.paste(layer, (0, 0), layer)
        di = ImageDraw.Draw(img)
        for members in d.links.values():
            if len(members) == 2:
                di.line(px(pose[members]), fill=_rgb(INK), width=5)
        for g in d.ground:
            x, y = px(rest[g])[0]
            di.polygon([(x, y), (x - 7, y + 11), (x + 7, y + 11)], outline=_rgb(INK), fill=(226, 232, 240))
        for x, y in px(pose):
            di.ellipse([x - 3, y - 3, x + 3, y + 3], fill="white", outline=_rgb(INK))
        for n, curve in enumerate(d.tracks.values()):
            x, y = px(curve[f])[0]
            c = _rgb(PALETTE[n % len(PALETTE)])
            di.ellipse([x - 3.5, y - 3.5, x + 3.5, y + 3.5], fill=c, outline=c)
        if turn is not None:
            di.text((8, 6), f"crank {abs(turn[k] - turn[0]):.0f}°", fill=_rgb(INK))
        images.append(img.convert("P", palette=Image.Palette.ADAPTIVE, colors=64))
    with atomic_path(path) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], loop=0,
                       duration=max(20, int(round(1000 * duration_s / len(images)))), disposal=2)


def _ring(points: np.ndarray) -> np.ndarray:
    """Order of a plate's corners around their centroid."""
    c = points - points.mean(axis=0)
    return np.argsort(np.arctan2(c[:, 1], c[:, 0]))
