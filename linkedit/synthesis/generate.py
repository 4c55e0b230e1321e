"""``linkedit synthesize --function`` and ``--motion``: from prescribed pairs or poses to a linkage.

Each run reads its table, fits the linkage (:mod:`linkedit.synthesis.function`, :mod:`~.function_six`,
:mod:`linkedit.synthesis.motion`, :mod:`~.motion_slider`), writes it as a LinkageSpec, measures its errors on that
written spec evaluated through the planar core at the prescribed inputs (what ``linkedit
simulate result.yaml`` computes), and writes ``result.yaml``, ``result.h5`` (its simulation) and
``report.json`` (``specs/synthesis-report.md``) into the output folder, each atomically.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from linkedit import __version__
from linkedit.errors import InputError, MechanismError
from linkedit.io.atomic import write_text
from linkedit.spec.tables import read_columns
from linkedit.io.planar_hdf5 import write_motion
from linkedit.planar import Geometry, compile_plan, simulate
from linkedit.planar.feasibility import assembles
from linkedit.planar.kinematics import evaluate
from linkedit.planar.law_of_cosines import dyad
from linkedit.planar.simulate import Motion
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage
from linkedit.synthesis import function, function_six, motion, motion_slider

FILES = ("result.yaml", "result.h5", "report.json")
#: the ground link's length of a function generator, in UNITS (angles do not depend on it)
GROUND = 100.0
UNITS = "mm"
#: samples of the written simulation (result.h5): both ends of the input range included
RESULT_SAMPLES = 361
#: a motion generator whose coupler point misses a pose by more than this fraction of the size gets a note
POSITION_TOLERANCE = 0.005
#: ... and one whose longest link is more than this many times the poses' size (a coupler that barely turns)
FAR = 100.0
#: the units a poses file's angle_deg column may name (any other is refused: the column is in degrees)
DEGREES = ("deg", "degree", "degrees", "°")
#: the units a poses file's t column may name (t is the motor's phase: one turn = 1)
TURNS = ("turn", "turns")


def at_inputs(spec: LinkageSpec, angles: np.ndarray) -> dict[str, np.ndarray]:
    """Joint and track positions (T,) complex each of ``spec`` at absolute motor angles ``angles``
    (T,) radians, evaluated through the planar core as ``simulate`` does (NaN where it does not
    assemble)."""
    plan = compile_plan(spec)
    state = evaluate(plan, Geometry.of(plan, plan.normalized_points()), np.asarray(angles, dtype=float), order=0)
    z = state.z * plan.scale + plan.origin
    z = np.where(np.all(assembles(state.ds), axis=0, keepdims=True), z, np.nan)
    out = {name: z[plan.row_of[i]] for i, name in enumerate(plan.joint_names)}
    out |= {name: z[plan.row_of[p]] for name, p in zip(plan.track_names, plan.track_points)}
    return out


def _write(out: Path, spec: LinkageSpec, motion: Motion, header: str, report: dict[str, Any],
           options: dict[str, Any]) -> None:
    """result.yaml, result.h5 (``motion``: the spec simulated) and report.json into ``out``."""
    text = dump_linkage(spec, header=header)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "result.yaml", text)
    write_motion(out / "result.h5", motion, spec_text=text, options=options)
    write_text(out / "report.json", json.dumps(report, indent=2, allow_nan=False) + "\n")


def read_pairs(path: Path) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Input and output angles (N,) each, degrees, and their file lines; InputError for fewer than
    3 pairs, an input given twice (a function has one output per input) or inputs spanning
    more than a turn. The rows may come in any order: the pairs are points of the function."""
    table = read_columns(path, ("input_deg", "output_deg"), minimum=3)
    phi, psi, lines = table.columns["input_deg"], table.columns["output_deg"], table.lines
    _, first, inverse = np.unique(phi, return_index=True, return_inverse=True)
    again = np.flatnonzero(first[inverse] != np.arange(len(phi)))
    if len(again):  # with every input once, the 3 rows read_columns requires are 3 distinct inputs
        i = int(again[0])
        raise InputError(f"input {phi[i]:g}° is duplicated (line {lines[int(first[inverse[i]])]} gives it too): a "
                         "function has one output per input", file=str(path), line=lines[i], field="input_deg")
    if np.ptp(phi) > 360.0:
        raise InputError(f"the input angles span {np.ptp(phi):.6g}°, more than one turn of the crank", file=str(path),
                         field="input_deg")
    return phi, psi, lines


def function_spec(found: function.FunctionFit, rest_deg: float, span_deg: float, name: str) -> LinkageSpec:
    """The fitted four-bar at the crank's rest (input ``rest_deg``), ground O = 0, D = (GROUND, 0),
    the motor sweeping ``range_deg`` [0, span_deg], track ``target`` = the rocker tip B."""
    a, b, c, s, alpha, _ = found.params
    pin = a * np.exp(1j * (alpha + np.radians(rest_deg)))
    tip, _ = dyad(np.array([[pin]]), np.array([[1.0 + 0j]]), np.array([[0.5 * (b * b - c * c)]]),
                           np.array([[b * b]]), np.array([[s]]))
    joints = {"O": 0j, "A": GROUND * pin, "B": GROUND * complex(tip[0, 0]), "D": complex(GROUND)}
    return LinkageSpec.model_validate({
        "name": name, "units": UNITS,
        "description": "four-bar function generator: the rocker D-B turns as the pairs prescribe when the crank "
                       "O-A turns (linkedit synthesize --function)",
        "joints": {k: [z.real, z.imag] for k, z in joints.items()},
        "ground": ["O", "D"],
        "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        "motor": {"joint": "A", "pivot": "O", "direction": "ccw", "range_deg": [0.0, span_deg]},
        "tracks": {"target": {"joint": "B"}},
    })


def six_bar_spec(found: function_six.SixBarFit, rest_deg: float, span_deg: float, name: str) -> LinkageSpec:
    """The fitted Watt II six-bar at the crank's rest (input ``rest_deg``): ground O = 0, D = (GROUND, 0),
    F = (2·GROUND, 0), the motor sweeping ``range_deg`` [0, span_deg], track ``target`` = the output's tip E."""
    first, second = function_six.stages(found.params[None])
    a, b, c, s, alpha, _ = first[0]
    pin = np.array([[a * np.exp(1j * (alpha + np.radians(rest_deg)))]])
    tip, _ = dyad(pin, np.array([[1.0 + 0j]]), np.array([[0.5 * (b * b - c * c)]]), np.array([[b * b]]),
                  np.array([[s]]))
    a2, b2, c2, s2, arm, _ = second[0]
    arm_pin = np.array([[a2 * np.exp(1j * (arm + np.angle(tip[0, 0] - 1.0)))]])  # C − D
    out, _ = dyad(arm_pin, np.array([[1.0 + 0j]]), np.array([[0.5 * (b2 * b2 - c2 * c2)]]), np.array([[b2 * b2]]),
                  np.array([[s2]]))
    joints = {"O": 0j, "A": pin[0, 0], "B": tip[0, 0], "C": 1.0 + arm_pin[0, 0], "D": 1.0 + 0j,
              "E": 1.0 + out[0, 0], "F": 2.0 + 0j}
    return LinkageSpec.model_validate({
        "name": name, "units": UNITS,
        "description": "Watt II six-bar function generator: the output F-E turns as the pairs prescribe when the "
                       "crank O-A turns; the rocker D-B-C is a bell crank driving it through the link C-E "
                       "(linkedit synthesize --function --family six-bar)",
        "joints": {k: [GROUND * z.real, GROUND * z.imag] for k, z in joints.items()},
        "ground": ["O", "D", "F"],
        "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "bell_crank": ["D", "B", "C"], "link": ["C", "E"],
                  "output": ["F", "E"]},
        "motor": {"joint": "A", "pivot": "O", "direction": "ccw", "range_deg": [0.0, span_deg]},
        "tracks": {"target": {"joint": "E"}},
    })


def run_function(path: Path, out: Path, *, relative: bool, margin_deg: float, tolerance_deg: float,
                 options: dict[str, Any], family: str = "four-bar", sense: float | None = None) -> dict[str, Any]:
    """Synthesize a function generator (``family`` "four-bar" or "six-bar", the Watt II; ``sense`` +1/−1
    prescribes the output's turning way with relative angles) for the pairs in ``path`` and write it into
    ``out``; returns the report. MechanismError (exit 1) when no linkage works over the input range."""
    start = time.perf_counter()
    phi_deg, psi_deg, lines = read_pairs(path)
    phi, psi = np.radians(phi_deg), np.radians(psi_deg)
    six = family == "six-bar"
    found = (function_six.fit(phi, psi, margin_deg=margin_deg, sense=sense) if six else
             function.fit(phi, psi, relative=relative, margin_deg=margin_deg, sense=sense))
    if found is None:
        raise MechanismError(f"{path}: no {family} turns through the input range {phi_deg.min():.6g}°…"
                             f"{phi_deg.max():.6g}° with its transmission angle{'s' if six else ''} within "
                             f"[{margin_deg:g}°, {180 - margin_deg:g}°] (try a smaller --margin or a shorter input "
                             "range)")
    fitted = time.perf_counter()
    rest, span = float(phi_deg.min()), float(np.ptp(phi_deg))
    p = found.params
    if isinstance(found, function_six.SixBarFit):
        spec = six_bar_spec(found, rest, span, Path(path).stem)
        alpha, beta, tip, pivot = p[4], p[10], "E", "F"
        first, second = function_six.stages(p[None])
        ranges = [function.transmission_range(first, phi.min(), phi.max()),
                  function.transmission_range(second, *function_six.bell_crank_range(p[None], phi))]
        names = ("crank", "coupler", "rocker", "arm", "link", "output")
        lengths = dict(zip(names, (float(v) * GROUND for v in (*p[:3], *p[5:8]))))
        arm: dict[str, float] = {"arm_deg": float(np.degrees(p[9]))}  # the bell crank's arm D→C from D→B
    else:
        spec = function_spec(found, rest, span, Path(path).stem)
        alpha, beta, tip, pivot = p[4], p[5], "B", "D"
        ranges = [function.transmission_range(p[None], phi.min(), phi.max())]
        lengths = dict(zip(("crank", "coupler", "rocker"), (float(v) * GROUND for v in p[:3])))
        arm = {}
    at = at_inputs(spec, alpha + phi)  # the written spec, evaluated at each pair's input
    result = found.sense * function.wrap(np.angle(at[tip] - at[pivot]) - beta - found.sense * psi) + psi
    errors = np.degrees(result - psi)
    if not np.isfinite(errors).all():
        raise MechanismError(f"{spec.name}: the written linkage does not assemble at every pair's input")
    motion = simulate(spec, RESULT_SAMPLES)
    lo, hi = min(r[0] for r in ranges), max(r[1] for r in ranges)
    worst = float(np.abs(errors).max())
    note = "" if worst <= tolerance_deg else (
        f"no {family} found meets the pairs within {tolerance_deg:g}°: the best is off by {worst:.3g}° (max)"
        + (f"; its transmission angle reaches the band's edge ({margin_deg:g}°): a smaller --margin trades "
           "transmission quality for accuracy" if min(lo, 180 - hi) < margin_deg + 0.5 else "")
        + ("; a Watt II six-bar (--family six-bar) has more freedom" if relative and not six else ""))
    report = {
        "generator": f"linkedit {__version__}", "mode": "function", "family": family,
        "pairs": {"origin": str(path), "count": int(len(phi)), "angles": "relative" if relative else "absolute"},
        "options": options,
        "error": {"max_deg": worst, "rms_deg": float(np.sqrt(np.mean(errors ** 2))), "tolerance_deg": tolerance_deg,
                  "measured": "result.yaml evaluated at each pair's input (linkedit.planar): output angle − prescribed"},
        "linkage": {"units": UNITS, "ground": GROUND, **lengths},
        "angles": {"crank_at_input_0_deg": float(np.degrees(alpha)),
                   "rocker_at_output_0_deg": float(np.degrees(beta)),
                   "output_sense": "same" if found.sense > 0 else "opposite",
                   "rest_input_deg": rest} | arm,
        "transmission_deg": {"min": lo, "max": hi} | ({"stages": [list(r) for r in ranges]} if six else {}),
        "margin_deg": margin_deg,
        "min_singularity": float(np.min(found.lowest)),
        "points": [{"line": ln, "input_deg": float(x), "output_deg": float(y), "result_deg": float(np.degrees(r)),
                    "error_deg": float(e), "motor_angle_deg": float(np.degrees(alpha) + x), "t": float((x - rest) / span)}
                   for ln, x, y, r, e in zip(lines, phi_deg, psi_deg, result, errors)],
        "note": note,
        "result": {"spec": "result.yaml", "simulation": "result.h5", "track": "target", "samples": RESULT_SAMPLES},
        "seconds": {"fit": fitted - start, "total": time.perf_counter() - start},
    }
    link = "the link F-E is the output; track 'target' is its tip E" if six else (
        "the rocker D-B is the output; track 'target' is its tip B")
    header = ("Synthesized by linkedit synthesize --function; simulate it with:\n"
              f"  linkedit simulate result.yaml   ({link})")
    _write(out, spec, motion, header, report, options | {"command": "synthesize", "mode": "function"})
    return report


def read_poses(path: Path, *, timed: bool = False) -> tuple[np.ndarray, np.ndarray, list[int], str, np.ndarray | None]:
    """Coupler point positions (N,) complex, coupler angles (N,) degrees, file lines (in pose
    order: by ``t`` when given), units and the times ``t`` (N,) in that order (None without a t
    column); InputError for fewer than 3 poses, positions that all coincide, x and y in different units,
    angles in a unit other than degrees, t in a unit other than turns, or (``timed``: the six-bar meets the motor's timing) no t column."""
    table = read_columns(path, ("x", "y", "angle_deg"), ("t",), minimum=3)
    cols = table.columns
    if timed and "t" not in cols:
        raise InputError("--family six-bar meets the motor's timing: give a t column (the motor's phase, one turn "
                         "= 1)", file=str(path), line=table.header, field="t")
    angle_unit = table.units.get("angle_deg")
    if angle_unit is not None and angle_unit.lower() not in DEGREES:
        raise InputError(f"angle_deg is in degrees, the header gives it in {angle_unit!r}", file=str(path),
                         line=table.header, field="angle_deg")
    t_unit = table.units.get("t")
    if t_unit is not None and t_unit.lower() not in TURNS:
        raise InputError(f"t is the motor's phase (one turn = 1), the header gives it in {t_unit!r}", file=str(path),
                         line=table.header, field="t")
    order = np.argsort(cols["t"], kind="stable") if "t" in cols else np.arange(len(cols["x"]))
    points = (cols["x"] + 1j * cols["y"])[order]
    if np.abs(points - points[0]).max() <= 1e-12 * max(np.abs(points).max(), 1e-300):
        raise InputError("every pose has the same position: give the coupler point's path", file=str(path), field="x")
    units = {u for u in (table.units.get("x"), table.units.get("y")) if u is not None}
    if len(units) > 1:
        raise InputError(f"x and y are in different units ({', '.join(sorted(units))})", file=str(path),
                         line=table.header, field="y")
    times = cols["t"][order] if "t" in cols else None
    return points, cols["angle_deg"][order], [table.lines[i] for i in order], units.pop() if units else UNITS, times


def pose_frame(points: np.ndarray) -> tuple[complex, float]:
    """The poses' centre (their mean) and size (their largest distance apart), poses' units: the motion fits
    work on (points − centre)/size, and the written linkage is placed back by z ↦ centre + size·z
    (:func:`placer`)."""
    return complex(points.mean()), float(np.abs(points[:, None] - points[None, :]).max())


def placer(centre: complex, size: float) -> Callable[[complex], list[float]]:
    """z ↦ [x, y] of centre + size·z: a normalized point as a spec's coordinates."""
    def place(z: complex) -> list[float]:
        w = centre + size * z
        return [w.real, w.imag]

    return place


def written_pose_errors(spec: LinkageSpec, motor_angles: np.ndarray, coupler: tuple[str, str], kappa: float,
                        points: np.ndarray, theta: np.ndarray, size: float
                        ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The written ``spec`` evaluated at each pose's motor angle (radians, (N,)): its joints and track
    (:func:`at_inputs`), the coupler point's distance from each pose over ``size`` (N,) and the coupler's
    angle error (degrees, (N,)) — the coupler's angle being that of ``coupler``'s first joint → second plus
    ``kappa``. MechanismError where the spec does not assemble at some pose."""
    at = at_inputs(spec, motor_angles)
    tail, head = coupler
    gap = np.abs(at["target"] - points) / size
    turn_error = np.degrees(function.wrap(np.angle(at[head] - at[tail]) + kappa - theta))
    if not (np.isfinite(gap).all() and np.isfinite(turn_error).all()):
        raise MechanismError(f"{spec.name}: the written linkage does not assemble at every pose's motor angle")
    return at, gap, turn_error


def search_limit(points: np.ndarray, theta: np.ndarray, units: str) -> str:
    """The motion search's limit on where joints lie, in the poses' units (:func:`linkedit.synthesis.motion.reach_of`),
    for an exit-1 message."""
    centre, size = pose_frame(points)
    reach = motion.reach_of((points - centre) / size, theta) * size
    return (f"every joint within {reach:.4g} {units} of the poses' centre ({motion.REACH:g}× the larger of their "
            "size and their span over the coupler's turn, radians: poses spanning more of the motion reach farther)")


#: motion generation's families (``--motion --family``): name → fit of normalized poses
MOTION_FAMILIES: dict[str, Callable[..., motion.MotionFit | motion_slider.SliderFit | None]] = {
    "four-bar": motion.fit, "slider-crank": motion_slider.fit}


def motion_spec(found: motion.MotionFit | motion_slider.SliderFit, centre: complex, size: float, name: str,
                units: str) -> LinkageSpec:
    """The fitted linkage placed by z ↦ centre + size·z at its rest pose (the first pose), the motor
    sweeping the crank through every pose (``range_deg``), track ``target`` = the coupler point on
    the coupler A-B: a four-bar (rocker D-B) or a slider-crank (B on a ground guide)."""
    place = placer(centre, size)
    joints = {"O": found.O, "A": found.A, "B": found.B}
    if isinstance(found, motion_slider.SliderFit):
        kind = {"description": "slider-crank motion generator: its coupler A-B carries the coupler point (track "
                               "target) through the poses, B slides on a ground guide (linkedit synthesize --motion "
                               "--family slider-crank)",
                "ground": ["O"], "links": {"crank": ["O", "A"], "coupler": ["A", "B"]},
                "sliders": {"slider": {"joint": "B", "guide": "ground", "angle_deg": float(np.degrees(found.alpha))}}}
    else:
        joints["D"] = found.D
        kind = {"description": "four-bar motion generator: its coupler A-B carries the coupler point (track target) "
                               "through the poses (linkedit synthesize --motion)",
                "ground": ["O", "D"], "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]}}
    sweep = float(np.degrees(found.turns[-1]))
    return LinkageSpec.model_validate({
        "name": name, "units": units, **kind,
        "joints": {k: place(z) for k, z in joints.items()},
        "motor": {"joint": "A", "pivot": "O", "direction": "ccw" if sweep > 0 else "cw",
                  "range_deg": [0.0, abs(sweep)]},
        "tracks": {"target": {"link": "coupler", "at": place(found.P)}},
    })


def _motion_linkage(found: motion.MotionFit | motion_slider.SliderFit,
                    spec: LinkageSpec) -> tuple[dict[str, float], tuple[float, float]]:
    """The written linkage's dimensions (its units; a slider-crank's ``offset``: O's signed distance
    from the guide, left of its direction positive, and ``guide_angle_deg``) and its transmission
    angle's range (degrees) over the crank's sweep."""
    joints = {k: complex(*v) for k, v in spec.joints.items()}
    crank, coupler = abs(joints["A"] - joints["O"]), abs(joints["B"] - joints["A"])
    if isinstance(found, motion_slider.SliderFit):
        guide = np.exp(1j * found.alpha)
        offset = float((np.conj(guide) * (joints["O"] - joints["B"])).imag)
        lengths = {"crank": crank, "coupler": coupler, "offset": offset,
                   "guide_angle_deg": float(np.degrees(found.alpha))}
        return lengths, motion_slider.transmission_range(found)
    row = motion.frame_rows(*(np.array([z]) for z in (found.O, found.A, found.B, found.D)))
    lengths = {"ground": abs(joints["D"] - joints["O"]), "crank": crank, "coupler": coupler,
               "rocker": abs(joints["B"] - joints["D"])}
    return lengths, function.transmission_range(row, min(0.0, found.turns[-1]), max(0.0, found.turns[-1]))


def run_motion(path: Path, out: Path, *, margin_deg: float, tolerance_deg: float,
               options: dict[str, Any], family: str = "four-bar") -> dict[str, Any]:
    """Synthesize a motion generator (a ``family`` of :data:`MOTION_FAMILIES`) for the poses in ``path``
    and write it into ``out``; returns the report. MechanismError (exit 1) when no pair of dyads gives
    a working linkage."""
    start = time.perf_counter()
    points, angles_deg, lines, units, _ = read_poses(path)
    centre, size = pose_frame(points)
    theta = np.radians(angles_deg)
    found = MOTION_FAMILIES[family]((points - centre) / size, theta, margin_deg=margin_deg)
    if found is None:
        raise MechanismError(f"{path}: no pair of the dyads found makes a {family} that passes the {len(points)} poses "
                             f"in order on one assembly branch with its transmission angle within [{margin_deg:g}°, "
                             f"{180 - margin_deg:g}°] and {search_limit(points, theta, units)} (try a smaller "
                             "--margin, or fewer or other poses)")
    fitted = time.perf_counter()
    spec = motion_spec(found, centre, size, Path(path).stem, units)
    rest = float(np.angle(found.A - found.O))
    kappa = found.kappa
    at, gap, turn_error = written_pose_errors(spec, rest + found.turns, ("A", "B"), kappa, points, theta, size)
    simulated = simulate(spec, RESULT_SAMPLES)
    length, (lo, hi) = _motion_linkage(found, spec)
    worst_pos, worst_angle = float(gap.max()), float(np.abs(turn_error).max())
    notes = [] if worst_pos <= POSITION_TOLERANCE and worst_angle <= tolerance_deg else [
        f"no {family} found passes the poses within {100 * POSITION_TOLERANCE:g} % of their size and "
        f"{tolerance_deg:g}°: the best is off by {100 * worst_pos:.3g} % and {worst_angle:.3g}° (max)"]
    longest = max(abs(v) for k, v in length.items() if not k.endswith("_deg"))  # lengths, not the guide's angle
    if longest > FAR * size:
        notes.append(f"its longest link is {longest / size:,.0f}× the poses' size ({longest:.4g} {units}): the coupler "
                     f"turns only {float(np.degrees(np.ptp(theta))):.3g}° over the poses, so its pivots lie far out; "
                     "poses that turn the coupler more give a compact linkage")
    note = "; ".join(notes)
    sweep = float(np.degrees(found.turns[-1]))
    report = {
        "generator": f"linkedit {__version__}", "mode": "motion", "family": family,
        "poses": {"origin": str(path), "count": int(len(points)), "size": size, "units": units},
        "options": options,
        "error": {"position": {"max": worst_pos, "rms": float(np.sqrt(np.mean(gap ** 2)))},
                  "angle_deg": {"max": worst_angle, "rms": float(np.sqrt(np.mean(turn_error ** 2)))},
                  "tolerance": {"position": POSITION_TOLERANCE, "angle_deg": tolerance_deg},
                  "measured": "result.yaml evaluated at each pose's crank angle (linkedit.planar): the coupler "
                              "point's distance from the pose over the poses' size, and the coupler angle's error"},
        "linkage": {"units": units, **length},
        "coupler_angle_offset_deg": float(np.degrees(kappa)),
        "transmission_deg": {"min": lo, "max": hi},
        "margin_deg": margin_deg,
        "min_singularity": found.lowest,
        "crank_sweep_deg": sweep,
        "points": [{"line": ln, "x": z.real, "y": z.imag, "angle_deg": float(a),
                    "result": [float(r.real), float(r.imag)], "result_angle_deg": float(a + e),
                    "position_error": float(g), "angle_error_deg": float(e),
                    "motor_angle_deg": float(np.degrees(rest + d)), "motor_turn_deg": float(np.degrees(d)),
                    "t": float(abs(np.degrees(d)) / abs(sweep))}
                   for ln, z, a, r, g, e, d in zip(lines, points, angles_deg, at["target"], gap, turn_error, found.turns)],
        "note": note,
        "result": {"spec": "result.yaml", "simulation": "result.h5", "track": "target", "samples": RESULT_SAMPLES},
        "seconds": {"fit": fitted - start, "total": time.perf_counter() - start},
    }
    header = ("Synthesized by linkedit synthesize --motion; simulate it with:\n"
              "  linkedit simulate result.yaml   (track 'target' is the coupler point; the coupler's angle is the "
              "angle of A->B plus coupler_angle_offset_deg of report.json)")
    _write(out, spec, simulated, header, report, options | {"command": "synthesize", "mode": "motion"})
    return report
