"""pyslvs / PMKS mechanism expressions and pyslvs YAML projects → a linkage document.

An expression lists joints ``J[type, (A[angle],) (color[…],) P[x, y], L[link, …]]`` inside
``M[…]``; a joint on the link ``ground`` is fixed to the frame. linkedit names the joints
``P0``, ``P1``, … in the expression's order and keeps the link names. The motor is a revolute
pair (pivot, driven joint) given as ``input`` (point indices, as pyslvs' input pairs), by
default the first ground joint and the first other joint that shares a link with it.

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
from dataclasses import dataclass
from typing import Any

import numpy as np
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
    names = [f"P{n}" for n in range(len(joints))]
    pins = [j.links[1:] if j.kind != "R" else j.links for j in joints]  # the links a joint is pinned to
    ground = [names[n] for n in range(len(joints)) if FRAME in pins[n]]
    links: dict[str, list[str]] = {}
    for n, on in enumerate(pins):
        for link in on:
            if link != FRAME:
                links.setdefault(link, []).append(names[n])
    positions = {n: list(j.position) for n, j in zip(names, joints)}
    sliders = _sliders(joints, names, links, positions, source)
    if motor is None:
        motor = _default_motor(joints)
    pivot, driven = motor
    for i in motor:
        if not 0 <= i < len(joints):
            raise InputError(f"input point {i} does not exist (P0..P{len(joints) - 1})", file=source, field="--input")
    moving = [n for n in positions if n not in ground]
    on_one = [n for n in moving if sum(n in members for members in links.values()) == 1]
    tracks = {n: {"joint": n} for n in on_one} or ({moving[-1]: {"joint": moving[-1]}} if moving else {})
    doc = {
        "name": name, "units": units,
        "description": f"imported from pyslvs ({source}); joints P0.. in the expression's order",
        "joints": positions, "ground": ground, "links": links,
        "motor": {"joint": names[driven], "pivot": names[pivot]},
        "tracks": tracks,
    }
    if sliders:
        doc["sliders"] = sliders
    return doc


def _sliders(joints: list[Joint], names: list[str], links: dict[str, list[str]], positions: dict[str, list[float]],
             source: str) -> dict[str, dict[str, Any]]:
    """linkedit sliders of the P and RP joints (``links`` and ``positions`` gain a slot joint where needed)."""
    xy = np.array([j.position for j in joints], dtype=float)
    size = float(np.ptp(xy, axis=0).max()) or 1.0
    out: dict[str, dict[str, Any]] = {}
    for n, j in enumerate(joints):
        if j.kind == "R":
            continue
        where = f"joint P{n} ({j.kind})"
        if j.angle is None:
            raise InputError(f"{where}: a slider needs its slot angle A[degrees]", file=source)
        if len(j.links) < 2:
            raise InputError(f"{where}: a slider needs its slot link and a pinned link: L[slot, pin]", file=source)
        slot, pinned = j.links[0], [x for x in j.links[1:]]
        if j.kind == "RP":
            out[f"S{n}"] = {"joint": names[n], "guide": slot, "angle_deg": j.angle}
        else:
            if len(pinned) != 1 or pinned[0] == FRAME:
                raise InputError(f"{where}: a prismatic P joint imports with one moving pin link, not "
                                 f"{', '.join(pinned)}", file=source)
            out[f"S{n}"] = {"link": pinned[0], "guide": slot, "angle_deg": j.angle}
        if slot != FRAME and len(links.get(slot, [])) < 2:
            extra = f"{names[n]}_slot"
            a = math.radians(j.angle)
            positions[extra] = [j.position[0] + size * math.cos(a), j.position[1] + size * math.sin(a)]
            links.setdefault(slot, []).append(extra)
    return out


def _default_motor(joints: list[Joint]) -> tuple[int, int]:
    """The first revolute ground joint and the first other revolute joint on a link with it (pyslvs' usual input)."""
    for b, base in enumerate(joints):
        if base.kind != "R" or FRAME not in base.links:
            continue
        for d, other in enumerate(joints):
            if d != b and other.kind == "R" and FRAME not in other.links and set(base.links) & set(other.links) - {FRAME}:
                return b, d
    raise InputError("no revolute pair on a ground link to drive: give --input PIVOT,JOINT")
