"""Where curves come from: tracks of linkedit results, CSV files and YAML curve sets.

An input is written as on the command line:

* ``result.h5:foot`` — track ``foot`` of a result (``/tracks/foot/position``, (T, 2) or (T, 3));
  ``result.h5`` alone — every track of the file. An edit result (``kind = "edit"``) holds each
  track before and after the edit (``/before/tracks/<name>``, ``/after/tracks/<name>``):
  ``edit.h5:foot`` is the edited curve, ``edit.h5:before/foot`` and ``edit.h5:after/foot``
  choose, ``edit.h5`` alone gives every track before and after;
* ``path.csv`` — columns x, y[, z] and optionally t (a header names them; without a header,
  2 or 3 numeric columns are x, y[, z]); rows are ordered by t when it is given. Spreadsheet and
  PMKS+/SolveSpace exports read too: units in the header (``X (mm)``, ``y [mm]``: the curve's units,
  one for all coordinate columns), ``time`` for
  t, an index column (``index``, ``#``, ``point``…, ignored), ``;`` or tab separators (with
  ``;``, decimal commas), ``#`` and ``//`` comment lines;
* ``set.yaml`` — a curve set (``specs/curve-set.md``); ``set.yaml:circle`` — one curve of it;
* a folder — every .h5/.hdf5, .csv and .yaml/.yml file in it.

Every curve is checked: finite numbers, at least 3 distinct points, a positive length.
"""

from __future__ import annotations

import contextvars
import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.errors import InputError
from linkedit.spec.tables import column_name, column_unit, numbers, read_rows

HDF5_SUFFIXES = (".h5", ".hdf5")
YAML_SUFFIXES = (".yaml", ".yml")
#: The groups of an edit result (``specs/edit-hdf5.md``); a bare track name means the last one.
EDIT_STAGES = ("before", "after")
#: A curve is closed when its end lies this close to its start, relative to the bounding-box
#: diagonal, or within CLOSE_STEPS steps (median steps, or the steps at its ends).
CLOSE_GAP = 0.05
CLOSE_STEPS = 1.5


@dataclass(frozen=True)
class Curve:
    """One motion curve as read, in input units."""

    name: str
    points: np.ndarray  #: (M, D), D = 2 or 3, consecutive duplicates removed
    closed: bool
    origin: str  #: the file (and track) it was read from
    anchor: np.ndarray | None = None  #: (D,) an anchor point (e.g. the crank axle), input units
    units: str | None = None
    #: (M,) the sample times (a CSV ``t`` column; a result's motor phase ``/t``), increasing; None if not given
    times: np.ndarray | None = None
    #: a closed curve's cycle time (from the first sample to its return there), when ``times`` are given
    period: float | None = None


def load_inputs(inputs: list[str], *, closed: bool | None = None,
                skip: Callable[[InputError], None] | None = None) -> list[Curve]:
    """Read every input (see the module docstring); names are made unique.

    With ``skip``, an input (or a file in a folder) that cannot be read is handed to ``skip``
    and left out instead of stopping the run.
    """
    curves: list[Curve] = []
    for text in inputs:
        curves += _guarded(lambda: _load_one(str(text), closed, skip), skip)
    return _unique_names(curves)


def input_files(inputs: Iterable[str | Path]) -> list[Path]:
    """Every file and folder the curve inputs read: the inputs, a folder's curve files and a curve set's
    sources, recursively (for the checks that no output overwrites one). A set that cannot be read adds
    nothing here; loading it reports why."""
    from linkedit.spec.curveset import CurveSet
    from linkedit.spec.yamlload import load_yaml, validate

    found: list[Path] = []
    seen: set[str] = set()

    def visit(path: Path) -> None:
        if os.path.realpath(path) in seen:
            return
        seen.add(os.path.realpath(path))
        found.append(path)
        if path.is_dir():
            for child in sorted(path.iterdir()):
                if child.suffix.lower() in HDF5_SUFFIXES + YAML_SUFFIXES + (".csv",):
                    visit(child)
        elif path.suffix.lower() in YAML_SUFFIXES and path.is_file():
            try:
                data, lines = load_yaml(path)
                spec = validate(CurveSet, data, file=str(path), lines=lines)
            except InputError:
                return
            for entry in spec.curves:
                if entry.source is not None:
                    visit(_split_track(str(path.parent / entry.source))[0])

    for text in inputs:
        visit(_split_track(str(text))[0])
    return found


def _guarded(load: Callable[[], list[Curve]], skip: Callable[[InputError], None] | None) -> list[Curve]:
    if skip is None:
        return load()
    try:
        return load()
    except InputError as exc:
        skip(exc)
        return []


def _load_one(text: str, closed: bool | None, skip: Callable[[InputError], None] | None = None) -> list[Curve]:
    path, track = _split_track(text)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in HDF5_SUFFIXES + YAML_SUFFIXES + (".csv",))
        if not files:
            raise InputError("no .h5, .csv or .yaml curve files in this folder", file=str(path))
        return [c for f in files for c in _guarded(lambda: _load_one(str(f), closed), skip)]
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    suffix = path.suffix.lower()
    if suffix in HDF5_SUFFIXES:
        return read_tracks(path, None if track is None else [track], closed=closed)
    if suffix in YAML_SUFFIXES:
        curves = read_curve_set(path, closed=closed)
        if track is None:
            return curves
        chosen = [c for c in curves if c.name == track]
        if not chosen:
            raise InputError(f"unknown curve {track!r}; the set has: {', '.join(c.name for c in curves)}",
                             file=str(path), field=("curves",))
        return chosen
    if track is not None:
        raise InputError(f"':{track}' selects a track of a result or a curve of a set; this is neither", file=str(path))
    if suffix == ".csv":
        return [read_csv(path, closed=closed)]
    raise InputError("unknown curve file type (use .h5 results, .csv or .yaml curve sets)", file=str(path))


def _split_track(text: str) -> tuple[Path, str | None]:
    """``result.h5:foot`` → (result.h5, "foot"), ``edit.h5:before/foot`` and ``set.yaml:circle`` likewise;
    anything else → (path, None)."""
    head, sep, tail = text.rpartition(":")
    suffix = Path(head).suffix.lower()
    if sep and suffix in HDF5_SUFFIXES + YAML_SUFFIXES and "\\" not in tail:
        stage, slash, name = tail.partition("/")
        if not slash or (suffix in HDF5_SUFFIXES and stage and name and "/" not in name):
            return Path(head), tail
    return Path(text), None


def read_tracks(path: Path, names: list[str] | None, *, closed: bool | None = None) -> list[Curve]:
    """Tracks of a result file; ``names=None`` reads all of them (of an edit result: before and after).
    Read guarded (:mod:`linkedit.io.h5read`): no links followed, sizes checked before reading."""
    from linkedit.io.h5read import open_result

    with open_result(path, ours=False) as f:
        edit = f.attr("kind", default=None) == "edit" or not f.has("tracks") and all(f.has(s) for s in EDIT_STAGES)
        stages = EDIT_STAGES if edit else ("",)
        expected = "/before/tracks/<name>/position and /after/..." if edit else "/tracks/<name>/position"
        groups = {s: f"{s}/tracks" if s else "tracks" for s in stages}
        if not all(f.has(g) and f.names(g) for g in groups.values()):
            raise InputError(f"no tracks in this file (expected {expected})", file=str(path))
        available = sorted(f.names(groups[stages[0]]))
        units = f.attr("units", default=None)
        linear = f.attr("input", default=None) == "linear"
        if names is None:
            chosen = [f"{s}/{n}" for s in EDIT_STAGES for n in available] if edit else available
        else:
            chosen = [n if not edit or "/" in n else f"{EDIT_STAGES[-1]}/{n}" for n in names]
        out = []
        for key in chosen:
            stage, _, name = key.rpartition("/")
            if stage not in groups:
                raise InputError(f"{key!r}: " + (f"unknown stage {stage!r} (use before/ or after/)" if edit else
                                                  "before/ and after/ select a stage of an edit result; this file "
                                                  "is not one"), file=str(path))
            base = (stage, "tracks", name) if stage else ("tracks", name)
            if name not in f.names(groups[stage]):
                raise InputError(f"unknown track {name!r}; the file has: {', '.join(available)}", file=str(path),
                                 field=base)
            field = base + ("position",)
            where = "/".join(field)
            data = f.dataset(where)
            if data.ndim != 2 or data.shape[1] not in (2, 3) or data.dtype.kind not in "fiu":
                raise InputError("expected a (T, 2) or (T, 3) dataset of real numbers", file=str(path), field=field)
            points = np.asarray(f.array(where), dtype=float)
            bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
            if bad.size:
                raise InputError(f"{bad.size} samples are not finite (first at sample {bad[0]}; did the "
                                 f"mechanism lock up?)", file=str(path), field=field)
            phase = f"{stage}/t" if stage else "t"
            times = None
            if not linear and f.has(phase):
                ds = f.dataset(phase)
                if ds.shape == (len(points),) and ds.dtype.kind in "fiu":
                    times = np.asarray(f.array(phase), dtype=float)  # fractions of a revolution: one cycle takes 1
            out.append(make_curve(f"{path.stem}:{key}", points, closed=closed, origin=f"{path}:{key}",
                                  file=str(path), field=field, units=units,
                                  times=times, period=1.0 if times is not None else None))
    return out


def read_csv(path: Path, *, closed: bool | None = None) -> Curve:
    """One curve from a CSV file (columns x, y[, z], optional t)."""
    file = str(path)
    rows = read_rows(path)
    if not rows:
        raise InputError("the file has no data", file=file)
    line, first = rows[0]
    header = [column_name(c) for c in first]
    keep = list(range(len(header)))
    units = None
    if all(_is_number(c) for c in header):
        if len(header) not in (2, 3):
            raise InputError(f"{len(header)} columns without a header; give x, y[, z] or a header line", file=file,
                             line=line)
        columns = ["x", "y", "z"][: len(header)]
    else:
        keep = [i for i, name in enumerate(header) if name not in INDEX_COLUMNS]
        columns = [header[i] for i in keep]
        rows = rows[1:]
        for name in columns:
            if name not in ("x", "y", "z", "t"):
                raise InputError(f"unknown column {name!r} (use x, y, z, t; an index column is ignored)", file=file,
                                 line=line, field=name)
        if len(set(columns)) != len(columns) or "x" not in columns or "y" not in columns:
            raise InputError("the header must name x and y once each (and optionally z, t)", file=file, line=line)
        units = _header_units({header[i]: first[i] for i in keep if header[i] != "t"}, file, line)
        if not rows:
            raise InputError("the file has no data: a header and no rows", file=file, line=line)
    width = len(header)
    rows = [(ln, [row[i] for i in keep] if len(row) == width else row) for ln, row in rows]
    values = numbers(rows, columns, file)
    if "t" in columns:
        values = values[np.argsort(values[:, columns.index("t")], kind="stable")]
    points = values[:, [columns.index(a) for a in ("x", "y", "z") if a in columns]]
    times = values[:, columns.index("t")] if "t" in columns else None
    return make_curve(path.stem, points, closed=closed, origin=file, file=file, times=times, units=units)


def _header_units(cells: dict[str, str], file: str, line: int) -> str | None:
    """The length unit the coordinate columns' header cells give (``x (m)``, ``y [mm]``), or None;
    an InputError if they give different ones or one that cannot name units (see ``specs/linkage.md``)."""
    found = {name: unit for name, cell in cells.items() if (unit := column_unit(cell))}
    if len(set(found.values())) > 1:
        raise InputError("the columns give different units (" + ", ".join(f"{n} ({u})" for n, u in found.items())
                         + "): give the coordinates in one unit", file=file, line=line)
    unit = next(iter(found.values()), None)
    if unit is not None and not UNIT_NAME.fullmatch(unit):
        raise InputError(f"the unit {unit!r} is not a length unit's name (no '/', no leading '.')", file=file,
                         line=line, field=next(iter(found)))
    return unit


#: A length unit's name, as a spec's ``units`` takes it (:data:`linkedit.spec.common.Name`).
UNIT_NAME = re.compile(r"[^/.\x00-\x1f][^/\x00-\x1f]*")
#: header names of columns that only number the rows (ignored)
INDEX_COLUMNS = ("", "index", "idx", "#", "no", "n", "i", "point", "frame", "step", "sample", "unnamed: 0")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


#: The curve sets being read (a source that leads back to one of them is a loop).
_READING: contextvars.ContextVar[frozenset[Path]] = contextvars.ContextVar("reading", default=frozenset())


def read_curve_set(path: Path, *, closed: bool | None = None) -> list[Curve]:
    """The curves of a YAML curve set; sources are relative to the set's folder."""
    from linkedit.spec.curveset import CurveSet
    from linkedit.spec.yamlload import load_yaml, validate

    data, lines = load_yaml(path)
    spec = validate(CurveSet, data, file=str(path), lines=lines)
    out = []
    for i, entry in enumerate(spec.curves):
        flag = closed if closed is not None else entry.closed
        if entry.points is not None:
            field = ("curves", i, "points")
            curve = make_curve(entry.name, np.asarray(entry.points, dtype=float), closed=flag,
                               origin=f"{path}:{entry.name}", file=str(path), field=field,
                               line=lines.line_of(field), units=spec.units)
        else:
            assert entry.source is not None  # a curve gives points or a source (checked by CurveSet)
            source = path.parent / entry.source
            if source.resolve() in _READING.get():
                field = ("curves", i, "source")
                raise InputError(f"source {entry.source!r} leads back to this curve set (a loop)", file=str(path),
                                 field=field, line=lines.line_of(field))
            token = _READING.set(_READING.get() | {path.resolve()})
            try:
                loaded = _load_one(str(source), flag)
            finally:
                _READING.reset(token)
            if len(loaded) != 1:
                field = ("curves", i, "source")
                raise InputError(f"source {entry.source!r} holds {len(loaded)} curves; name one track "
                                 "(result.h5:track)", file=str(path), field=field, line=lines.line_of(field))
            curve = loaded[0]
        anchor = None if entry.anchor is None else np.asarray(entry.anchor, dtype=float)
        if anchor is not None and anchor.shape != curve.points.shape[1:]:
            field = ("curves", i, "anchor")
            raise InputError(f"a {anchor.size}D anchor for a {curve.points.shape[1]}D curve", file=str(path),
                             field=field, line=lines.line_of(field))
        out.append(Curve(entry.name, curve.points, curve.closed, curve.origin, anchor, curve.units or spec.units))
    return out


def make_curve(name: str, points: np.ndarray, *, closed: bool | None, origin: str, file: str | None = None,
               field: tuple[str | int, ...] | None = None, line: int | None = None, units: str | None = None,
               times: np.ndarray | None = None, period: float | None = None) -> Curve:
    """Check and clean points (M, D): finite, ≥ 3 distinct points, positive length; decide closedness.

    ``times`` (M,), increasing, go with the points; a closed curve's ``period`` is, unless given, the
    time of a last point repeating the first, or the span of the times plus their mean step."""
    where: dict[str, Any] = dict(file=file or origin, field=field, line=line)
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise InputError(f"expected points with 2 or 3 coordinates, got shape {points.shape}", **where)
    if not len(points):
        raise InputError("no data: the curve has no points", **where)
    if not np.isfinite(points).all():
        raise InputError("the points contain NaN or infinite values", **where)
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.any(points[1:] != points[:-1], axis=1)
    points = points[keep]
    if times is not None:
        times = np.asarray(times, dtype=float)[keep]
    distinct = _distinct_up_to_3(points)
    if distinct == 1:
        raise InputError("degenerate curve: all points coincide (zero length)", **where)
    if distinct < 3:
        raise InputError(f"a curve needs at least 3 distinct points, this one has {distinct}", **where)
    looped = bool(np.all(points[-1] == points[0]))
    if closed is None:
        closed = looped or is_closed(points)
    if times is not None and closed:
        if period is None:
            period = float(times[-1] - times[0]) * (1.0 if looped else len(times) / (len(times) - 1))
        if looped:
            times = times[:-1]
    if looped and closed:
        points = points[:-1]
    return Curve(name, points, bool(closed), origin, None, units, times, period if closed and times is not None else None)


def _distinct_up_to_3(points: np.ndarray) -> int:
    """How many distinct points (M, D) there are, counted up to 3 (two O(M) passes, no sort)."""
    other = np.any(points != points[0], axis=1)
    if not other.any():
        return 1
    second = points[int(np.argmax(other))]
    third = other & np.any(points != second, axis=1)
    return 3 if third.any() else 2


def is_closed(points: np.ndarray) -> bool:
    """Whether the end meets the start, from the geometry: the gap between them is at most 5 % of the
    bounding-box diagonal, or at most 1.5 median steps, or at most 1.5 times the longer of the first and
    last steps (the closing segment is spaced like the points beside it: a closed curve sampled
    unevenly, sparsely where it starts and ends, is closed; an open part of a cycle leaves a gap many
    steps long)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    with np.errstate(over="ignore"):
        box = float(np.max(hi - lo))
    unit = (points - (0.5 * lo + 0.5 * hi)) / box  # no square under- or overflows, whatever the units
    gap = float(np.linalg.norm(unit[-1] - unit[0]))
    diagonal = float(np.linalg.norm(unit.max(axis=0) - unit.min(axis=0)))
    steps = np.linalg.norm(np.diff(unit, axis=0), axis=1)
    spacing = max(float(np.median(steps)), float(steps[0]), float(steps[-1]))
    return gap <= CLOSE_GAP * diagonal or gap <= CLOSE_STEPS * spacing


def _unique_names(curves: list[Curve]) -> list[Curve]:
    """Curves sharing a name are renamed after their origin (and numbered if still equal)."""
    counts: dict[str, int] = {}
    for c in curves:
        counts[c.name] = counts.get(c.name, 0) + 1
    renamed = [c if counts[c.name] == 1 else replace(c, name=c.origin) for c in curves]
    seen: dict[str, int] = {}
    out = []
    for c in renamed:
        seen[c.name] = seen.get(c.name, 0) + 1
        out.append(c if seen[c.name] == 1 else replace(c, name=f"{c.name}#{seen[c.name]}"))
    return out
