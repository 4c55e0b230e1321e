"""The edit picture of an :class:`~linkedit.edit.runner.EditResult`: before faint, after solid,
target curves dashed, displaced points' moves and the (last) envelope box (``linkedit edit``'s
SVG, and an edit result's picture in a notebook)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from linkedit.edit.runner import EditResult
from linkedit.io.planar_svg import drawing
from linkedit.io.svg import edit_overlay
from linkedit.spec.edit_script import EditScript


def edit_picture(path: str | Path | None, result: EditResult, script: EditScript | None) -> str:
    """Write (``path``; None: only return) and return the SVG text; without the ``script`` no
    envelope box or displacement arrows are drawn."""
    targets = {label: curve for op in result.operations for label, curve in op.targets.items()}
    boxes = [op.envelope for op in script.operations if op.envelope is not None] if script else []
    envelope = (boxes[-1].xmin, boxes[-1].xmax, boxes[-1].ymin, boxes[-1].ymax) if boxes else None
    opened = {label for op in result.operations for label in op.open_targets}
    return edit_overlay(path, before=drawing(result.before), after=drawing(result.after), targets=targets,
                        cyclic=result.before.cyclic, open_targets=opened,
                        envelope=envelope, units=result.original.units, title=f"{result.original.name}: edit",
                        displacements=_displacements(result, script) if script else [])


def _displacements(result: EditResult, script: EditScript) -> list[tuple[str, Any, Any]]:
    """(label, where the point was, its target) of every displace goal of the script."""
    before = result.before
    names = before.plan.joint_names
    out = []
    for op in script.operations:
        for d in op.listed("displace"):
            when = d.when
            if d.joint is not None:
                j = names.index(d.joint)
                old = (result.original.joints[d.joint] if when is None
                       else before.positions[int(round(when * before.t.size)) % before.t.size, j])
            else:
                old = d.at if when is None else None
            out.append((d.label, old, d.to))
    return out
