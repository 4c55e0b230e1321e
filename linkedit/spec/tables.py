"""CSV tables of numbers given as input — target curves, function pairs, poses: one reader for all.

Rows are the lines that are not blank and do not start with ``#`` or ``//``; cells are separated
by the most frequent of ``,``, ``;`` and tab in the first row (with ``;`` a decimal comma reads as
a point, as spreadsheets export it). A header cell names its column without case or spaces, a
unit in brackets dropped and kept (``X (mm)`` is ``x`` in mm; ``time`` is ``t``). Every error is
one :class:`~linkedit.errors.InputError` naming the file, the line and the column.
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

Rows = list[tuple[int, list[str]]]

_UNITS = re.compile(r"\s*[\(\[][^\)\]]*[\)\]]\s*")
_UNIT = re.compile(r"[\(\[]([^\)\]]*)[\)\]]")


def read_rows(path: Path) -> Rows:
    """The rows of the CSV file ``path``: (line number, cells), comments and blank lines left out."""
    text = read_text(path)
    data_lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith(("#", "//"))]
    delimiter = max((",", ";", "\t"), key=data_lines[0].count) if data_lines else ","
    if delimiter == ";" and any("," in ln and "." not in ln for ln in data_lines[1:3]):
        text = text.replace(",", ".")  # a decimal comma
    return [(i + 1, r) for i, r in enumerate(csv.reader(io.StringIO(text), delimiter=delimiter))
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith(("#", "//"))]


def column_name(cell: str) -> str:
    """A header cell as a column name: ``X (mm)``, ``x [mm]``, `` X `` → ``x``; ``time`` → ``t``."""
    name = _UNITS.sub("", cell).strip().lower()
    return {"time": "t"}.get(name, name)


def column_unit(cell: str) -> str | None:
    """The unit a header cell gives in brackets (``x (mm)`` → ``mm``), or None."""
    found = _UNIT.search(cell)
    return (found.group(1).strip() or None) if found else None


def numbers(rows: Rows, names: Sequence[str], file: str) -> np.ndarray:
    """The cells of ``rows`` (N rows of len(names) cells) as finite numbers (N, C); an InputError
    naming the line and column for a short row, a cell that is not a number, or NaN/inf."""
    values = np.empty((len(rows), len(names)))
    for r, (line, row) in enumerate(rows):
        if len(row) != len(names):
            raise InputError(f"{len(row)} values, expected {len(names)}", file=file, line=line)
        for c, cell in enumerate(row):
            try:
                values[r, c] = float(cell)
            except ValueError:
                raise InputError(f"not a number: {cell.strip()!r}", file=file, line=line, field=names[c]) from None
            if not np.isfinite(values[r, c]):
                raise InputError(f"not a finite number: {cell.strip()!r}", file=file, line=line, field=names[c])
    return values


@dataclass(frozen=True)
class Table:
    """Named columns (N,) float each, the file line of each row, each column's unit (or None) and the
    header's line."""

    columns: dict[str, np.ndarray]
    lines: list[int]
    units: dict[str, str | None]
    header: int


def read_columns(path: Path, required: Sequence[str], optional: Sequence[str] = (), *, minimum: int = 1) -> Table:
    """The columns of the CSV file ``path`` by name (``optional`` ones only when present), under a
    header row naming each once. At least ``minimum`` rows, else an InputError."""
    file = str(path)
    rows = read_rows(path)
    if not rows:
        raise InputError("the file has no data", file=file)
    line, header = rows[0]
    names = [column_name(c) for c in header]
    wanted = [*required, *optional]
    for name in names:
        if name not in wanted:
            raise InputError(f"unknown column {name!r} (columns: {', '.join(required)}"
                             + (f"[, {', '.join(optional)}]" if optional else "") + ")", file=file, line=line)
    missing = [name for name in required if name not in names]
    if missing or len(set(names)) != len(names):
        raise InputError(f"the header must name {', '.join(required)} once each"
                         + (f" (and optionally {', '.join(optional)})" if optional else ""), file=file, line=line)
    values = numbers(rows[1:], names, file)
    if len(values) < minimum:
        raise InputError(f"{len(values)} data rows; at least {minimum} are needed", file=file)
    return Table({name: values[:, names.index(name)] for name in wanted if name in names}, [n for n, _ in rows[1:]],
                 {name: column_unit(cell) for name, cell in zip(names, header)}, line)
