"""Four-bars: Hoekens' straight-line linkage and a Grashof crank-rocker (the six-bars' base)."""

from __future__ import annotations


from linkedit.planar.catalog.geometry import linkage, meet, xy
from linkedit.spec.linkage import LinkageSpec


HOEKENS_STRAIGHT = (0.25, 0.75)


def hoekens() -> LinkageSpec:
    """Hoekens' straight-line linkage (cm): crank 1, ground 2, coupler 2.5 extended to 5, rocker 2.5.

    The tracer P sits on the coupler line A–B at AP = 5 (a rigid link with three collinear
    joints). While the crank turns from 90° to 270° (t ∈ :data:`HOEKENS_STRAIGHT`), P runs
    along a horizontal line within 0.01.
    """
    o, d = 0j, 2 + 0j
    a = 1 + 0j
    b = meet(a, 2.5, d, 2.5, left=True)
    p = a + 2.0 * (b - a)
    return linkage(
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


def crank_rocker_pose() -> tuple[complex, complex, complex, complex]:
    """O, D (ground), A, B of the shared crank-rocker at crank angle 0."""
    n = CRANK_ROCKER
    o, d, a = 0j, complex(n["ground"], 0), complex(n["crank"], 0)
    return o, d, a, meet(a, n["coupler"], d, n["rocker"], left=True)


def crank_rocker() -> LinkageSpec:
    """A Grashof crank-rocker four-bar (mm) with a coupler point traced off the coupler line."""
    o, d, a, b = crank_rocker_pose()
    point = a + (b - a) * complex(0.5, 0.4)  # halfway along the coupler, 0.4·AB to its left
    return linkage(
        name="crank-rocker", units="mm",
        description="A Grashof crank-rocker four-bar (crank 25, coupler 70, rocker 60, ground 75) "
                    "with a coupler point.",
        joints={"O": o, "D": d, "A": a, "B": b}, ground=["O", "D"],
        links={"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        motor={"joint": "A", "pivot": "O"},
        tracks={"coupler_point": {"link": "coupler", "at": xy(point)}, "rocker_tip": {"joint": "B"}},
    )
