"""The example mechanisms, built from their link lengths: the source of ``examples/*.yaml``.

Every rest pose is computed exactly (circle–circle intersections in double precision) from the
mechanism's defining lengths, not typed in as rounded coordinates, so link lengths are the
designer's numbers to the last bit. Each function returns a validated :class:`LinkageSpec`;
:func:`~linkedit.spec.linkage_yaml.dump_linkage` writes one as YAML (with optional comments) and :data:`EXAMPLES` says which
file holds which mechanism. Regenerate the files with ``python -m linkedit.planar.catalog``.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage

# ---------------------------------------------------------------- geometry helpers


def _meet(p: complex, r_p: float, q: complex, r_q: float, left: bool) -> complex:
    """The point at distance ``r_p`` from ``p`` and ``r_q`` from ``q``, on the left (or right) of p→q."""
    d = q - p
    dist = abs(d)
    along = (r_p * r_p - r_q * r_q + dist * dist) / (2.0 * dist)
    across = math.sqrt(r_p * r_p - along * along)
    return p + d / dist * complex(along, across if left else -across)


def _xy(z: complex) -> tuple[float, float]:
    return (z.real, z.imag)


def _spec(joints: dict[str, complex], **fields: object) -> LinkageSpec:
    """Validate a spec given as plain data (joints as complex numbers)."""
    return LinkageSpec.model_validate({**fields, "joints": {n: _xy(z) for n, z in joints.items()}})


# ---------------------------------------------------------------- Jansen and the Strandbeest

#: Theo Jansen's "holy numbers", mm: a = OB horizontal, l = OB vertical, m = crank OA.
HOLY = dict(a=38.0, b=41.5, c=39.3, d=40.1, e=55.8, f=39.4, g=36.7, h=65.7, i=49.0, j=50.0, k=61.9,
            l=7.8, m=15.0)

#: Jansen's links (name → joints), the joints named as in the issue: O crank axle, A crank pin,
#: B ground pivot, G foot.
JANSEN_LINKS = {
    "crank": ["O", "A"], "upper_rod": ["A", "C"], "lower_rod": ["A", "D"], "upper": ["B", "C", "E"],
    "rocker": ["B", "D"], "knee": ["E", "F"], "lower": ["D", "F", "G"],
}


def _frame_pivot(mirror: bool) -> complex:
    """Jansen's frame pivot B = (−a, −l), or (+a, −l) for the mirrored leg."""
    return complex(HOLY["a"] if mirror else -HOLY["a"], -HOLY["l"])


def _jansen_pose(pin: complex, mirror: bool = False) -> dict[str, complex]:
    """Joints B…G of Jansen's leg driven by the crank pin ``pin`` (crank axle O = 0).

    The branch of every triangle is the one of the issue's rest pose (C above the line A–B,
    D below it, E to the left of B→C, F to the right of E→D, G to the left of D→F).
    ``mirror``: the leg mirrored about x = 0 (frame pivot at (+a, −l), every triangle of the
    opposite orientation), driven by the same pin.
    """
    n = HOLY
    a, b = pin, _frame_pivot(mirror)
    c = _meet(a, n["j"], b, n["b"], left=mirror)
    d = _meet(a, n["k"], b, n["c"], left=not mirror)
    e = _meet(b, n["d"], c, n["e"], left=not mirror)
    f = _meet(e, n["f"], d, n["g"], left=mirror)
    g = _meet(d, n["i"], f, n["h"], left=not mirror)
    return {"B": b, "C": c, "D": d, "E": e, "F": f, "G": g}


def _crank_pin(angle_deg: float) -> complex:
    """Jansen's crank pin at ``angle_deg`` (exact at multiples of 90°)."""
    quarter, rest = divmod(angle_deg, 90.0)
    return HOLY["m"] * 1j ** int(quarter) * cmath.exp(1j * math.radians(rest))


def jansen_leg() -> LinkageSpec:
    """Theo Jansen's Strandbeest leg (holy numbers, mm); rest pose at crank angle 0, A = (15, 0)."""
    return _spec(
        name="jansen-leg", units="mm",
        description="Theo Jansen's Strandbeest leg with the holy numbers. The crank OA turns about "
                    "the axle O; B is the frame pivot; G is the foot.",
        joints={"O": 0j, "A": _crank_pin(0.0), **_jansen_pose(_crank_pin(0.0))},
        ground=["O", "B"], links=JANSEN_LINKS, motor={"joint": "A", "pivot": "O"}, tracks={"foot": {"joint": "G"}},
    )


def strandbeest(pairs: int) -> LinkageSpec:
    """A Strandbeest with ``pairs`` leg pairs on one crank (mm).

    The crank is one rigid link [O, A_0, A_1, …] whose pins sit at phases 360°·p/pairs. Pin
    A_p drives leg p_L (ground pivot B_L = (−38, −7.8)) and its mirror image p_R about x = 0
    (B_R = (+38, −7.8)); the two pivots are shared by all legs. Tracks foot_<p>_L, foot_<p>_R.
    """
    if pairs < 1:
        raise ValueError("a Strandbeest needs at least one leg pair")
    pins = {f"A_{p}": _crank_pin(360.0 * p / pairs) for p in range(pairs)}
    joints: dict[str, complex] = {"O": 0j, "B_L": _frame_pivot(False), "B_R": _frame_pivot(True)}
    joints.update(pins)
    links: dict[str, list[str]] = {"crank": ["O", *pins]}
    tracks: dict[str, dict[str, str]] = {}
    for p, pin in enumerate(pins.values()):
        for side in ("L", "R"):
            pose = _jansen_pose(pin, mirror=side == "R")
            rename = {j: f"{j}_{p}_{side}" for j in "CDEFG"} | {"A": f"A_{p}", "B": f"B_{side}"}
            joints.update({rename[j]: z for j, z in pose.items() if j in "CDEFG"})
            for name, members in JANSEN_LINKS.items():
                if name != "crank":
                    links[f"{name}_{p}_{side}"] = [rename[j] for j in members]
            tracks[f"foot_{p}_{side}"] = {"joint": rename["G"]}
    return _spec(
        name=f"strandbeest-{pairs}", units="mm",
        description=f"A Strandbeest with {pairs} mirrored pairs of Jansen legs on one crank, "
                    f"the crank pins {360 / pairs:g}° apart.",
        joints=joints, ground=["O", "B_L", "B_R"], links=links,
        motor={"joint": "A_0", "pivot": "O"}, tracks=tracks,
    )


# ---------------------------------------------------------------- Klann

#: Klann leg lengths (mm) after the optimized geometry published at boim.com/Walkin8r/Klann.html:
#: crank A–C, frame pivots B (lower rocker) and D (upper rocker) relative to the crank axle A.
#: lengths (float) and ground pivots (complex), mm
KLANN: dict[str, Any] = dict(crank=17.5, B=complex(-38.8, -12.5), D=complex(-14.6, 41.9), BH=23.7, CF=73.4, CH=38.8,
             DE=34.1, EF=57.7, EG=111.7, FG=59.0, FH=35.2)


def klann_leg() -> LinkageSpec:
    """Joe Klann's walking leg (a Stephenson III six-bar, mm); rest pose at crank angle 0.

    The connecting rod C–H–F is driven by the crank pin C and steered by the lower rocker B–H;
    the leg E–F–G hangs from the upper rocker D–E. The foot G walks a flat-bottomed stride.
    """
    k = KLANN
    a, b, d = 0j, k["B"], k["D"]
    c = a + k["crank"]
    h = _meet(c, k["CH"], b, k["BH"], left=False)
    f = _meet(c, k["CF"], h, k["FH"], left=True)
    e = _meet(d, k["DE"], f, k["EF"], left=False)
    g = _meet(e, k["EG"], f, k["FG"], left=True)
    return _spec(
        name="klann-leg", units="mm",
        description="Klann's walking leg: crank A-C, connecting rod C-H-F steered by the lower "
                    "rocker B-H, leg E-F-G hung from the upper rocker D-E; G is the foot.",
        joints={"A": a, "B": b, "D": d, "C": c, "H": h, "F": f, "E": e, "G": g},
        ground=["A", "B", "D"],
        links={"crank": ["A", "C"], "lower_rocker": ["B", "H"], "connecting_rod": ["C", "H", "F"],
               "upper_rocker": ["D", "E"], "leg": ["E", "F", "G"]},
        motor={"joint": "C", "pivot": "A"}, tracks={"foot": {"joint": "G"}},
    )


# ---------------------------------------------------------------- four-bars

#: The crank angles (as motor phases t) over which Hoekens' tracer runs straight.
HOEKENS_STRAIGHT = (0.25, 0.75)


def hoekens() -> LinkageSpec:
    """Hoekens' straight-line linkage (cm): crank 1, ground 2, coupler 2.5 extended to 5, rocker 2.5.

    The tracer P sits on the coupler line A–B at AP = 5 (a rigid link with three collinear
    joints). While the crank turns from 90° to 270° (t ∈ :data:`HOEKENS_STRAIGHT`), P runs
    along a horizontal line within 0.01.
    """
    o, d = 0j, 2 + 0j
    a = 1 + 0j
    b = _meet(a, 2.5, d, 2.5, left=True)
    p = a + 2.0 * (b - a)
    return _spec(
        name="hoekens", units="cm",
        description="Hoekens' approximate straight-line linkage. The tracer P runs straight "
                    "while the crank turns from 90 to 270 degrees.",
        joints={"O": o, "D": d, "A": a, "B": b, "P": p}, ground=["O", "D"],
        links={"crank": ["O", "A"], "coupler": ["A", "B", "P"], "rocker": ["D", "B"]},
        motor={"joint": "A", "pivot": "O"}, tracks={"tracer": {"joint": "P"}},
    )


#: The Grashof crank-rocker shared by :func:`crank_rocker` and the six-bars (mm):
#: crank 25, coupler 70, rocker 60, ground 75 (s + l = 100 ≤ p + q = 130); transmission 44°…100°.
CRANK_ROCKER = dict(crank=25.0, coupler=70.0, rocker=60.0, ground=75.0)


def _crank_rocker_pose() -> tuple[complex, complex, complex, complex]:
    """O, D (ground), A, B of the shared crank-rocker at crank angle 0."""
    n = CRANK_ROCKER
    o, d, a = 0j, complex(n["ground"], 0), complex(n["crank"], 0)
    return o, d, a, _meet(a, n["coupler"], d, n["rocker"], left=True)


def crank_rocker() -> LinkageSpec:
    """A Grashof crank-rocker four-bar (mm) with a coupler point traced off the coupler line."""
    o, d, a, b = _crank_rocker_pose()
    point = a + (b - a) * complex(0.5, 0.4)  # halfway along the coupler, 0.4·AB to its left
    return _spec(
        name="crank-rocker", units="mm",
        description="A Grashof crank-rocker four-bar (crank 25, coupler 70, rocker 60, ground 75) "
                    "with a coupler point.",
        joints={"O": o, "D": d, "A": a, "B": b}, ground=["O", "D"],
        links={"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        motor={"joint": "A", "pivot": "O"},
        tracks={"coupler_point": {"link": "coupler", "at": _xy(point)}, "rocker_tip": {"joint": "B"}},
    )


# ---------------------------------------------------------------- six-bars


def watt_six_bar() -> LinkageSpec:
    """A Watt II six-bar (mm): the crank-rocker's rocker is a bell crank driving a second rocker.

    The two ternary links (frame O–D–F and bell crank D–B–C) share the joint D. The bell
    crank's arm DC = 62 is 100° clockwise from DB; dyad C–E–F (CE = 74, FE = 52, F = (55, −29)).
    Transmission angles: 44°…100° at B, 81°…99° at E.
    """
    o, d, a, b = _crank_rocker_pose()
    c = d + (b - d) / abs(b - d) * 62.0 * cmath.exp(-1j * math.radians(100.0))
    f = complex(55.0, -29.0)
    e = _meet(c, 74.0, f, 52.0, left=True)
    return _spec(
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
    o, d, a, b = _crank_rocker_pose()
    c = a + (b - a) / abs(b - a) * complex(74.0, -6.0)
    f = complex(108.0, -13.0)
    e = _meet(c, 72.0, f, 49.0, left=True)
    return _spec(
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
    return _spec(
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


# ---------------------------------------------------------------- sliders and inputs

#: The offset slider-crank (mm): crank r, rod l, offset e of the slider line above the crank axle.
SLIDER_CRANK = dict(r=20.0, l=70.0, e=12.0)


def slider_crank() -> LinkageSpec:
    """An offset slider-crank (mm) with a coupler point C on the rod; x_B = r·cos θ + sqrt(l² − (r·sin θ − e)²)."""
    n = SLIDER_CRANK
    a = complex(n["r"], 0)
    b = complex(n["r"] + math.sqrt(n["l"] ** 2 - n["e"] ** 2), n["e"])
    return _spec(
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
    return _spec(
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
    return _spec(
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
    return _spec(
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
    return _spec(
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
    return _spec(
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
    return _spec(
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
    o, d, a, b = _crank_rocker_pose()
    c = a + (b - a) * complex(0.5, 0.4)
    e = complex(c.real + math.sqrt(60.0 ** 2 - (c.imag - 20.0) ** 2), 20.0)
    return _spec(
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
    return _spec(
        name="lifting-arm", units="mm",
        description="A boom on pivot O lifted by a cylinder from P; the rod end R extends by 0…25 mm.",
        joints={"O": 0j, "P": p, "Q": q, "R": r, "T": 150 + 20j}, ground=["O", "P"],
        links={"barrel": ["P", "Q"], "boom": ["O", "R", "T"]},
        sliders={"cylinder": {"joint": "R", "guide": "barrel", "angle_deg": math.degrees(cmath.phase(r - p))}},
        motor={"slider": "cylinder", "stroke": [0.0, 25.0]}, tracks={"tip": {"joint": "T"}},
    )


def figure_eight_six_bar() -> LinkageSpec:
    """A Stephenson III six-bar whose tracer P draws Gerono's figure-eight x = 20 cos t, y = 10 sin 2t (mm)
    to 0.26 % RMS with every transmission angle in [20°, 160°]; dimensions found by a global search
    (random six-bars, then SLSQP with the band as constraints), README, synthesis."""
    return _spec(
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


# ---------------------------------------------------------------- YAML files


@dataclass(frozen=True)
class Example:
    """One file of ``examples/``: which mechanism it holds and the comments written with it."""

    file: str
    build: Callable[[], LinkageSpec]
    header: str = ""
    notes: Mapping[str, str] = field(default_factory=dict)
    #: False for a linkage that linkedit must reject (the complex loop)
    simulates: bool = True

    def text(self) -> str:
        return dump_linkage(self.build(), self.header, self.notes)


EXAMPLES: tuple[Example, ...] = (
    Example(
        "jansen.yaml", jansen_leg,
        header="""\
Theo Jansen's Strandbeest leg, the bundled demo:  linkedit simulate examples/jansen.yaml
Holy numbers (mm): a=38 l=7.8 (frame pivot B = (-a, -l)), m=15 (crank), j=50 (AC), k=61.9 (AD),
b=41.5 (BC), c=39.3 (BD), d=40.1 (BE), e=55.8 (CE), f=39.4 (EF), g=36.7 (DF), h=65.7 (FG), i=49 (DG).
The rest pose below is the crank at 0 degrees, computed exactly from these lengths
(written by linkedit.planar.catalog; regenerate with: python -m linkedit.planar.catalog).""",
        notes={
            "joints": "rest pose, mm: name -> [x, y]",
            "joints.O": "crank axle (ground)", "joints.A": "crank pin", "joints.B": "frame pivot (ground)",
            "joints.C": "upper knee", "joints.D": "lower knee", "joints.E": "hip corner",
            "joints.F": "ankle", "joints.G": "foot",
            "ground": "joints fixed to the frame",
            "links": "rigid bodies: name -> the joints they carry",
            "links.crank": "m = 15", "links.upper_rod": "j = 50", "links.lower_rod": "k = 61.9",
            "links.upper": "triangle: BC = b, BE = d, CE = e", "links.rocker": "c = 39.3",
            "links.knee": "f = 39.4", "links.lower": "triangle: DF = g, FG = h, DG = i",
            "motor": "A turns counter-clockwise about O; t = 0 is the rest pose",
            "tracks.foot": "the walking foot",
        },
    ),
    Example("strandbeest-3.yaml", lambda: strandbeest(3),
            header="Strandbeest with 3 leg pairs on one crank (pins 120 degrees apart); "
                   "written by linkedit.planar.catalog."),
    Example("strandbeest-10.yaml", lambda: strandbeest(10),
            header="Strandbeest with 10 leg pairs on one crank (pins 36 degrees apart); "
                   "written by linkedit.planar.catalog."),
    Example("klann.yaml", klann_leg,
            header="Klann's walking leg, lengths after boim.com/Walkin8r/Klann.html (optimized geometry);\n"
                   "written by linkedit.planar.catalog.",
            notes={"joints.A": "crank axle", "joints.C": "crank pin", "joints.G": "foot"}),
    Example("hoekens.yaml", hoekens,
            header="Hoekens' straight-line linkage: crank 1, ground 2, coupler 2.5 extended to 5, rocker 2.5.\n"
                   "P runs along a straight line (within 0.01) while the crank turns from 90 to 270 degrees.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"links.coupler": "P is on the line A-B, AP = 5", "tracks.tracer": "the straight-line point"}),
    Example("crank-rocker.yaml", crank_rocker,
            header="Grashof crank-rocker four-bar; written by linkedit.planar.catalog.",
            notes={"tracks.coupler_point": "a point fixed to the coupler, given at the rest pose"}),
    Example("watt-six-bar.yaml", watt_six_bar,
            header="Watt II six-bar of linkedit's own design; written by linkedit.planar.catalog.",
            notes={"links.bell_crank": "ternary: shares D with the frame (Watt's chain)"}),
    Example("stephenson-six-bar.yaml", stephenson_six_bar,
            header="Stephenson III six-bar of linkedit's own design; written by linkedit.planar.catalog.",
            notes={"links.coupler": "ternary: touches the frame only through crank and rocker"}),
    Example("complex-loop.yaml", complex_loop,
            header="A six-bar with a complex kinematic loop (class-III Assur group): no joint can be placed\n"
                   "from two known ones, so T1, T2, T3 are solved as one numeric group at every sample.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"links.body": "ternary body hung from P1, P2 and the crank pin A"}),
    Example("slider-crank.yaml", slider_crank,
            header="Offset slider-crank: crank r = 20, rod l = 70, slider line y = e = 12;\n"
                   "x_B = r cos(theta) + sqrt(l^2 - (r sin(theta) - e)^2). Written by linkedit.planar.catalog.",
            notes={"sliders.piston": "B stays on the horizontal line through its rest position"}),
    Example("quick-return.yaml", quick_return,
            header="Crank-shaper quick-return: the crank pin A slides in the rocker's slot (through O2);\n"
                   "the rod C-R drives the ram R along y = 75. Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "the slot turns with the rocker", "sliders.ram": "the ram's guide"}),
    Example("scotch-yoke.yaml", scotch_yoke,
            header="Scotch yoke: the yoke moves by r cos(theta). Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "A in the yoke's vertical slot", "sliders.guide": "the yoke translates along x"}),
    Example("figure-eight-six-bar.yaml", figure_eight_six_bar,
            header="A Stephenson III six-bar whose tracer draws Gerono's figure-eight x = 20 cos t, y = 10 sin 2t (mm) to\n"
                   "0.26 % RMS of its width with every transmission angle within [20°, 160°] (no four-bar does better\n"
                   "than 4.15 % in that band: README, synthesis). Found by a global search outside linkedit (random\n"
                   "six-bars, then SLSQP with the band and every link and pivot within 3 widths of the figure as\n"
                   "constraints). `linkedit atlas build --family examples/figure-eight-six-bar.yaml` makes it a\n"
                   "synthesis family. Written by linkedit.planar.catalog."),
    Example("scotch-yoke-coupler.yaml", scotch_yoke_coupler,
            header="A Scotch yoke driving a coupler: the yoke carries the coupler Y2-B-P of the rocker Q-B.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "A in the yoke's vertical slot", "sliders.guide": "the yoke translates along x"}),
    Example("inverted-slider-crank.yaml", inverted_slider_crank,
            header="Inverted slider-crank: the arm A-X slides through the ground pivot Q.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.sleeve": "Q slides in the arm's slot (the slot line passes through A)"}),
    Example("two-slots.yaml", two_slots,
            header="A pin in two slots: P = crossing of the slotted crank's line and the rail y = 30,\n"
                   "x_P = 30 cot(theta). Written by linkedit.planar.catalog.",
            notes={"sliders.arm": "P in the crank's slot (the line O-A)", "sliders.rail": "and in the rail y = 30"}),
    Example("stephenson-slider.yaml", stephenson_slider,
            header="Stephenson III six-bar with a slider output. Written by linkedit.planar.catalog.",
            notes={"sliders.output": "E slides along y = 20"}),
    Example("invalid/locking-slider-crank.yaml", locking_slider_crank, simulates=False,
            header="A deliberate failure: the rod is too short, so the slider locks up for part of the turn:\n"
                   "  linkedit simulate examples/invalid/locking-slider-crank.yaml  ->  exit 1, slider piston.\n"
                   "Written by linkedit.planar.catalog."),
    Example("lifting-arm.yaml", lifting_arm,
            header="A cylinder-driven boom (linear input): the rod end R extends 0..25 mm out of the barrel.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.cylinder": "R slides along the barrel P-Q",
                   "motor": "linear input: R's displacement along the barrel from rest"}),
)


def write_examples(directory: str | Path) -> list[Path]:
    """Write every :data:`EXAMPLES` file into ``directory`` (atomically); returns the paths."""
    from linkedit.io.atomic import write_text

    paths = [Path(directory) / ex.file for ex in EXAMPLES]
    for ex, path in zip(EXAMPLES, paths):
        write_text(path, ex.text())
    return paths


def main(argv: list[str] | None = None) -> None:
    """``python -m linkedit.planar.catalog [DIR]``: rewrite the example files.

    Without DIR it writes into the source checkout's ``examples/`` and refuses when linkedit
    is installed (it never writes into site-packages).
    """
    import argparse

    parser = argparse.ArgumentParser(prog="python -m linkedit.planar.catalog",
                                     description="Write the example linkages (examples/*.yaml) from exact geometry.")
    parser.add_argument("directory", nargs="?", type=Path,
                        help="where to write them [default: examples/ of the source checkout]")
    args = parser.parse_args(argv)
    directory = args.directory
    if directory is None:
        checkout = Path(__file__).resolve().parents[2]
        if not (checkout / "pyproject.toml").is_file() or not (checkout / "examples").is_dir():
            parser.error("not a source checkout: give the folder to write into")
        directory = checkout / "examples"
    for written in write_examples(directory):
        print(written)


if __name__ == "__main__":
    main()
