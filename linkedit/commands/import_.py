"""``linkedit import``: bring a mechanism in from pyslvs / PMKS or pylinkage."""

from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, guard, refuse_json_with_stdout, report
from linkedit.errors import InputError


class Tool(str, Enum):
    pyslvs = "pyslvs"
    pylinkage = "pylinkage"


def _pair(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        a, b = (int(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{text!r}: give two point indices PIVOT,JOINT such as 0,1", field="--input") from None
    return a, b


def _range(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{text!r}: give two lengths S0,S1 such as 0,25", field="--stroke") from None
    return a, b  # (checked with the spec: finite, different)


def register(app: typer.Typer) -> None:
    @app.command("import")
    @guard
    def import_(
        source: str = typer.Argument(..., help="A pyslvs/PMKS expression 'M[J[R, P[x, y], L[ground, L1]], …]', "
                                               "a pyslvs YAML project, or a pylinkage JSON file."),
        tool: Tool = typer.Option(None, "--from", help="The tool it comes from [default: pylinkage for .json, else pyslvs]."),
        output: Path = typer.Option(Path("-"), "--output", "-o", help="The linkage spec .yaml, or - for stdout.",
                                    show_default="- (stdout)"),
        motor: str = typer.Option(None, "--input", help="pyslvs: the motor as point indices PIVOT,JOINT "
                                                        "[default: the project's first input, else the first revolute pair on a ground link]."),
        stroke: str = typer.Option(None, "--stroke", help="pyslvs: a slider input's (--input N,N) range S0,S1: the "
                                                          "joint's displacement from rest along its slot, in --units."),
        dimensions: Path = typer.Option(None, "--dimensions", help="pylinkage graph (graph_to_json): its Dimensions "
                                                                  "(Dimensions.to_dict() saved as JSON)."),
        units: str = typer.Option("mm", "--units", help="Length unit of the source's numbers."),
        name: str = typer.Option(None, "--name", help="The linkage's name [default: the file's stem]."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Import a mechanism from pyslvs/PMKS (expression or project) or pylinkage (JSON) as a linkage spec.

        Joints from a pyslvs expression are named P0, P1, … in its order.
        """
        from linkedit.interop.convert import guess_tool, import_spec, import_yaml
        from linkedit.io.formats import output_format, write_out

        output_format(output, ("yaml",), stdout="yaml")
        check_outputs([("--output", output)], [source] + ([str(dimensions)] if dimensions else []))
        refuse_json_with_stdout(output)
        which = tool.value if tool else guess_tool(source)
        spec = import_spec(source, which, units=units, name=name, motor=_pair(motor),  # type: ignore[arg-type]
                           dimensions=str(dimensions) if dimensions else None, stroke=_range(stroke))
        write_out(output, import_yaml(spec, source, which))
        report({"source": source, "from": which, "output": str(output), "name": spec.name,
                "joints": list(spec.joints), "links": list(spec.links), "sliders": list(spec.sliders)})
