"""The edit script (see ``specs/edit-script.md``): operations applied in order to a linkage.

Each operation is a set of objectives solved to convergence; its result starts the next one.
Shapes are checked here; names (joints, tracks, locks) are checked against the linkage by
:func:`check_against`.
"""

from __future__ import annotations

from typing import Annotated, Literal

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import MAX_WEIGHT, Count, Finite, Name, SpecModel, Vec2
from linkedit.spec.linkage import LinkageSpec

Phase = Annotated[float, pydantic.Strict(), pydantic.Field(ge=0.0, lt=1.0, allow_inf_nan=False)]
#: a weight of an objective term: sums of weighted squares must not overflow
Weight = Annotated[float, pydantic.Strict(), pydantic.Field(ge=0.0, le=MAX_WEIGHT, allow_inf_nan=False)]
Positive = Annotated[float, pydantic.Strict(), pydantic.Field(gt=0.0, allow_inf_nan=False)]
#: the weight of one target among an operation's targets
ItemWeight = Annotated[float, pydantic.Strict(), pydantic.Field(gt=0.0, le=MAX_WEIGHT, allow_inf_nan=False)]
#: the singularity barrier's threshold ε on d_s, in (0, 1)
Epsilon = Annotated[float, pydantic.Strict(), pydantic.Field(gt=0.0, lt=1.0)]


class Displace(SpecModel):
    """Move a joint (or a point fixed on a link) to ``to``, at the rest pose or at a motor phase.

    A joint: ``{joint: C, to: [x, y]}``, at a phase ``{joint: C, to: [x, y], at: 0.5}``.
    A point on a link, given by its rest position: ``{link: knee, at: [x, y], to: [x, y]}``,
    at a phase with ``phase: 0.5``.
    """

    joint: Name | None = None
    link: Name | None = None
    to: Vec2
    at: Finite | Vec2 | None = None
    phase: Phase | None = None
    weight: ItemWeight = 1.0

    @pydantic.field_validator("at")
    @classmethod
    def _phase(cls, v: float | tuple[float, float] | None) -> float | tuple[float, float] | None:
        if isinstance(v, float) and not 0.0 <= v < 1.0:
            raise ValueError(f"a motor phase must be at least 0 and less than 1, not {v:g}")
        return v

    @pydantic.model_validator(mode="after")
    def _what(self) -> "Displace":
        if (self.joint is None) == (self.link is None):
            raise ValueError("give either joint (a joint) or link (a point on a link)")
        if self.link is not None and not isinstance(self.at, tuple):
            raise ValueError("a point on a link needs at: [x, y], its rest position")
        if self.joint is not None and isinstance(self.at, tuple):
            raise ValueError("for a joint, at is a motor phase in [0, 1)")
        if self.joint is not None and self.at is not None and self.phase is not None:
            raise ValueError("give the phase once: at or phase")
        return self

    @property
    def when(self) -> float | None:
        """Motor phase of the target, or None for the rest pose."""
        if self.link is not None or self.at is None:
            return self.phase
        assert not isinstance(self.at, tuple)  # a joint's ``at`` is a phase (checked by _what)
        return self.at

    @property
    def label(self) -> str:
        if self.joint is not None:
            what = self.joint
        else:
            assert isinstance(self.at, tuple)  # a link point's ``at`` is its rest position (checked by _what)
            what = f"{self.link}@({self.at[0]:g}, {self.at[1]:g})"
        return f"displace {what}" + ("" if self.when is None else f" at {self.when:g}")


class Preserve(SpecModel):
    """Keep a track's curve: over the whole cycle or ``phases: [a, b]`` (a > b wraps around),
    sample by sample, or with ``timing: false`` only its shape (distance to the curve)."""

    track: Name
    weight: ItemWeight = 1.0
    phases: tuple[Phase, Phase] | None = None
    timing: bool = True


class Lock(SpecModel):
    """Lock one axis of a joint's rest position."""

    joint: Name
    axis: Literal["x", "y"]


class MotorFreedom(SpecModel):
    """Whether the motor's rest angle is part of what the edit may change (default: no)."""

    free_angle: bool = False


class Envelope(SpecModel):
    """Keep joints inside a box over the whole cycle (any subset of the four sides)."""

    xmin: Finite | None = None
    xmax: Finite | None = None
    ymin: Finite | None = None
    ymax: Finite | None = None
    joints: list[Name] | None = pydantic.Field(default=None, min_length=1)  #: default: every joint

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
    weight: ItemWeight = 1.0


class Follow(SpecModel):
    """Make a track follow a given curve: its shape (``timing: false``, the default: the
    distance of every sample to the polyline) or, with ``timing: true``, point by point with
    the curve's points spread evenly over the cycle from phase 0."""

    track: Name
    curve: list[Vec2] = pydantic.Field(min_length=3)
    timing: bool = False
    closed: bool = True
    weight: ItemWeight = 1.0


class Drag(SpecModel):
    """Drag a track's curve at phase ``at`` by ``by``, with a Gaussian falloff of ``radius`` in phase."""

    track: Name
    at: Phase
    by: Vec2
    radius: Positive = 0.1
    weight: ItemWeight = 1.0


class Transform(SpecModel):
    """Targets for a set of joints: scale, rotate and translate them about ``about``
    (default: their centroid)."""

    joints: Literal["all"] | list[Name] = "all"
    scale: Positive = 1.0
    rotate_deg: Finite = 0.0
    translate: Vec2 = (0.0, 0.0)
    about: Vec2 | None = None

    @pydantic.field_validator("joints")
    @classmethod
    def _some(cls, joints: Literal["all"] | list[str]) -> Literal["all"] | list[str]:
        if not joints:
            raise ValueError("name at least one joint, or all (a transform of no joints has no goal)")
        return joints


class TermWeights(SpecModel):
    """Relative weights of an operation's objective terms (inside the edit weight)."""

    preserve: Weight = 100.0
    displace: Weight = 1.0
    envelope: Weight = 1.0
    retarget: Weight = 1.0
    follow: Weight = 1.0
    drag: Weight = 1.0
    transform: Weight = 1.0


class Operation(SpecModel):
    """One editing step: objectives solved together to convergence."""

    name: str | None = None
    preserve: list[Name | Preserve] = pydantic.Field(default_factory=list)
    displace: Displace | list[Displace] | None = None
    envelope: Envelope | None = None
    retarget: Retarget | list[Retarget] | None = None
    follow: Follow | list[Follow] | None = None
    drag: Drag | list[Drag] | None = None
    transform: Transform | None = None
    terms: TermWeights = TermWeights()
    max_iterations: Count = pydantic.Field(default=200, ge=1)

    @property
    def preserved(self) -> list[Preserve]:
        return [Preserve(track=p) if isinstance(p, str) else p for p in self.preserve]

    @pydantic.model_validator(mode="after")
    def _has_goal(self) -> "Operation":
        if not any((self.displace, self.envelope, self.retarget, self.follow, self.drag, self.transform)):
            raise ValueError("an operation needs a goal: displace, envelope, retarget, follow, drag or transform")
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
    #: at most 20,000: the final check simulates 4× as many, and the Jacobian holds samples × directions
    samples: Count = pydantic.Field(default=120, ge=8, le=20_000)
    operations: list[Operation] = pydantic.Field(min_length=1)
    lock: list[Name | Lock] = pydantic.Field(default_factory=list)
    motor: MotorFreedom = MotorFreedom()
    weights: Weights = Weights()
    singularity_epsilon: Epsilon = 0.05
    solver: Literal["gauss-newton", "bfgs"] = "gauss-newton"
    #: Mirrored parts: pairs of joint-name suffixes, e.g. [[_L, _R]]: joints whose names differ only
    #: by them are mirror images, and corresponding lengths stay equal through the edit.
    symmetric: list[tuple[str, str]] = pydantic.Field(default_factory=list)

    def mirror(self, joints: list[str]) -> dict[str, str]:
        """Joint → its mirror image, both ways, for the ``symmetric`` suffixes."""
        out: dict[str, str] = {}
        names = set(joints)
        for a, b in self.symmetric:
            for n in joints:
                if n.endswith(a) and n[: len(n) - len(a)] + b in names:
                    out[n] = n[: len(n) - len(a)] + b
                    out[out[n]] = n
        return out

    def locked(self) -> dict[str, str]:
        """Joint name → locked axes ("xy", "x" or "y")."""
        out: dict[str, str] = {}
        for item in self.lock:
            name, axes = (item, "xy") if isinstance(item, str) else (item.joint, item.axis)
            out[name] = "".join(a for a in "xy" if a in out.get(name, "") + axes)
        return out


#: How much a scale may grow: beyond, the objective's squares overflow long before the edit could get there.
REACH = 1e6
#: How far (in linkage sizes, grown by earlier transforms' scales) a target may lie, or a move or box edge
#: reach: further is a script written in other units than its spec (mm on a spec in m: 1000×) or a slip.
FAR = 10.0


def check_against(script: EditScript, linkage: LinkageSpec) -> None:
    """Check every joint, link and track name of ``script`` against ``linkage``, and that every
    target is within :data:`FAR` linkage sizes; InputError names the field."""
    _check_reach(script, linkage)
    joints, tracks, links = set(linkage.joints), set(linkage.tracks), set(linkage.links)
    locked = {name for name, axes in script.locked().items() if axes == "xy"}
    for n, item in enumerate(script.lock):
        name = item if isinstance(item, str) else item.joint
        if name not in joints:
            raise InputError(f"unknown joint {name!r}", field=("lock", n) if isinstance(item, str) else ("lock", n, "joint"))
    for n, (a, b) in enumerate(script.symmetric):
        single = script.model_copy(update={"symmetric": [(a, b)]})
        if not single.mirror(list(linkage.joints)):
            raise InputError(f"no joint name ends in {a!r} with a twin ending in {b!r}", field=("symmetric", n))
    if locked >= joints:
        raise InputError("every joint is locked: nothing is left for the edit to change", field=("lock",))
    for o, op in enumerate(script.operations):
        base: tuple = ("operations", o)
        for n, kept in enumerate(op.preserve):
            track = kept if isinstance(kept, str) else kept.track
            if track not in tracks:
                raise InputError(f"unknown track {track!r} (tracks: {', '.join(sorted(tracks)) or 'none'})",
                                 field=base + ("preserve", n))
        for kind in ("retarget", "follow", "drag"):
            items = op.listed(kind)
            for n, item in enumerate(items):
                field = base + ((kind, n) if isinstance(getattr(op, kind), list) else (kind,))
                if item.track not in tracks:
                    raise InputError(f"unknown track {item.track!r} (tracks: {', '.join(sorted(tracks)) or 'none'})",
                                     field=field + ("track",))
        displaces = op.listed("displace")
        for n, d in enumerate(displaces):
            field = base + (("displace", n) if isinstance(op.displace, list) else ("displace",))
            if d.link is not None:
                if d.link not in links:
                    raise InputError(f"unknown link {d.link!r}", field=field + ("link",))
                continue
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

    grown = 1.0  # the linkage's growth by the transforms before the operation at hand

    def near(values: tuple, field: tuple, relative_to: list[float] | None) -> None:
        for k, v in enumerate(values):
            off = None if v is None else abs(v - (relative_to[k % 2] if relative_to else 0.0))
            if off is not None and not off <= FAR * size * grown:
                what = "away from its centre" if relative_to else "long"
                raise InputError(f"{v:g} is {off / size:.3g}× the linkage's size ({size:g} {linkage.units}) {what} "
                                 f"(at most {FAR:g}×): the spec is in {linkage.units}; is the script in other units? "
                                 "(its lengths are in the spec's)", field=field)

    def scale(values: tuple, field: tuple) -> None:
        for v in values:
            if abs(v) > REACH:
                raise InputError(f"a scale of {v:g} is beyond {REACH:g}: out of reach of an edit", field=field)

    for o, op in enumerate(script.operations):
        base: tuple = ("operations", o)
        for kind in ("displace", "retarget", "follow", "drag"):
            for n, item in enumerate(op.listed(kind)):
                field = base + ((kind, n) if isinstance(getattr(op, kind), list) else (kind,))
                if kind == "displace":
                    near(item.to, field + ("to",), centre)
                elif kind == "follow":
                    for k, point in enumerate(item.curve):
                        near(point, field + ("curve", k), centre)
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
            grown *= max(1.0, abs(t.scale))
