"""What the importers share: reading JSON with line numbers, and the tracks a document gets by default."""

from __future__ import annotations

import bisect
import json
import json.scanner
import math
import re
from collections import Counter
from typing import Any

from linkedit.errors import InputError
from linkedit.spec.yamlload import MAX_DEPTH

#: Longest run of digits read: Python's own limit on integers (``specs/limits.md``).
MAX_DIGITS = 4300
_SHAPE = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|(?P<open>[\[{])|(?P<close>[\]}])|(?P<digits>\d{%d,})' % (MAX_DIGITS + 1))


def default_tracks(joints: list[str], ground: list[str], links: dict[str, list[str]]) -> dict[str, dict[str, str]]:
    """A track on every moving joint carried by one link only (a coupler point), else on the last moving joint."""
    fixed = set(ground)
    moving = [n for n in joints if n not in fixed]
    count = Counter(n for members in links.values() for n in members)
    return {n: {"joint": n} for n in moving if count[n] == 1} or ({moving[-1]: {"joint": moving[-1]}} if moving else {})


class JsonFile:
    """A JSON document that remembers the line of each of its objects and lists, for ``file:line`` errors.

    Refused in one line (exit 2) before parsing: nesting deeper than ``MAX_DEPTH``, a number of more
    than ``MAX_DIGITS`` digits; then malformed JSON (line and column) and duplicate keys.
    """

    def __init__(self, text: str, source: str) -> None:
        self.source = source
        _check_shape(text, source)
        newlines = [m.start() for m in re.finditer("\n", text)]
        self.lines: dict[int, int] = {}
        decoder: Any = json.JSONDecoder(object_pairs_hook=_unique)
        parse_object, parse_array = decoder.parse_object, decoder.parse_array

        def located(parse: Any) -> Any:
            def wrapped(state: tuple[str, int], *args: Any) -> Any:
                line = bisect.bisect_left(newlines, state[1]) + 1
                try:
                    value, end = parse(state, *args)
                except _Duplicate as exc:
                    raise InputError(f"duplicate key {exc.args[0]!r}", file=source, line=line) from None
                self.lines[id(value)] = line
                return value, end
            return wrapped

        decoder.parse_object = located(parse_object)
        decoder.parse_array = located(parse_array)
        scanner: Any = json.scanner
        decoder.scan_once = scanner.py_make_scanner(decoder)  # the Python scanner calls the two above
        try:
            self.data = decoder.decode(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"malformed JSON: {exc.msg} (column {exc.colno})", file=source, line=exc.lineno) from None

    def error(self, where: Any, message: str, field: tuple[str | int, ...] | None = None) -> InputError:
        """An InputError at the line of ``where`` (an object or list of the document)."""
        return InputError(message, file=self.source, line=self.lines.get(id(where)), field=field)

    def get(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...], default: Any = ...) -> Any:
        if key in obj:
            return obj[key]
        if default is ...:
            raise self.error(obj, "required field is missing", (*field, key))
        return default

    def number(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...], default: Any = ...) -> float:
        """A finite number (not a boolean, not a quoted number)."""
        value = self.get(obj, key, field, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(obj, f"expected a finite number, got {_shown(value)}", (*field, key))
        return float(value)

    def name(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...], default: Any = ...) -> str:
        value = self.get(obj, key, field, default)
        if not isinstance(value, str) or not value:
            raise self.error(obj, f"expected a name, got {_shown(value)}", (*field, key))
        return value

    def point(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...]) -> list[float]:
        """``[x, y]``, two finite numbers."""
        value = self.get(obj, key, field)
        if not isinstance(value, list) or len(value) != 2:
            raise self.error(obj, f"expected [x, y], got {_shown(value)}", (*field, key))
        return [_coordinate(self, obj, value, i, (*field, key)) for i in range(2)]

    def objects(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...] = (), default: Any = ...) -> list[dict[str, Any]]:
        """A list of objects."""
        value = self.get(obj, key, field, default)
        if not isinstance(value, list):
            raise self.error(obj, f"expected a list, got {_shown(value)}", (*field, key))
        for n, item in enumerate(value):
            if not isinstance(item, dict):
                raise self.error(value, f"expected an object {{…}}, got {_shown(item)}", (*field, key, n))
        return value

    def mapping(self, obj: dict[str, Any], key: str, field: tuple[str | int, ...] = (), default: Any = ...) -> dict[str, Any]:
        value = self.get(obj, key, field, default)
        if not isinstance(value, dict):
            raise self.error(obj, f"expected an object {{…}}, got {_shown(value)}", (*field, key))
        return value


def _coordinate(file: JsonFile, obj: dict[str, Any], pair: list[Any], i: int, field: tuple[str | int, ...]) -> float:
    value = pair[i]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise file.error(obj, f"expected a finite number, got {_shown(value)}", (*field, i))
    return float(value)


class _Duplicate(Exception):
    pass


def _unique(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _Duplicate(key)
        out[key] = value
    return out


def _shown(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, float) or math.isfinite(value) else str(value)
    return text if len(text) <= 40 else text[:37] + "…"


def _check_shape(text: str, source: str) -> None:
    """Nesting and digit runs, in one linear pass (strings skipped), before the recursive parser sees them."""
    depth, line, last = 0, 1, 0
    for m in _SHAPE.finditer(text):
        kind = m.lastgroup
        if kind is None:
            continue
        line += text.count("\n", last, m.start())
        last = m.start()
        if kind == "digits":
            raise InputError(f"a number of more than {MAX_DIGITS} digits", file=source, line=line)
        depth += 1 if kind == "open" else -1
        if depth > MAX_DEPTH:
            raise InputError(f"nested more than {MAX_DEPTH} levels deep", file=source, line=line)
