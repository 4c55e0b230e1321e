"""Sliders and linear inputs: slider-cranks, quick return, Scotch yokes, slots, a Stephenson
slider and a cylinder-driven boom."""

from __future__ import annotations

import cmath
import math

from linkedit.planar.catalog.four_bars import crank_rocker_pose
from linkedit.planar.catalog.geometry import linkage
from linkedit.spec.linkage import LinkageSpec


SLIDER_CRANK = dict(r=20.0, l=70.0, e=12.0)


def slider_crank() -> LinkageSpec:
    """An offset slider-crank (mm) with a coupler point C on the rod; x_B = r·cos θ + sqrt(l² − (r·sin θ − e)²)."""
    n = SLIDER_CRANK
    a = complex(n["r"], 0)
    b = complex(n["r"] + math.sqrt(n["l"] ** 2 - n["e"] ** 2), n["e"])
    return linkage(
        name="slider-crank", units="mm",
        description="An offset slider-crank (crank 20, rod 70, offset 12) with a coupler point on the rod.",
        joints={"O": 0j, "A": a, "B": b, "C": a + (b - a) * complex(0.5, 0.3)}, ground=["O"],
        links={"crank": ["O", "A"], "rod": ["A", "B", "C"]},
        sliders={"piston": {"joint": "B", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"},
        tracks={"piston": {"joint": "B"}, "coupler_point": {"joint": "C"}},
    )


def locking_slider_crank() -> LinkageSpec:
    """The offset slider-crank with a rod of 25 (mm): it cannot reach its line for crank angles
    of about 220°…320° (|r·sin θ − e| > l): a deliberate failure, exit 1 naming the slider."""
    n = dict(SLIDER_CRANK, l=25.0)
    a = complex(n["r"], 0)
    b = complex(n["r"] + math.sqrt(n["l"] ** 2 - n["e"] ** 2), n["e"])
    return linkage(
        name="locking-slider-crank", units="mm",
        description="An offset slider-crank whose rod (25) is too short to follow the crank all the way round.",
        joints={"O": 0j, "A": a, "B": b}, ground=["O"], links={"crank": ["O", "A"], "rod": ["A", "B"]},
        sliders={"piston": {"joint": "B", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"}, tracks={"piston": {"joint": "B"}},
    )


#: The crank-shaper quick return (mm): rocker pivot O2 at the origin, crank axle O above it.
QUICK_RETURN = dict(axle=30.0, crank=15.0, rocker=60.0, rod=40.0, ram=75.0)


def quick_return() -> LinkageSpec:
    """A crank-shaper quick-return (mm): the crank pin A slides in a slot of the rocker O2–C (the
    slot passes through O2), and the rod C–R drives the ram R along a horizontal line."""
    n = QUICK_RETURN
    o, a = complex(0, n["axle"]), complex(n["crank"], n["axle"])
    c = n["rocker"] * a / abs(a)
    r = complex(c.real + math.sqrt(n["rod"] ** 2 - (n["ram"] - c.imag) ** 2), n["ram"])
    return linkage(
        name="quick-return", units="mm",
        description="A crank-shaper quick-return: crank pin sliding in a slotted rocker, rod to a ram.",
        joints={"O2": 0j, "O": o, "A": a, "C": c, "R": r}, ground=["O2", "O"],
        links={"crank": ["O", "A"], "rocker": ["O2", "C"], "rod": ["C", "R"]},
        sliders={"slot": {"joint": "A", "guide": "rocker", "angle_deg": math.degrees(cmath.phase(a))},
                 "ram": {"joint": "R", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"},
        tracks={"ram": {"joint": "R"}, "rocker_tip": {"joint": "C"}},
    )


def scotch_yoke() -> LinkageSpec:
    """A Scotch yoke (mm): the crank pin A slides in the yoke's vertical slot; the yoke Y1–Y2
    translates horizontally, so it moves by r·cos θ."""
    return linkage(
        name="scotch-yoke", units="mm",
        description="A Scotch yoke: crank 20, the yoke translates along x by 20·cos θ.",
        joints={"O": 0j, "A": 20 + 0j, "Y1": 50 + 0j, "Y2": 90 + 0j}, ground=["O"],
        links={"crank": ["O", "A"], "yoke": ["Y1", "Y2"]},
        sliders={"slot": {"joint": "A", "guide": "yoke", "angle_deg": 90.0},
                 "guide": {"link": "yoke", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"}, tracks={"yoke": {"joint": "Y2"}},
    )


def scotch_yoke_coupler() -> LinkageSpec:
    """A Scotch yoke driving a coupler (mm): the yoke Y1–Y2 of :func:`scotch_yoke` carries the
    coupler Y2–B–P, B on the rocker Q–B; P retraces its arc as the yoke goes and comes back."""
    return linkage(
        name="scotch-yoke-coupler", units="mm",
        description="A Scotch yoke (crank 20) driving the coupler Y2-B-P of a rocker Q-B: P's path.",
        joints={"O": 0j, "A": 20 + 0j, "Y1": 50 + 0j, "Y2": 90 + 0j, "B": 115 + 45j, "Q": 150 - 10j, "P": 140 + 50j},
        ground=["O", "Q"],
        links={"crank": ["O", "A"], "yoke": ["Y1", "Y2"], "coupler": ["Y2", "B", "P"], "rocker": ["Q", "B"]},
        sliders={"slot": {"joint": "A", "guide": "yoke", "angle_deg": 90.0},
                 "guide": {"link": "yoke", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"}, tracks={"point": {"joint": "P"}},
    )


#: two-slots: the rail's height h, the rod P–Q, the column's x
TWO_SLOTS = {"h": 30.0, "rod": math.hypot(10.0, 40.0), "column": 40.0}


def two_slots() -> LinkageSpec:
    """A joint in two slots (mm): the pin P rides in the slotted crank O–A (a line through O at the
    crank angle θ) and in the horizontal rail y = h, so x_P = h·cot θ; the rod P–Q drives Q along
    the vertical column x = 40. The crank sweeps θ = 25°…85° (at θ = 0° the slots are parallel)."""
    n = TWO_SLOTS
    return linkage(
        name="two-slots", units="mm",
        description="A pin in two slots: the slotted crank and a horizontal rail (x_P = 30·cot θ); "
                    "the rod P-Q drives Q along a vertical column.",
        joints={"O": 0j, "A": 20 + 20j, "P": n["h"] + 1j * n["h"], "Q": n["column"] - 10j}, ground=["O"],
        links={"crank": ["O", "A"], "rod": ["P", "Q"]},
        sliders={"arm": {"joint": "P", "guide": "crank", "angle_deg": 45.0},
                 "rail": {"joint": "P", "guide": "ground", "angle_deg": 0.0},
                 "column": {"joint": "Q", "guide": "ground", "angle_deg": 90.0}},
        motor={"joint": "A", "pivot": "O", "range_deg": [-20.0, 40.0]},
        tracks={"pin": {"joint": "P"}, "foot": {"joint": "Q"}},
    )


def inverted_slider_crank() -> LinkageSpec:
    """An inverted slider-crank (mm): the ground pivot Q slides in the slotted arm A–X, so the arm
    always points from the crank pin A through Q."""
    return linkage(
        name="inverted-slider-crank", units="mm",
        description="An inverted slider-crank: crank 20, the arm A-X turns about and slides through the pivot Q.",
        joints={"O": 0j, "A": 20 + 0j, "Q": 60 + 0j, "X": 100 + 10j}, ground=["O", "Q"],
        links={"crank": ["O", "A"], "arm": ["A", "X"]},
        sliders={"sleeve": {"joint": "Q", "guide": "arm", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"}, tracks={"arm_tip": {"joint": "X"}},
    )


def stephenson_slider() -> LinkageSpec:
    """A Stephenson III six-bar with a slider output (mm): the shared crank-rocker, a coupler
    point C and a rod C–E driving the slider E along a horizontal line."""
    o, d, a, b = crank_rocker_pose()
    c = a + (b - a) * complex(0.5, 0.4)
    e = complex(c.real + math.sqrt(60.0 ** 2 - (c.imag - 20.0) ** 2), 20.0)
    return linkage(
        name="stephenson-slider", units="mm",
        description="A Stephenson III six-bar: crank-rocker (25, 70, 60, 75), coupler point C, rod 60 "
                    "to a slider on y = 20.",
        joints={"O": o, "D": d, "A": a, "B": b, "C": c, "E": e}, ground=["O", "D"],
        links={"crank": ["O", "A"], "coupler": ["A", "B", "C"], "rocker": ["D", "B"], "rod": ["C", "E"]},
        sliders={"output": {"joint": "E", "guide": "ground", "angle_deg": 0.0}},
        motor={"joint": "A", "pivot": "O"}, tracks={"output": {"joint": "E"}, "coupler_point": {"joint": "C"}},
    )


def lifting_arm() -> LinkageSpec:
    """A boom lifted by a hydraulic cylinder (mm): the barrel P–Q turns about the ground pivot P,
    its rod end R slides in it (the linear input) and carries the boom O–R–T about O."""
    p, r = complex(40, -30), complex(60, 10)
    q = p + 30 * (r - p) / abs(r - p)
    return linkage(
        name="lifting-arm", units="mm",
        description="A boom on pivot O lifted by a cylinder from P; the rod end R extends by 0…25 mm.",
        joints={"O": 0j, "P": p, "Q": q, "R": r, "T": 150 + 20j}, ground=["O", "P"],
        links={"barrel": ["P", "Q"], "boom": ["O", "R", "T"]},
        sliders={"cylinder": {"joint": "R", "guide": "barrel", "angle_deg": math.degrees(cmath.phase(r - p))}},
        motor={"slider": "cylinder", "stroke": [0.0, 25.0]}, tracks={"tip": {"joint": "T"}},
    )
