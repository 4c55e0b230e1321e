"""Benchmark of the closed-form engine: µs per time step at 360 samples and at 1 sample.

"positions" is the reconstruction alone (:func:`linkedit.planar.kinematics.positions`);
"+derivatives" adds analytic velocities and accelerations and the singularity distances
(:func:`linkedit.planar.kinematics.evaluate`), "×" is their ratio (target ≤ 3); both reuse a
:class:`~linkedit.planar.kinematics.Workspace` as a caller evaluating repeatedly does. The
second table times the new rule kinds at 360 samples against a dyadic four-bar of the same
size: a closed-form slider (slider-crank) and a numeric group (the complex-loop six-bar:
continued sequentially through a sample each time the crank pin has moved 8 % of the linkage's
size, then every sample polished in one batch; its group is a triad, solved as its body's
pose), with the ratio to the four-bar and its target.
The third table, when pylinkage is installed (the ``bench`` extra), times the first table's
linkages side by side with pylinkage's numba solver (``step_fast``, 360 steps) after checking
that both give the same trajectories (:mod:`linkedit.planar.peer`).
Every figure is a median over 5 rounds (1 with ``--quick``) in which the calls compared take turns
(:func:`linkedit.timing.alternating`), and every ratio the median of the rounds' ratios: a burst of
another process's load on this shared machine falls on one round of both sides.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from functools import partial

import numpy as np

from linkedit.planar import catalog, peer
from linkedit.planar.kinematics import Workspace, evaluate, positions
from linkedit.planar.plan import Geometry, compile_plan
from linkedit.planar.simulate import motor_angles
from linkedit.timing import alternating

TARGETS_360 = {"Jansen leg": 0.3, "Strandbeest 3 pairs": 0.7, "Strandbeest 10 pairs": 1.5}
#: positions + velocities + accelerations + d_s at most this many times positions alone
TARGET_RATIO = 3.0
#: µs per step with derivatives, as a multiple of the dyadic four-bar's
TARGET_RATIOS = {"complex-loop six-bar": 5.0}
#: pylinkage's step_fast time over linkedit's positions, at least (360 samples)
TARGET_PEER = 2.5


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    budget, rounds = (0.02, 1) if quick else (0.5, 5)
    mechanisms = {"Jansen leg": catalog.jansen_leg(), "Strandbeest 3 pairs": catalog.strandbeest(3),
                  "Strandbeest 10 pairs": catalog.strandbeest(10)}
    echo(f"{'mechanism':<22}{'joints':>7}{'levels':>7}  {'samples':>7}  {'positions µs/step':>18}  "
         f"{'+derivatives µs/step':>21}  {'×':>5}  target")
    for name, spec in mechanisms.items():
        plan = compile_plan(spec)
        geom = plan.geometry()
        for samples in (360, 1):
            angle = motor_angles(spec, samples)[1]
            work, full_work = Workspace(plan, samples), Workspace(plan, samples, order=2)
            rows = alternating([lambda: positions(plan, geom, angle, work),
                                lambda: evaluate(plan, geom, angle, 2, full_work)], rounds, budget)
            pos, full = (statistics.median(r[n] for r in rows) / samples * 1e6 for n in (0, 1))
            ratio = statistics.median(f / p for p, f in rows)
            target = f"≤ {TARGETS_360[name]}, " if samples == 360 else ""
            echo(f"{name:<22}{plan.n_joints:>7}{plan.levels:>7}  {samples:>7}  {pos:>18.3f}  {full:>21.3f}  "
                 f"{ratio:>5.2f}  {target}× ≤ {TARGET_RATIO:g}")
    rule_kinds(echo, budget, rounds)
    pylinkage_side_by_side(echo, mechanisms, budget, rounds)


def rule_kinds(echo: Callable[[str], None], budget: float, rounds: int) -> None:
    """µs per step at 360 samples: four-bar (dyads only), slider-crank, complex-loop six-bar; each one's ratio to
    the four-bar is the median of their ratios in alternating rounds."""
    mechanisms = {"four-bar (dyad)": catalog.crank_rocker(), "slider-crank": catalog.slider_crank(),
                  "complex-loop six-bar": catalog.complex_loop()}
    echo("")
    echo(f"{'rule kinds, 360 samples':<24}{'rules':>24}  {'positions µs/step':>18}  {'+derivatives µs/step':>21}  {'× four-bar':>10}  target")
    calls: list[Callable[[], object]] = []
    kinds = []
    for spec in mechanisms.values():
        plan = compile_plan(spec)
        geom = Geometry.of(plan, plan.normalized_points())
        angle = motor_angles(spec, 360)[1]
        work = Workspace(plan, 360, order=2)
        calls += [partial(positions, plan, geom, angle), partial(evaluate, plan, geom, angle, 2, work)]
        kinds.append(", ".join(sorted({r.kind for r in plan.rules if r.ds_count()})))
    rows = alternating(calls, rounds, budget)
    for k, (name, kind) in enumerate(zip(mechanisms, kinds)):
        pos, full = (statistics.median(r[2 * k + n] for r in rows) / 360 * 1e6 for n in (0, 1))
        ratio = statistics.median(r[2 * k + 1] / r[1] for r in rows)
        target = f"≤ {TARGET_RATIOS[name]:g}" if name in TARGET_RATIOS else ""
        echo(f"{name:<24}{kind:>24}  {pos:>18.3f}  {full:>21.3f}  {ratio:>10.1f}  {target}")


def pylinkage_side_by_side(echo: Callable[[str], None], mechanisms: dict, budget: float, rounds: int) -> None:
    """µs per step at 360 samples, linkedit's positions against pylinkage's ``step_fast`` (numba),
    medians of alternating best-of runs, after checking both trace the same joints."""
    echo("")
    try:
        import numba  # noqa: F401
        import pylinkage  # noqa: F401
    except ImportError:
        echo("vs pylinkage: pylinkage with numba is not installed (pip install 'linkedit[bench]')")
        return
    samples = 360
    echo(f"vs pylinkage {pylinkage.__version__} step_fast (numba), {samples} samples, µs per step, medians of {rounds}; "
         f"target: pylinkage ÷ linkedit ≥ {TARGET_PEER:g}")
    echo(f"{'mechanism':<22}{'linkedit':>10}{'pylinkage':>11}{'ratio':>8}  {'same path (of size)':>20}  first call (numba compile)")
    for name, spec in mechanisms.items():
        plan = compile_plan(spec)
        geom, angle = plan.geometry(), motor_angles(spec, samples)[1]
        work = Workspace(plan, samples)
        linkage, joints = peer.build(plan, samples)
        t0 = time.perf_counter()
        theirs = linkage.step_fast(iterations=samples)
        first = time.perf_counter() - t0
        ours = positions(plan, geom, angle, work)[plan.row_of[joints]]  # (J, T) complex, in pylinkage's order
        apart = np.max(np.abs(np.roll(ours, -1, axis=1).T - (theirs[..., 0] + 1j * theirs[..., 1]))) / plan.scale
        rows = alternating([lambda: positions(plan, geom, angle, work), lambda: linkage.step_fast(iterations=samples)],
                           rounds, rounds * budget)
        a, b = (statistics.median(r[n] for r in rows) / samples * 1e6 for n in (0, 1))
        echo(f"{name:<22}{a:>10.3f}{b:>11.3f}{statistics.median(t / o for o, t in rows):>8.2f}  {apart:>20.1e}  "
             f"{first:.2f} s")
