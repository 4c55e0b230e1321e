"""An edit script read and checked against its linkage, from a file, a dict or a model.

The CLI and the Python API (``le.edit``) read scripts through :func:`read_script` and check
them with :meth:`Script.check`, so both raise the same :class:`~linkedit.errors.InputError`
(``file:line: field: what is wrong``) for a name the linkage does not have, a phase window
that holds none of the script's samples, or a drag narrower than their spacing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.edit.operation import select
from linkedit.errors import InputError
from linkedit.planar.simulate import motor_phases
from linkedit.spec.edit_script import EditScript, check_against
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import LineMap, load_yaml, validate


@dataclass
class Script:
    """A validated script, the file it came from ('' for a dict or a model) and its lines."""

    script: EditScript
    file: str = ""
    lines: LineMap = field(default_factory=LineMap)

    def check(self, linkage: LinkageSpec) -> None:
        """Every name against ``linkage`` (:func:`check_against`) and every phase window against the
        samples; the error located in the file."""
        try:
            check_against(self.script, linkage)
            _windows(self.script, linkage)
        except InputError as exc:
            exc.file, exc.line = (self.file or None), (self.lines.line_of(exc.field) if self.file else None)
            raise


def _windows(script: EditScript, linkage: LinkageSpec) -> None:
    """Every ``preserve`` window ``phases: [a, b]`` holds at least one of the script's samples, and
    every ``drag`` is at least as wide (``radius``) as their spacing: narrower, it falls between them."""
    t = motor_phases(linkage, script.samples)
    spacing = float(t[1] - t[0])
    for o, op in enumerate(script.operations):
        for n, d in enumerate(op.listed("drag")):
            if d.radius < spacing:
                where = ("drag", n) if isinstance(op.drag, list) else ("drag",)
                need = int(np.ceil(1.0 / d.radius)) + (not linkage.motor.cyclic)
                raise InputError(f"a drag of radius {d.radius:g} is narrower than the samples' spacing "
                                 f"(one every {spacing:.4g} of the cycle): it falls between them; raise "
                                 f"samples: {need} or more, or widen it", field=("operations", o, *where, "radius"))
        for n, kept in enumerate(op.preserve):
            if isinstance(kept, str) or kept.phases is None or select(t, kept.phases).size:
                continue
            a, b = kept.phases
            raise InputError(f"[{a:g}, {b:g}] hold none of the {t.size} samples (one every {t[1] - t[0]:.4g} "
                             "of the cycle): widen the window or raise samples",
                             field=("operations", o, "preserve", n, "phases"))


def read_script(source: str | Path | Mapping[str, Any] | EditScript) -> Script:
    """A script from a YAML path, a dict (as the YAML would load) or an :class:`EditScript`."""
    if isinstance(source, EditScript):
        return Script(source)
    if isinstance(source, Mapping):
        return Script(validate(EditScript, dict(source), file=""))
    data, lines = load_yaml(source)
    return Script(validate(EditScript, data, file=str(source), lines=lines), str(source), lines)
