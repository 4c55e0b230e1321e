"""``linkedit synthesize --motion POSES.csv --family six-bar``: timed poses to a Watt II six-bar.

The ``t`` column is the motor's phase (:mod:`linkedit.synthesis.motion_six`), as everywhere in
linkedit: one motor turn is t = 1, so the motor turns 360°·(t_j − t₁) from the first pose (the rest
pose) to pose j. The run fits the six-bar, writes it as a LinkageSpec, measures the pose errors on
that written spec evaluated through the planar core at the prescribed motor angles (what ``linkedit
simulate result.yaml`` computes) and writes ``result.yaml``, ``result.h5`` and ``report.json``
(:func:`linkedit.synthesis.generate.run_motion`'s, with the timing and both stages' transmission).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from linkedit import __version__
from linkedit.errors import InputError, MechanismError
from linkedit.planar import simulate
from linkedit.spec.linkage import LinkageSpec
from linkedit.synthesis import function, motion, motion_six
from linkedit.synthesis.generate import (POSITION_TOLERANCE, RESULT_SAMPLES, _write, placer, pose_frame, read_poses,
                                         search_limit, written_pose_errors)

#: the links of the written six-bar (joints, in the spec's order)
LINKS = {"crank1": ["O1", "A1"], "coupler1": ["A1", "B1"], "ternary": ["D1", "B1", "A2"], "coupler2": ["A2", "B2"],
         "rocker2": ["D2", "B2"]}


def read_timed_poses(path: Path) -> tuple[np.ndarray, np.ndarray, list[int], str, np.ndarray]:
    """:func:`linkedit.synthesis.generate.read_poses` with its t column required, the times distinct and
    spanning less than one motor turn (t = 1); InputError (exit 2) otherwise."""
    points, angles, lines, units, times = read_poses(path, timed=True)
    assert times is not None  # read_poses(timed=True) requires the t column
    again = np.flatnonzero(np.diff(times) <= 0)
    if len(again):
        i = int(again[0])
        raise InputError(f"t {times[i]:g} is given twice (line {lines[i]} too): the motor meets one pose at a time",
                         file=str(path), line=lines[i + 1], field="t")
    if times[-1] - times[0] >= 1.0:
        raise InputError(f"the times span {times[-1] - times[0]:.6g}, one motor turn or more (t is the motor's "
                         "phase: one turn = 1)", file=str(path), line=lines[-1], field="t")
    return points, angles, lines, units, times


def six_bar_motion_spec(found: motion_six.SixMotionFit, centre: complex, size: float, name: str,
                        units: str) -> LinkageSpec:
    """The fitted six-bar placed by z ↦ centre + size·z at its rest pose (the first pose), the motor
    sweeping through every pose's time (``range_deg``), track ``target`` = the coupler point on coupler2."""
    place = placer(centre, size)
    joints = {k: place(z) for k, z in found.joints.items() if k != "P"}
    return LinkageSpec.model_validate({
        "name": name, "units": units,
        "description": "Watt II six-bar motion generator with timing: the motor O1-A1 drives the ternary link "
                       "D1-B1-A2 through the coupler A1-B1; the coupler A2-B2 carries the coupler point (track "
                       "target) through the poses at the motor angles their t prescribes (linkedit synthesize "
                       "--motion --family six-bar)",
        "joints": joints,
        "ground": ["O1", "D1", "D2"],
        "links": LINKS,
        "motor": {"joint": "A1", "pivot": "O1", "direction": "ccw" if found.direction > 0 else "cw",
                  "range_deg": [0.0, float(np.degrees(found.turns[-1]))]},
        "tracks": {"target": {"link": "coupler2", "at": place(found.joints["P"])}},
    })


def run_motion_six(path: Path, out: Path, *, margin_deg: float, tolerance_deg: float,
                   options: dict[str, Any]) -> dict[str, Any]:
    """Synthesize a six-bar motion generator for the timed poses in ``path`` and write it into ``out``;
    returns the report. MechanismError (exit 1) when no working six-bar is found."""
    start = time.perf_counter()
    points, angles_deg, lines, units, times = read_timed_poses(path)
    centre, size = pose_frame(points)
    theta = np.radians(angles_deg)
    phi = 2 * np.pi * (times - times[0])
    found = motion_six.fit((points - centre) / size, theta, phi, margin_deg=margin_deg)
    if found is None:
        raise MechanismError(f"{path}: no Watt II six-bar found passes the {len(points)} poses with both transmission "
                             f"angles within [{margin_deg:g}°, {180 - margin_deg:g}°] and "
                             f"{search_limit(points, theta, units)} (no four-bar passes them on "
                             "one assembly branch, or none is driven by a working stage 1: try a smaller --margin, "
                             "or fewer or other poses)")
    fitted = time.perf_counter()
    spec = six_bar_motion_spec(found, centre, size, Path(path).stem, units)
    rest = float(np.angle(found.joints["A1"] - found.joints["O1"]))
    at, gap, turn_error = written_pose_errors(spec, rest + found.direction * phi, ("A2", "B2"), found.kappa, points,
                                              theta, size)  # at each pose's prescribed motor angle
    timing = np.degrees(found.achieved - phi)
    simulated = simulate(spec, RESULT_SAMPLES)
    rows = [found.stage1[None], motion.frame_rows(*(np.array([found.joints[k]]) for k in ("D1", "A2", "B2", "D2")))]
    stages = [function.transmission_range(rows[0], 0.0, float(phi[-1])),
              function.transmission_range(rows[1], *found.crank2)]
    joints = {k: np.array(v) for k, v in spec.joints.items()}
    length = {name: float(np.hypot(*(joints[q] - joints[p]))) for name, (p, q) in (
        ("ground1", ("O1", "D1")), ("crank1", ("O1", "A1")), ("coupler1", ("A1", "B1")), ("rocker1", ("D1", "B1")),
        ("arm", ("D1", "A2")), ("coupler2", ("A2", "B2")), ("rocker2", ("D2", "B2")), ("ground2", ("D1", "D2")))}
    worst = {"position": float(gap.max()), "angle": float(np.abs(turn_error).max()),
             "timing": float(np.abs(timing).max())}
    note = "" if worst["position"] <= POSITION_TOLERANCE and max(worst["angle"], worst["timing"]) <= tolerance_deg \
        else (f"no six-bar found passes the poses at their times within {100 * POSITION_TOLERANCE:g} % of their size "
              f"and {tolerance_deg:g}°: the best is off by {100 * worst['position']:.3g} % and {worst['angle']:.3g}° "
              f"at the prescribed motor angles, and meets the poses best {worst['timing']:.3g}° of motor turn away "
              "from them (max)")
    report = {
        "generator": f"linkedit {__version__}", "mode": "motion", "family": "six-bar",
        "poses": {"origin": str(path), "count": int(len(points)), "size": size, "units": units,
                  "period": 1.0},
        "options": options,
        "error": {"position": {"max": worst["position"], "rms": float(np.sqrt(np.mean(gap ** 2)))},
                  "angle_deg": {"max": worst["angle"], "rms": float(np.sqrt(np.mean(turn_error ** 2)))},
                  "timing_deg": {"max": worst["timing"], "rms": float(np.sqrt(np.mean(timing ** 2)))},
                  "tolerance": {"position": POSITION_TOLERANCE, "angle_deg": tolerance_deg},
                  "measured": "result.yaml evaluated at each pose's prescribed motor angle (linkedit.planar): the "
                              "coupler point's distance from the pose over the poses' size, and the coupler angle's "
                              "error; timing: the motor turn at which the six-bar meets each pose best nearest the "
                              "prescribed one (the nearest local minimum of the pose error), minus the prescribed one"},
        "linkage": {"units": units, **length},
        "coupler_angle_offset_deg": float(np.degrees(found.kappa)),
        "transmission_deg": {"min": min(s[0] for s in stages), "max": max(s[1] for s in stages),
                             "stages": [list(s) for s in stages]},
        "margin_deg": margin_deg,
        "min_singularity": float(found.lowest.min()),
        "crank_sweep_deg": float(np.degrees(phi[-1])),
        "motor_direction": "ccw" if found.direction > 0 else "cw",
        "points": [{"line": ln, "x": z.real, "y": z.imag, "angle_deg": float(a), "t": float(t),
                    "result": [float(r.real), float(r.imag)], "result_angle_deg": float(a + e),
                    "position_error": float(g), "angle_error_deg": float(e),
                    "motor_angle_deg": float(np.degrees(rest + found.direction * f)),
                    "motor_turn_deg": float(np.degrees(f)), "achieved_motor_turn_deg": float(np.degrees(h)),
                    "timing_error_deg": float(d)}
                   for ln, z, a, t, r, g, e, f, h, d in zip(lines, points, angles_deg, times, at["target"], gap,
                                                           turn_error, phi, found.achieved, timing)],
        "note": note,
        "result": {"spec": "result.yaml", "simulation": "result.h5", "track": "target", "samples": RESULT_SAMPLES},
        "seconds": {"fit": fitted - start, "total": time.perf_counter() - start},
    }
    header = ("Synthesized by linkedit synthesize --motion --family six-bar; simulate it with:\n"
              "  linkedit simulate result.yaml   (track 'target' is the coupler point; coupler2's angle is the "
              "angle of A2->B2 plus coupler_angle_offset_deg of report.json; pose j at motor turn "
              "360°·(t_j − t_1))")
    _write(out, spec, simulated, header, report, options | {"command": "synthesize", "mode": "motion"})
    return report
