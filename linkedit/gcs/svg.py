"""SVG picture of a solved 3D mechanism: member shapes and output curves in a projection.

Views: ``xy``, ``xz``, ``yz`` (orthographic) and ``iso`` (isometric). Shapes are drawn at a
few poses over the run (the first one solid, the others faint); tracked curves as polylines,
with velocity arrows on request.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.gcs import quaternions as quat
from linkedit.gcs.result import GcsResult
from linkedit.io.atomic import write_text
from linkedit.io.svg_figure import text

VIEWS = ("xy", "xz", "yz", "iso")
COLORS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def project(p: np.ndarray, view: str) -> np.ndarray:
    """World points (..., 3) → drawing coordinates (..., 2), y up."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    if view == "xy":
        return np.stack([x, y], axis=-1)
    if view == "xz":
        return np.stack([x, z], axis=-1)
    if view == "yz":
        return np.stack([y, z], axis=-1)
    if view == "iso":
        c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
        return np.stack([(x - y) * c, (x + y) * s + z], axis=-1)
    raise InputError(f"unknown view {view!r} (choose from {', '.join(VIEWS)})", field="--view")


def _polylines(res: GcsResult, member: str) -> list[list[str]]:
    names = list(res.points.get(member, {}))
    if res.lines.get(member):
        return res.lines[member]
    if len(names) >= 3:
        return [names + names[:1]]
    return [names] if names else []


def draw(path: str | Path, res: GcsResult, view: str = "iso", velocity: bool = False, poses: int = 8) -> None:
    """Write the picture atomically."""
    project(np.zeros(3), view)  # validates the view name
    T = res.t.size
    frames = np.unique(np.linspace(0, T - 1, min(poses, T)).round().astype(int))
    shapes = []  # (frame, member, list of (K, 2) polylines)
    for k in frames:
        R = quat.to_matrix(res.orientation[k])
        for m, name in enumerate(res.member_names):
            pts = res.points.get(name, {})
            lines = []
            for line in _polylines(res, name):
                local = np.array([pts[p] for p in line], dtype=float).reshape(-1, 3)
                lines.append(project(res.position[k, m] + local @ R[m].T, view))
            shapes.append((k, m, lines))
    curves = {n: project(tr.position, view) for n, tr in res.tracks.items()}
    every = list(curves.values()) + [ln for _, _, ls in shapes for ln in ls]
    allpts = np.vstack(every) if every else np.zeros((1, 2))
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    size = float(max((hi - lo).max(), 1e-9))
    pad = 0.08 * size
    lo, hi = lo - pad, hi + pad
    width = 800.0
    scale = width / (hi[0] - lo[0]) if hi[0] > lo[0] else width / size
    height = max((hi[1] - lo[1]) * scale, 100.0)

    def xy(p: np.ndarray) -> str:
        q = np.column_stack([(p[:, 0] - lo[0]) * scale, height - (p[:, 1] - lo[1]) * scale])
        return " ".join(f"{a:.2f},{b:.2f}" for a, b in q)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height + 40:.0f}" '
           f'viewBox="0 0 {width:.0f} {height + 40:.0f}">',
           '<rect width="100%" height="100%" fill="white"/>',
           f'<text x="10" y="{height + 28:.0f}" font-family="sans-serif" font-size="14">{text(res.name)} — view {view}, '
           f'{T} steps, units {text(res.units)}</text>',
           '<defs><marker id="arrow" markerWidth="8" markerHeight="8" refX="7" refY="4" orient="auto">'
           '<path d="M0,0 L8,4 L0,8 z" fill="#333"/></marker></defs>']
    for k, m, lines in shapes:
        first = k == frames[0]
        style = 'stroke="#222" stroke-width="2.5"' if first else 'stroke="#999" stroke-width="1" stroke-opacity="0.5"'
        for ln in lines:
            if len(ln) == 1:
                out.append(f'<circle cx="{(ln[0, 0] - lo[0]) * scale:.2f}" cy="{height - (ln[0, 1] - lo[1]) * scale:.2f}" '
                           f'r="3" fill="#222"/>')
            else:
                out.append(f'<polyline points="{xy(ln)}" fill="none" {style}><title>{text(res.member_names[m])}</title></polyline>')
    for i, (name, c) in enumerate(curves.items()):
        color = COLORS[i % len(COLORS)]
        out.append(f'<polyline points="{xy(c)}" fill="none" stroke="{color}" stroke-width="1.5">'
                   f'<title>{text(name)}</title></polyline>')
        out.append(f'<text x="{width - 150:.0f}" y="{20 + 18 * i}" font-family="sans-serif" font-size="13" '
                   f'fill="{color}">{text(name)}</text>')
        if velocity:
            v2 = project(res.tracks[name].velocity, view)  # the projections are linear
            vmax = float(np.linalg.norm(v2, axis=1).max())
            if vmax > 0:
                k_idx = np.linspace(0, T - 1, 16, endpoint=False).round().astype(int)
                for k in k_idx:
                    a = c[k]
                    b = a + v2[k] * (0.08 * size / vmax)
                    out.append(f'<polyline points="{xy(np.vstack([a, b]))}" stroke="#333" stroke-width="1" '
                               f'marker-end="url(#arrow)"/>')
    out.append("</svg>")
    write_text(path, "\n".join(out) + "\n")
