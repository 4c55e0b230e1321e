"""Refinement of a placed atlas candidate against the target curve.

The unknowns are the family parameters (the branch stays) and the placement z ↦ τ + k·e^{iφ}·z
(z conjugated for a mirrored candidate). The residuals are geometric: every target point's
distance to the candidate's curve and every candidate point's distance to the target's
(only the first set for an open target, which may be part of a cycle), both over the
target's size; for precision points each point's exact distance to the whole curve
(:mod:`linkedit.synthesis.points`) over their RMS radius; with timing (:mod:`linkedit.synthesis.timed`),
the position and velocity gaps at the target's times instead, the start phase free too. scipy's trust-region least squares
minimizes them. The refinement keeps the linkage working, as LinkEdit's barrier does: an
iterate whose linkage does not work with the singularity margin m (sin² of the transmission
band's edge, the family's 20° unless asked otherwise; the one planar predicate,
:mod:`linkedit.planar.feasibility`) is never kept (its residuals are a wall, and only the best
working iterate is returned), and within BAND·m above the margin one more residual, BARRIER·ln(BAND·m/(d_s − m)),
turns the wall into a slope the trust region slides along (a design whose best fit lies on the
margin — a figure-eight — reaches the margin's constrained optimum instead of stopping at the
first iterate that hits it).

The editing optimizer of :mod:`linkedit.edit` works on the rest pose (not the family's coupler
point) with a one-sided shape distance; it polishes the refined result afterwards
(:mod:`linkedit.synthesis.polish`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from types import ModuleType

import numpy as np
from scipy.optimize import least_squares

from linkedit.curves.polyline import arc_resample, distances_to, near_distances
from linkedit.planar.feasibility import works
from linkedit.synthesis.points import family_at, family_nearest
from linkedit.synthesis.timed import SAMPLES as TIMED_SAMPLES
from linkedit.synthesis.timed import VELOCITY_WEIGHT, TimedTarget, central, timed_sequence

#: Crank samples of the candidate curve during refinement.
SAMPLES = 256
#: Points per curve where residuals are taken.
POINTS = 120
#: Residual of an iterate that does not work (a wall for the trust region).
WALL = 10.0
#: Trust-region iterations per candidate (each one evaluates the residuals about P + 5 times).
ITERATIONS = 40
#: Stop once the normalized RMS error is below this.
GOOD_ENOUGH = 1e-6
#: The barrier acts within this fraction of the margin above it: w·log(BAND·m / (d_s − m)) while positive.
BAND = 0.5
#: Weight of the barrier residual, in units of the normalized distance residuals.
BARRIER = 1e-3


def barrier(low: np.ndarray, margin: float) -> np.ndarray:
    """The barrier residual (…,) of lowest d_s ``low`` (…,) above ``margin``: BARRIER·log(BAND·m / (d_s − m))
    while positive, 0 farther from the margin; NaN or inf on or below it (the caller's wall)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return BARRIER * np.log(np.maximum(BAND * margin / (low - margin), 1.0))


class _Done(Exception):
    """Raised from the residuals once the fit is good enough."""


@dataclass(frozen=True)
class Placement:
    """z ↦ shift + scale·e^{i·angle}·(conj(z) if mirrored else z); with timing, the family phase at
    the target's first sample and whether the crank turns the other way (``reversed``)."""

    scale: float
    angle: float
    shift: complex
    mirrored: bool
    phase: float = 0.0
    reversed: bool = False

    def apply(self, z: np.ndarray) -> np.ndarray:
        return self.shift + self.scale * np.exp(1j * self.angle) * (np.conj(z) if self.mirrored else z)


@dataclass(frozen=True)
class Frame:
    """The target's frame: synthesis works on the target centred on its bounding box and scaled to a largest
    side of 1 (the fit is scale-free: no square leaves the float range, whatever the units); a point z of that
    unit frame is ``centre + scale·z`` in input units."""

    centre: complex
    scale: float

    def unit(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2), input units → (...,) complex, unit frame."""
        return ((points[..., 0] - self.centre.real) + 1j * (points[..., 1] - self.centre.imag)) / self.scale

    def place(self, placement: Placement) -> Placement:
        """A placement onto the unit frame as the same placement onto input units."""
        return replace(placement, scale=placement.scale * self.scale, shift=self.centre + self.scale * placement.shift)


#: The unit frame itself.
UNIT = Frame(0j, 1.0)


@dataclass
class Refined:
    params: np.ndarray
    placement: Placement
    error: float  #: RMS of the residuals (normalized by the target's size)
    history: list[float] = field(default_factory=list)  #: best error after each evaluation


def curve_error(target: np.ndarray, closed: bool, curve: np.ndarray, size: float) -> tuple[float, float]:
    """(RMS, max) distance between a target polyline and a closed candidate curve (planar (M,) and (T,) complex,
    or spatial (M, D) and (T, D) real), over ``size``, each curve sampled evenly along its length: target → curve
    and, for a closed target, curve → target (an open arc may be part of the cycle). The max counts each curve's own
    points too: a sharp tip, short but passed slowly, holds few of the evenly spaced ones."""
    parts = [distances_to(arc_resample(target, 4 * POINTS, closed), curve, True)]
    own = [distances_to(target, curve, True)]
    if closed:
        parts.append(distances_to(arc_resample(curve, 4 * POINTS, True), target, True))
        own.append(distances_to(curve, target, True))
    d = np.concatenate(parts) / size
    return float(np.sqrt(np.mean(d * d))), max(float(d.max()), float(np.concatenate(own).max()) / size)


def timed_error(timed: TimedTarget, fam: ModuleType, params: np.ndarray, placement: Placement) -> tuple[float, float]:
    """(RMS, max) distance, over the target's size, between the timed target's samples and the placed
    candidate at the same phases (:mod:`linkedit.synthesis.timed`): one evaluation per sample."""
    phase = placement.phase + (-1.0 if placement.reversed else 1.0) * timed.phases
    z = fam.curves(np.repeat(params[None], len(phase), axis=0), 1, phase)[:, 0]
    return timed.error(placement.apply(z))


@dataclass
class Kept:
    """The best working iterate of :func:`kept_least_squares`."""

    x: np.ndarray
    error: float  #: its error (inf: no working iterate)
    history: list[float] = field(default_factory=list)  #: best error after each evaluation


def kept_least_squares(residuals: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], x0: np.ndarray, *,
                       iterations: int, tol: float, error: Callable[[np.ndarray], float],
                       good_enough: float = 0.0,
                       perturbed: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None) -> Kept:
    """The refinement loop of planar and spatial synthesis: scipy's trust-region least squares from ``x0`` (n,)
    on ``residuals`` (x (K, n) → working mask (K,), residuals (K, R); a batch, so the forward-difference
    Jacobian evaluates every perturbed x in one call), keeping the best working iterate by ``error`` (of one
    residual row; a non-working iterate is never kept), stopping once it is below ``good_enough``.
    ``perturbed``: the Jacobian's residuals instead (of x and its perturbations, (1 + n, n); to first order)."""
    best = Kept(x0, np.inf)

    def fun(x: np.ndarray) -> np.ndarray:
        ok, r = residuals(x[None])
        e = error(r[0])
        if ok[0] and e < best.error:
            best.x, best.error = x.copy(), e
        best.history.append(best.error)
        if e < good_enough:
            raise _Done
        return r[0]

    def jac(x: np.ndarray) -> np.ndarray:
        step = 1e-7 * np.maximum(1.0, np.abs(x))
        _, r = (perturbed or residuals)(np.vstack([x, x + np.diag(step)]))
        return ((r[1:] - r[0]) / step[:, None]).T

    try:
        fun(x0)
        if np.isfinite(best.error):
            least_squares(fun, x0, jac=jac, method="trf", x_scale="jac", max_nfev=iterations, xtol=tol, ftol=tol,
                          gtol=tol)
    except _Done:
        pass
    return best


def refine(fam: ModuleType, params: np.ndarray, placement: Placement, target: np.ndarray, closed: bool,
           size: float, *, margin: float, timed: TimedTarget | None = None, points: bool = False,
           iterations: int = ITERATIONS) -> Refined:
    """Refine one candidate (``params`` (P,), the branch fixed) against ``target`` (M,) complex:
    by shape (point-to-curve distances), with ``points`` by each precision point's exact distance to
    the whole curve (:mod:`linkedit.synthesis.points`; ``size`` their RMS radius), or with ``timed`` by
    positions and velocities at the target's times (the start phase free too); every kept iterate works
    with ``margin``.

    The finite-difference Jacobian evaluates all perturbed linkages in one batched call.
    """
    free = np.array([name != "branch" for name in fam.PARAMETERS])
    n_free = int(free.sum())
    goal = arc_resample(target, POINTS, closed)
    outline = arc_resample(target, 4 * POINTS, closed)  # the target as the reverse distances see it
    unit = size

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameter rows (K, P), the placements' complex factors (K,) and shifts (K,) of x (K, n)."""
        p = np.repeat(params[None], len(x), axis=0)
        p[:, free] = x[:, :n_free]
        k, angle, sx, sy = x[:, n_free:n_free + 4].T
        return p, np.exp(k + 1j * angle), (sx + 1j * sy) * unit

    last = [np.zeros(0), np.zeros(0)]  # precision points: the last residuals' x (n,) and its closest phases (N,)

    def distances(x: np.ndarray, linear: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameter rows (K, P), min d_s (K,) and residuals (K, R): point-to-curve distances; ``linear``
        (precision points, the Jacobian's batch): every row's at the closest phases of the first row's curve."""
        p, factor, shift = unpack(x)
        ds = fam.min_singularity(p, margin)
        if points and linear:
            if not np.array_equal(x[0], last[0]):  # the trust region asks the Jacobian where it asked the residuals
                last[:] = x[0], family_nearest(fam, p[:1], factor[:1], shift[:1], placement.mirrored, target)[1][0]
            return p, ds, family_at(fam, p, factor, shift, placement.mirrored, target, last[1])
        if points:
            d, phases = family_nearest(fam, p, factor, shift, placement.mirrored, target)
            last[:] = x[0], phases[0]
            return p, ds, d
        z = fam.curves(p, SAMPLES)
        curve = shift[:, None] + factor[:, None] * (np.conj(z) if placement.mirrored else z)
        with np.errstate(invalid="ignore"):
            r = near_distances(np.broadcast_to(goal, (len(x), len(goal))), curve)
            if closed:
                back = np.stack([arc_resample(c, POINTS, True) if np.isfinite(c).all() else goal for c in curve])
                r = np.concatenate([r, near_distances(back, np.broadcast_to(outline, (len(x), len(outline))))], axis=1)
        return p, ds, r

    def timed_residuals(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameter rows (K, P), min d_s (K,) and residuals (K, 4N): positions and λ·velocities, x and y
        apart (times √2: their RMS is that of the distances)."""
        assert timed is not None
        p, factor, shift = unpack(x)
        z = timed_sequence(fam.curves(p, TIMED_SAMPLES, x[:, -1]), placement.reversed)
        curve = shift[:, None] + factor[:, None] * (np.conj(z) if placement.mirrored else z)
        gap = np.concatenate([timed.points - curve, VELOCITY_WEIGHT * (timed.velocities - central(curve))], axis=1)
        return p, fam.min_singularity(p, margin), np.concatenate([gap.real, gap.imag], axis=1) * np.sqrt(2.0)

    def residuals(x: np.ndarray, linear: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameter rows (K, P), working mask (K,) and residuals (K, R + 1) of x (K, n): the
        distances over the target's size and √R, then the barrier (R: the distance count)."""
        p, ds, r = distances(x, linear) if timed is None else timed_residuals(x)
        push = barrier(ds, margin)
        ok = works(ds, margin) & np.isfinite(push) & np.isfinite(r).all(axis=1)  # on the margin: the wall
        r = np.concatenate([r / (size * np.sqrt(r.shape[1])), push[:, None]], axis=1)
        return p, ok, np.where(ok[:, None], r, WALL)

    x0 = np.concatenate([params[free], [np.log(placement.scale), placement.angle,
                                        placement.shift.real / unit, placement.shift.imag / unit],
                         [] if timed is None else [placement.phase]])
    kept = kept_least_squares(lambda x: residuals(x)[1:], x0, iterations=iterations, tol=1e-9, good_enough=GOOD_ENOUGH,
                              error=lambda r: float(np.sqrt(np.sum(r[:-1] ** 2))),  # the barrier is no error
                              perturbed=(lambda x: residuals(x, True)[1:]) if points else None)
    if not np.isfinite(kept.error):
        return Refined(params.copy(), placement, np.inf, kept.history)
    x = kept.x
    k, angle, sx, sy = x[n_free:n_free + 4]
    return Refined(unpack(x[None])[0][0], replace(placement, scale=float(np.exp(k)), angle=float(angle),
                                                  shift=complex(sx, sy) * unit,
                                                  phase=placement.phase if timed is None else float(x[-1] % 1.0)),
                   kept.error, kept.history)
