"""The files ``linkedit synthesize`` writes into its output folder (each one atomically).

``result.yaml`` (the linkage, placed in the target's frame, in its units, track ``target``),
``result.h5`` (its simulation, ``specs/planar-hdf5.md``), ``overlay.svg`` (the target the error is
measured against dashed — with --smooth the smoothed one, so named —, the atlas candidate as placed
faint, the refined linkage solid), ``history.svg`` (convergence of every refined candidate: its best
RMS error so far against evaluations, log scale) and ``report.json``. Every file's text is made
before the first is written: a run that fails leaves nothing behind, not even the folder.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from linkedit import __version__
from linkedit.io.atomic import write_text
from linkedit.io.planar_hdf5 import write_motion
from linkedit.io.planar_svg import drawing
from linkedit.io.svg import edit_overlay
from linkedit.io.svg_chart import Panel, chart
from linkedit.planar import compile_plan, simulate
from linkedit.planar.simulate import Motion
from linkedit.spec.linkage_yaml import dump_linkage
from linkedit.synthesis.families import family
from linkedit.synthesis.refine import Refined
from linkedit.synthesis.synthesize import RESULT_SAMPLES, Candidate, Synthesis, result_spec

FILES = ("result.yaml", "result.h5", "overlay.svg", "history.svg", "report.json")


#: The overlay's name for the curve the linkage's track ``target`` draws (its legend entry beside the target's).
DRAWN = "drawn by the linkage"


def write_all(out: Path, result: Synthesis, options: dict[str, Any]) -> dict[str, Any]:
    """Write every file into ``out``; returns the report (also in report.json)."""
    text = dump_linkage(result.spec, header="Synthesized by linkedit synthesize; simulate it with:\n"
                                            "  linkedit simulate result.yaml   (track 'target' draws the curve)")
    overlay, history = _overlay(result), _history(result)
    report = _report(result, options)
    report_text = json.dumps(report, indent=2, allow_nan=False) + "\n"
    write_text(out / "result.yaml", text)
    write_motion(out / "result.h5", result.motion, spec_text=text, options=options | {"command": "synthesize"})
    write_text(out / "overlay.svg", overlay)
    write_text(out / "history.svg", history)
    write_text(out / "report.json", report_text)
    return report


def _candidate_row(c: Candidate) -> dict[str, Any]:
    fam = family(c.family)
    refined = c.refined
    row = {"family": c.family, "atlas_row": c.row, "index_distance": c.index_distance, "curve_distance": c.distance,
           "error_before": {"rms": c.before[0], "max": c.before[1]},
           "timed_error_before": None if c.timed_before is None else {"rms": c.timed_before[0], "max": c.timed_before[1]},
           "parameters_before": dict(zip(fam.PARAMETERS, c.params.tolist()))}
    if refined is not None and np.isfinite(c.after[0]):
        row |= {"error_after": {"rms": c.after[0], "max": c.after[1]},
                "timed_error_after": None if c.timed_after is None else {"rms": c.timed_after[0], "max": c.timed_after[1]},
                "parameters_after": dict(zip(fam.PARAMETERS, refined.params.tolist())),
                "placement": {"scale": refined.placement.scale, "rotation_deg": float(np.degrees(refined.placement.angle)),
                              "translation": [refined.placement.shift.real, refined.placement.shift.imag],
                              "mirrored": refined.placement.mirrored, "motor_reversed": refined.placement.reversed},
                "evaluations": len(refined.history)}
    else:
        row["error_after"] = None
    return row


def _report(result: Synthesis, options: dict[str, Any]) -> dict[str, Any]:
    best = result.best
    track = result.motion.tracks["target"].position
    return {
        "generator": f"linkedit {__version__}",
        "target": {"origin": result.target.origin, "points": len(result.target.points),
                   "closed": bool(result.target.closed), "size": result.size,
                   "units": result.spec.units, "smoothed": result.smooth > 0, "curve": result.points.tolist()},
        "options": options,
        "family": best.family,
        "error": {"before": {"rms": best.before[0], "max": best.before[1]},
                  "refined": {"rms": best.after[0], "max": best.after[1]},
                  "after": {"rms": result.error[0], "max": result.error[1]},
                  "normalized_by": _normalized_by(result)}
        | ({} if result.timed_error is None or best.timed_before is None or best.timed_after is None else {"timed": {
            "before": {"rms": best.timed_before[0], "max": best.timed_before[1]},
            "refined": {"rms": best.timed_after[0], "max": best.timed_after[1]},
            "after": {"rms": result.timed_error[0], "max": result.timed_error[1]},
            "measured": "distance from each target sample to the result at the sample's time (rest pose = first "
                        "sample), over the target size"}}),
        "polish": None if result.polish is None else {
            "kept": result.polish.kept, "why": result.polish.why,
            "error": None if result.polish.error is None else {"rms": result.polish.error[0],
                                                                "max": result.polish.error[1]},
            "min_singularity": result.polish.min_singularity},
        "precision_points": _precision(result),
        "note": result.note,
        "result": {"spec": "result.yaml", "simulation": "result.h5", "track": "target", "samples": RESULT_SAMPLES,
                   "min_singularity": _min_singularity(result.motion),
                   "curve": track.tolist()},
        "candidates": [_candidate_row(c) for c in result.candidates],
        "seconds": result.seconds,
    }


def _normalized_by(result: Synthesis) -> str:
    """What the errors are measured by and over, in words."""
    if result.points_mode is not None:
        return ("the precision points' RMS radius about their centroid; RMS and max over the points of each point's "
                "distance to the linkage's whole curve (any crank phase); after: result.yaml simulated")
    return ("target size (major extent); RMS over target→result and result→target distances, "
            "both curves sampled evenly along their length (the max also over each curve's own points); "
            "after: result.yaml simulated")


def _precision(result: Synthesis) -> dict[str, Any] | None:
    """Precision points: how they were told from a curve, their RMS radius and each one's distance to the result."""
    if result.points_mode is None or result.point_distances is None:
        return None
    d = result.point_distances
    return {"mode": result.points_mode, "count": len(d), "radius": result.size, "distances": d.tolist(),
            "mean": float(d.mean() / result.size)}


def _overlay(result: Synthesis) -> str:
    """The overlay's SVG text: the target the errors are measured against, the atlas candidate, the result."""
    best = result.best
    as_placed = Candidate(best.family, best.row, best.params, best.index_distance, best.distance, best.placement,
                          refined=Refined(best.params, best.placement, best.before[0]))
    before = simulate(compile_plan(result_spec(as_placed, complex(*result.points[0]), name="atlas candidate",
                                               units=result.spec.units, description="")), RESULT_SAMPLES)
    smoothed = result.smooth > 0
    against = f"the smoothed target's size (σ = {result.smooth:g})" if smoothed else "the target's size"
    return edit_overlay(None, before=_named(drawing(before)), after=_named(drawing(result.motion)),
                        targets={"smoothed target" if smoothed else "target": result.points}, envelope=None,
                        units=result.spec.units,
                        title=f"{best.family}: RMS error {100 * best.before[0]:.2g} % → "
                              f"{100 * result.error[0]:.2g} % of {against}")


def _named(kw: dict[str, Any]) -> dict[str, Any]:
    """A linkage drawing whose track ``target`` is named for what it is, the curve the linkage draws."""
    return kw | {"tracks": {DRAWN if n == "target" else n: p for n, p in kw["tracks"].items()}}


def _history(result: Synthesis) -> str:
    """The history chart of the planar synthesis's refined candidates (:func:`history_chart`)."""
    return history_chart([None if c.refined is None else c.refined.history for c in result.candidates],
                         next(k for k, c in enumerate(result.candidates) if c is result.best))


def history_chart(histories: list[list[float] | None], kept: int) -> str:
    """The history chart's SVG text: each refined candidate's best normalized RMS error so far (log₁₀ of
    its percentage of the target's size) against evaluations of its residuals; ``histories``: each
    candidate's (numbered as report.json lists them; None or empty: not refined), ``kept``: the result's."""
    longest = max((len(h) for h in histories if h), default=1)
    panel = Panel("log₁₀ RMS error (% of the target's size)", name="history")
    for k, h in enumerate(histories):
        if not h:
            continue
        values = np.full(longest, np.nan)
        with np.errstate(divide="ignore"):
            values[:len(h)] = np.log10(100.0 * np.asarray(h, dtype=float))
        panel.line(f"candidate {k + 1}" + (" (kept)" if k == kept else ""),
                   np.where(np.isfinite(values), values, np.nan))
    return chart(np.arange(1, max(longest, 1) + 1), [panel], xlabel="evaluations",
                 title="refinement: best RMS error so far, log scale")


def _min_singularity(motion: Motion) -> float | None:
    """The smallest d_s of the result over its cycle (None for a linkage without dyads or slider rules)."""
    found = motion.min_singularity()
    return None if found is None else found[0]
