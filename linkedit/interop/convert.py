"""Read another tool's mechanism (file or expression) and turn it into a validated linkage spec."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from linkedit.errors import InputError
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage
from linkedit.spec.yamlload import read_text, validate

Tool = Literal["pyslvs", "pylinkage"]


def guess_tool(source: str) -> Tool:
    """pylinkage for ``.json`` files, pyslvs for expressions and other files."""
    return "pylinkage" if source.lower().endswith(".json") else "pyslvs"


def import_spec(source: str, tool: Tool | None = None, *, units: str = "mm", name: str | None = None,
                motor: tuple[int, int] | None = None, dimensions: str | None = None,
                stroke: tuple[float, float] | None = None) -> LinkageSpec:
    """The linkage in ``source`` (a file path, or a pyslvs expression ``M[…]``) as a spec.

    ``motor`` (pyslvs only): (pivot, driven joint) point indices; default the project's first
    input pair, else the first revolute pair on a ground link; ``stroke`` the range of a slider input
    (pivot = joint). ``dimensions`` (pylinkage graphs only): the file of the graph's ``Dimensions``.
    """
    from linkedit.interop import pylinkage, pyslvs

    tool = tool or guess_tool(source)
    if dimensions is not None and tool != "pylinkage":
        raise InputError("--dimensions goes with a pylinkage graph", field="--dimensions")
    if stroke is not None and tool != "pyslvs":
        raise InputError("goes with a pyslvs slider input (--input N,N)", field="--stroke")
    is_expression = source.lstrip().startswith("M[")
    text = source if is_expression else read_text(source)
    where = "<expression>" if is_expression else source
    stem = name or ("pyslvs" if is_expression else Path(source).stem)
    if tool == "pylinkage":
        if is_expression:
            raise InputError("pylinkage input is a JSON file, not an expression", field="--from")
        sizes = (read_text(dimensions), dimensions) if dimensions is not None else None
        doc = pylinkage.to_document(text, source=where, units=units, name=name, dimensions=sizes)
    else:
        pairs: list[tuple[int, int]] = []
        line = None
        if not text.lstrip().startswith("M["):
            text, line, pairs = pyslvs.read_project(text, where)
        joints = pyslvs.parse_expression(text, where, line)
        doc = pyslvs.to_document(joints, name=_name(stem), units=units, motor=motor or (pairs[0] if pairs else None),
                                 source=where, stroke=stroke)
    return validate(LinkageSpec, doc, file=where)


def _name(stem: str) -> str:
    return stem.replace("/", "-").lstrip(".") or "imported"


def import_yaml(spec: LinkageSpec, source: str, tool: str) -> str:
    """YAML text of an imported spec, with a header naming where it came from."""
    return dump_linkage(spec, header=f"imported from {tool} by linkedit import\nsource: {source[:200]}")
