"""Laying a figure out in pixels: the world → pixel map, round axis ticks and label placement."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

_CHAR_EM = 0.6          # width of a character of the label font, in font sizes (generous)


def finite(name: str, a: object, shape: tuple[int | None, ...]) -> np.ndarray:
    """``a`` as a float array of ``shape`` (``None`` = any length); ValueError if not finite."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name}: expected an array of shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def link_outline(points: np.ndarray) -> np.ndarray:
    """The joint indices outlining a link whose joints are at ``points`` (n, 2): a bar's two ends (two
    joints, or all on one line: the outermost two), else a plate's corners by angle about their centroid
    (a simple polygon, whatever order the joints are listed in). Pictures and DXF draw links so."""
    c = points - points.mean(axis=0)
    if len(points) == 2:
        return np.arange(2)
    _, sv, vt = np.linalg.svd(c)
    if sv[1] <= 1e-9 * sv[0]:
        along = c @ vt[0]
        return np.array([int(np.argmin(along)), int(np.argmax(along))])
    return np.argsort(np.arctan2(c[:, 1], c[:, 0]))


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


def text_box(x: float, y: float, words: str, size: float, anchor: str = "start") -> np.ndarray:
    """Pixel box ``(x0, y0, x1, y1)`` a label of ``size`` px with its baseline at ``(x, y)`` covers (an
    upper bound of its width: :data:`_CHAR_EM` per character)."""
    w = _CHAR_EM * size * len(words)
    x0 = x - {"start": 0.0, "middle": w / 2, "end": w}[anchor]
    return np.array([x0, y - 0.8 * size, x0 + w, y + 0.25 * size])


def place_labels(anchors: np.ndarray, boxes: np.ndarray, area: Sequence[float],
                 avoid: np.ndarray = np.zeros((0, 2))) -> tuple[np.ndarray, np.ndarray]:
    """Greedy label placement, in pixels: label n's ``boxes[n]`` (x0, y0, x1, y1) at its preferred
    place, or the first place on rings around ``anchors[n]`` (2,) where it overlaps no label placed
    before it, covers no point of ``avoid`` (m, 2) and stays inside ``area`` (x0, y0, x1, y1).

    Returns the shift of each box (n, 2) and whether it moved off its preferred place (n,): such a
    label gets a leader line to its anchor. A label with no free place keeps its preferred one.
    """
    placed: list[np.ndarray] = []
    shifts, moved = np.zeros((len(anchors), 2)), np.zeros(len(anchors), dtype=bool)
    angles = np.radians([45, 0, 90, 135, 180, 270, 315, 225, 22.5, 67.5, 112.5, 157.5, 202.5, 247.5, 292.5, 337.5])
    for n, (a, box) in enumerate(zip(np.asarray(anchors, float), np.asarray(boxes, float))):
        half = (box[2:] - box[:2]) / 2
        centre = (box[:2] + box[2:]) / 2
        tries = [np.zeros(2)] + [a + np.array([math.cos(t) * (half[0] + r), -math.sin(t) * (half[1] + r)]) - centre
                                 for r in (4.0, 12.0, 22.0, 34.0, 48.0, 64.0) for t in angles]
        for k, s in enumerate(tries):
            b = box + np.r_[s, s]
            inside = b[0] >= area[0] and b[1] >= area[1] and b[2] <= area[2] and b[3] <= area[3]
            free = not any(b[0] < q[2] + 1 and q[0] < b[2] + 1 and b[1] < q[3] + 1 and q[1] < b[3] + 1 for q in placed)
            clear = not np.any((avoid[:, 0] > b[0] - 2) & (avoid[:, 0] < b[2] + 2)
                               & (avoid[:, 1] > b[1] - 2) & (avoid[:, 1] < b[3] + 2)) if len(avoid) else True
            if inside and free and clear:
                shifts[n], moved[n] = s, k > 0
                break
        placed.append(box + np.r_[shifts[n], shifts[n]])
    return shifts, moved



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

    @property
    def area(self) -> tuple[float, float, float, float]:
        """Pixel ``(x0, y0, x1, y1)`` of the plot area."""
        return (self.left, self.top, self.left + self.width, self.top + self.height)

