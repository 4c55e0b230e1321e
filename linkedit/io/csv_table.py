"""Every CSV linkedit writes: one header row, then rows, through the ``csv`` module.

* a cell with a comma, a quote or a line break is quoted (a joint named ``A,x`` stays one cell);
* a text cell (a header, a name) that begins with ``=``, ``+``, ``-``, ``@``, a tab or a carriage
  return gets a leading ``'``, so a spreadsheet shows it as text instead of running it as a formula
  (``=B_x`` is written ``'=B_x``); numbers are never changed;
* a column name that repeats an earlier one is numbered (``name#2``), so every column has its own name;
* numbers are written with 17 significant digits (they read back as the same doubles), a missing or
  non-finite number as an empty cell (never NaN).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Iterator, Sequence

import numpy as np

#: first characters that make a spreadsheet cell a formula (OWASP "CSV injection")
FORMULA_PREFIXES = ("=", "+", "-", "@", "\t", "\r")

#: one cell: text, a number, or None (empty)
Cell = str | float | int | bool | None


def text_cell(text: str) -> str:
    """``text`` as a spreadsheet shows it literally: a leading ``'`` before a formula prefix."""
    return "'" + text if text.startswith(FORMULA_PREFIXES) else text


def header_cells(names: Sequence[str]) -> list[str]:
    """Column names as written: formula prefixes neutralized, repeats numbered ``name#2``, ``name#3``…"""
    out: list[str] = []
    taken: set[str] = set()
    for name in map(text_cell, names):
        unique, n = name, 1
        while unique in taken:
            n += 1
            unique = f"{name}#{n}"
        taken.add(unique)
        out.append(unique)
    return out


def number_cells(table: np.ndarray) -> list[list[str]]:
    """A (rows, columns) float table as cells: shortest round-trip digits, empty where not finite."""
    table = np.asarray(table, dtype=float)
    text = table.astype(str)
    text[~np.isfinite(table)] = ""
    return text.tolist()


def _cell(value: Cell) -> str:
    if value is None:
        return ""
    if isinstance(value, str):
        return text_cell(value)
    if isinstance(value, (bool, int, np.integer, np.bool_)):
        return str(value)
    return repr(float(value)) if np.isfinite(value) else ""


#: rows formatted at a time: a long table (``simulate --samples 3000000 -o o.csv``) is written in pieces,
#: never held as text all at once
CHUNK_ROWS = 10_000


def csv_chunks(header: Sequence[str], rows: Iterable[Sequence[Cell]] | np.ndarray, *,
               comment: str | None = None) -> Iterator[str]:
    """The CSV text of a table (see the module docstring) in pieces of :data:`CHUNK_ROWS` rows.

    ``rows``: a (rows, columns) float array, or rows of cells (str: text; bool, int, float: numbers;
    None: empty). ``comment``: a first line ``# comment`` (units, provenance).
    """
    out = io.StringIO()
    if comment is not None:
        out.write(f"# {comment}\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header_cells(header))
    if isinstance(rows, np.ndarray):
        for start in range(0, len(rows), CHUNK_ROWS):
            writer.writerows(number_cells(rows[start:start + CHUNK_ROWS]))
            yield out.getvalue()
            out.seek(0)
            out.truncate()
    else:
        writer.writerows([_cell(v) for v in row] for row in rows)
    yield out.getvalue()


def csv_text(header: Sequence[str], rows: Iterable[Sequence[Cell]] | np.ndarray, *, comment: str | None = None) -> str:
    """The CSV text of a table at once (see :func:`csv_chunks`)."""
    return "".join(csv_chunks(header, rows, comment=comment))
