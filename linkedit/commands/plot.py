"""``linkedit plot``: kinematics and transmission-angle plots of a planar result."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, guard, refuse_json_with_stdout, report, say
from linkedit.errors import InputError


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def plot(
        result: Path = typer.Argument(..., help="A planar result .h5 (from linkedit simulate)."),
        output: Path = typer.Option(None, "--output", "-o", help="The plot .svg, or - for stdout [default: RESULT-plot.svg]."),
        track: str = typer.Option(None, "--track", help="The track to plot [default: the first track]."),
        joint: str = typer.Option(None, "--joint", help="Plot this joint instead of a track."),
        per_second: bool = typer.Option(False, "--per-second", help="Derivatives per second (needs --rpm) instead of per radian of crank angle."),
        rpm: float = typer.Option(None, "--rpm", min=0.0, help="Motor speed, revolutions per minute (with --per-second)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Plot a point's position, velocity, acceleration and jerk, the transmission angles (40°–140° band,
        worst samples marked) and d_s against crank angle."""
        from linkedit.io.formats import output_format, write_out
        from linkedit.io.kinematics_plot import kinematics_svg, read_kinematics

        if track is not None and joint is not None:
            raise InputError("give --track or --joint, not both", field="--joint")
        if rpm is not None and not (math.isfinite(rpm) and rpm > 0.0):
            raise InputError(f"must be a finite speed above 0, got {rpm:g}", field="--rpm")
        if per_second != (rpm is not None):
            raise InputError("--per-second and --rpm go together (derivatives per second at that speed)", field="--rpm")
        out = output if output is not None else result.with_name(f"{result.stem}-plot.svg")
        output_format(out, ("svg",), stdout="svg")
        check_outputs([("--output", out)], [result])
        refuse_json_with_stdout(out)
        k = read_kinematics(result, track=track, joint=joint)
        write_out(out, kinematics_svg(k, rpm=rpm))
        report({"result": str(result), "point": k.point, "output": str(out)})
        if str(out) != "-":
            say(f"{result}: {k.point} → {out}")
