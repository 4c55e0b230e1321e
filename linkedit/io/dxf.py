"""A planar linkage as DXF for CAD and laser cutting (needs the optional ``ezdxf``: ``pip install linkedit[dxf]``).

Layers: ``FRAME`` (the ground joints and the links between them), ``LINK-<name>`` (one per
moving link: its centre line — a bar between its outermost joints, or a plate's closed outline around its
corners (:func:`~linkedit.io.figure_layout.link_outline`, as the pictures draw it) —, and a pin
hole circle per joint and per point tracked on it (a coupler point: a corner of its part); a slider's slot outline, as wide as a pin hole, over the stretch its joint
travels and its rest position, in its guide at rest (with the centre line of the arm joining it to its
link's bar or plate where they do not touch), is on its guide link's layer, or on ``FRAME`` for a guide on the frame), ``TRACK-<name>`` (each track's curve as a polyline, closed for a full
cycle, broken where the linkage does not assemble). Coordinates are the rest pose in the
spec's units, moved so the first ground joint is the origin; ``$INSUNITS`` says the unit.

Layer names: characters DXF forbids (``<>/\\":;?*|=`,``) become ``_``; DXF compares layer names
without case, so a name that would repeat an earlier one (``c;x`` after ``c_x``, ``COUPLER`` after
``coupler``) is numbered in spec order: ``LINK-COUPLER#2``, ``#3``…
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from linkedit.io import slides
from linkedit.io.atomic import atomic_path
from linkedit.io.figure_layout import link_outline
from linkedit.io.formats import require
from linkedit.planar.simulate import Motion
from linkedit.spec.linkage import LinkTrack

#: spec units → DXF $INSUNITS code (0 = unitless)
INSUNITS = {"in": 1, "inch": 1, "ft": 2, "mi": 3, "mm": 4, "cm": 5, "m": 6, "km": 7, "um": 13, "µm": 13,
            "dm": 14, "yd": 10, "nm": 12}
#: pin hole radius as a fraction of the rest pose's largest extent
PIN_RADIUS = 0.015


def layer_name(kind: str, name: str) -> str:
    """A DXF-safe layer name: characters DXF forbids become ``_``."""
    return f"{kind}-" + re.sub(r'[<>/\\":;?*|=`,]', "_", name) if kind else name


def unique_layers(names: list[str], taken: set[str]) -> list[str]:
    """``names`` (DXF-safe layer names) made distinct from each other and from ``taken`` (folded to
    lower case, updated) as DXF compares them: a repeat is numbered ``name#2``, ``name#3``…"""
    out = []
    for name in names:
        unique, n = name, 1
        while unique.lower() in taken:
            n += 1
            unique = f"{name}#{n}"
        taken.add(unique.lower())
        out.append(unique)
    return out


def write_motion_dxf(path: str | Path, motion: Motion) -> None:
    """Write the rest pose and the track curves of ``motion`` as DXF (R2010), atomically."""
    require("dxf", path)
    import ezdxf

    plan = motion.plan
    graph = plan.graph
    origin = graph.rest[graph.ground[0]]
    rest = graph.rest - origin
    size = float(np.ptp(rest, axis=0).max()) or 1.0
    hole = PIN_RADIUS * size

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = INSUNITS.get(plan.spec.units.lower(), 0)
    doc.header["$MEASUREMENT"] = 0 if plan.spec.units.lower() in ("in", "inch", "ft", "mi", "yd") else 1
    msp = doc.modelspace()
    ground = set(graph.ground)
    doc.layers.add("FRAME", color=8)
    taken = {"frame"}
    links = unique_layers([layer_name("LINK", name) for name in graph.link_names], taken)
    links = ["FRAME" if set(members) <= ground else layer for layer, members in zip(links, graph.links)]
    on_link: dict[str, list[np.ndarray]] = {}  # points tracked on a link: corners of its part, as in the pictures
    for tracked in plan.spec.tracks.values():
        if isinstance(tracked, LinkTrack):
            on_link.setdefault(tracked.link, []).append(np.asarray(tracked.at, dtype=float) - origin)
    for color, (layer, name, members) in enumerate(zip(links, graph.link_names, graph.links), start=1):
        if layer != "FRAME":
            doc.layers.add(layer, color=color % 255 or 1)
        corners = np.concatenate([rest[list(members)], np.reshape(on_link.get(name, []), (-1, 2))])
        pts = [tuple(p) for p in corners]
        order = link_outline(corners)
        msp.add_lwpolyline([pts[k] for k in order], close=len(order) > 2, dxfattribs={"layer": layer})
        for p in pts if layer != "FRAME" else ():  # the frame's holes: one per ground joint, below
            msp.add_circle(p, hole, dxfattribs={"layer": layer})
    for g in graph.ground:
        msp.add_circle(tuple(rest[g]), hole, dxfattribs={"layer": "FRAME"})
    # the rest pose first: slots are cut where their guide is at rest, as the links are drawn
    moved = np.concatenate([rest[None], motion.positions[motion.assembled] - origin])
    for s, pair in zip(slides.from_graph(graph, rest), graph.sliders):
        layer = "FRAME" if s.guide is None else links[pair.guide]
        msp.add_lwpolyline(_slot_outline(slides.slot(s, moved), hole), format="xyb", close=True,
                           dxfattribs={"layer": layer})
        arm = slides.arm(s, moved)  # a slot off its link's body is joined to it, as the pictures draw it
        if arm is not None:
            msp.add_lwpolyline([tuple(p) for p in arm], dxfattribs={"layer": layer})
    closed = motion.cyclic and bool(motion.assembled.all())
    tracks = unique_layers([layer_name("TRACK", name) for name in motion.tracks], taken)
    for color, (layer, track) in enumerate(zip(tracks, motion.tracks.values()), start=1):
        doc.layers.add(layer, color=color % 255 or 1)
        for piece in _assembled_runs(track.position - origin, motion.assembled, motion.cyclic):
            if len(piece) > 1:
                msp.add_lwpolyline([tuple(p) for p in piece], close=closed, dxfattribs={"layer": layer})
    with atomic_path(path) as tmp:
        doc.saveas(tmp)


def _slot_outline(ends: np.ndarray, half: float) -> list[tuple[float, float, float]]:
    """A slot around the segment ``ends`` (2, 2), ``half`` its half width: (x, y, bulge) corners of a
    closed polyline (two straight sides, two half circles)."""
    a, b = ends
    d = b - a
    u = d / (float(np.hypot(*d)) or 1.0)
    n = np.array([-u[1], u[0]]) * half
    return [(*(a + n), 0.0), (*(b + n), -1.0), (*(b - n), 0.0), (*(a - n), -1.0)]


def _assembled_runs(points: np.ndarray, ok: np.ndarray, cyclic: bool) -> list[np.ndarray]:
    """The runs of consecutive assembled samples of ``points`` (T, 2); of a ``cyclic`` motion (the
    last sample followed by the first) a run through the last sample goes on into the first's."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
    runs = [points[a:b] for a, b in zip(edges[::2], edges[1::2])]
    if cyclic and len(runs) > 1 and ok[0] and ok[-1]:
        runs = [np.concatenate([runs[-1], runs[0]])] + runs[1:-1]
    return runs
