"""``linkedit synthesize``: from a target curve to a working linkage.

1. the target (one curve) is moved into its unit frame (centred, its largest side 1: the fit is
   scale-free, the same in any units), optionally smoothed, and described like any curve;
2. the atlas index gives the nearest ``POOL`` linkages by the index descriptor (those that turn
   with the singularity margin asked for: a transmission band [μ, 180° − μ], d_s ≥ sin² μ);
3. they are re-simulated and re-ranked by the full curve distance (every term, mirror images
   included), each placed onto the target by the aligning similarity transform;
4. the best ``top`` distinct candidates are refined (:mod:`linkedit.synthesis.refine`) inside that
   band;
5. the best working result is placed in the target's frame at the crank phase where its
   tracked point is nearest the target's first point (with timing: at the first sample's phase),
   polished through ``edit`` when that helps (:mod:`linkedit.synthesis.polish`), and its
   errors are measured on its ``simulate`` in the target's frame and units.

Precision points (``--points``, or a closed target of few, unevenly spaced points:
:mod:`linkedit.synthesis.points`) are not a polygon: the error is each point's distance to the whole
curve over the points' RMS radius; the pool is ranked and placed by it, the refinement minimizes it,
and the polish (whose distance runs from the curve to the target polygon) is skipped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import ModuleType

import numpy as np

from linkedit.curves.compare import describe_curves, placements
from linkedit.curves.descriptors import Descriptors, describe
from linkedit.curves.distance import term_distances, weighted
from linkedit.curves.partial import COARSE, partial_placement, partial_rms
from linkedit.curves.smooth import smooth as smooth_curve
from linkedit.curves.sources import Curve
from linkedit.errors import InputError, MechanismError
from linkedit.planar import compile_plan, feasibility, simulate
from linkedit.planar.simulate import Motion
from linkedit.spec.geometry3d import MAX_COORDINATE
from linkedit.spec.linkage import LinkageSpec, LinkTrack
from linkedit.synthesis import points as precision
from linkedit.synthesis.atlas import Atlas
from linkedit.synthesis.families import family
from linkedit.synthesis.index import Hit, Index, target_variants
from linkedit.synthesis.polish import Polish, measure, polish
from linkedit.synthesis.refine import ITERATIONS, Frame, Placement, Refined, curve_error, refine, timed_error
from linkedit.synthesis.shortlist import diverse, union, within
from linkedit.synthesis.timed import SAMPLES as TIMED_SAMPLES
from linkedit.synthesis.timed import TimedTarget, timed_fit, timed_target

#: Candidates taken from the index for re-ranking (closed targets; open ones take more and re-rank them by
#: partial matching: OPEN_POOL of the arc retraced there and back, as many of it closed by its chord, whose
#: descriptors are near those of a long arc's whole curve).
POOL = 64
OPEN_POOL = 512
#: With --timing: candidates taken from the index (a close shape may have the wrong timing).
TIMED_POOL = 512
#: Precision points: candidates taken from the index, placed and ranked by the point distances (points on an open
#: arc: as many from each of the open curve's two queries).
POINTS_POOL = 256
#: Open targets: candidates ranked on the fine partial grid after the coarse screening.
SCREENED = 48
#: Samples of the final check and of the written result.
RESULT_SAMPLES = 360
#: Precision points: samples of each candidate's curve placed and ranked on them.
RANK_SAMPLES = 64
#: Precision points: trust-region iterations per candidate (their residuals are few and cheap).
POINT_ITERATIONS = 200
#: Precision points: SCREEN × --top distinct candidates are refined for SCREEN_ITERATIONS first, and the best
#: --top of them go on (a start outside the right basin stalls in a nearby linkage, so more starts are tried).
SCREEN = 4
SCREEN_ITERATIONS = 30
#: Normalized RMS error above which the result carries a note that no family draws the target well.
POOR = 0.03
#: The transmission band's edge μ (degrees) by default: the atlas families' own margin, d_s ≥ sin² μ.
MARGIN_DEG = 20.0
#: A result whose min d_s is within this factor of the margin lies on it (the note then names --margin).
ON_MARGIN = 1.02


@dataclass
class Candidate:
    family: str
    row: int
    params: np.ndarray
    index_distance: float
    distance: float  #: full curve distance to the target (normalized curves)
    placement: Placement
    before: tuple[float, float] = (np.inf, np.inf)  #: (RMS, max) error as placed from the atlas
    refined: Refined | None = None
    after: tuple[float, float] = (np.inf, np.inf)
    #: with --timing: (RMS, max) error of the positions at the target's times, as placed and refined
    timed_before: tuple[float, float] | None = None
    timed_after: tuple[float, float] | None = None
    #: precision points: the screening's short refinement, where the full one starts
    start: Refined | None = None


@dataclass
class Synthesis:
    target: Curve
    #: the target's size (major extent; precision points: their RMS radius; input units): errors are over it
    size: float
    #: (M, 2) the target the errors are measured against, input units: ``target.points`` smoothed with --smooth
    points: np.ndarray
    smooth: float  #: the --smooth width σ (a fraction of the points; 0: not smoothed)
    candidates: list[Candidate]
    best: Candidate
    spec: LinkageSpec
    motion: Motion
    seconds: dict[str, float] = field(default_factory=dict)
    note: str = ""
    #: (RMS, max) error of the written result (``spec`` simulated), over the target's size: its shape,
    #: and with --timing its positions at the target's times
    error: tuple[float, float] = (np.inf, np.inf)
    timed_error: tuple[float, float] | None = None
    polish: Polish | None = None  #: the final polish through `edit` (closed targets)
    margin_deg: float = MARGIN_DEG  #: the transmission band's edge μ the result keeps (d_s ≥ sin² μ)
    #: precision points: why the target is taken for them ("given (--points)" or "detected: …"); None: a curve
    points_mode: str | None = None
    #: precision points: each point's distance (N,) to the written result's curve (input units)
    point_distances: np.ndarray | None = None


def target_frame(target: Curve) -> Frame:
    """The frame of ``target`` (input units): its bounding box's centre and largest side. An InputError
    (exit 2) naming the magnitude if a coordinate exceeds ``MAX_COORDINATE`` or the curve is less than
    1/``MAX_COORDINATE`` across: the written linkage's lengths squared would leave the float range."""
    points = target.points[:, :2]
    lo, hi = points.min(axis=0), points.max(axis=0)
    largest = float(np.max(np.abs(points)))
    if largest > MAX_COORDINATE:
        raise InputError(f"coordinates up to {largest:.1e}: synthesize takes |x|, |y| ≤ {MAX_COORDINATE:.0e} "
                         "(give the target in other units)", file=target.origin)
    side = float(np.max(hi - lo))
    if side < 1.0 / MAX_COORDINATE:
        raise InputError(f"the target is only {side:.1e} across: synthesize takes curves at least "
                         f"{1.0 / MAX_COORDINATE:.0e} across (give it in other units)", file=target.origin)
    centre = 0.5 * lo + 0.5 * hi
    return Frame(complex(centre[0], centre[1]), side)


def in_frame(spec: LinkageSpec, frame: Frame) -> LinkageSpec:
    """The linkage ``spec`` (unit frame) in ``frame``'s input units: every position moved, every length scaled."""
    def place(p: tuple[float, float]) -> tuple[float, float]:
        return (frame.centre.real + frame.scale * p[0], frame.centre.imag + frame.scale * p[1])

    tracks = {name: t.model_copy(update={"at": place(t.at)}) if isinstance(t, LinkTrack) else t
              for name, t in spec.tracks.items()}
    motor = spec.motor if spec.motor.stroke is None else \
        spec.motor.model_copy(update={"stroke": tuple(frame.scale * s for s in spec.motor.stroke)})
    return spec.model_copy(update={"joints": {k: place(p) for k, p in spec.joints.items()}, "tracks": tracks,
                                   "motor": motor})


def target_size(points: np.ndarray, closed: bool) -> float:
    """The target's major extent (input units), as :mod:`linkedit.curves.normalize` measures it."""
    return float(describe(points[None], closed).normalized.scale[0])


def margin_of(margin_deg: float) -> float:
    """The singularity margin sin² μ of the transmission band [μ, 180° − μ], μ = ``margin_deg`` (degrees)."""
    if not 0.0 < margin_deg < 90.0:
        raise InputError(f"the transmission band's edge must lie between 0° and 90° (got {margin_deg:g}°)",
                         field="--margin")
    return feasibility.margin_of(margin_deg)


def synthesize(target: Curve, atlas: Atlas, index: Index | None = None, *, top: int = 5, smooth: float = 0.0,
               timing: bool = False, margin_deg: float = MARGIN_DEG, seed: int = 1, name: str = "synthesized",
               units: str = "mm", points: bool | None = None) -> Synthesis:
    """Find, place and refine linkages drawing ``target``; MechanismError if none survives.

    ``timing``: the target's sample times count (:mod:`linkedit.synthesis.timed`): candidates are
    ranked, placed and refined by positions and velocities at those times, and the result's rest
    pose is the target's first sample. ``margin_deg``: every candidate, iterate and the result keep
    the transmission angle (every rebuilt joint's angle) within [μ, 180° − μ], d_s ≥ sin² μ; below
    the atlas's 20° the refinement may leave the atlas's band, trading transmission for accuracy.
    ``points``: the target is precision points (:mod:`linkedit.synthesis.points`), or a curve (False); None:
    a closed target of few, unevenly spaced points is taken for them unless ``timing`` or ``smooth`` is asked."""
    margin_of(margin_deg)  # a band outside (0°, 90°) is an input error
    clock = {"start": time.perf_counter()}
    frame = target_frame(target)
    z = frame.unit(target.points)
    if points and (timing or smooth > 0):
        raise InputError("precision points are matched at any crank phase and not smoothed: --points takes "
                         "neither --timing nor --smooth", field="--points")
    swings = [n for n in atlas.families if getattr(family(n), "swing", None) is not None] if timing else []
    if swings:
        raise InputError(f"family {swings[0]!r} swings its input out and back (an oscillating crank or a linear "
                         "input): a spec's motion starts at the swing's start, not at a fitted phase; "
                         "synthesize its path without --timing", field="--timing")
    mode = ("given (--points)" if points else None if points is False or timing or smooth > 0
            else precision.detect(z, target.closed))
    unit = replace(target, points=smooth_curve(np.stack([z.real, z.imag], axis=1), target.closed, smooth),
                   anchor=None)
    found = _search(unit, atlas, index, top=top, timing=timing, margin_deg=margin_deg, name=name, units=units, clock=clock, frame=frame, points=mode is not None)
    for c in found.candidates:
        c.placement = frame.place(c.placement)
        if c.refined is not None:
            c.refined.placement = frame.place(c.refined.placement)
    centre = np.array([frame.centre.real, frame.centre.imag])
    return replace(found, target=target, size=found.size * frame.scale, smooth=smooth,
                   points=centre + frame.scale * unit.points, points_mode=mode,
                   point_distances=None if found.point_distances is None else found.point_distances * frame.scale)


def _search(target: Curve, atlas: Atlas, index: Index | None, *, top: int, timing: bool, margin_deg: float,
            name: str, units: str, clock: dict[str, float], frame: Frame, points: bool) -> Synthesis:
    """:func:`synthesize` on the (smoothed) target in its unit frame; the result's spec and simulation in ``frame``."""
    pts = target.points
    z_target = pts[:, 0] + 1j * pts[:, 1]
    size = precision.rms_radius(z_target) if points else target_size(pts, target.closed)
    timed = timed_target(z_target, target.times, target.period, target.closed, size, target.origin) if timing else None
    index = index or Index(atlas)
    asked = precision.spline(z_target, target.closed) if points else z_target
    closed_target = asked if target.closed else np.concatenate([asked, asked[-2:0:-1]])
    pool = TIMED_POOL if timed else POINTS_POOL if points else POOL if target.closed else OPEN_POOL
    hits = index.query(target_variants(closed_target), pool)
    if not (target.closed or timed):  # and closed by its chord: a long arc's descriptors are its curve's
        hits = union(hits, index.query(target_variants(asked), pool))
    hits = within(hits, atlas, margin_deg)
    clock["query"] = time.perf_counter()
    if points:
        chosen = _screened(_point_candidates(z_target, hits, atlas, SCREEN * top), z_target, size, margin_deg, top)
        return _finish(target, z_target, size, chosen, None, clock, name, units, margin_deg, frame, points=True)
    if timed is not None:
        return _finish(target, z_target, size, _timed_candidates(timed, hits, atlas, top), timed, clock, name, units,
                       margin_deg, frame)

    t_desc = describe_curves([target])
    candidates: list[Candidate] = []
    curve_of: dict[int, tuple[Descriptors, int]] = {}  # id(candidate) → its curve, for placing it below
    for fam_name in dict.fromkeys(h.family for h in hits):
        fam = family(fam_name)
        mine = [h for h in hits if h.family == fam_name]
        params = atlas.families[fam_name]["params"][[h.row for h in mine]]
        z = fam.curves(params, RESULT_SAMPLES)
        desc = describe(np.stack([z.real, z.imag], axis=2), True)
        if target.closed:
            terms = term_distances(t_desc, desc, mirror=True)
            dist = weighted(terms, dict.fromkeys(terms, 1.0))[0]
        else:  # screen with the coarse partial grid, rank the best with the fine one
            dist = partial_rms(t_desc.points, desc.points, mirror=True, grid=COARSE)[0]
            best = np.argsort(dist)[:SCREENED]
            dist[best] = partial_rms(t_desc.points, desc.points[best], mirror=True)[0]
            dist[np.setdiff1d(np.arange(len(dist)), best)] = np.inf
        for k, (h, p, d) in enumerate(zip(mine, params, dist)):
            c = Candidate(fam_name, h.row, p, h.distance, float(d), Placement(1.0, 0.0, 0j, False))
            candidates.append(c)
            curve_of[id(c)] = (desc, k)
    candidates.sort(key=lambda c: c.distance)
    chosen = diverse(candidates, top)
    for c in chosen:
        desc, k = curve_of[id(c)]
        if target.closed:
            c.placement = _placement(placements(t_desc, desc.take([k]), mirror=True)[0])
            continue
        c.placement = _partial_placement(t_desc, desc, k)
        if not np.isfinite(c.distance):  # a distinct one from beyond the SCREENED: its fine distance too
            c.distance = float(partial_rms(t_desc.points, desc.points[[k]], mirror=True)[0][0])
    chosen.sort(key=lambda c: c.distance)
    return _finish(target, z_target, size, chosen, None, clock, name, units, margin_deg, frame)


def _point_candidates(z: np.ndarray, hits: list[Hit], atlas: Atlas, top: int) -> list[Candidate]:
    """The index hits placed on the precision points ``z`` (N,) complex and ranked by their RMS distance to the
    points (:func:`linkedit.synthesis.points.fit`, over the points' RMS radius); the best ``top`` distinct ones."""
    candidates: list[Candidate] = []
    radius = precision.rms_radius(z)
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = [h for h in hits if h.family == fam_name]
        params = atlas.families[fam_name]["params"][[h.row for h in mine]]
        with np.errstate(invalid="ignore"):
            dist, alpha, beta, mirrored = precision.fit(z, family(fam_name).curves(params, RANK_SAMPLES))
        for h, p, d, a, b, m in zip(mine, params, dist, alpha, beta, mirrored):
            place = Placement(float(abs(a)), float(np.angle(a)), complex(b), bool(m))
            candidates.append(Candidate(fam_name, h.row, p, h.distance, float(d) / radius, place))
    candidates.sort(key=lambda c: c.distance)
    return diverse(candidates, top)


def _screened(candidates: list[Candidate], z: np.ndarray, size: float, margin_deg: float,
              top: int) -> list[Candidate]:
    """The ``top`` candidates best after SCREEN_ITERATIONS of refinement on the precision points ``z``, in that
    order, each with its short refinement as ``start``."""
    for c in candidates:
        fam = family(c.family)
        c.start = refine(fam, c.params, c.placement, z, True, size, margin=fam.margin(margin_deg), points=True,
                         iterations=SCREEN_ITERATIONS)
    kept = sorted((c for c in candidates if c.start is not None and np.isfinite(c.start.error)),
                  key=lambda c: c.start.error if c.start is not None else np.inf)
    return kept[:top] or candidates[:top]


def _point_error(fam_name: str, params: np.ndarray, place: Placement, z: np.ndarray,
                 size: float) -> tuple[float, float]:
    """(RMS, max) exact distance of the precision points ``z`` (N,) complex to the placed curve, over ``size``."""
    factor = np.array([place.scale * np.exp(1j * place.angle)])
    d = precision.family_closest(family(fam_name), params[None], factor, np.array([place.shift]), place.mirrored, z)
    return precision.error(d[0], size) if np.isfinite(d).all() else (np.inf, np.inf)


def _exact(fam: ModuleType, refined: Refined, z: np.ndarray, size: float, margin: float) -> Refined:
    """The refined linkage polished by Gauss–Newton onto the precision points ``z`` (N,) complex
    (:func:`linkedit.synthesis.points.newton`), kept working with ``margin``, where that lowers its exact RMS point
    distance; else ``refined`` itself."""
    place = refined.placement
    found = precision.newton(fam, refined.params, place.scale * np.exp(1j * place.angle), place.shift, place.mirrored,
                             z, margin)
    if found is None:
        return refined
    params, factor, shift = found
    polished = replace(place, scale=abs(factor), angle=float(np.angle(factor)), shift=shift)
    rms = _point_error(fam.NAME, params, polished, z, size)[0]
    before = _point_error(fam.NAME, refined.params, place, z, size)[0]
    if not rms < before:
        return refined
    return Refined(params, polished, rms, refined.history + [rms])


def _timed_candidates(timed: TimedTarget, hits: list, atlas: Atlas, top: int) -> list[Candidate]:
    """The index hits re-ranked and placed by the timed distance; the best ``top`` distinct ones."""
    candidates: list[Candidate] = []
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = [h for h in hits if h.family == fam_name]
        params = atlas.families[fam_name]["params"][[h.row for h in mine]]
        with np.errstate(invalid="ignore"):
            fit = timed_fit(timed, family(fam_name).curves(params, TIMED_SAMPLES))
        for k, (h, p) in enumerate(zip(mine, params)):
            place = Placement(float(fit.scale[k]), float(fit.angle[k]), complex(fit.shift[k]), bool(fit.mirrored[k]),
                              float(fit.phase[k]), bool(fit.reversed[k]))
            distance = float(fit.distance[k]) if np.isfinite(fit.distance[k]) else np.inf
            candidates.append(Candidate(fam_name, h.row, p, h.distance, distance, place))
    candidates.sort(key=lambda c: c.distance)
    return diverse(candidates, top)


def _finish(target: Curve, z_target: np.ndarray, size: float, chosen: list[Candidate], timed: TimedTarget | None,
            clock: dict[str, float], name: str, units: str, margin_deg: float, frame: Frame,
            points: bool = False) -> Synthesis:
    """Refine the chosen candidates (unit frame), keep the best working one, write its spec in ``frame`` and
    check it by ``simulate``."""
    clock["rank"] = time.perf_counter()
    for c in chosen:
        fam = family(c.family)
        margin = fam.margin(margin_deg)
        with np.errstate(invalid="ignore"):
            curve = c.placement.apply(fam.curves(c.params[None], RESULT_SAMPLES)[0])
            c.before = (_point_error(c.family, c.params, c.placement, z_target, size) if points
                        else curve_error(z_target, target.closed, curve, size))
            if timed is not None:
                c.timed_before = timed_error(timed, fam, c.params, c.placement)
        start = c.start or Refined(c.params, c.placement, np.inf)
        c.refined = refine(fam, start.params, start.placement, z_target, target.closed, size, margin=margin,
                           timed=timed, points=points, iterations=POINT_ITERATIONS if points else ITERATIONS)
        c.refined.history[:0] = start.history
        if points and np.isfinite(c.refined.error):
            c.refined = _exact(fam, c.refined, z_target, size, margin)
        if np.isfinite(c.refined.error):
            curve = c.refined.placement.apply(fam.curves(c.refined.params[None], RESULT_SAMPLES)[0])
            c.after = (_point_error(c.family, c.refined.params, c.refined.placement, z_target, size) if points
                       else curve_error(z_target, target.closed, curve, size))
            if timed is not None:
                c.timed_after = timed_error(timed, fam, c.refined.params, c.refined.placement)
    clock["refine"] = time.perf_counter()
    working = [c for c in chosen if c.refined is not None and np.isfinite(c.after[0])]
    if not working:
        raise MechanismError(f"none of the {len(chosen)} candidates kept working through refinement "
                             "(the atlas's linkages do not turn with its margin: rebuild it with `linkedit atlas build`)")
    best = min(working, key=lambda c: c.after[0] if timed is None or c.timed_after is None else c.timed_after[0])
    spec = result_spec(best, z_target[0], name=name, units=units, timed=timed is not None, description="")
    refined = best.after if timed is None else best.timed_after
    assert refined is not None
    margin = family(best.family).margin(margin_deg)
    polished = None
    if points:
        polished = Polish(False, "precision points are not polished: the edit's follow distance runs from the "
                                 "linkage's curve to the target polygon, not from each point to the curve")
    elif target.closed:  # the final polish through `edit` (kept only if it lowers the error within the margin)
        polished = polish(spec, z_target, size, refined, margin, RESULT_SAMPLES, timed)
        if polished.kept:
            assert polished.spec is not None
            spec = polished.spec
    clock["polish"] = time.perf_counter()
    spec = in_frame(spec, frame)
    motion = simulate(compile_plan(spec), RESULT_SAMPLES)
    shape = curve_error(z_target, target.closed, frame.unit(motion.tracks["target"].position), size)
    point_distances = None
    if points:  # each point's exact distance to result.yaml's curve (the refined linkage: points are not polished)
        assert best.refined is not None
        place = best.refined.placement
        point_distances = precision.family_closest(family(best.family), best.refined.params[None],
                                                   np.array([place.scale * np.exp(1j * place.angle)]),
                                                   np.array([place.shift]), place.mirrored, z_target)[0]
        shape = precision.error(point_distances, size)
    timed_final = None if timed is None else measure(spec, z_target, size, RESULT_SAMPLES, timed, frame)[0]
    error = shape[0] if timed_final is None else timed_final[0]
    spec = spec.model_copy(update={"description": f"Synthesized by linkedit from {target.origin}: {best.family} "
                                                  f"(atlas row {best.row}), normalized RMS error {error:.3g}"
                                                  f"{' at the target times' if timed is not None else ''}."})
    clock["check"] = time.perf_counter()
    note = ""
    if error > POOR:
        against = "the points' RMS radius" if points else "the target's size"
        note = (f"no family in the atlas draws this curve well{' with its timing' if timed is not None else ''}: "
                f"the best found is off by {100 * error:.1f} % of {against} (RMS)")
        worst = motion.min_singularity()
        if worst is not None and worst[0] <= ON_MARGIN * margin:
            note += (f"; it lies on the transmission band's edge ({margin_deg:g}°): a smaller --margin trades "
                     "transmission quality for accuracy")
    seconds = {"query": clock["query"] - clock["start"], "rank": clock["rank"] - clock["query"],
               "refine": clock["refine"] - clock["rank"], "polish": clock["polish"] - clock["refine"],
               "check": clock["check"] - clock["polish"], "total": clock["check"] - clock["start"]}
    return Synthesis(target, size, target.points, 0.0, chosen, best, spec, motion, seconds, note, shape, timed_final,
                     polished, margin_deg, point_distances=point_distances)


def _placement(place: dict) -> Placement:
    """A ranking's placement (:func:`linkedit.curves.compare.placements`) as a :class:`Placement`."""
    return Placement(place["scale"], float(np.radians(place["rotation_deg"])), complex(*place["translation"]),
                     place["mirrored"])


def _partial_placement(target: Descriptors, library: Descriptors, k: int) -> Placement:
    """Where the open target fits best along library curve ``k``, as a placement of the library curve."""
    _, alpha, beta, mirrored = partial_placement(target.points[0], library.points[k], mirror=True)
    t, lib = target.normalized, library.normalized
    f_t = t.frame[0, 0, 0] + 1j * t.frame[0, 1, 0]
    f_l = lib.frame[k, 0, 0] + 1j * lib.frame[k, 1, 0]
    c_t, c_l = complex(*t.centroid[0]), complex(*lib.centroid[k])
    a = t.scale[0] * f_t * alpha * (f_l if mirrored else np.conj(f_l)) / lib.scale[k]
    b = c_t + t.scale[0] * f_t * beta - a * (np.conj(c_l) if mirrored else c_l)
    return Placement(float(abs(a)), float(np.angle(a)), complex(b), mirrored)


def result_spec(c: Candidate, start: complex, *, name: str, units: str, description: str,
                timed: bool = False) -> LinkageSpec:
    """The refined candidate placed in the target's frame, its rest pose at the crank phase where
    the tracked point is nearest the target's first point ``start`` (``timed``: the fitted phase
    of the target's first sample, the motor reversed when the fit runs the crank backwards)."""
    fam = family(c.family)
    assert c.refined is not None
    place = c.refined.placement
    if timed:
        phase = place.phase
    else:
        curve = place.apply(fam.curves(c.refined.params[None], 3600)[0])
        phase = float(np.argmin(np.abs(curve - start))) / 3600  # mirrored: the motor turns cw, the same family phase
    return fam.to_spec(c.refined.params, phase=phase, scale=place.scale, turn=np.exp(1j * place.angle),
                       shift=place.shift, mirrored=place.mirrored, reversed=timed and place.reversed, name=name,
                       units=units, description=description)
