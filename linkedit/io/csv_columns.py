"""Read a CSV table of named numeric columns (the inputs of ``synthesize --function`` / ``--motion``).

One header row names the columns (case and surrounding spaces ignored, a unit in brackets
dropped from the name and kept as the column's unit: ``x (mm)`` is ``x`` in mm); ``,``, ``;`` or tab separate cells; blank lines and
lines starting with ``#`` or ``//`` are skipped. Every other row must hold one finite number
per column. Errors are :class:`~linkedit.errors.InputError` naming the file, line and column.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.spec.yamlload import read_text

_UNIT = re.compile(r"\s*[\(\[][^\)\]]*[\)\]]\s*")


def _name(cell: str) -> str:
    return _UNIT.sub("", cell).strip().lower()


def _unit(cell: str) -> str | None:
    found = _UNIT.search(cell)
    return found.group(0).strip()[1:-1].strip() or None if found else None


@dataclass(frozen=True)
class Table:
    """Named columns (N,) float each, the file line of each row, and each column's unit (or None)."""

    columns: dict[str, np.ndarray]
    lines: list[int]
    units: dict[str, str | None]


def read_columns(path: Path, required: Sequence[str], optional: Sequence[str] = (), *, minimum: int = 1) -> Table:
    """The columns of ``path`` by name (``optional`` ones only when present). At least ``minimum``
    rows, else an InputError."""
    file = str(path)
    text = read_text(path)
    rows = [(n + 1, line) for n, line in enumerate(text.splitlines())
            if line.strip() and not line.lstrip().startswith(("#", "//"))]
    if not rows:
        raise InputError("the file has no data", file=file)
    delimiter = max((",", ";", "\t"), key=rows[0][1].count)
    cells = [(n, next(csv.reader(io.StringIO(line), delimiter=delimiter))) for n, line in rows]
    line, header = cells[0]
    names = [_name(c) for c in header]
    wanted = [*required, *optional]
    for name in names:
        if name not in wanted:
            raise InputError(f"unknown column {name!r} (columns: {', '.join(required)}"
                             + (f"[, {', '.join(optional)}]" if optional else "") + ")", file=file, line=line)
    missing = [name for name in required if name not in names]
    if missing or len(set(names)) != len(names):
        raise InputError(f"the header must name {', '.join(required)} once each"
                         + (f" (and optionally {', '.join(optional)})" if optional else ""), file=file, line=line)
    values = np.empty((len(cells) - 1, len(names)))
    for r, (line, row) in enumerate(cells[1:]):
        if len(row) != len(names):
            raise InputError(f"{len(row)} values, expected {len(names)}", file=file, line=line)
        for c, cell in enumerate(row):
            try:
                values[r, c] = float(cell)
            except ValueError:
                raise InputError(f"not a number: {cell.strip()!r}", file=file, line=line, field=names[c]) from None
            if not np.isfinite(values[r, c]):
                raise InputError(f"not a finite number: {cell.strip()!r}", file=file, line=line, field=names[c])
    if len(values) < minimum:
        raise InputError(f"{len(values)} data rows; at least {minimum} are needed", file=file)
    return Table({name: values[:, names.index(name)] for name in wanted if name in names}, [n for n, _ in cells[1:]],
                 {name: _unit(cell) for name, cell in zip(names, header)})
