"""The edit script (see ``specs/edit-script.md``): operations applied in order to a linkage.

Each operation is a set of objectives solved to convergence; its result starts the next one.
Shapes are checked here; names (joints, tracks, locks) are checked against the linkage by
:func:`check_against`.
"""

from __future__ import annotations

from typing import Literal

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import MAX_WEIGHT, Count, Finite, Name, SpecModel, Vec2
from linkedit.spec.linkage import LinkageSpec

Phase = pydantic.confloat(strict=True, ge=0.0, lt=1.0, allow_inf_nan=False)
#: a weight of an objective term: sums of weighted squares must not overflow
Weight = pydantic.confloat(strict=True, ge=0.0, le=MAX_WEIGHT, allow_inf_nan=False)
Positive = pydantic.confloat(strict=True, gt=0.0, allow_inf_nan=False)


class Displace(SpecModel):
    """Move a joint's rest position (or its position at motor phase ``at``) to ``to``."""

    joint: Name
    to: Vec2
    at: Phase | None = None


class Envelope(SpecModel):
    """Keep joints inside a box over the whole cycle (any subset of the four sides)."""

    xmin: Finite | None = None
    xmax: Finite | None = None
    ymin: Finite | None = None
    ymax: Finite | None = None
    joints: list[Name] | None = None  #: default: every joint

    @pydantic.model_validator(mode="after")
    def _sides(self) -> "Envelope":
        if all(v is None for v in (self.xmin, self.xmax, self.ymin, self.ymax)):
            raise ValueError("give at least one of xmin, xmax, ymin, ymax")
        for lo, hi in (("xmin", "xmax"), ("ymin", "ymax")):
            a, b = getattr(self, lo), getattr(self, hi)
            if a is not None and b is not None and a >= b:
                raise ValueError(f"{lo} ({a}) must be less than {hi} ({b})")
        return self


class Retarget(SpecModel):
    """Make a track follow its current curve transformed about the curve's centroid."""

    track: Name
    scale: Vec2 = (1.0, 1.0)
    translate: Vec2 = (0.0, 0.0)
    rotate_deg: Finite = 0.0


class Drag(SpecModel):
    """Drag a track's curve at phase ``at`` by ``by``, with a Gaussian falloff of ``radius`` in phase."""

    track: Name
    at: Phase
    by: Vec2
    radius: Positive = 0.1


class Transform(SpecModel):
    """Targets for a set of joints: scale, rotate and translate them about ``about``
    (default: their centroid)."""

    joints: Literal["all"] | list[Name] = "all"
    scale: Positive = 1.0
    rotate_deg: Finite = 0.0
    translate: Vec2 = (0.0, 0.0)
    about: Vec2 | None = None


class TermWeights(SpecModel):
    """Relative weights of an operation's objective terms (inside the edit weight)."""

    preserve: Weight = 100.0
    displace: Weight = 1.0
    envelope: Weight = 1.0
    retarget: Weight = 1.0
    drag: Weight = 1.0
    transform: Weight = 1.0


class Operation(SpecModel):
    """One editing step: objectives solved together to convergence."""

    name: str | None = None
    preserve: list[Name] = pydantic.Field(default_factory=list)
    displace: Displace | list[Displace] | None = None
    envelope: Envelope | None = None
    retarget: Retarget | list[Retarget] | None = None
    drag: Drag | list[Drag] | None = None
    transform: Transform | None = None
    terms: TermWeights = TermWeights()
    max_iterations: Count = pydantic.Field(default=500, ge=1)

    @pydantic.model_validator(mode="after")
    def _has_goal(self) -> "Operation":
        if not any((self.displace, self.envelope, self.retarget, self.drag, self.transform)):
            raise ValueError("an operation needs a goal: displace, envelope, retarget, drag or transform")
        return self

    def listed(self, kind: str) -> list:
        value = getattr(self, kind)
        return [] if value is None else value if isinstance(value, list) else [value]


class Weights(SpecModel):
    """μ_e, μ_s, μ_r of E = μ_e·f_edit + μ_s·f_singularity + μ_r·f_regularization."""

    edit: Weight = 1.0
    singularity: Weight = 1.0
    regularization: Weight = 0.01


class EditScript(SpecModel):
    """An edit script: which linkage, how many samples, the operations, locks and weights."""

    linkage: str | None = None  #: path of the linkage spec, relative to the script
    samples: Count = pydantic.Field(default=120, ge=8)
    operations: list[Operation] = pydantic.Field(min_length=1)
    lock: list[Name] = pydantic.Field(default_factory=list)
    weights: Weights = Weights()
    singularity_epsilon: pydantic.confloat(strict=True, gt=0.0, lt=1.0) = 0.05


#: How far (in linkage sizes) a target may lie, and how much a scale may grow or shrink: beyond,
#: the objective's squares overflow long before the edit could get there.
REACH = 1e6


def check_against(script: EditScript, linkage: LinkageSpec) -> None:
    """Check every joint and track name of ``script`` against ``linkage``, and that every target is
    within :data:`REACH` linkage sizes; InputError names the field."""
    _check_reach(script, linkage)
    joints, tracks = set(linkage.joints), set(linkage.tracks)
    locked = set(script.lock)
    for n, name in enumerate(script.lock):
        if name not in joints:
            raise InputError(f"unknown joint {name!r}", field=("lock", n))
    for o, op in enumerate(script.operations):
        base: tuple = ("operations", o)
        for n, name in enumerate(op.preserve):
            if name not in tracks:
                raise InputError(f"unknown track {name!r} (tracks: {', '.join(sorted(tracks)) or 'none'})",
                                 field=base + ("preserve", n))
        for kind in ("retarget", "drag"):
            items = op.listed(kind)
            for n, item in enumerate(items):
                field = base + ((kind, n) if isinstance(getattr(op, kind), list) else (kind,))
                if item.track not in tracks:
                    raise InputError(f"unknown track {item.track!r} (tracks: {', '.join(sorted(tracks)) or 'none'})",
                                     field=field + ("track",))
        displaces = op.listed("displace")
        for n, d in enumerate(displaces):
            field = base + (("displace", n) if isinstance(op.displace, list) else ("displace",))
            if d.joint not in joints:
                raise InputError(f"unknown joint {d.joint!r}", field=field + ("joint",))
            if d.joint in locked and d.at is None:
                raise InputError(f"joint {d.joint!r} is locked (lock: [...]) and cannot be displaced", field=field + ("joint",))
        if op.envelope is not None and op.envelope.joints:
            for n, name in enumerate(op.envelope.joints):
                if name not in joints:
                    raise InputError(f"unknown joint {name!r}", field=base + ("envelope", "joints", n))
        if op.transform is not None and isinstance(op.transform.joints, list):
            for n, name in enumerate(op.transform.joints):
                if name not in joints:
                    raise InputError(f"unknown joint {name!r}", field=base + ("transform", "joints", n))


def _check_reach(script: EditScript, linkage: LinkageSpec) -> None:
    rest = list(linkage.joints.values())
    lo = [min(p[k] for p in rest) for k in (0, 1)]
    hi = [max(p[k] for p in rest) for k in (0, 1)]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    size = max(max(b - a for a, b in zip(lo, hi)), 1e-300)

    def near(values: tuple, field: tuple, relative_to: list[float] | None) -> None:
        for k, v in enumerate(values):
            if v is not None and abs(v - (relative_to[k % 2] if relative_to else 0.0)) > REACH * size:
                raise InputError(f"{v:g} is more than {REACH:g} times the linkage's size ({size:g} {linkage.units}) "
                                 "away: out of reach of an edit", field=field)

    def scale(values: tuple, field: tuple) -> None:
        for v in values:
            if abs(v) > REACH:
                raise InputError(f"a scale of {v:g} is beyond {REACH:g}: out of reach of an edit", field=field)

    for o, op in enumerate(script.operations):
        base: tuple = ("operations", o)
        for kind in ("displace", "retarget", "drag"):
            for n, item in enumerate(op.listed(kind)):
                field = base + ((kind, n) if isinstance(getattr(op, kind), list) else (kind,))
                if kind == "displace":
                    near(item.to, field + ("to",), centre)
                elif kind == "drag":
                    near(item.by, field + ("by",), None)
                else:
                    near(item.translate, field + ("translate",), None)
                    scale(item.scale, field + ("scale",))
        if op.envelope is not None:
            e = op.envelope
            near((e.xmin, e.ymin, e.xmax, e.ymax), base + ("envelope",), centre)
        if op.transform is not None:
            t = op.transform
            near(t.translate, base + ("transform", "translate"), None)
            if t.about is not None:
                near(t.about, base + ("transform", "about"), centre)
            scale((t.scale,), base + ("transform", "scale"))
