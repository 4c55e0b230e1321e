"""The synthesis bench's motion-generation rows (``linkedit bench -s synthesis``, issue 23 §2): poses drawn from
known linkages of each ``--motion`` family (held out: the crank-rocker and slider-crank examples and a Watt II six-bar,
not the bundled pose CSVs' linkages), synthesized as the CLI does (:func:`linkedit.synthesis.generate.run_motion`,
:func:`~.generate_six.run_motion_six`) and scored by the report's errors, measured on the written ``result.yaml``."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from linkedit.errors import MechanismError
from linkedit.io.atomic import commit
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model
from linkedit.synthesis.generate import at_inputs, run_motion
from linkedit.synthesis.generate_six import run_motion_six
from linkedit.synthesis.synthesize import MARGIN_DEG

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: the crank's partial sweep the poses are drawn over (degrees from the rest pose)
SWEEP_DEG = 150.0
#: poses of the exact case per family; least squares: LSQ poses, exact and with noise (NOISE of the size in
#: position, NOISE_DEG in angle: standard deviations, seed SEED)
EXACT = {"four-bar": 5, "slider-crank": 4, "six-bar": 5}
LSQ = 8
NOISE, NOISE_DEG, SEED = 1e-3, 0.05, 23


def six_bar() -> LinkageSpec:
    """A Watt II six-bar in :mod:`linkedit.synthesis.generate_six`'s joint layout (the geometry of
    ``examples/watt-six-bar.yaml``, renamed), with track ``target`` on coupler2 A2-B2 off its line."""
    watt = load_model(LinkageSpec, EXAMPLES / "watt-six-bar.yaml")
    name = {"O": "O1", "A": "A1", "B": "B1", "D": "D1", "C": "A2", "E": "B2", "F": "D2"}
    joints = {name[k]: list(v) for k, v in watt.joints.items()}
    a2, b2 = complex(*joints["A2"]), complex(*joints["B2"])
    point = a2 + (b2 - a2) * (0.4 + 0.5j)
    return LinkageSpec.model_validate({
        "name": "held-out-watt-ii", "units": "mm", "joints": joints, "ground": ["O1", "D1", "D2"],
        "links": {"crank1": ["O1", "A1"], "coupler1": ["A1", "B1"], "ternary": ["D1", "B1", "A2"],
                  "coupler2": ["A2", "B2"], "rocker2": ["D2", "B2"]},
        "motor": {"joint": "A1", "pivot": "O1"},
        "tracks": {"target": {"link": "coupler2", "at": [point.real, point.imag]}}})


def _known() -> dict[str, tuple[LinkageSpec, str, str, str]]:
    """Family → (its known linkage, its coupler's two joints (the angle: first → second), its coupler point's
    track)."""
    return {"four-bar": (load_model(LinkageSpec, EXAMPLES / "crank-rocker.yaml"), "A", "B", "coupler_point"),
            "slider-crank": (load_model(LinkageSpec, EXAMPLES / "slider-crank.yaml"), "A", "B", "coupler_point"),
            "six-bar": (six_bar(), "A2", "B2", "target")}


def poses(family: str, count: int, noise: bool) -> str:
    """A poses CSV (text; columns x, y, angle_deg, t) of ``count`` poses of the known ``family`` linkage over
    SWEEP_DEG of its crank from rest (t: the motor's phase), with Gaussian noise when ``noise``."""
    spec, first, second, track = _known()[family]
    pin, pivot = spec.motor.joint, spec.motor.pivot
    assert pin is not None and pivot is not None  # each known linkage's motor is a crank
    rest = np.angle(complex(*spec.joints[pin]) - complex(*spec.joints[pivot]))
    turn = np.radians(np.linspace(0.0, SWEEP_DEG, count))
    at = at_inputs(spec, rest + turn)
    z, angle = at[track], np.degrees(np.unwrap(np.angle(at[second] - at[first])))
    if noise:
        rng = np.random.default_rng(SEED)
        size = float(np.abs(z[:, None] - z[None, :]).max())
        z = z + NOISE * size * (rng.standard_normal(count) + 1j * rng.standard_normal(count))
        angle = angle + NOISE_DEG * rng.standard_normal(count)
    rows = "".join(f"{float(p.real)!r}, {float(p.imag)!r}, {float(a)!r}, {float(t)!r}\n"
                   for p, a, t in zip(z, angle, turn / (2 * np.pi)))
    return "x (mm), y (mm), angle_deg, t\n" + rows


def motion_generation(echo: Callable[[str], None], quick: bool) -> None:
    """``synthesize --motion`` per family on poses of a known linkage: the exact case (5, 4, 5 timed poses) and (not
    ``quick``) least squares through 8 poses, exact and noisy; max position error over the poses' size, max angle
    error, max timing error (six-bar, degrees of motor turn) from the report (measured on result.yaml), CPU s."""
    echo(f"motion generation, poses of held-out linkages over {SWEEP_DEG:g}° of crank (max errors of the written "
         f"linkage: position over the poses' size, coupler angle, timing in degrees of motor turn; noise: "
         f"{NOISE:g} of the size and {NOISE_DEG:g}°, seed {SEED}):")
    echo(f"  {'family':<12s} {'case':<22s} {'position':>9s}  {'angle °':>9s}  {'timing °':>9s}  CPU s")
    cases = [(f"exact, {n} poses", family, n, False) for family, n in EXACT.items()]
    if not quick:
        cases += [(f"lsq, {LSQ} poses{', noisy' if noisy else ''}", family, LSQ, noisy)
                  for family in EXACT for noisy in (False, True)]
    with tempfile.TemporaryDirectory(prefix="linkedit-bench-") as folder:
        for i, (case, family, count, noisy) in enumerate(cases):
            path = Path(folder) / f"poses-{i}.csv"
            path.write_text(poses(family, count, noisy), encoding="utf-8")
            out = Path(folder) / f"out-{i}"
            cpu = time.process_time()
            try:  # the CLI's defaults: --margin 20, --tolerance 0.5
                if family == "six-bar":
                    report = run_motion_six(path, out, margin_deg=MARGIN_DEG, tolerance_deg=0.5, options={})
                else:
                    report = run_motion(path, out, margin_deg=MARGIN_DEG, tolerance_deg=0.5, options={}, family=family)
            except MechanismError:
                echo(f"  {family:<12s} {case:<22s} none found (exit 1)  {time.process_time() - cpu:5.2f}")
                continue
            cpu = time.process_time() - cpu
            commit()  # the command's outputs are renamed together at its end; these live in a folder about to go
            error = report["error"]
            timing = f"{error['timing_deg']['max']:9.2e}" if "timing_deg" in error else f"{'—':>9s}"
            echo(f"  {family:<12s} {case:<22s} {error['position']['max']:9.2e}  {error['angle_deg']['max']:9.2e}  "
                 f"{timing}  {cpu:5.2f}")
