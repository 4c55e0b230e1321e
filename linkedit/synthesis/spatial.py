"""``linkedit synthesize`` of a 3D target (x, y, z): which spatial linkage draws this curve?

1. the target (a closed curve, or an open arc: closure is told from the geometry as for planar targets,
   :func:`linkedit.curves.sources.is_closed`) is moved into its unit frame (centred on its bounding box, its
   largest side 1: the fit is scale-free);
2. the atlas index (:func:`~linkedit.synthesis.chunks.index_efd`: the EFDs of the curve's projection onto its
   principal plane, the descriptor ``linkedit features`` computes for 3D curves) gives the nearest ``POOL``
   linkages of the atlas's spatial families (:mod:`~linkedit.synthesis.spherical`, :mod:`~linkedit.synthesis.rssr`)
   that turn with the singularity margin; an open arc, whose whole-cycle descriptor says little about which
   cycles hold a stretch like it, takes ``SCREEN_POOL`` for each of its descriptors (closed by its chord,
   retraced there and back) and keeps the ``OPEN_POOL`` best by partial matching on the atlas's stored coarse
   curves (:data:`~linkedit.curves.partial.SCREEN`);
3. they are re-ranked by the full 3D curve distance (:func:`linkedit.curves.distance.term_distances`, pose
   normalized: invariant to the target's rotation, translation and scale, mirror images included) and each
   of the best ``top`` distinct ones is placed on the target by its aligning similarity
   (:func:`linkedit.curves.compare.placements`: p ↦ shift + scale·matrix·p, matrix orthogonal); an open arc
   by the best-fitting stretch of each candidate's cycle instead (:func:`linkedit.curves.partial.partial_rms`,
   :func:`~linkedit.curves.partial.partial_placement3`, as planar open targets);
4. each is refined by least squares on the closed form: the family parameters (the branch stays) and the
   placement (log scale, a rotation vector, the shift) against the two-sided point-to-curve distances (an open
   arc: the arc's distances to the cycle only, it may be part of it), every kept iterate turning with the margin
   (:func:`linkedit.planar.feasibility.works`);
5. the best is written as a 3D mechanism spec (its rest pose at the crank phase nearest the target's
   first point, track ``target``), solved by ``solve3d``'s solver (:func:`linkedit.gcs.solve_spec`), and
   its errors are measured on that solution: what ``linkedit solve3d result.yaml`` gives; ``overlay.svg`` draws
   the target, the atlas candidate as placed and the result face-on to the curves' plane
   (:func:`linkedit.io.gcs_svg.overlay`), ``history.svg`` the refinement as for planar targets.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from linkedit import __version__
from linkedit.curves.compare import placements
from linkedit.curves.descriptors import describe
from linkedit.curves.distance import term_distances, weighted
from linkedit.curves.partial import COARSE, SCREEN, partial_placement3, partial_rms
from linkedit.curves.polyline import arc_resample, near_distances
from linkedit.curves.sources import Curve
from linkedit.errors import InputError, MechanismError
from linkedit.gcs import GcsResult, check_solved, solve_spec
from linkedit.io.atomic import write_text
from linkedit.io.gcs_hdf5 import write_result
from linkedit.io.gcs_svg import Curve3, overlay
from linkedit.planar.feasibility import works
from linkedit.spec.geometry3d import MAX_COORDINATE
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_yaml, validate
from linkedit.synthesis.atlas import Atlas
from linkedit.synthesis import chunks
from linkedit.synthesis.chunks import coarse_curves, dimension
from linkedit.synthesis.families import family
from linkedit.synthesis.index import Index, target_variants
from linkedit.synthesis.outputs import DRAWN, history_chart
from linkedit.synthesis.refine import POINTS, SAMPLES, WALL, curve_error, kept_least_squares
from linkedit.synthesis.shortlist import diverse, within
from linkedit.synthesis.synthesize import MARGIN_DEG, POOR, SCREENED, margin_of

FILES = ("result.yaml", "result.h5", "overlay.svg", "history.svg", "report.json")
#: Candidates taken from the index for re-ranking (closed targets; an open arc, whose index descriptor is that
#: of the arc closed by its chord, takes more and re-ranks them by partial matching: the coarse grid, then the
#: fine one on the best ``SCREENED``).
POOL = 256
OPEN_POOL = 512
#: An open arc's index candidates (each of its two descriptors: closed by its chord, retraced there and back),
#: screened by partial matching on the atlas's stored coarse curves (:data:`~linkedit.curves.partial.SCREEN`)
#: down to the ``OPEN_POOL`` re-ranked: the index describes whole cycles, and the linkages with the best
#: stretch for an arc are often far down its ranking.
SCREEN_POOL = 2048
#: Crank samples of each candidate's curve when it is re-ranked.
RANK_SAMPLES = 128
#: Trust-region evaluations per candidate.
ITERATIONS = 60
#: Time steps of the written spec (t = 0 and 1 both: 360 distinct crank angles).
STEPS = 361


def restrict(atlas: Atlas, dim: int) -> Atlas:
    """The part of ``atlas`` holding its planar (``dim`` 2) or spatial (3) families; an InputError (exit 2)
    when it has none."""
    kept = {n: v for n, v in atlas.families.items() if dimension(family(n)) == dim and len(v["params"])}
    if not kept:
        kinds = "spatial (spherical-four-bar, rssr)" if dim == 3 else "planar"
        raise InputError(f"the atlas holds no {kinds} family for a {dim}D target "
                         f"(build one with `linkedit atlas build --family ...`)", file=str(atlas.path))
    return Atlas(atlas.path, kept, atlas.seed)


@dataclass
class Placement3:
    """p ↦ shift + scale·matrix·p (``matrix`` orthogonal, det ±1)."""

    scale: float
    matrix: np.ndarray  #: (3, 3)
    shift: np.ndarray  #: (3,)

    def apply(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) placed."""
        return self.shift + self.scale * p @ self.matrix.T


@dataclass
class Candidate3:
    family: str
    row: int
    params: np.ndarray
    index_distance: float
    distance: float  #: 3D curve distance to the target (normalized curves)
    placement: Placement3 | None = None
    before: tuple[float, float] = (np.inf, np.inf)  #: (RMS, max) error as placed from the atlas
    refined: np.ndarray | None = None  #: refined parameters
    refined_placement: Placement3 | None = None
    after: tuple[float, float] = (np.inf, np.inf)
    history: list[float] = field(default_factory=list)


@dataclass
class SpatialSynthesis:
    target: Curve
    size: float  #: the target's major extent (input units): errors are over it
    candidates: list[Candidate3]
    best: Candidate3
    text: str  #: result.yaml
    result: GcsResult  #: result.yaml solved
    error: tuple[float, float]  #: (RMS, max) of the solved track against the target, over ``size``
    seconds: dict[str, float]
    note: str = ""
    margin_deg: float = MARGIN_DEG


def _frame(target: Curve) -> tuple[np.ndarray, float]:
    """The target's bounding-box centre (3,) and largest side; InputError naming the magnitude if the
    written mechanism's coordinates would leave the range a spec takes."""
    p = target.points
    largest = float(np.max(np.abs(p)))
    if largest > MAX_COORDINATE:
        raise InputError(f"coordinates up to {largest:.1e}: synthesize takes |x|, |y|, |z| ≤ {MAX_COORDINATE:.0e} "
                         "(give the target in other units)", file=target.origin)
    side = float(np.max(p.max(axis=0) - p.min(axis=0)))
    if side < 1.0 / MAX_COORDINATE:
        raise InputError(f"the target is only {side:.1e} across: give it in other units", file=target.origin)
    return 0.5 * p.min(axis=0) + 0.5 * p.max(axis=0), side


def synthesize3d(target: Curve, atlas: Atlas, index: Index | None = None, *, top: int = 5,
                 margin_deg: float = MARGIN_DEG, name: str = "synthesized", units: str = "mm") -> SpatialSynthesis:
    """Find, place and refine spatial linkages drawing the 3D ``target`` (a closed curve or an open arc); write
    nothing. ``index``: the search of ``atlas`` (a cluster's, :mod:`~linkedit.synthesis.shard_search`), else an
    in-process :class:`Index` of its spatial families. MechanismError if none survives, or if the written spec
    does not solve."""
    margin = margin_of(margin_deg)
    clock = {"start": time.perf_counter()}
    centre, side = _frame(target)
    unit = (target.points - centre) / side
    closed = target.closed
    spatial = restrict(atlas, 3)
    index = index or Index(spatial)
    hits = (within(index.query(target_variants(unit), POOL), spatial, margin_deg) if closed
            else _screened(unit, spatial, index, margin_deg))
    clock["query"] = time.perf_counter()
    t_desc = describe(unit[None], closed)
    size = float(t_desc.normalized.scale[0])  # unit frame
    ranked = (_ranked if closed else _ranked_open)(t_desc, unit, size, hits, spatial)
    ranked.sort(key=lambda c: c.distance)
    chosen = diverse(ranked, top)
    if not closed:
        for c in chosen:
            _, scale, matrix, shift = partial_placement3(arc_resample(unit, POINTS, False),
                                                        family(c.family).curves(c.params[None], RANK_SAMPLES)[0],
                                                        mirror=True)
            c.placement = Placement3(scale, matrix, shift)
    clock["rank"] = time.perf_counter()
    for c in chosen:
        fam = family(c.family)
        assert c.placement is not None
        with np.errstate(invalid="ignore"):
            c.before = curve_error(unit, closed, c.placement.apply(fam.curves(c.params[None], SAMPLES)[0]), size)
        refine3d(fam, c, unit, size, margin, closed=closed)
    clock["refine"] = time.perf_counter()
    working = [c for c in chosen if c.refined is not None and np.isfinite(c.after[0])]
    if not working:
        raise MechanismError(f"none of the {len(chosen)} candidates kept working through refinement "
                             "(rebuild the atlas with `linkedit atlas build`)")
    best = min(working, key=lambda c: c.after[0])
    for c in chosen:  # placements in input units from here on
        for attr in ("placement", "refined_placement"):
            p = getattr(c, attr)
            if p is not None:
                setattr(c, attr, Placement3(p.scale * side, p.matrix, centre + side * p.shift))
    text = result_text(best, target, name=name, units=units)
    data, lines = load_yaml("result.yaml", text)
    spec = validate(MechanismSpec, data, file="result.yaml", lines=lines)
    solved = solve_spec(spec, spec_text=text)
    check_solved(solved)
    size_in = size * side
    error = curve_error(target.points, closed, solved.tracks["target"].position[:-1], size_in)
    clock["check"] = time.perf_counter()
    note = "" if error[0] <= POOR else (f"no spatial family in the atlas draws this curve well: the best found is off "
                                         f"by {100 * error[0]:.1f} % of the target's size (RMS)")
    seconds = {"query": clock["query"] - clock["start"], "rank": clock["rank"] - clock["query"],
               "refine": clock["refine"] - clock["rank"], "check": clock["check"] - clock["refine"],
               "total": clock["check"] - clock["start"]}
    return SpatialSynthesis(target, size_in, chosen, best, text, solved, error, seconds, note, margin_deg)


def _ranked(t_desc: Any, unit: np.ndarray, size: float, hits: list[Any], spatial: Atlas) -> list[Candidate3]:
    """The hits ranked by the full 3D curve distance to the closed target, each placed by its aligning similarity."""
    ranked: list[Candidate3] = []
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = [h for h in hits if h.family == fam_name]
        params = spatial.families[fam_name]["params"][[h.row for h in mine]]
        desc = describe(family(fam_name).curves(params, RANK_SAMPLES), True)
        terms = term_distances(t_desc, desc, mirror=True)
        dist = weighted(terms, dict.fromkeys(terms, 1.0))[0]
        for k, (h, p, d) in enumerate(zip(mine, params, dist)):
            c = Candidate3(fam_name, h.row, p, h.distance, float(d))
            place = placements(t_desc, desc.take([k]), mirror=True)[0]
            c.placement = Placement3(place["scale"], np.array(place["matrix"]), np.array(place["translation"]))
            ranked.append(c)
    return ranked


def _screened(unit: np.ndarray, spatial: Atlas, index: Any, margin_deg: float) -> list[Any]:
    """The open arc ``unit`` (M, 3)'s hits in ``index`` (``SCREEN_POOL`` for each of its descriptors) that turn with
    the margin, the best ``OPEN_POOL`` by partial matching (:data:`~linkedit.curves.partial.SCREEN`) on the atlas's
    coarse curves (stored in an atlas file; a sharded atlas stores none: made from the params as a build makes
    them), best first."""
    found: dict[tuple[str, int], Any] = {}
    for closure in (unit, np.concatenate([unit, unit[-2:0:-1]])):
        for h in index.query(target_variants(closure), SCREEN_POOL):
            found.setdefault((h.family, h.row), h)
    hits = within(list(found.values()), spatial, margin_deg)
    arc = arc_resample(unit, POINTS, False)[None]
    score = np.empty(len(hits))
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = np.array([k for k, h in enumerate(hits) if h.family == fam_name])
        rows = [hits[k].row for k in mine]
        book = spatial.families[fam_name]
        coarse = (book["curves"][rows] if "curves" in book  # an atlas file's (float32)
                  else coarse_curves(family(fam_name).curves(book["params"][rows], chunks.SAMPLES)).astype(np.float32))
        stored = np.asarray(coarse, dtype=float)  # scored in float64 both ways: a folder ranks as a file
        score[mine] = partial_rms(arc, stored, mirror=True, grid=SCREEN)[0]
    return [hits[k] for k in np.argsort(score, kind="stable")[:OPEN_POOL]]


def _ranked_open(t_desc: Any, unit: np.ndarray, size: float, hits: list[Any], spatial: Atlas) -> list[Candidate3]:
    """The hits ranked by the RMS distance (over ``size``) of the open arc ``unit`` (M, 3) from the best-fitting
    stretch of each one's cycle: the coarse partial grid, then the fine one on the best ``SCREENED``."""
    arc = arc_resample(unit, POINTS, False)[None]
    ranked: list[Candidate3] = []
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = [h for h in hits if h.family == fam_name]
        params = spatial.families[fam_name]["params"][[h.row for h in mine]]
        with np.errstate(invalid="ignore"):
            curves = family(fam_name).curves(params, RANK_SAMPLES)
        dist = partial_rms(arc, curves, mirror=True, grid=COARSE)[0]
        best = np.argsort(dist)[:SCREENED]
        dist[best] = partial_rms(arc, curves[best], mirror=True)[0]
        dist[np.setdiff1d(np.arange(len(dist)), best)] = np.inf
        ranked += [Candidate3(fam_name, h.row, p, h.distance, float(d) / size) for h, p, d in zip(mine, params, dist)]
    return ranked


def refine3d(fam: Any, c: Candidate3, target: np.ndarray, size: float, margin: float,
             iterations: int | None = None, closed: bool = True) -> None:
    """Refine candidate ``c`` (its parameters, the branch fixed, and its placement) against ``target`` (M, 3)
    by scipy's trust-region least squares on the point-to-curve distances over ``size`` (both ways; an open
    target's to the curve only); sets ``c.refined``, ``c.refined_placement``, ``c.after`` and ``c.history``
    (the best working iterate's; an iterate that does not turn with ``margin`` is a wall, never kept)."""
    assert c.placement is not None
    free = np.array([n != "branch" for n in fam.PARAMETERS])
    n_free = int(free.sum())
    goal = arc_resample(target, POINTS, closed)
    outline = arc_resample(target, 4 * POINTS, True) if closed else goal  # the target as the reverse distances see it
    base = c.placement.matrix

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Parameter rows (K, P), scales (K,), matrices (K, 3, 3) and shifts (K, 3) of x (K, n)."""
        p = np.repeat(c.params[None], len(x), axis=0)
        p[:, free] = x[:, :n_free]
        turn = Rotation.from_rotvec(x[:, n_free + 1:n_free + 4]).as_matrix() @ base
        return p, np.exp(x[:, n_free]), turn, x[:, n_free + 4:n_free + 7]

    def residuals(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Working mask (K,) and residuals (K, R): both ways' distances over the size and √R."""
        p, scale, turn, shift = unpack(x)
        with np.errstate(invalid="ignore", over="ignore"):
            curve = shift[:, None] + scale[:, None, None] * fam.curves(p, SAMPLES) @ turn.transpose(0, 2, 1)
            ok = works(fam.min_singularity(p, margin), margin) & np.isfinite(curve).all(axis=(1, 2))
            r = near_distances(np.broadcast_to(goal, (len(x), *goal.shape)), curve)
            if closed:
                good = ok[:, None, None]  # a failed curve (NaN) is resampled as a point and replaced by the goal
                back = np.where(good, arc_resample(np.where(good, curve, 0.0), POINTS, True), goal)
                r = np.concatenate([r, near_distances(back, np.broadcast_to(outline, (len(x), *outline.shape)))],
                                   axis=1)
        r = r / (size * np.sqrt(r.shape[1]))
        ok &= np.isfinite(r).all(axis=1)
        return ok, np.where(ok[:, None], r, WALL)

    x0 = np.concatenate([c.params[free], [np.log(c.placement.scale)], np.zeros(3), c.placement.shift])
    kept = kept_least_squares(residuals, x0, iterations=iterations or ITERATIONS, tol=1e-10,
                              error=lambda r: float(np.sqrt(np.sum(r ** 2))))
    c.history = kept.history
    if not np.isfinite(kept.error):
        return
    p, scale, turn, shift = unpack(kept.x[None])
    c.refined, c.refined_placement = p[0], Placement3(float(scale[0]), turn[0], shift[0])
    with np.errstate(invalid="ignore"):
        c.after = curve_error(target, closed, c.refined_placement.apply(fam.curves(p, SAMPLES)[0]), size)


def result_text(c: Candidate3, target: Curve, *, name: str, units: str) -> str:
    """result.yaml: the refined candidate as a 3D mechanism spec in the target's frame and units, its rest pose
    at the crank phase where the tracked point is nearest the target's first point."""
    fam = family(c.family)
    place = c.refined_placement
    assert c.refined is not None and place is not None
    curve = place.apply(fam.curves(c.refined[None], 3600)[0])
    phase = float(np.argmin(np.linalg.norm(curve - target.points[0], axis=1))) / 3600
    spec = fam.to_spec(c.refined, phase=phase, scale=place.scale, matrix=place.matrix, shift=place.shift, name=name,
                       units=units, description=f"Synthesized by linkedit from {target.origin}: {c.family} "
                                                f"(atlas row {c.row}).")
    spec["outputs"]["steps"] = STEPS
    header = ("# Synthesized by linkedit synthesize; solve it with:\n"
              "#   linkedit solve3d result.yaml   (track 'target' draws the curve)\n")
    return header + yaml.dump(spec, Dumper=_Dumper, sort_keys=False, default_flow_style=None, allow_unicode=True,
                              width=120)


class _Dumper(yaml.SafeDumper):
    """YAML without anchors and aliases (a point shared by two shapes is written twice)."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def write_all(out: Path, result: SpatialSynthesis, options: dict[str, Any]) -> dict[str, Any]:
    """result.yaml, result.h5 (its solution, ``specs/gcs-hdf5.md``), overlay.svg, history.svg and report.json
    into ``out`` (every text made before the first file is written); returns the report."""
    report = _report(result, options)
    report_text = json.dumps(report, indent=2, allow_nan=False) + "\n"
    pictures = {"overlay.svg": _overlay(result),
                "history.svg": history_chart([c.history for c in result.candidates],
                                             next(k for k, c in enumerate(result.candidates) if c is result.best))}
    write_text(out / "result.yaml", result.text)
    write_result(out / "result.h5", result.result)
    for name, text in pictures.items():
        write_text(out / name, text)
    write_text(out / "report.json", report_text)
    return report


def _overlay(result: SpatialSynthesis) -> str:
    """overlay.svg: the target dashed, the atlas candidate as placed faint and result.yaml solved (its members and
    the curve its track draws), face-on to the plane of the curves, in the target's units."""
    best = result.best
    assert best.placement is not None
    with np.errstate(invalid="ignore"):
        placed = best.placement.apply(family(best.family).curves(best.params[None], SAMPLES)[0])
    closed = result.target.closed
    curves = [Curve3("target" if closed else "target (open arc)", result.target.points, closed, "dashed")]
    if np.isfinite(placed).all():
        curves.append(Curve3("atlas candidate as placed", placed, True, "faint"))
    return overlay(None, result.result, curves, track_labels={"target": DRAWN},
                   title=f"{best.family}: RMS error {100 * best.before[0]:.2g} % → {100 * result.error[0]:.2g} % "
                         f"of the target's size")


def _row(c: Candidate3) -> dict[str, Any]:
    fam = family(c.family)
    row: dict[str, Any] = {"family": c.family, "atlas_row": c.row, "index_distance": c.index_distance,
                           "curve_distance": c.distance, "error_before": {"rms": c.before[0], "max": c.before[1]},
                           "parameters_before": dict(zip(fam.PARAMETERS, c.params.tolist())), "error_after": None}
    place = c.refined_placement
    if c.refined is not None and place is not None and np.isfinite(c.after[0]):
        row |= {"error_after": {"rms": c.after[0], "max": c.after[1]},
                "parameters_after": dict(zip(fam.PARAMETERS, c.refined.tolist())),
                "placement": {"scale": place.scale, "matrix": place.matrix.tolist(), "translation": place.shift.tolist(),
                              "mirrored": bool(np.linalg.det(place.matrix) < 0)},
                "evaluations": len(c.history)}
    return row


def _report(result: SpatialSynthesis, options: dict[str, Any]) -> dict[str, Any]:
    best = result.best
    solved = result.result
    return {
        "generator": f"linkedit {__version__}",
        "target": {"origin": result.target.origin, "points": len(result.target.points),
                   "closed": bool(result.target.closed),
                   "size": result.size, "units": solved.units, "dimensions": 3},
        "options": options,
        "family": best.family,
        "error": {"before": {"rms": best.before[0], "max": best.before[1]},
                  "refined": {"rms": best.after[0], "max": best.after[1]},
                  "after": {"rms": result.error[0], "max": result.error[1]},
                  "normalized_by": "target size (major extent); RMS over "
                                   + ("target→result and result→target distances, each curve"
                                      if result.target.closed else "target→result distances (an open arc: part of "
                                                                   "the cycle), the target")
                                   + " sampled evenly along its length (the max also over its own points); "
                                   "after: result.yaml solved "
                                   "(linkedit solve3d), its track 'target'"},
        "note": result.note,
        "margin_deg": result.margin_deg,
        "result": {"spec": "result.yaml", "solution": "result.h5", "track": "target", "steps": int(solved.t.size),
                   "max_residual": float(np.max(solved.diagnostics.residual)),
                   "curve": solved.tracks["target"].position.tolist()},
        "candidates": [_row(c) for c in result.candidates],
        "seconds": result.seconds,
    }
