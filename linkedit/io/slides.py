"""Where a linkage's sliders are, for pictures and CAD: each prismatic pair's line, carried by its guide.

A slider keeps a joint (the pin in a slot, or a translating link's first frame joint) on a
line fixed to its guide — the frame, or a link that moves and turns. Sample 0 is the reference:
the line passes through the joint's sample-0 position with direction ``angle`` there; at sample
t it is carried rigidly by the guide (the guide link's frame joints ``a``, ``b``: translated
with ``a``, turned as ``b − a`` turns). Positions are ``(T, J, 2)`` in the linkage's units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.graph import LinkageGraph


@dataclass(frozen=True)
class Slide:
    """One prismatic pair as drawn: ``joint`` slides on a line through its sample-0 position at
    ``angle`` (radians, at sample 0), fixed to the frame (``guide`` None) or to the link whose frame
    joints are ``guide`` (a, b); ``link``: the guide link's joints (its body, for the slot's arm)."""

    name: str
    joint: int
    guide: tuple[int, int] | None = None
    angle: float = 0.0
    link: tuple[int, ...] = ()


def from_graph(graph: LinkageGraph, first: np.ndarray) -> list[Slide]:
    """The slides of ``graph``'s sliders, referred to the pose ``first`` (J, 2) (a pose of the motion)."""
    out = []
    for s in graph.sliders:
        joint = s.joint if s.joint >= 0 else graph.frame_pair(s.link)[0]
        if graph.fixed(s.guide):
            out.append(Slide(s.name, joint, None, s.angle))
            continue
        a, b = graph.frame_pair(s.guide)
        rest, now = graph.rest[b] - graph.rest[a], first[b] - first[a]
        turned = np.arctan2(now[1], now[0]) - np.arctan2(rest[1], rest[0])
        out.append(Slide(s.name, joint, (a, b), float(s.angle + turned), tuple(graph.links[s.guide])))
    return out


def carry(s: Slide, positions: np.ndarray, points: np.ndarray) -> np.ndarray:
    """World points ``(k, 2)`` fixed to ``s``'s guide at sample 0, over the samples: ``(T, k, 2)``."""
    p = np.asarray(points, dtype=float)
    if s.guide is None:
        return np.broadcast_to(p, (positions.shape[0],) + p.shape).copy()
    a, b = s.guide
    m = positions[:, b] - positions[:, a]
    turn = np.arctan2(m[:, 1], m[:, 0]) - np.arctan2(m[0, 1], m[0, 0])
    c, si = np.cos(turn)[:, None], np.sin(turn)[:, None]
    local = p - positions[0, a]
    return positions[:, None, a] + np.stack([c * local[:, 0] - si * local[:, 1], si * local[:, 0] + c * local[:, 1]], -1)


def travel(s: Slide, positions: np.ndarray) -> np.ndarray:
    """The joint's coordinate along its line, from its sample-0 position (T,), in the guide's frame."""
    u = np.array([np.cos(s.angle), np.sin(s.angle)])
    along = carry(s, positions, np.array([positions[0, s.joint], positions[0, s.joint] + u]))
    d = along[:, 1] - along[:, 0]
    return np.sum((positions[:, s.joint] - along[:, 0]) * d, axis=1)


def slot(s: Slide, positions: np.ndarray) -> np.ndarray:
    """World ends ``(2, 2)`` at sample 0 of the stretch of the line the joint travels over."""
    u = np.array([np.cos(s.angle), np.sin(s.angle)])
    t = travel(s, positions)
    return positions[0, s.joint] + np.outer([t.min(), t.max()], u)


def arm(s: Slide, positions: np.ndarray) -> np.ndarray | None:
    """World ends ``(2, 2)`` at sample 0 of the shortest bar joining the slot (:func:`slot`) to its guide
    link's body (the bar or plate through its joints), or None where they touch (or on the frame)."""
    if s.guide is None or not s.link:
        return None
    ends = slot(s, positions)
    body = positions[0, list(s.link)]
    if len(body) > 2:
        c = body - body.mean(axis=0)
        body = body[np.argsort(np.arctan2(c[:, 1], c[:, 0]))]
        edges = [(body[i], body[(i + 1) % len(body)]) for i in range(len(body))]
    else:
        edges = [(body[0], body[1])]
    size = float(np.ptp(positions[0], axis=0).max()) or 1.0
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for e0, e1 in edges:
        if _cross(ends[0], ends[1], e0, e1):
            return None
        for p, (q0, q1), flip in ((ends[0], (e0, e1), False), (ends[1], (e0, e1), False),
                                  (e0, tuple(ends), True), (e1, tuple(ends), True)):
            q = _nearest(p, q0, q1)
            dist = float(np.hypot(*(p - q)))
            if best is None or dist < best[0]:
                best = (dist, q, p) if flip else (dist, p, q)
    assert best is not None
    return None if best[0] <= 1e-9 * size else np.array([best[1], best[2]])


def _nearest(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    t = float(np.clip((p - a) @ d / max(float(d @ d), 1e-300), 0.0, 1.0))
    return a + t * d


def _cross(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> bool:
    """Whether segments a-b and c-d cross (properly)."""
    def side(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return side(a, b, c) * side(a, b, d) < 0 and side(c, d, a) * side(c, d, b) < 0
