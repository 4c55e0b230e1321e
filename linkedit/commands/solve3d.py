"""``linkedit solve3d``: solve a 3D mechanism spec over time; write HDF5 (and SVG)."""

from __future__ import annotations

import os
from collections import deque
from enum import Enum
from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, guard, report, say
from linkedit.errors import InputError


def parse_track(text: str) -> tuple[str, str, str | tuple[float, float, float]]:
    """``[name=]member:x,y,z`` or ``[name=]member:point`` → (name, member, point)."""
    name, eq, rest = text.partition("=")
    if not eq:
        name, rest = text, text
    member, colon, point = rest.partition(":")
    if not colon or not member or not point:
        raise InputError(f"{text!r}: expected [name=]member:x,y,z or [name=]member:point", field="--track")
    from linkedit.spec.common import name_problem  # a track name becomes an HDF5 group, as a spec's names

    if name_problem(name):
        raise InputError(f"{text!r}: {name_problem(name)}", field="--track")
    parts = point.split(",")
    if len(parts) == 1:
        return name, member, point
    from linkedit.spec.geometry3d import MAX_COORDINATE  # pydantic models: loaded when needed (start-up)

    try:
        xyz = tuple(float(p) for p in parts)
    except ValueError:
        xyz = ()
    if len(xyz) != 3 or not all(abs(c) <= MAX_COORDINATE for c in xyz):
        raise InputError(f"{text!r}: the point needs three coordinates x,y,z of at most {MAX_COORDINATE:g}",
                         field="--track")
    return name, member, xyz  # type: ignore[return-value]


def _add_tracks(res, tracks: list[str]) -> None:
    import numpy as np

    for text in tracks:
        name, member, point = parse_track(text)
        if name in res.tracks:
            raise InputError(f"{text!r}: a track named {name!r} exists already (name it: NEW=member:x,y,z)",
                             field="--track")
        if isinstance(point, str):
            pts = res.points.get(res.member_names[res.member_index(member)], {})
            if point not in pts:
                raise InputError(f"{text!r}: member {member!r} has no point {point!r}", field="--track")
            point = pts[point]
        res.add_track(name, member, np.asarray(point, dtype=float))


def _line(res, out: Path, svg: Path | None) -> str:
    s = res.summary()
    st = s["status"]
    text = (f"{res.name}: {s['steps']} steps, {s['members']} members, {s['constraints']} constraints; "
            f"{st['converged']} converged")
    if st["inconsistent"] or st["did not converge"]:
        text += f", {st['inconsistent']} inconsistent, {st['did not converge']} did not converge"
    text += f"; max residual {s['max_residual']:.2g}; dof {s['dof']}, redundant {s['redundant']}"
    if s["redundant_constraints"]:
        text += f" (redundant: {', '.join(s['redundant_constraints'])})"
    text += f"\n  → {out}" + (f", {svg}" if svg else "")
    return text


class Progress:
    """Reports a long solve on stderr: a line every few seconds once it runs past the first
    ones (step, rate, time left), none for a quick one.

    The rate is taken over the last :attr:`WINDOW` seconds (the last line or two), not since the start: the first steps
    (assembly, building the solver's structures) are far slower than the rest, and an average over
    them promised hours for a run of seconds. No estimate is given before :attr:`FIRST` of the steps
    are done."""

    EVERY = 2.0  #: seconds between lines
    WINDOW = 4.0  #: seconds of recent steps the rate is taken over (at most; the last line's at least)
    FIRST = 0.05  #: fraction of the steps done before the time left is estimated

    def __init__(self, name: str) -> None:
        import time

        self.name = name
        self.clock = time.perf_counter
        self.next = self.clock() + self.EVERY
        self.seen: deque[tuple[float, int]] = deque([(self.clock(), 0)])  # (time, steps done) at each line

    def __call__(self, k: int, total: int) -> None:
        now = self.clock()
        if now < self.next:
            return
        self.next = now + self.EVERY
        done = k + 1
        while len(self.seen) > 1 and now - self.seen[0][0] > self.WINDOW:
            self.seen.popleft()
        then, before = self.seen[0]
        self.seen.append((now, done))
        rate = (done - before) / max(now - then, 1e-9)
        text = f"{self.name}: step {done:,}/{total:,} ({rate:,.1f} steps/s"
        if self.FIRST * total <= done < total and rate > 0:
            text += f", about {_duration((total - done) / rate)} left"
        typer.echo(text + ")", err=True)


def _duration(seconds: float) -> str:
    """``12 s``, ``4 min``, ``2.5 h`` for a time left."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class View(str, Enum):
    """SVG projection."""

    plane = "plane"
    xy = "xy"
    xz = "xz"
    yz = "yz"
    iso = "iso"


class VelocityRule(str, Enum):
    """How track velocities are taken."""

    exact = "exact"
    parabola = "parabola"


class Solver(str, Enum):
    """Step solver (see linkedit.gcs.tolerances.SOLVERS)."""

    lm = "lm"
    slsqp_fd = "slsqp-fd"


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def solve3d(
        spec: Path = typer.Argument(None, help="3D mechanism spec (YAML); not needed with --from."),
        output: Path = typer.Option(None, "--output", "-o", help="Result .h5 [default: out/<spec>.h5; with --from: the same file]."),
        svg: Path = typer.Option(None, "--svg", help="Draw shapes and output curves to this .svg."),
        view: View = typer.Option(None, "--view", help="SVG projection: plane (face-on to the plane of motion), xy, xz, yz (orthographic) or iso [default: the plane of motion (xy, xz or yz when it faces one) for a mechanism that moves in a plane, else iso]."),
        arrows: bool = typer.Option(False, "--arrows", help="Draw velocity arrows on the curves."),
        velocity: VelocityRule = typer.Option(VelocityRule.exact, "--velocity", help="Track velocities: exact (from the constraint Jacobian at each pose) or parabola (the paper's three-point rule on positions)."),
        steps: int = typer.Option(None, "--steps", help="Time steps over t in [0, 1] [default: the spec's]."),
        solver: Solver = typer.Option(None, "--solver", help="lm (Gauss-Newton/Levenberg-Marquardt, analytic Jacobians) or slsqp-fd (the paper's: SLSQP, finite differences) [default: lm]."),
        source: Path = typer.Option(None, "--from", help="Re-use the member states of a gcs result instead of solving."),
        track: list[str] = typer.Option(None, "--track", help="Extra tracked point [name=]member:x,y,z (or member:point); repeatable."),
        allow_python: bool = typer.Option(False, "--allow-python", help="Allow custom constraints that run Python code (python: module:function)."),
        partial: bool = typer.Option(False, "--partial", help="Write the result even if some steps fail (their status says so)."),
        accelerations: bool = typer.Option(False, "--accelerations", help="Also compute and write the exact member accelerations (J a = -gamma at each pose, batched after the solve: 1.0-2.3x its time at 361 steps, see the README)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Solve a 3D mechanism (members, constraints, inputs) at every time step."""
        from linkedit.gcs import check_solved, solve_spec
        from linkedit.io.gcs_hdf5 import read_result, write_result
        from linkedit.spec.mechanism3d import MAX_STEPS, MechanismSpec
        from linkedit.spec.yamlload import load_yaml, located, read_text, validate

        if steps is not None and not 2 <= steps <= MAX_STEPS:
            raise InputError(f"needs between 2 and {MAX_STEPS:,} steps, not {steps:,}", field="--steps")
        if source is not None:
            if spec is not None:
                raise InputError("give a spec or --from RESULT.h5, not both", field="--from")
            given = {"--steps": steps is not None, "--solver": solver is not None,
                     "--allow-python": allow_python, "--partial": partial,
                     "--velocity": velocity != VelocityRule.exact, "--accelerations": accelerations}
            ignored = [option for option, on in given.items() if on]
            if ignored:
                raise InputError(f"nothing is solved with --from: drop {', '.join(ignored)}", field="--from")
            if output is None:  # read and replaced in place (a link's target, not the link), under its lock
                from linkedit.io.atomic import hold

                out = Path(os.path.realpath(source))
                hold(out)
            else:
                out = output
            res = read_result(source)
        else:
            if spec is None:
                raise InputError("missing SPEC (or --from RESULT.h5)", field="spec")
            text = read_text(spec)
            data, lines = load_yaml(spec, text)
            model = validate(MechanismSpec, data, file=str(spec), lines=lines, context={"allow_python": allow_python})
            try:
                res = solve_spec(model, steps=steps, solver=solver.value if solver else "lm",
                                 allow_python=allow_python, spec_text=text, velocity=velocity.value,
                                 accelerations=accelerations, stop_at_failure=not partial,
                                 progress=None if quiet else Progress(model.name))
            except InputError as exc:  # found compiling the spec (half-turn keyframes): its field's line
                raise located(exc, str(spec), lines) from None
            out = output or Path("out") / f"{spec.stem}.h5"
            if not partial:
                check_solved(res)
        _add_tracks(res, track or [])
        # with --from and no -o the result is updated in place (atomically): the source is not an input then
        inputs = [spec] if spec is not None else [source] if output is not None else []
        check_outputs([("--output", out), ("--svg", svg)], inputs)
        from linkedit.io.formats import output_format

        output_format(out, ("hdf5",))
        if svg is not None:
            output_format(svg, ("svg",), option="--svg")
        write_result(out, res)
        if svg is not None:
            from linkedit.io.gcs_svg import draw

            draw(svg, res, view=view.value if view else None, velocity=arrows)
        summary = res.summary()
        summary["status"] = {k.replace(" ", "_"): v for k, v in summary["status"].items()}  # JSON keys: no spaces
        report(summary | {"output": str(out), "svg": str(svg) if svg else None})
        say(_line(res, out, svg))
