"""YAML loading that remembers where every value came from.

``load_yaml`` returns the plain data and a map from field paths to 1-based line numbers, and
rejects duplicate keys (PyYAML silently keeps the last one). Hostile files get one line too:
only regular files up to :data:`MAX_BYTES` are read, and aliases may not expand the document
past :data:`MAX_NODES` nodes or :data:`MAX_DEPTH` levels (``specs/limits.md``). ``load_model`` validates the data
with a pydantic model and turns the first problem into one :class:`InputError` line:
``file:line: field.path: what is wrong``.
"""

from __future__ import annotations

import difflib
import os
import re
import stat
import types
import typing
from pathlib import Path
from typing import Any, TypeVar, cast

import pydantic
import yaml

from linkedit.errors import InputError
from linkedit.spec.common import PATTERN_WORDS, SPEC_KINDS

Path_ = tuple[str | int, ...]

#: Largest spec file read (bytes): far above any real mechanism, far below the memory of a laptop.
MAX_BYTES = 16 * 2**20
#: Largest document, in nodes after alias expansion (a "billion laughs" file is refused here).
MAX_NODES = 1_000_000
#: Deepest nesting of lists and mappings (the formats need fewer than 10 levels).
MAX_DEPTH = 64
M = TypeVar("M", bound=pydantic.BaseModel)


class SpecLoader(yaml.SafeLoader):
    """The safe loader, reading ``1e-3``, ``2E6`` and ``7.5e1`` as numbers (YAML 1.1 wants ``7.5e+1``)."""


SpecLoader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
SpecLoader.add_implicit_resolver("tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
                                 list("-+.0123456789"))


class LineMap(dict[Path_, int]):
    """Field path → line number; ``line_of`` falls back to the closest enclosing field."""

    def line_of(self, path: Path_ | None) -> int | None:
        path = tuple(path or ())
        while path:
            if path in self:
                return self[path]
            path = path[:-1]
        return self.get((), None)


def _walk(loader: SpecLoader, node: yaml.Node, path: Path_, lines: LineMap, file: str) -> None:
    lines.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, Any] = {}  # a name is read without surrounding spaces: " B" is B
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if not isinstance(key, (str, int, float, bool)) or key is None:
                raise InputError("mapping keys must be plain names", file=file, line=line, field=path)
            sub = cast(Path_, (*path, key))  # YAML keys may also be numbers or booleans
            same = key.strip() if isinstance(key, str) else key
            if same in seen:
                other = seen[same]
                spaces = "" if other == key else (f" ({other!r} above is the same name: names are read without "
                                                  "surrounding spaces)")
                raise InputError(f"duplicate key {key!r}{spaces}", file=file, line=line, field=sub)
            seen[same] = key
            lines[sub] = line
            _walk(loader, value_node, sub, lines, file)
    elif isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            _walk(loader, item, path + (index,), lines, file)


def require_regular_file(source: str | Path) -> os.stat_result:
    """Stat an input file; InputError unless it is a regular file (a FIFO or device would hang or never end).
    TypeError for a ``source`` that is not a path (os.stat would take an int as an open file descriptor)."""
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"expected a file path (str or pathlib.Path), not {type(source).__name__}: {source!r}")
    try:
        info = os.stat(source)
    except OSError as exc:
        raise InputError(f"cannot read file: {exc.strerror or exc}", file=str(source)) from None
    if not stat.S_ISREG(info.st_mode):
        what = "it is a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise InputError(f"cannot read file: {what}", file=str(source))
    return info


def read_text(source: str | Path) -> str:
    """The text of a spec file; InputError (exit 2) if it cannot be read, is not a regular file,
    is larger than :data:`MAX_BYTES` or is not UTF-8 text (a leading byte-order mark is dropped)."""
    file = str(source)
    info = require_regular_file(source)
    if info.st_size > MAX_BYTES:
        raise InputError(f"file too large ({info.st_size:,} bytes; the limit is {MAX_BYTES:,})", file=file)
    try:
        with open(source, "rb") as fh:
            raw = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"cannot read file: {exc.strerror or exc}", file=file) from None
    if len(raw) > MAX_BYTES:
        raise InputError(f"file too large (more than {MAX_BYTES:,} bytes)", file=file)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = None
    if text is None or "\0" in text:
        raise InputError("not a UTF-8 text file (is it a result file rather than a spec?)", file=file)
    return text


def _check_size(root: yaml.Node, file: str) -> None:
    """Refuse documents whose aliases expand past MAX_NODES nodes or MAX_DEPTH levels, or refer to themselves."""
    sizes: dict[int, int] = {}
    open_: set[int] = set()

    def size(node: yaml.Node, depth: int) -> int:
        key = id(node)
        if key in sizes:
            return sizes[key]
        line = node.start_mark.line + 1
        if key in open_:
            raise InputError("an alias refers to itself (recursive data)", file=file, line=line)
        if depth > MAX_DEPTH:
            raise InputError(f"nested more than {MAX_DEPTH} levels deep", file=file, line=line)
        open_.add(key)
        total = 1
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = node.value
        else:
            children = []
        for child in children:
            total += size(child, depth + 1)
            if total > MAX_NODES:
                raise InputError(f"the document expands to more than {MAX_NODES:,} values (through aliases?)",
                                 file=file, line=line)
        open_.discard(key)
        sizes[key] = total
        return total

    size(root, 0)


def load_yaml(source: str | Path, text: str | None = None) -> tuple[Any, LineMap]:
    """Parse YAML from ``source`` (a path; or a display name when ``text`` is given).

    Returns ``(data, lines)``. Raises :class:`InputError` for unreadable files, malformed YAML
    and duplicate keys.
    """
    file = str(source)
    if text is None:
        text = read_text(source)
    loader = SpecLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise InputError("the file is empty", file=file, line=1)
        _check_size(node, file)
        data = loader.construct_document(node)
        lines = LineMap()
        _walk(loader, node, (), lines, file)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        raise InputError(f"malformed YAML: {exc.problem or exc.context}", file=file, line=line) from None
    except yaml.YAMLError as exc:
        raise InputError(f"malformed YAML: {exc}", file=file) from None
    except RecursionError:  # the composer recurses once per nesting level, before _check_size
        raise InputError(f"nested more than {MAX_DEPTH} levels deep", file=file) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise InputError(f"unreadable value: {str(exc).split(':')[0]}", file=file) from None
    finally:
        loader.dispose()
    return data, lines


def _data_path(data: Any, loc: tuple) -> Path_:
    """Keep the parts of a pydantic location that exist in the data (drops union-member tags)."""
    out: list[str | int] = []
    for part in loc:
        if isinstance(data, dict) and part in data:
            data = data[part]
        elif isinstance(data, list) and isinstance(part, int) and 0 <= part < len(data):
            data = data[part]
        elif isinstance(data, (dict, list)) or not isinstance(part, str) or part[:1].isupper() or "[" in part:
            continue
        out.append(part)
    return tuple(out)


#: pydantic's bound errors: the bound's key in ``ctx`` and the words of the message.
BOUNDS = {"less_than_equal": ("le", "less than or equal to"), "greater_than_equal": ("ge", "greater than or equal to"),
          "less_than": ("lt", "less than"), "greater_than": ("gt", "greater than")}


def first_problem(model: type[pydantic.BaseModel], exc: pydantic.ValidationError, data: Any) -> tuple[Path_, str]:
    """The problem to report of ``exc`` (``model`` validating ``data``): its field path in the data and
    what is wrong. A misspelt key (an unknown field close to one of its model's) comes first, with
    ``did you mean 'joints'?``: the field it hides is reported missing too. Of a union of models
    the members whose keys fit the entry are reported (see :func:`_fitting`)."""
    errors = _fitting(exc.errors(include_url=False))
    typos = [(err, hint) for err in errors if err["type"] == "extra_forbidden"
             for hint in [_hint(model, tuple(err["loc"]), data)] if hint]
    err, hint = typos[0] if typos else (errors[0], "")
    loc = _data_path(data, tuple(err["loc"]))
    if err["type"] in ("missing", "extra_forbidden") and err["loc"]:
        loc = loc + (err["loc"][-1],) if loc[-1:] != (err["loc"][-1],) else loc
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        msg = "unknown field (not part of this format)" + hint
    elif err["type"] == "missing":
        msg = "required field is missing"
    elif err["type"] == "too_short" and "min_length" in err.get("ctx", {}):
        least = err["ctx"]["min_length"]
        msg = f"needs at least {least} {'entry' if least == 1 else 'entries'}, not {err['ctx'].get('actual_length', 0)}"
    elif err["type"] == "string_pattern_mismatch" and err.get("ctx", {}).get("pattern") in PATTERN_WORDS:
        msg = PATTERN_WORDS[err["ctx"]["pattern"]](str(err["input"]).strip()) or msg
    elif err["type"] in BOUNDS and abs(bound := err["ctx"][BOUNDS[err["type"]][0]]) >= 1e16:
        msg = f"Input should be {BOUNDS[err['type']][1]} {float(bound)!r}"  # pydantic writes 1e150 in 151 digits
    elif msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    return loc, msg


def _other_kind(model: type[pydantic.BaseModel], data: Any) -> tuple[Path_, str] | None:
    """A mechanism spec of another kind than ``model`` reads (a 3D one given to ``simulate``): its
    first top-level key only that kind has, and what it is; None if ``data`` is not one."""
    own = SPEC_KINDS.get(str(getattr(model, "spec_kind", None)))
    if own is None or not isinstance(data, dict) or any(k in data for k in own[2]):
        return None
    for what, command, keys in SPEC_KINDS.values():
        found = [k for k in data if k in keys]
        if found:
            return (found[0],), f"this is {what}, not {own[0]}: use `{command}`"
    return None


def _fitting(errors: list) -> list:
    """``errors`` without those of a union's model members that the entry's keys do not fit (a field
    missing or unknown there) when another member's keys do fit: ``{link, at: [1, 2, 3]}`` is a
    link track with a bad ``at``, not a joint track without ``joint``."""
    def member(err: dict) -> tuple | None:  # the location up to its union member's tag (a class name)
        loc = tuple(err["loc"])
        tags = [n for n, part in enumerate(loc) if isinstance(part, str) and part[:1].isupper()]
        return loc[:tags[0] + 1] if tags else None

    unfit = {member(err) for err in errors if err["type"] in ("missing", "extra_forbidden")}
    fit = [err for err in errors if member(err) is None or member(err) not in unfit]
    return fit or errors


def _hint(model: type[pydantic.BaseModel], loc: tuple, data: Any) -> str:
    """``; did you mean 'joints'?`` for the unknown key at the end of ``loc``: the closest field of the
    model(s) there that the data does not give already ("" if none is close)."""
    given = data
    for part in _data_path(data, loc[:-1]):
        given = given[part]
    types: list[Any] = [model]
    for part in loc[:-1]:
        types = [inner for t in types for inner in _inside(t, part)]
    fields = {name for t in types for m in _members(t) if isinstance(m, type) and issubclass(m, pydantic.BaseModel)
              for name in m.model_fields if not (isinstance(given, dict) and name in given)}
    close = difflib.get_close_matches(str(loc[-1]), sorted(fields), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _inside(typ: Any, part: str | int) -> list[Any]:
    """The types inside ``typ`` that one step ``part`` of a pydantic error location leads to."""
    members = _members(typ)
    if isinstance(part, str) and "[" in part:  # a union member's tag such as 'list[float]'
        return members
    tagged = [m for m in members if isinstance(part, str) and _tagged(m, part)]
    if tagged:  # a union member's tag: its class name, or its discriminator's value ('pin')
        return tagged
    out: list[Any] = []
    for m in members:
        if isinstance(m, type) and issubclass(m, pydantic.BaseModel) and part in m.model_fields:
            out.append(m.model_fields[str(part)].annotation)
        elif typing.get_origin(m) in (list, tuple) and isinstance(part, int):
            out += [a for a in typing.get_args(m) if a is not Ellipsis]
        elif typing.get_origin(m) is dict:
            out.append(typing.get_args(m)[1])
    return out


def _tagged(typ: Any, tag: str) -> bool:
    """Whether ``tag`` names the model ``typ`` in a union: its class name, or a ``Literal`` field's value."""
    return isinstance(typ, type) and issubclass(typ, pydantic.BaseModel) and (typ.__name__ == tag or any(
        typing.get_origin(f.annotation) is typing.Literal and tag in typing.get_args(f.annotation)
        for f in typ.model_fields.values()))


def _members(typ: Any) -> list[Any]:
    """``typ`` without ``Annotated`` and ``Optional``, a union as its members."""
    origin = typing.get_origin(typ)
    if origin is typing.Annotated:
        return _members(typing.get_args(typ)[0])
    if origin in (typing.Union, types.UnionType):
        return [m for a in typing.get_args(typ) for m in _members(a)]
    return [typ]


def validate(model: type[M], data: Any, *, file: str, lines: LineMap | None = None,
             context: dict[str, Any] | None = None) -> M:
    """Validate ``data`` with ``model``; any problem becomes one located :class:`InputError`."""
    lines = lines or LineMap()
    try:
        return model.model_validate(data, context=context)
    except pydantic.ValidationError as exc:
        loc, msg = _other_kind(model, data) or first_problem(model, exc, data)
        raise InputError(msg, file=file, line=lines.line_of(loc), field=loc) from None
    except InputError as exc:
        # semantic checks raise InputError(field=...) from inside validators
        raise located(exc, file, lines) from None


def located(exc: InputError, file: str, lines: LineMap) -> InputError:
    """``exc`` with the file and the line of its field filled in where missing (a check of a
    validated document that names a field of it, e.g. when a spec is compiled)."""
    exc.file = exc.file or file
    if exc.line is None:
        exc.line = lines.line_of(exc.field)
    return exc


def load_model(model: type[M], source: str | Path, text: str | None = None,
               context: dict[str, Any] | None = None) -> M:
    """Load a YAML file and validate it as ``model`` (see :func:`validate`)."""
    data, lines = load_yaml(source, text)
    return validate(model, data, file=str(source), lines=lines, context=context)
