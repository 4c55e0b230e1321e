"""Six-bars: Watt II, Stephenson III, a complex loop (class-III Assur group) and the figure-eight six-bar."""

from __future__ import annotations

import cmath
import math

from linkedit.planar.catalog.four_bars import crank_rocker_pose
from linkedit.planar.catalog.geometry import linkage, meet
from linkedit.spec.linkage import LinkageSpec


def watt_six_bar() -> LinkageSpec:
    """A Watt II six-bar (mm): the crank-rocker's rocker is a bell crank driving a second rocker.

    The two ternary links (frame O–D–F and bell crank D–B–C) share the joint D. The bell
    crank's arm DC = 62 is 100° clockwise from DB; dyad C–E–F (CE = 74, FE = 52, F = (55, −29)).
    Transmission angles: 44°…100° at B, 81°…99° at E.
    """
    o, d, a, b = crank_rocker_pose()
    c = d + (b - d) / abs(b - d) * 62.0 * cmath.exp(-1j * math.radians(100.0))
    f = complex(55.0, -29.0)
    e = meet(c, 74.0, f, 52.0, left=True)
    return linkage(
        name="watt-six-bar", units="mm",
        description="A Watt II six-bar: a crank-rocker whose rocker D-B-C is a bell crank driving "
                    "a second rocker F-E through the link C-E.",
        joints={"O": o, "D": d, "F": f, "A": a, "B": b, "C": c, "E": e}, ground=["O", "D", "F"],
        links={"crank": ["O", "A"], "coupler": ["A", "B"], "bell_crank": ["D", "B", "C"],
               "link": ["C", "E"], "output": ["F", "E"]},
        motor={"joint": "A", "pivot": "O"}, tracks={"output_tip": {"joint": "E"}, "bell_crank_tip": {"joint": "C"}},
    )


def stephenson_six_bar() -> LinkageSpec:
    """A Stephenson III six-bar (mm): a point C of the crank-rocker's coupler drives a dyad C–E–F.

    The ternary links (frame O–D–F and coupler A–B–C) do not touch. C = A + (74, −6) in the
    coupler frame (x along AB); CE = 72, FE = 49, F = (108, −13). The output F–E swings 47°;
    transmission angles: 44°…100° at B, 75°…93° at E.
    """
    o, d, a, b = crank_rocker_pose()
    c = a + (b - a) / abs(b - a) * complex(74.0, -6.0)
    f = complex(108.0, -13.0)
    e = meet(c, 72.0, f, 49.0, left=True)
    return linkage(
        name="stephenson-six-bar", units="mm",
        description="A Stephenson III six-bar: the ternary coupler A-B-C of a crank-rocker drives "
                    "the output rocker F-E through the link C-E.",
        joints={"O": o, "D": d, "F": f, "A": a, "B": b, "C": c, "E": e}, ground=["O", "D", "F"],
        links={"crank": ["O", "A"], "coupler": ["A", "B", "C"], "rocker": ["D", "B"],
               "link": ["C", "E"], "output": ["F", "E"]},
        motor={"joint": "A", "pivot": "O"}, tracks={"output_tip": {"joint": "E"}, "coupler_point": {"joint": "C"}},
    )


def complex_loop() -> LinkageSpec:
    """A six-bar with a complex loop (mm): a class-III Assur group driven by a crank.

    The ternary body T1–T2–T3 hangs from the ground pivots P1, P2 and the crank pin A by three
    binary links. Once O, A, P1, P2 are known, no moving joint has two known neighbours, so
    Algorithm 1 stops; T1, T2, T3 are solved as one numeric group (the crank turns fully).
    """
    return linkage(
        name="complex-loop", units="mm",
        description="A six-bar with a complex loop: a class-III Assur group driven by a crank. No joint "
                    "can be placed from two known joints; T1, T2, T3 are solved as one numeric group.",
        joints={"O": 0j, "A": 8 + 0j, "P1": -30 + 0j, "P2": 45 + 5j,
                "T1": -34 + 20j, "T2": 27 + 26j, "T3": 14 + 24j},
        ground=["O", "P1", "P2"],
        links={"crank": ["O", "A"], "left": ["P1", "T1"], "right": ["P2", "T2"], "middle": ["A", "T3"],
               "body": ["T1", "T2", "T3"]},
        motor={"joint": "A", "pivot": "O"}, tracks={"body_tip": {"joint": "T3"}},
    )


def figure_eight_six_bar() -> LinkageSpec:
    """A Stephenson III six-bar whose tracer P draws Gerono's figure-eight x = 20 cos t, y = 10 sin 2t (mm)
    to 0.26 % RMS with every transmission angle in [20°, 160°]; dimensions found by a global search
    (random six-bars, then SLSQP with the band as constraints), README, synthesis."""
    return linkage(
        name="figure-eight-six-bar", units="mm",
        description="A Stephenson III six-bar: the ternary coupler A-B-C of a crank-rocker drives the dyad C-E-F; "
                    "the tracer P on the link C-E-P draws a figure-eight.",
        joints={"O": -32.959319 - 71.837896j, "D": 61.708637 - 74.215687j, "F": 81.645012 - 87.943684j,
                "A": -15.294082 - 72.281597j, "B": 86.916256 - 133.343073j, "C": 69.929481 - 5.961648j,
                "E": 87.249289 - 4.152154j, "P": 15.723682 + 9.696014j},
        ground=["O", "D", "F"],
        links={"crank": ["O", "A"], "coupler": ["A", "B", "C"], "rocker": ["D", "B"], "link": ["C", "E", "P"],
               "output": ["F", "E"]},
        motor={"joint": "A", "pivot": "O"}, tracks={"tracer": {"joint": "P"}},
    )
