"""Walking legs: Theo Jansen's Strandbeest leg (and whole Strandbeests) and Joe Klann's leg."""

from __future__ import annotations

import cmath
import math
from typing import Any

from linkedit.planar.catalog.geometry import linkage, meet
from linkedit.spec.linkage import LinkageSpec


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
    c = meet(a, n["j"], b, n["b"], left=mirror)
    d = meet(a, n["k"], b, n["c"], left=not mirror)
    e = meet(b, n["d"], c, n["e"], left=not mirror)
    f = meet(e, n["f"], d, n["g"], left=mirror)
    g = meet(d, n["i"], f, n["h"], left=not mirror)
    return {"B": b, "C": c, "D": d, "E": e, "F": f, "G": g}


def _crank_pin(angle_deg: float) -> complex:
    """Jansen's crank pin at ``angle_deg`` (exact at multiples of 90°)."""
    quarter, rest = divmod(angle_deg, 90.0)
    return HOLY["m"] * 1j ** int(quarter) * cmath.exp(1j * math.radians(rest))


def jansen_leg() -> LinkageSpec:
    """Theo Jansen's Strandbeest leg (holy numbers, mm); rest pose at crank angle 0, A = (15, 0)."""
    return linkage(
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
    return linkage(
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
    h = meet(c, k["CH"], b, k["BH"], left=False)
    f = meet(c, k["CF"], h, k["FH"], left=True)
    e = meet(d, k["DE"], f, k["EF"], left=False)
    g = meet(e, k["EG"], f, k["FG"], left=True)
    return linkage(
        name="klann-leg", units="mm",
        description="Klann's walking leg: crank A-C, connecting rod C-H-F steered by the lower "
                    "rocker B-H, leg E-F-G hung from the upper rocker D-E; G is the foot.",
        joints={"A": a, "B": b, "D": d, "C": c, "H": h, "F": f, "E": e, "G": g},
        ground=["A", "B", "D"],
        links={"crank": ["A", "C"], "lower_rocker": ["B", "H"], "connecting_rod": ["C", "H", "F"],
               "upper_rocker": ["D", "E"], "leg": ["E", "F", "G"]},
        motor={"joint": "C", "pivot": "A"}, tracks={"foot": {"joint": "G"}},
    )
