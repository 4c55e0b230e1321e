"""The built-in four-bar and slider-crank families are evaluated by the one planar core (the plan's
K-linkage evaluation, like every catalog and spec family), and agree with closed forms derived here."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from linkedit.planar import law_of_cosines
from linkedit.planar.kinematics import Workspace, _evaluate
from linkedit.planar.plan import Geometry, compile_plan
from linkedit.planar.rules import Dyad, Rigid, Slider
from linkedit.synthesis import fourbar, slidercrank
from linkedit.synthesis.legs import CatalogFamily


def working(fam, count: int, seed: int) -> np.ndarray:
    rows = fam.sample(np.random.default_rng(seed), 20 * count)
    return rows[fam.min_singularity(rows) >= fam.margin()][:count]


def four_bar_point(row: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """P by angles: B = A + b·e^{i(arg(D − A) + branch·α)}, α the angle at A of triangle A, D, B."""
    a, b, c, u, v, branch = row
    pin = a * np.exp(1j * theta)
    d = np.abs(1 - pin)
    alpha = np.arccos((b * b + d * d - c * c) / (2 * b * d))
    coupler = pin + b * np.exp(1j * (np.angle(1 - pin) + branch * alpha))
    return pin + complex(u, v) * (coupler - pin)


def slider_crank_point(row: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """P with B on y = e at distance 1 from A: B_x = A_x + branch·sqrt(1 − (e − A_y)²)."""
    a, e, u, v, branch = row
    pin = a * np.exp(1j * theta)
    slider = pin.real + branch * np.sqrt(1 - (e - pin.imag) ** 2) + 1j * e
    return pin + complex(u, v) * (slider - pin)


@pytest.mark.parametrize("fam, closed", [(fourbar, four_bar_point), (slidercrank, slider_crank_point)],
                         ids=["four-bar", "slider-crank"])
def test_family_curves_are_the_closed_form(fam, closed):
    """Curves of K linkages at one phase and at a phase each equal the closed form to 1e-12."""
    rows = working(fam, 40, seed=11)
    phase = np.random.default_rng(2).uniform(0, 1, len(rows))
    for ph in (0.0, 0.37, phase):
        z = fam.curves(rows, 90, ph)
        assert z.shape == (len(rows), 90)
        for k, row in enumerate(rows):
            theta = 2 * np.pi * (np.broadcast_to(ph, len(rows))[k] + np.arange(90) / 90)
            assert np.abs(z[k] - closed(row, theta)).max() <= 1e-12 * max(1.0, np.abs(z[k]).max())


@pytest.mark.parametrize("fam, kinds", [(fourbar, (Dyad, Rigid)), (slidercrank, (Slider, Rigid))],
                         ids=["four-bar", "slider-crank"])
def test_built_in_families_are_evaluated_by_the_planar_core(fam, kinds, monkeypatch):
    """A family's curves are the rules of one compiled plan placing K linkages (no evaluator of its own)."""
    assert isinstance(fam.CORE, CatalogFamily)
    assert tuple(type(r) for r in fam.CORE.plan.rules) == kinds
    calls = []
    for kind in kinds:
        original = kind.evaluate

        def spy(self, *args, _original=original, **kwargs):
            calls.append(type(self))
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(kind, "evaluate", spy)
    fam.curves(working(fam, 5, seed=1), 16)
    assert calls == list(kinds)


def test_a_row_that_cannot_assemble_is_nan():
    """|b − c| > |A − D| = 0.5 at θ = 0: B cannot be placed there (NaN), but can at θ = π (|A − D| = 1.5)."""
    z = fourbar.curves(np.array([[0.5, 1.5, 0.5, 0.3, 0.1, 1.0]]), 2)
    assert np.isnan(z[0, 0]) and np.isfinite(z[0, 1])
    z = slidercrank.curves(np.array([[0.5, 0.8, 0.5, 0.0, 1.0]]), 4)  # |e − A_y| = 1.3 at θ = 270°
    assert np.isfinite(z[0, :3]).all() and np.isnan(z[0, 3])


def test_linkages_at_common_angles_turn_like_each_at_its_own():
    """K linkages turned through common angles (T,) (K + T exponentials) equal the same angles given
    per linkage (K, T) to rounding, and one linkage's motor is arm·e^{i(angle − rest)} bit for bit."""
    plan = compile_plan(fourbar.CORE.spec)
    rng = np.random.default_rng(6)
    rest = plan.rest_points[None] + 0.02 * rng.normal(size=(7, *plan.rest_points.shape))
    geom = Geometry.of(plan, rest)
    angle = np.linspace(-2.0, 5.0, 33)
    common = _evaluate(plan, geom, angle, 0).z
    each = _evaluate(plan, geom, np.broadcast_to(angle, (7, 33)).copy(), 0).z
    assert np.abs(common - each).max() <= 1e-14
    one = plan.geometry()
    z = _evaluate(plan, one, angle, 0, Workspace(plan, 33)).z[plan.motor_row]
    assert np.array_equal(z, one.pivot + one.arm * np.exp(1j * (angle - one.rest_angle)))


#: Measured in a fresh interpreter: tracemalloc traces every thread, and a test before this one in the same
#: process may leave threads running (a Dask cluster's event loop) whose allocations would count.
ALLOCATIONS = """
import sys, tracemalloc
import numpy as np
from linkedit.planar.kinematics import Workspace
from linkedit.synthesis import fourbar, slidercrank
fam = {"four-bar": fourbar, "slider-crank": slidercrank}[sys.argv[1]]
rows = fam.sample(np.random.default_rng(3), 20 * 256)
rows = rows[fam.min_singularity(rows) >= fam.margin()][:256]
fam.curves(rows, 64)
work = Workspace(fam.CORE.plan, 64, 0, (len(rows),))
def whole(a):
    while a.base is not None:
        a = a.base
    return a
tracemalloc.start()
fam.curves(rows, 64)
print(tracemalloc.get_traced_memory()[1], whole(work.orders).nbytes + whole(work.pair).nbytes + len(rows) * 64 * 16)
"""


@pytest.mark.parametrize("fam", ["four-bar", "slider-crank"])
def test_curves_allocate_only_their_workspace_and_result(fam):
    """A block's curves (256 linkages × 64 samples) allocate the evaluation's workspace and the result, no
    temporary of the block's size besides (the slider placed K linkages through ~8 fresh (K, T) arrays, ~30 % of
    its time): the peak is within 112 KB of them — the small arrays (constants, angles) take 64.6 KB, any
    temporary of the block's size 128 KB (float) or 256 KB (complex)."""
    done = subprocess.run([sys.executable, "-c", ALLOCATIONS, fam], capture_output=True, text=True, check=True,
                          cwd=Path(__file__).resolve().parent.parent)
    peak, accounted = map(int, done.stdout.split())
    assert peak <= accounted + (112 << 10), (peak, accounted)


def test_curves_form_no_singularity_distances(monkeypatch):
    """Curves are positions alone: the dyads' d_s (which only the margin check reads) are not formed,
    and the positions are those of the evaluation that forms them, bit for bit."""
    calls = []
    original = law_of_cosines.singularity_distance
    monkeypatch.setattr(law_of_cosines, "singularity_distance", lambda *a: calls.append(1) or original(*a))
    rows = working(fourbar, 30, seed=4)
    z = fourbar.curves(rows, 40)
    assert calls == []
    core = fourbar.CORE
    full = core._state(rows, 40, 0.0)
    assert full.ds.shape == (core.plan.n_ds, len(rows), 40) and calls == [1]
    assert np.array_equal(z, full.z[core.plan.row_of[core.track_joint]], equal_nan=True)
    assert core._state(rows, 40, 0.0, distances=False).ds.shape[0] == 0
