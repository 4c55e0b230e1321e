"""Random Grashof crank-rockers (hypothesis): every one simulates a full turn and stays rigid."""

from __future__ import annotations

import cmath
import math

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from linkedit.planar import simulate
from linkedit.spec.linkage import LinkageSpec

unit = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)


@st.composite
def crank_rockers(draw) -> tuple[LinkageSpec, dict[str, float]]:
    """A Grashof crank-rocker with the crank the shortest link, s + l ≤ p + q − margin.

    Lengths are drawn at unit scale, then the whole linkage is scaled (1e-2…1e3), rotated and
    translated; the rest crank angle and the branch (coupler above or below) are random.
    """
    ground, coupler, rocker = (draw(st.floats(1.0, 4.0)) for _ in range(3))
    others = sorted((ground, coupler, rocker))
    longest, p, q = others[2], others[0], others[1]
    # the crank is the shortest link and leaves a margin in Grashof's inequality
    margin = 0.05 * longest
    crank_max = min(others[0], p + q - longest - margin)
    assume(crank_max > 0.1)
    crank = draw(st.floats(0.1, crank_max))
    assume(crank < others[0])
    scale = 10.0 ** draw(st.floats(-2.0, 3.0))
    turn = cmath.exp(2j * math.pi * draw(unit))
    shift = complex(draw(st.floats(-1e3, 1e3)), draw(st.floats(-1e3, 1e3))) * scale
    rest_angle = 2 * math.pi * draw(unit)
    above = draw(st.booleans())

    o, d = 0j, complex(ground, 0)
    a = crank * cmath.exp(1j * rest_angle)
    ad = d - a
    along = (coupler**2 - rocker**2 + abs(ad) ** 2) / (2 * abs(ad))
    b = a + ad / abs(ad) * complex(along, (1 if above else -1) * math.sqrt(coupler**2 - along**2))
    point = a + (b - a) * complex(draw(st.floats(-0.5, 1.5)), draw(st.floats(-1.0, 1.0)))

    def place(z: complex) -> tuple[float, float]:
        w = shift + scale * turn * z
        return (w.real, w.imag)

    spec = LinkageSpec.model_validate({
        "name": "random-crank-rocker", "units": "mm",
        "joints": {"O": place(o), "D": place(d), "A": place(a), "B": place(b)},
        "ground": ["O", "D"],
        "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        "motor": {"joint": "A", "pivot": "O", "direction": draw(st.sampled_from(["ccw", "cw"]))},
        "tracks": {"coupler_point": {"link": "coupler", "at": place(point)}},
    })
    return spec, {"crank": crank * scale, "coupler": coupler * scale, "rocker": rocker * scale, "ground": ground * scale}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(crank_rockers())
def test_random_grashof_crank_rockers_turn_fully_and_stay_rigid(case):
    spec, lengths = case
    m = simulate(spec, 180)
    assert m.assembled.all() and np.isfinite(m.positions).all()
    p = m.positions
    names = m.plan.joint_names

    def length(a: str, b: str) -> np.ndarray:
        return np.linalg.norm(p[:, names.index(a)] - p[:, names.index(b)], axis=-1)

    size = max(lengths.values())
    for (a, b), key in {("O", "A"): "crank", ("A", "B"): "coupler", ("D", "B"): "rocker", ("O", "D"): "ground"}.items():
        assert np.abs(length(a, b) - lengths[key]).max() <= 1e-9 * size, (a, b)
    assert (m.orientation == m.plan.table.orientation).all()
    # the coupler point rides on the coupler: fixed distances to A and B
    c = m.tracks["coupler_point"].position
    for j in ("A", "B"):
        r = np.linalg.norm(c - p[:, names.index(j)], axis=-1)
        assert np.ptp(r) <= 1e-9 * size
