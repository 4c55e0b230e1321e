"""pyslvs / PMKS mechanism expressions and pyslvs YAML projects → a linkage document.

An expression lists joints ``J[type, (A[angle],) (color[…],) P[x, y], L[link, …]]`` inside
``M[…]``; a joint on the link ``ground`` is fixed to the frame. linkedit names the joints
``P0``, ``P1``, … in the expression's order and keeps the link names. The motor is a revolute
pair (pivot, driven joint) given as ``input`` (point indices, as pyslvs' input pairs), by
default the first ground joint and the first other joint that shares a link with it. Comments are
pyslvs' own: ``# …`` to the end of the line, ``#[ … #]`` over lines.

Sliders: in ``J[P|RP, A[a], P[x, y], L[slot, pin, …]]`` the first link carries the slot (a line
through (x, y) at ``a`` degrees from +x at the rest pose given), the others are pinned at the
joint. ``RP`` (the pin turns in the slot) becomes a joint slider ``{joint: Pn, guide: slot}`` with
the joint on the pin links; ``P`` (the pin link slides without turning relative to the slot)
becomes a translating link ``{link: pin, guide: slot}``. A slot link that would keep fewer than
two joints gets one more, ``Pn_slot``, on the slot line one slot length (the mechanism's size)
away, so its turning is drawn and tracked.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from linkedit.errors import InputError
from linkedit.interop.document import default_tracks
from linkedit.spec.yamlload import load_yaml

FRAME = "ground"
#: Deepest nesting of ``NAME[…]`` and ``(…)`` read (``M[J[P[x, y]]]`` needs 3; colours a few more).
MAX_DEPTH = 16
_LEX = re.compile(r"\s*(?:(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<name>[A-Za-z_][\w-]*)"
                  r"|(?P<sym>[\[\](),])|(?P<bad>\S))")
_Token = tuple[str, str, int]  # kind (num, name, sym, bad or end), text, offset in the expression
_Term = tuple[str, _Token, tuple[Any, ...]]  # kind (call, tuple, num or name), its first token, items


@dataclass(frozen=True)
class Joint:
    """One joint of an expression: type (R, P, RP), slider angle (degrees), position, links."""

    kind: str
    angle: float | None
    position: tuple[float, float]
    links: tuple[str, ...]


def _what(term: _Term) -> str:
    kind, (_, text, _), _ = term
    return {"call": f"{text}[…]", "tuple": "(…)", "num": "a number"}.get(kind, f"the name {text!r}")


def _strip_comments(text: str) -> str:
    """``text`` with pyslvs' comments blanked out, line breaks kept (lines and columns stay where they were).

    As pyslvs' grammar matches them: a line's first ``#`` opens a block ``#[`` up to the last ``#]`` of the
    text and the rest of that line (the longer terminal, tried first; so there is at most one), else runs to
    the end of its line. One pass over the lines.
    """
    last = text.rfind("#]")
    out, offset = [], 0
    for line in text.split("\n"):
        k = line.find("#")
        if k >= 0 and line.startswith("#[", k) and offset + k + 2 <= last:
            end = text.find("\n", last)
            end = len(text) if end < 0 else end
            out.append(line[:k] + re.sub(r"[^\n]", " ", text[offset + k:end]) + _strip_comments(text[end:]))
            return "\n".join(out)
        out.append(line if k < 0 else line[:k] + " " * (len(line) - k))
        offset += len(line) + 1
    return "\n".join(out)


def _tokens(body: str) -> Iterator[_Token]:
    """The tokens of an expression in one regular-expression pass (time linear in its length), then ``end``."""
    for m in _LEX.finditer(body):
        kind = m.lastgroup or "bad"
        yield kind, m.group(kind), m.start(kind)
    yield "end", "", len(body.rstrip())


class _Parser:
    """Recursive descent over the token stream, one token of look-ahead, at most MAX_DEPTH levels deep."""

    def __init__(self, text: str, source: str, line: int | None) -> None:
        self.source, self.line = source, line
        self.body = _strip_comments(text)
        self.stream = _tokens(self.body)
        self.next: _Token = ("start", "", 0)
        self.take()

    def take(self) -> _Token:
        """The look-ahead token, moving on to the next one (past the end: the end again)."""
        token, self.next = self.next, next(self.stream, self.next)
        if self.next[0] == "bad":
            raise self.fail(self.next, f"unexpected character {self.next[1]!r}")
        return token

    def fail(self, token: _Token, message: str) -> InputError:
        """A located error: line and column in an expression, or character and the project's line of it."""
        offset = token[2]
        if self.line is None:
            line = self.body.count("\n", 0, offset) + 1
            column = offset - self.body.rfind("\n", 0, offset)
            return InputError(f"column {column}: {message}", file=self.source, line=line)
        return InputError(f"character {offset + 1} of the expression: {message}", file=self.source,
                          line=self.line, field="mechanism")

    def term(self, depth: int) -> _Term:
        token = self.take()
        kind, text, _ = token
        if kind == "num" or (kind == "name" and self.next[1] != "["):
            return kind, token, ()
        if kind == "name":
            return "call", token, self.items(self.take(), "]", depth + 1)
        if text == "(":
            return "tuple", token, self.items(token, ")", depth + 1)
        raise self.fail(token, "the expression ends too early" if kind == "end" else f"unexpected {text!r}")

    def items(self, opening: _Token, close: str, depth: int) -> tuple[_Term, ...]:
        if depth > MAX_DEPTH:
            raise self.fail(opening, f"nested more than {MAX_DEPTH} levels deep")
        out: list[_Term] = []
        while self.next[1] != close:
            out.append(self.term(depth))
            if self.next[1] == ",":
                self.take()
            elif self.next[0] == "end":
                raise self.fail(self.next, f"the expression ends before its closing {close!r}")
            elif self.next[1] != close:
                raise self.fail(self.next, f"expected ',' or {close!r}")
        self.take()
        return tuple(out)

    def whole(self) -> _Term:
        tree = self.term(0)
        if self.next[0] != "end":
            raise self.fail(self.next, "text after the end of M[…]")
        return tree


def parse_expression(text: str, source: str = "<expression>", line: int | None = None) -> list[Joint]:
    """The joints of a pyslvs / PMKS expression ``M[J[…], …]``; InputError (line, column) for anything else.

    ``line``: the line of a project's ``mechanism`` field, the expression's text being its value.
    """
    parser = _Parser(text, source, line)
    tree = parser.whole()
    if tree[0] != "call" or tree[1][1] != "M":
        raise parser.fail(tree[1], "a pyslvs expression starts with M[")
    joints = [_joint(j, n, parser) for n, j in enumerate(tree[2])]
    if not joints:
        raise parser.fail(tree[1], "the expression has no joints")
    return joints


def _joint(term: _Term, n: int, parser: _Parser) -> Joint:
    """One ``J[type, A[angle]?, P[x, y], L[link, …], …]`` (other fields, such as colours, ignored)."""
    where = f"joint P{n}"
    kind, at, items = term
    if kind != "call" or at[1] != "J" or not items:
        raise parser.fail(at, f"{where}: expected J[type, …, P[x, y], L[…]], got {_what(term)}")
    if items[0][0] != "name" or items[0][1][1] not in ("R", "P", "RP"):
        raise parser.fail(items[0][1], f"{where}: the joint type is R, P or RP, not {_what(items[0])}")
    fields: dict[str, _Term] = {}
    for f in items[1:]:
        if f[0] == "call" and f[1][1] in ("A", "P", "L"):
            if f[1][1] in fields:
                raise parser.fail(f[1], f"{where}: {f[1][1]}[…] given twice")
            fields[f[1][1]] = f
    if "P" not in fields or "L" not in fields or not fields["L"][2]:
        raise parser.fail(at, f"{where}: needs P[x, y] and L[…]")
    x, y = _numbers(fields["P"], 2, f"{where}: P[x, y] takes two numbers", parser)
    angle = _numbers(fields["A"], 1, f"{where}: A[degrees] takes one number", parser)[0] if "A" in fields else None
    for link in fields["L"][2]:
        if link[0] != "name":
            raise parser.fail(link[1], f"{where}: L[…] lists link names, got {_what(link)}")
    joint = Joint(items[0][1][1], angle, (x, y), tuple(link[1][1] for link in fields["L"][2]))
    if joint.kind != "R":
        _check_slider(joint, f"{where} ({joint.kind})", at, fields["L"][1], parser)
    return joint


def _check_slider(joint: Joint, where: str, at: _Token, links: _Token, parser: _Parser) -> None:
    """What linkedit needs of a P or RP joint: its slot angle, a slot link and pinned links (a P joint: one
    moving one, which slides without turning)."""
    if joint.angle is None:
        raise parser.fail(at, f"{where}: a slider needs its slot angle A[degrees]")
    if len(joint.links) < 2:
        raise parser.fail(links, f"{where}: a slider needs its slot link and a pinned link: L[slot, pin]")
    pinned = joint.links[1:]
    if joint.kind == "P" and (len(pinned) != 1 or pinned[0] == FRAME):
        raise parser.fail(links, f"{where}: a prismatic P joint imports with one moving pin link, not {', '.join(pinned)}")


def _numbers(term: _Term, count: int, message: str, parser: _Parser) -> list[float]:
    """The ``count`` finite numbers of ``NAME[…]``."""
    items = term[2]
    bad = next((x for x in items if x[0] != "num" or not math.isfinite(float(x[1][1]))), None)
    if bad is not None or len(items) != count:
        got = f"{len(items)} values" if bad is None else "a number out of range" if bad[0] == "num" else _what(bad)
        raise parser.fail(term[1] if bad is None else bad[1], f"{message}, got {got}")
    return [float(x[1][1]) for x in items]


def read_project(text: str, source: str) -> tuple[str, int | None, list[tuple[int, int]]]:
    """A pyslvs YAML project's ``mechanism`` expression, its line, and the ``input`` pairs (PIVOT, JOINT point indices)."""
    data, lines = load_yaml(source, text)
    if not isinstance(data, dict) or not isinstance(data.get("mechanism"), str):
        raise InputError("not a pyslvs project (no 'mechanism' expression)", file=source, line=lines.line_of(("mechanism",)))
    inputs = data.get("input") or []
    if not isinstance(inputs, list):
        raise InputError("must be a list of [pivot, joint] point index pairs", file=source,
                         line=lines.line_of(("input",)), field="input")
    pairs = []
    for n, pair in enumerate(inputs):
        if not (isinstance(pair, list) and len(pair) >= 2 and all(_index(i) for i in pair[:2])):
            raise InputError(f"an input is [pivot, joint], two point indices, not {str(pair)[:40]}", file=source,
                             line=lines.line_of(("input", n)), field=("input", n))
        pairs.append((pair[0], pair[1]))
    return data["mechanism"], lines.line_of(("mechanism",)), pairs


def _index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**31


def to_document(joints: list[Joint], *, name: str, units: str, motor: tuple[int, int] | None,
                source: str, stroke: tuple[float, float] | None = None) -> dict[str, Any]:
    """A linkage document (``specs/linkage.md``) from parsed joints.

    ``motor`` (n, n), pyslvs' slider input, is a linear input: the RP joint n pushed along its slot over
    ``stroke`` (its displacement from rest towards the slot's angle, in ``units``; pyslvs does not save it).
    """
    names = [f"P{n}" for n in range(len(joints))]
    pins = [j.links[1:] if j.kind != "R" else j.links for j in joints]  # the links a joint is pinned to
    ground = [names[n] for n in range(len(joints)) if FRAME in pins[n]]
    links: dict[str, list[str]] = {}
    for n, on in enumerate(pins):
        for link in on:
            if link != FRAME:
                links.setdefault(link, []).append(names[n])
    positions = {n: list(j.position) for n, j in zip(names, joints)}
    sliders = _sliders(joints, names, links, positions)
    if motor is None:
        motor = _default_motor(joints, source)
    pivot, driven = motor
    for i in motor:
        if not 0 <= i < len(joints):
            raise InputError(f"input point {i} does not exist (P0..P{len(joints) - 1})", file=source, field="--input")
    tracks = default_tracks(names, ground, links)  # (the source's points: not a slot's added joint)
    doc = {
        "name": name, "units": units,
        "description": f"imported from pyslvs ({source}); joints P0.. in the expression's order",
        "joints": positions, "ground": ground, "links": links,
        "motor": _motor(joints, pivot, driven, stroke, units, source),
        "tracks": tracks,
    }
    if sliders:
        doc["sliders"] = sliders
    return doc


def _motor(joints: list[Joint], pivot: int, driven: int, stroke: tuple[float, float] | None, units: str,
           source: str) -> dict[str, Any]:
    """The motor of input pair (pivot, driven): a crank, or for (n, n) the linear input of RP joint n."""
    if pivot != driven:
        if stroke is not None:
            raise InputError("goes with a slider input (--input N,N: pyslvs' input pair of one slider joint)",
                             field="--stroke")
        return {"joint": f"P{driven}", "pivot": f"P{pivot}"}
    kind = joints[driven].kind
    if kind != "RP":
        what = "a revolute joint" if kind == "R" else "a P joint (its pin link slides without turning)"
        raise InputError(f"input P{driven},P{driven} is pyslvs' slider input, but P{driven} is {what}: linkedit "
                         "pushes a pin along its slot (an RP joint)", file=source, field="--input")
    if stroke is None:
        raise InputError(f"input P{driven},P{driven} is pyslvs' slider input, whose range pyslvs does not save: give "
                         f"--stroke S0,S1 (P{driven}'s displacement from rest along its slot, in {units})",
                         file=source, field="--stroke")
    return {"slider": f"S{driven}", "stroke": list(stroke)}


def _sliders(joints: list[Joint], names: list[str], links: dict[str, list[str]],
             positions: dict[str, list[float]]) -> dict[str, dict[str, Any]]:
    """linkedit sliders of the P and RP joints (``links`` and ``positions`` gain a slot joint where needed)."""
    xy = np.array([j.position for j in joints], dtype=float)
    size = float(np.ptp(xy, axis=0).max()) or 1.0
    out: dict[str, dict[str, Any]] = {}
    for n, j in enumerate(joints):
        if j.kind == "R":
            continue
        assert j.angle is not None  # (checked as it was read: _check_slider)
        slot = j.links[0]
        if j.kind == "RP":
            out[f"S{n}"] = {"joint": names[n], "guide": slot, "angle_deg": j.angle}
        else:
            out[f"S{n}"] = {"link": j.links[1], "guide": slot, "angle_deg": j.angle}
        if slot != FRAME and len(links.get(slot, [])) < 2:
            extra = f"{names[n]}_slot"
            a = math.radians(j.angle)
            positions[extra] = [j.position[0] + size * math.cos(a), j.position[1] + size * math.sin(a)]
            links.setdefault(slot, []).append(extra)
    return out


def _default_motor(joints: list[Joint], source: str) -> tuple[int, int]:
    """The first revolute ground joint and the first other moving joint pinned to a link with it (pyslvs'
    usual input): a slider's pin links are its links after the slot's (a Scotch yoke's crank pin)."""
    moving: dict[str, list[int]] = {}  # link → the moving joints pinned to it, in order
    for d, other in enumerate(joints):
        pins = other.links if other.kind == "R" else other.links[1:]
        if FRAME not in pins:
            for link in pins:
                moving.setdefault(link, []).append(d)
    for b, base in enumerate(joints):
        if base.kind == "R" and FRAME in base.links:
            candidates = [d for link in base.links if link != FRAME for d in moving.get(link, [])[:1]]
            if candidates:
                return b, min(candidates)
    raise InputError("no revolute pair on a ground link to drive: give --input PIVOT,JOINT", file=source)
