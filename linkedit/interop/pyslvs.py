"""pyslvs / PMKS mechanism expressions and pyslvs YAML projects → a linkage document.

An expression lists joints ``J[type, (A[angle],) (color[…],) P[x, y], L[link, …]]`` inside
``M[…]``; a joint on the link ``ground`` is fixed to the frame. linkedit names the joints
``P0``, ``P1``, … in the expression's order and keeps the link names. The motor is a revolute
pair (pivot, driven joint) given as ``input`` (point indices, as pyslvs' input pairs), by
default the first ground joint and the first other joint that shares a link with it.
Only revolute (``R``) joints import for now: ``P`` and ``RP`` (sliders) are reported, exit 2.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import yaml

from linkedit.errors import InputError

FRAME = "ground"
_TOKEN = re.compile(r"\s*(?:(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<name>[A-Za-z_][\w-]*)|(?P<sym>[\[\](),]))")


@dataclass(frozen=True)
class Joint:
    """One joint of an expression: type (R, P, RP), slider angle (degrees), position, links."""

    kind: str
    angle: float | None
    position: tuple[float, float]
    links: tuple[str, ...]


def _strip_comments(text: str) -> str:
    return "\n".join(line.split("#", 1)[0] for line in text.splitlines())


def _tokens(text: str, source: str) -> list[tuple[str, str, int]]:
    out, pos, body = [], 0, _strip_comments(text)
    while pos < len(body):
        if body[pos:].strip() == "":
            break
        m = _TOKEN.match(body, pos)
        if not m:
            line = body.count("\n", 0, pos) + 1
            raise InputError(f"cannot read the expression at {body[pos:pos + 12].strip()!r}", file=source, line=line)
        kind = m.lastgroup or "sym"
        out.append((kind, m.group(kind), body.count("\n", 0, m.start(kind)) + 1))
        pos = m.end()
    return out


def _parse(tokens: list[tuple[str, str, int]], source: str) -> Any:
    """Terms: ``NAME[term, …]`` → (NAME, [terms]); a number; a bare name; ``(a, b, …)`` → tuple."""
    at = 0

    def fail(msg: str) -> InputError:
        line = tokens[min(at, len(tokens) - 1)][2] if tokens else 1
        return InputError(msg, file=source, line=line)

    def term() -> Any:
        nonlocal at
        if at >= len(tokens):
            raise fail("the expression ends too early")
        kind, value, _ = tokens[at]
        at += 1
        if kind == "num":
            return float(value)
        if kind == "name":
            if at < len(tokens) and tokens[at][1] == "[":
                at += 1
                return (value, items("]"))
            return value
        if value == "(":
            return tuple(items(")"))
        raise fail(f"unexpected {value!r}")

    def items(close: str) -> list[Any]:
        nonlocal at
        out: list[Any] = []
        while True:
            if at < len(tokens) and tokens[at][1] == close:
                at += 1
                return out
            out.append(term())
            if at < len(tokens) and tokens[at][1] == ",":
                at += 1
            elif not (at < len(tokens) and tokens[at][1] == close):
                raise fail(f"expected ',' or {close!r}")

    result = term()
    if at != len(tokens):
        raise fail("text after the end of M[…]")
    return result


def parse_expression(text: str, source: str = "<expression>") -> list[Joint]:
    """The joints of a pyslvs / PMKS expression ``M[J[…], …]``."""
    tree = _parse(_tokens(text, source), source)
    if not (isinstance(tree, tuple) and tree[0] == "M"):
        raise InputError("a pyslvs expression starts with M[", file=source)
    joints = []
    for n, j in enumerate(tree[1]):
        if not (isinstance(j, tuple) and j[0] == "J" and j[1]):
            raise InputError(f"joint {n}: expected J[type, …, P[x, y], L[…]]", file=source)
        kind, fields = str(j[1][0]), j[1][1:]
        angle = position = links = None
        for f in fields:
            if isinstance(f, tuple) and f[0] == "A":
                angle = float(f[1][0])
            elif isinstance(f, tuple) and f[0] == "P" and len(f[1]) == 2:
                position = (float(f[1][0]), float(f[1][1]))
            elif isinstance(f, tuple) and f[0] == "L":
                links = tuple(str(x) for x in f[1])
        if kind not in ("R", "P", "RP"):
            raise InputError(f"joint P{n}: unknown joint type {kind!r} (R, P or RP)", file=source)
        if position is None or not links:
            raise InputError(f"joint P{n}: needs P[x, y] and L[…]", file=source)
        joints.append(Joint(kind, angle, position, links))
    if not joints:
        raise InputError("the expression has no joints", file=source)
    return joints


def read_project(text: str, source: str) -> tuple[str, list[tuple[int, int]]]:
    """A pyslvs YAML project's ``mechanism`` expression and ``input`` pairs."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"malformed YAML: {exc}", file=source) from None
    if not isinstance(data, dict) or not isinstance(data.get("mechanism"), str):
        raise InputError("not a pyslvs project (no 'mechanism' expression)", file=source)
    pairs = [(int(p[0]), int(p[1])) for p in data.get("input") or []]
    return data["mechanism"], pairs


def to_document(joints: list[Joint], *, name: str, units: str, motor: tuple[int, int] | None,
                source: str) -> dict[str, Any]:
    """A linkage document (``specs/linkage.md``) from parsed joints."""
    for n, j in enumerate(joints):
        if j.kind != "R":
            raise InputError(f"joint P{n} is a {j.kind} joint (slider): not supported yet, only revolute R joints",
                             file=source)
    names = [f"P{n}" for n in range(len(joints))]
    ground = [names[n] for n, j in enumerate(joints) if FRAME in j.links]
    links: dict[str, list[str]] = {}
    for n, j in enumerate(joints):
        for link in j.links:
            if link != FRAME:
                links.setdefault(link, []).append(names[n])
    if motor is None:
        motor = _default_motor(joints)
    pivot, driven = motor
    for i in motor:
        if not 0 <= i < len(joints):
            raise InputError(f"input point {i} does not exist (P0..P{len(joints) - 1})", file=source, field="--input")
    moving = set(names) - set(ground)
    tracks = {n: {"joint": n} for n, j in zip(names, joints) if n in moving and len(j.links) == 1}
    if not tracks:
        tracks = {names[-1]: {"joint": names[-1]}} if names[-1] in moving else {}
    return {
        "name": name, "units": units,
        "description": f"imported from pyslvs ({source}); joints P0.. in the expression's order",
        "joints": {n: list(j.position) for n, j in zip(names, joints)},
        "ground": ground, "links": links,
        "motor": {"joint": names[driven], "pivot": names[pivot]},
        "tracks": tracks,
    }


def _default_motor(joints: list[Joint]) -> tuple[int, int]:
    """The first ground joint and the first other joint on a link with it (pyslvs' usual input)."""
    for b, base in enumerate(joints):
        if FRAME not in base.links:
            continue
        for d, other in enumerate(joints):
            if d != b and FRAME not in other.links and set(base.links) & set(other.links) - {FRAME}:
                return b, d
    raise InputError("no revolute pair on a ground link to drive: give --input PIVOT,JOINT")
