"""The files ``linkedit synthesize`` writes into its output folder (each one atomically).

``result.yaml`` (the linkage, placed in the target's frame, track ``target``), ``result.h5``
(its simulation, ``specs/planar-hdf5.md``), ``overlay.svg`` (target dashed, the atlas
candidate as placed faint, the refined linkage solid), ``history.svg`` (convergence of every
refined candidate) and ``report.json``.
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
from linkedit.io.svg_figure import INK, PALETTE, Figure, Stroke
from linkedit.planar import compile_plan, simulate
from linkedit.planar.simulate import Motion
from linkedit.spec.linkage_yaml import dump_linkage
from linkedit.synthesis.families import family
from linkedit.synthesis.refine import Refined
from linkedit.synthesis.synthesize import RESULT_SAMPLES, Candidate, Synthesis, result_spec

FILES = ("result.yaml", "result.h5", "overlay.svg", "history.svg", "report.json")


def write_all(out: Path, result: Synthesis, options: dict[str, Any]) -> dict[str, Any]:
    """Write every file into ``out``; returns the report (also in report.json)."""
    out.mkdir(parents=True, exist_ok=True)
    text = dump_linkage(result.spec, header="Synthesized by linkedit synthesize; simulate it with:\n"
                                            "  linkedit simulate result.yaml   (track 'target' draws the curve)")
    write_text(out / "result.yaml", text)
    write_motion(out / "result.h5", result.motion, spec_text=text, options=options | {"command": "synthesize"})
    _overlay(out / "overlay.svg", result)
    _history(out / "history.svg", result)
    report = _report(result, options)
    write_text(out / "report.json", json.dumps(report, indent=2, allow_nan=False) + "\n")
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
                   "units": result.spec.units},
        "options": options,
        "family": best.family,
        "error": {"before": {"rms": best.before[0], "max": best.before[1]},
                  "refined": {"rms": best.after[0], "max": best.after[1]},
                  "after": {"rms": result.error[0], "max": result.error[1]},
                  "normalized_by": "target size (major extent); RMS over target→result and result→target distances, "
                                   "both curves sampled evenly along their length; after: result.yaml simulated"}
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
        "note": result.note,
        "result": {"spec": "result.yaml", "simulation": "result.h5", "track": "target", "samples": RESULT_SAMPLES,
                   "min_singularity": _min_singularity(result.motion),
                   "curve": track.tolist()},
        "candidates": [_candidate_row(c) for c in result.candidates],
        "seconds": result.seconds,
    }


def _overlay(path: Path, result: Synthesis) -> None:
    best = result.best
    as_placed = Candidate(best.family, best.row, best.params, best.index_distance, best.distance, best.placement,
                          refined=Refined(best.params, best.placement, best.before[0]))
    before = simulate(compile_plan(result_spec(as_placed, complex(*result.target.points[0]), name="atlas candidate",
                                               units=result.spec.units, description="")), RESULT_SAMPLES)
    edit_overlay(path, before=drawing(before), after=drawing(result.motion),
                 targets={"target": result.target.points[:, :2]}, envelope=None, units=result.spec.units,
                 title=f"synthesize: {best.family}, RMS error {100 * best.before[0]:.2g} % → "
                       f"{100 * result.error[0]:.2g} % of the target's size")


def _history(path: Path, result: Synthesis) -> None:
    """log₁₀ of each refined candidate's best normalized RMS error against evaluations."""
    refined = [c for c in result.candidates if c.refined is not None and c.refined.history]
    histories = [c.refined.history for c in refined if c.refined is not None]
    longest = max((len(h) for h in histories), default=1)
    lows = [np.log10(max(min(h), 1e-12)) for h in histories] or [0.0]
    highs = [np.log10(max(max(h), 1e-12)) for h in histories if np.isfinite(max(h))] or [1.0]
    span = max(max(highs) - min(lows), 1e-3)
    stretch = 1.6 * span / longest  # x: evaluations, drawn 1.6 times as wide as the error range is high
    fig = Figure(title=f"refinement: log10(normalized RMS error) against evaluations (x: 1 unit = "
                       f"{1 / stretch:.3g} evaluations)")
    for k, h in enumerate(histories):
        values = np.log10(np.maximum(np.asarray(h, dtype=float), 1e-12))
        ok = np.isfinite(values)
        x = np.arange(len(h))[ok] * stretch
        kept = refined[k] is result.best
        stroke = Stroke(INK if kept else PALETTE[k % len(PALETTE)], 1.8)
        if ok.sum() >= 2:
            fig.polyline(np.stack([x, values[ok]], axis=1), stroke, cls="history", name=f"candidate {k + 1}",
                         label=f"candidate {k + 1}" + (" (kept)" if kept else ""))
    write_text(path, fig.render())


def _min_singularity(motion: Motion) -> float | None:
    """The smallest d_s of the result over its cycle (None for a linkage without dyads or slider rules)."""
    found = motion.min_singularity()
    return None if found is None else found[0]
