"""Linkages given by link lengths: assemble the rest pose in closed form.

A spec may give a link by its length instead of leaving it to the joints' coordinates::

    joints:
      O: [0, 0]                                  # a position, as usual
      A: {from: [O], angle_deg: 0}               # at its link length from O, at this angle
      C: {from: [A, B], branch: cw}              # from its lengths to A and B; triangle A, B, C clockwise
      D: {near: [-27, -45]}                      # from its lengths to two placed joints; the solution nearer this point
      S: {line: [O, D], near: [5, 1]}            # on the line O-D at its length from a placed joint; the nearer one
    links:
      crank: {joints: [O, A], length: 15}
      upper: {joints: [B, C, E], lengths: [41.5, 40.1, 55.8]}   # BC, BE, CE: pairs in list order

:func:`assemble` turns such a document into the plain form (every joint a position, every link a
list of joints) before the spec is validated, so every command takes either. Conflicting
lengths, triangles that cannot close and joints nothing places are one :class:`InputError`
naming the link or joint (exit 2).
"""

from __future__ import annotations

import math
import sys
from itertools import combinations
from typing import Annotated, Any, Literal

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import Finite, Name, SpecModel, Vec2
from linkedit.spec.yamlload import first_problem

#: A positive finite length; ``true`` is not 1 (strict).
Length = Annotated[Finite, pydantic.Field(gt=0)]


class Placement(SpecModel):
    """How to place a joint whose position is not given (see module docstring)."""

    model_config = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, populate_by_name=True)

    near: Vec2 | None = None
    line: list[Name] | None = pydantic.Field(default=None, min_length=2, max_length=2)
    from_: list[Name] | None = pydantic.Field(default=None, alias="from", min_length=1, max_length=2)
    branch: Literal["ccw", "cw"] | None = None
    angle_deg: Finite | None = None

    @pydantic.model_validator(mode="after")
    def _one_way(self) -> "Placement":
        if self.line is not None and self.near is None:
            raise ValueError("line: [P, Q] needs near: [x, y] (which of the two crossings of the line)")
        if self.near is not None:
            if self.from_ or self.branch or self.angle_deg is not None:
                raise ValueError("give either near, or from with branch / angle_deg")
        elif not self.from_:
            raise ValueError("give near: [x, y], from: [P, Q] with branch: ccw|cw, or from: [P] with angle_deg")
        elif len(self.from_) == 2 and (self.branch is None or self.angle_deg is not None):
            raise ValueError("from two joints needs branch: ccw or cw (the turn of the triangle from, from, joint)")
        elif len(self.from_) == 1 and (self.angle_deg is None or self.branch is not None):
            raise ValueError("from one joint needs angle_deg (the direction from it, degrees ccw from +x)")
        return self


class LinkLengths(SpecModel):
    """A link given by its joints and length(s): ``length`` for 2 joints, ``lengths`` for a plate."""

    joints: list[Name] = pydantic.Field(min_length=2)
    length: Length | None = None
    lengths: list[Length] | None = None

    @pydantic.model_validator(mode="after")
    def _count(self) -> "LinkLengths":
        n = len(self.joints)
        if len(set(self.joints)) != n:
            raise ValueError("a joint is listed twice")
        if n == 2 and (self.length is None) == (self.lengths is None):
            raise ValueError("a link of 2 joints needs length (or lengths: [one value])")
        if n > 2 and (self.lengths is None or self.length is not None):
            raise ValueError(f"a plate of {n} joints needs lengths: one per joint pair, {n * (n - 1) // 2} values")
        if self.lengths is not None and len(self.lengths) != n * (n - 1) // 2:
            raise ValueError(f"lengths needs {n * (n - 1) // 2} values for {n} joints "
                             f"(pairs {', '.join(f'{a}-{b}' for a, b in combinations(self.joints, 2))})")
        if any(not math.isfinite(v) for v in self.lengths or ()):
            raise ValueError("lengths must be finite")
        return self

    def pair_lengths(self) -> list[tuple[str, str, float]]:
        values = [self.length] if self.length is not None else list(self.lengths or ())
        return [(a, b, float(v)) for (a, b), v in zip(combinations(self.joints, 2), values)]


def uses_lengths(data: Any) -> bool:
    """Whether a raw spec document gives any joint by placement or any link by length."""
    if not isinstance(data, dict):
        return False
    joints, links = data.get("joints"), data.get("links")
    return (isinstance(joints, dict) and any(isinstance(v, dict) for v in joints.values())) or (
        isinstance(links, dict) and any(isinstance(v, dict) for v in links.values()))


def _model(cls: type[SpecModel], value: Any, field: tuple[str | int, ...]) -> Any:
    try:
        return cls.model_validate(value)
    except pydantic.ValidationError as exc:
        loc, msg = first_problem(cls, exc, value)
        raise InputError(msg, field=field + loc) from None


def link_lengths(data: dict[str, Any]) -> dict[str, LinkLengths]:
    """The links given by length in a raw document, validated."""
    return {name: _model(LinkLengths, v, ("links", name)) for name, v in data["links"].items() if isinstance(v, dict)}


def assemble(data: dict[str, Any]) -> dict[str, Any]:
    """The raw document with every joint placed (see module docstring); unchanged if it uses no lengths."""
    if not uses_lengths(data) or not isinstance(data.get("joints"), dict) or not isinstance(data.get("links"), dict):
        return data
    given = link_lengths(data)
    known: dict[str, complex] = {}
    pending: dict[str, Placement] = {}
    for name, v in data["joints"].items():
        if isinstance(v, dict):
            pending[name] = _model(Placement, v, ("joints", name))
        elif isinstance(v, (list, tuple)) and len(v) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) for c in v):
            known[name] = complex(float(v[0]), float(v[1]))
        else:
            return data  # let the spec model report the malformed position
    for name, how in pending.items():
        for field, refs in (("from", how.from_), ("line", how.line)):
            for i, j in enumerate(refs or ()):
                if j == name or (j not in known and j not in pending):
                    what = "the joint itself" if j == name else "an unknown joint"
                    raise InputError(f"{j!r} is {what}", field=("joints", name, field, i))
    length: dict[frozenset[str], tuple[float, str]] = {}
    for link, ll in given.items():
        for a, b, value in ll.pair_lengths():
            for j in (a, b):
                if j not in known and j not in pending:
                    raise InputError(f"unknown joint {j!r}", field=("links", link, "joints"))
            key = frozenset((a, b))
            if key in length and not math.isclose(length[key][0], value, rel_tol=1e-12):
                raise InputError(f"conflicting lengths: {a}-{b} is {value:.12g} here but {length[key][0]:.12g} on link "
                                 f"{length[key][1]}", field=("links", link))
            length.setdefault(key, (value, link))
    placed = _place(known, pending, length)
    _check_lengths(placed, length)
    _check_slots(data.get("sliders"), pending, placed)
    joints = {n: [placed[n].real, placed[n].imag] for n in data["joints"]}
    links = {n: (list(v["joints"]) if isinstance(v, dict) else v) for n, v in data["links"].items()}
    return {**data, "joints": joints, "links": links}


def _place(known: dict[str, complex], pending: dict[str, Placement],
           length: dict[frozenset[str], tuple[float, str]]) -> dict[str, complex]:
    known = dict(known)
    todo = dict(pending)

    def r(a: str, b: str) -> float | None:
        hit = length.get(frozenset((a, b)))
        return None if hit is None else hit[0]

    while todo:
        progress = False
        for name, how in list(todo.items()):
            anchors = how.from_ or [a for a in known if r(a, name) is not None]
            if how.from_ and not all(a in known for a in anchors):
                continue
            if how.line:
                if not anchors or not all(a in known for a in how.line):
                    continue
                known[name] = _on_line(name, anchors[0], known[anchors[0]], r(anchors[0], name) or 0.0,
                                       [known[a] for a in how.line], complex(*(how.near or (0.0, 0.0))))
            elif how.from_ and len(anchors) == 1:
                (p,) = anchors
                rp = r(p, name)
                if rp is None:
                    raise InputError(f"no link gives the length {p}-{name}", field=("joints", name, "from"))
                known[name] = known[p] + rp * complex(math.cos(math.radians(how.angle_deg or 0.0)),
                                                      math.sin(math.radians(how.angle_deg or 0.0)))
            elif len(anchors) >= 2:
                p, q = _widest(anchors, known) if not how.from_ else anchors
                rp, rq = r(p, name), r(q, name)
                if rp is None or rq is None:
                    raise InputError(f"no link gives the length {p if rp is None else q}-{name}",
                                     field=("joints", name, "from"))
                known[name] = _intersect(name, p, known[p], rp, q, known[q], rq, how)
            else:
                continue
            del todo[name]
            progress = True
        if not progress:
            name = next(iter(todo))
            raise InputError(f"joint {name!r} cannot be placed: it needs links with lengths to two placed joints "
                             f"(not placed: {', '.join(todo)})", field=("joints", name))
    return known


def _widest(anchors: list[str], known: dict[str, complex]) -> tuple[str, str]:
    """The two anchors farthest apart (the best-conditioned triangle)."""
    return max(combinations(anchors, 2), key=lambda pq: abs(known[pq[0]] - known[pq[1]]))


def _intersect(name: str, p: str, zp: complex, rp: float, q: str, zq: complex, rq: float, how: Placement) -> complex:
    """The point at ``rp`` from p and ``rq`` from q, on the branch ``how`` asks for (computed in units
    of |p-q|, so that no square over- or underflows at any magnitude a double holds)."""
    d = zq - zp
    dist = abs(d)
    a, b = (rp / dist, rq / dist) if dist > 0 else (math.inf, math.inf)
    along = (a * a - b * b + 1.0) / 2.0
    h2 = a * a - along * along
    if -8 * sys.float_info.epsilon * (a * a + b * b + 1.0) <= h2 < 0:
        h2 = 0.0  # a flat triangle (1 + 2.5 = 3.5), negative only by rounding
    if not math.isfinite(h2) or h2 < 0:
        raise InputError(f"cannot be assembled: {name}-{p} = {rp:g} and {name}-{q} = {rq:g} cannot close a triangle "
                         f"with {p}-{q} = {dist:g}", field=("joints", name))
    across = math.sqrt(h2)
    left = zp + d * complex(along, across)
    right = zp + d * complex(along, -across)
    if how.near is not None:
        target = complex(*how.near)
        return left if abs(left - target) <= abs(right - target) else right
    return left if how.branch == "ccw" else right


def _on_line(name: str, p: str, zp: complex, rp: float, line: list[complex], near: complex) -> complex:
    """The point of the line through ``line``'s two points at ``rp`` from p, the crossing nearer ``near``."""
    a, b = line
    if a == b:
        raise InputError("the line it slides on has no direction: its two joints coincide",
                         field=("joints", name, "line"))
    u = (b - a) / abs(b - a)
    foot = a + u * ((zp - a) * u.conjugate()).real  # the foot of the perpendicular from p
    off = abs(zp - foot) / rp  # in units of rp: no square over- or underflows
    h2 = (1.0 - off) * (1.0 + off)
    if -4 * sys.float_info.epsilon <= h2 < 0:
        h2 = 0.0  # the rod just touches the line, past it only by rounding
    if not math.isfinite(h2) or h2 < 0:
        raise InputError(f"cannot be assembled: {name}-{p} = {rp:g} cannot reach the line it slides on "
                         f"({abs(zp - foot):g} from {p})", field=("joints", name))
    ends = (foot + u * rp * math.sqrt(h2), foot - u * rp * math.sqrt(h2))
    return min(ends, key=lambda z: abs(z - near))


def _check_slots(sliders: Any, pending: dict[str, Placement], placed: dict[str, complex]) -> None:
    """A joint placed on the line P-Q whose slider's slot points another way (``angle_deg`` not along
    P-Q at rest) is a contradiction, refused like conflicting lengths."""
    for name, s in (sliders or {}).items() if isinstance(sliders, dict) else ():
        joint = s.get("joint") if isinstance(s, dict) else None
        how = pending.get(joint) if isinstance(joint, str) else None
        angle = s.get("angle_deg", 0.0) if how is not None and how.line is not None else None
        if how is None or how.line is None or not isinstance(angle, (int, float)) or isinstance(angle, bool) \
                or not math.isfinite(angle):
            continue  # no line placement, or a malformed angle the spec model reports
        p, q = (placed[j] for j in how.line)
        line = math.degrees(math.atan2((q - p).imag, (q - p).real))
        if abs(math.sin(math.radians(angle - line))) > 1e-9:
            raise InputError(f"the slot points at {angle:g}° but joint {joint!r} is placed on the line "
                             f"{how.line[0]}-{how.line[1]} ({line % 180:.12g}° or {line % 180 + 180:.12g}°)",
                             field=("sliders", name, "angle_deg"))


def _check_lengths(placed: dict[str, complex], length: dict[frozenset[str], tuple[float, str]]) -> None:
    """Every given length within 1e-9 of the linkage's size of its joints' distance (plus the rounding
    of coordinates far from the origin): relative to the linkage, not to where it lies."""
    first = next(iter(placed.values()), 0j)
    size = max((abs(z - first) for z in placed.values()), default=0.0)
    rounding = 16 * sys.float_info.epsilon * max((abs(z) for z in placed.values()), default=0.0)
    for key, (value, link) in length.items():
        a, b = sorted(key)
        got = abs(placed[a] - placed[b])
        if abs(got - value) > 1e-9 * max(size, value) + rounding:
            raise InputError(f"conflicting lengths: {a}-{b} is {value:.12g} but the other lengths and positions "
                             f"make it {got:.12g}", field=("links", link))
