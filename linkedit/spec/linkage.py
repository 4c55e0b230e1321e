"""The planar linkage spec (see ``specs/linkage.md``).

Shape and types are checked by pydantic; the cross-references (joint names in links, ground,
motor and tracks; coincident joints) by :meth:`LinkageSpec._check_references`, which names
the offending field so the loader can point at its line.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar, Literal

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import Count, Finite, Name, SpecModel, Vec2
from linkedit.spec.lengths import LinkLengths, Placement, assemble


def _given(v: Any) -> Any:
    return v


#: In a YAML file a joint may be placed from link lengths and a link given by length
#: (:mod:`linkedit.spec.lengths`); the validated model always holds positions and joint lists. The schema
#: describes the file: its input types carry the least sizes too.
RestPose = Annotated[dict[Name, Vec2], pydantic.Field(min_length=3), pydantic.BeforeValidator(
    _given, json_schema_input_type=Annotated[dict[Name, Vec2 | Placement], pydantic.Field(min_length=3)])]
Links = Annotated[dict[Name, list[Name]], pydantic.Field(min_length=1), pydantic.BeforeValidator(
    _given, json_schema_input_type=Annotated[dict[Name, list[Name] | LinkLengths], pydantic.Field(min_length=1)])]


#: a linear input's stroke may reach this many linkage sizes (see specs/limits.md)
MAX_STROKE = 1e3


class Motor(SpecModel):
    """The input: a joint turning about a ground pivot (a crank or rocker), or a joint pushed along
    a slider (a linear input, e.g. a hydraulic cylinder).

    Rotary: phase t ∈ [0, 1) is one revolution, or one back-and-forth swing with
    ``oscillate_deg``, or t ∈ [0, 1] across a ``range_deg`` sweep. Linear: ``slider`` names a
    joint slider, ``stroke`` [s0, s1] its displacement from the rest pose along the slot (spec
    units), swept over t ∈ [0, 1].
    """

    joint: Name | None = None
    pivot: Name | None = None
    direction: Literal["ccw", "cw"] = "ccw"
    #: Optional partial sweep, degrees of motor rotation from the rest pose: [start, end].
    #: Without it the motor makes a full revolution.
    range_deg: tuple[Finite, Finite] | None = None
    #: Optional rocker input: from a to b and back over one cycle, degrees from the rest pose.
    oscillate_deg: tuple[Finite, Finite] | None = None
    #: Linear input: the joint slider that is driven, and its displacement range from rest.
    slider: Name | None = None
    stroke: tuple[Finite, Finite] | None = None

    @pydantic.field_validator("range_deg")
    @classmethod
    def _range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (v[0] < v[1] <= v[0] + 360.0):
            raise ValueError("range_deg must be [start, end] with start < end <= start + 360")
        return v

    @pydantic.field_validator("oscillate_deg")
    @classmethod
    def _oscillate(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (v[0] != v[1] and abs(v[1] - v[0]) <= 360.0):
            raise ValueError("oscillate_deg must be [a, b] with a != b and |b - a| <= 360")
        return v

    @pydantic.field_validator("stroke")
    @classmethod
    def _stroke(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and v[0] == v[1]:
            raise ValueError("stroke must be [s0, s1] with s0 != s1")
        return v

    @pydantic.model_validator(mode="after")
    def _one_kind(self) -> "Motor":
        if self.slider is not None or self.stroke is not None:
            for name in ("joint", "pivot", "range_deg", "oscillate_deg"):
                if getattr(self, name) is not None:
                    raise InputError(f"a linear input (slider, stroke) takes no {name}", field=("motor", name))
            if self.slider is None or self.stroke is None:
                missing = "slider" if self.slider is None else "stroke"
                raise InputError("a linear input needs both slider and stroke", field=("motor", missing))
            return self
        for name in ("joint", "pivot"):
            if getattr(self, name) is None:
                raise InputError(f"a rotary motor needs {name} (or give slider and stroke for a linear input)",
                                 field=("motor", name))
        if self.range_deg is not None and self.oscillate_deg is not None:
            raise InputError("give range_deg or oscillate_deg, not both", field=("motor", "oscillate_deg"))
        return self

    @property
    def linear(self) -> bool:
        """True for a linear input (a driven slider)."""
        return self.slider is not None

    @property
    def cyclic(self) -> bool:
        """True when the last sample joins the first (a full turn or a back-and-forth swing)."""
        return not self.linear and self.range_deg is None


class JointTrack(SpecModel):
    """Track the motion of a joint."""

    joint: Name


class LinkTrack(SpecModel):
    """Track a point rigidly attached to a link, given by its rest-pose position."""

    link: Name
    at: Vec2


#: The name a slider's ``guide`` uses for the frame.
FRAME = "ground"


class Slider(SpecModel):
    """A prismatic pair. ``joint``: that joint stays on a line fixed to ``guide`` (a pin in a slot);
    ``link``: every joint of that link slides along ``guide`` without turning relative to it.

    The line passes through the joint's (or the link's first joint's) rest position with
    direction ``angle_deg`` at rest; ``guide`` is a link name or ``ground`` (the frame).
    """

    joint: Name | None = None
    link: Name | None = None
    guide: Name
    angle_deg: Finite = 0.0

    @pydantic.model_validator(mode="after")
    def _joint_or_link(self) -> "Slider":
        if (self.joint is None) == (self.link is None):
            raise ValueError("give exactly one of joint (a pin in a slot) or link (a translating link)")
        return self


class LinkageSpec(SpecModel):
    """A planar linkage: rest pose, ground, rigid links, one motor and tracked points."""

    spec_kind: ClassVar[str | None] = "planar"

    name: Name
    units: Name
    description: str | None = None
    joints: RestPose
    ground: list[Name] = pydantic.Field(min_length=1)
    links: Links
    motor: Motor
    tracks: dict[Name, JointTrack | LinkTrack] = pydantic.Field(default_factory=dict)
    #: Prismatic pairs (sliders), by name.
    sliders: dict[Name, Slider] = pydantic.Field(default_factory=dict)
    #: Default number of time samples per cycle (the CLI's --samples overrides it).
    samples: Count | None = pydantic.Field(default=None, ge=1)

    @pydantic.model_validator(mode="before")
    @classmethod
    def _assemble_from_lengths(cls, data: Any) -> Any:
        return assemble(data)

    @pydantic.field_validator("links")
    @classmethod
    def _links_have_two_joints(cls, links: dict[str, list[str]]) -> dict[str, list[str]]:
        for name, joints in links.items():
            if len(joints) < 2:
                raise InputError("a link needs at least 2 joints", field=("links", name))
            if len(set(joints)) != len(joints):
                raise InputError("a joint is listed twice", field=("links", name))
        return links

    @pydantic.model_validator(mode="after")
    def _check_references(self) -> "LinkageSpec":
        joints = self.joints

        def known(name: str, field: tuple[str | int, ...]) -> None:
            if name not in joints:
                raise InputError(f"unknown joint {name!r}", field=field)

        for i, g in enumerate(self.ground):
            known(g, ("ground", i))
        if len(set(self.ground)) != len(self.ground):
            raise InputError("a joint is listed twice", field=("ground",))
        for name, members in self.links.items():
            for i, j in enumerate(members):
                known(j, ("links", name, i))
        self._check_sliders()
        if self.motor.linear:
            self._check_linear_input()
        else:
            self._check_rotary_input(known)
        on_links = {j for m in self.links.values() for j in m}
        for name in joints:
            if name not in on_links and name not in self.ground:
                raise InputError(f"joint {name!r} is on no link", field=("joints", name))
        for name, track in self.tracks.items():
            if isinstance(track, JointTrack):
                known(track.joint, ("tracks", name, "joint"))
            elif track.link not in self.links:
                raise InputError(f"unknown link {track.link!r}", field=("tracks", name, "link"))
        self._check_coincident()
        self._check_stroke()
        return self

    def _check_rotary_input(self, known) -> None:
        known(self.motor.joint, ("motor", "joint"))
        known(self.motor.pivot, ("motor", "pivot"))
        if self.motor.pivot not in self.ground:
            raise InputError(f"the motor pivot {self.motor.pivot!r} is not a ground joint", field=("motor", "pivot"))
        if self.motor.joint in self.ground:
            raise InputError(f"the motor joint {self.motor.joint!r} is a ground joint", field=("motor", "joint"))
        if not any(self.motor.joint in m and self.motor.pivot in m for m in self.links.values()):
            raise InputError("no link carries both the motor joint and its pivot (the crank)", field=("motor",))

    def _check_linear_input(self) -> None:
        slider = self.sliders.get(self.motor.slider) if self.motor.slider is not None else None
        if slider is None:
            raise InputError(f"unknown slider {self.motor.slider!r}", field=("motor", "slider"))
        if slider.joint is None:
            raise InputError(f"slider {self.motor.slider!r} moves a link; a linear input drives a joint slider",
                             field=("motor", "slider"))
        if slider.joint in self.ground:
            raise InputError(f"slider {self.motor.slider!r} carries ground joint {slider.joint!r}, which cannot be driven",
                             field=("motor", "slider"))

    def _check_sliders(self) -> None:
        ground = set(self.ground)
        for name, s in self.sliders.items():
            field = ("sliders", name)
            if s.guide != FRAME and s.guide not in self.links:
                raise InputError(f"guide {s.guide!r} is not a link (give a link name or {FRAME!r})", field=field + ("guide",))
            guide = set(self.links.get(s.guide, ())) if s.guide != FRAME else ground
            if s.joint is not None:
                if s.joint not in self.joints:
                    raise InputError(f"unknown joint {s.joint!r}", field=field + ("joint",))
                if s.guide == FRAME and s.joint in ground:
                    raise InputError(f"joint {s.joint!r} is a ground joint: it cannot slide on the frame", field=field + ("joint",))
                if s.guide != FRAME and s.joint in guide:
                    raise InputError(f"joint {s.joint!r} is on its guide link {s.guide!r}: a joint cannot slide on "
                                     "its own link (remove it from the link, it is pinned to the links that list it)",
                                     field=field + ("joint",))
            else:
                if s.link not in self.links:
                    raise InputError(f"unknown link {s.link!r}", field=field + ("link",))
                if s.link == s.guide:
                    raise InputError(f"link {s.link!r} cannot slide on itself", field=field + ("guide",))
                if set(self.links[s.link]) <= ground:
                    raise InputError(f"link {s.link!r} is fixed to the frame: it cannot slide", field=field + ("link",))
                if set(self.links[s.link]) & guide:
                    shared = sorted(set(self.links[s.link]) & guide)[0]
                    raise InputError(f"link {s.link!r} shares joint {shared!r} with its guide: it cannot slide on it",
                                     field=field + ("link",))

    def _check_stroke(self) -> None:
        """A linear input's stroke within ``MAX_STROKE`` sizes of the linkage: a cylinder that
        moves a joint a thousand times further than the linkage is large cannot keep it
        assembled, and continuing the motion over such a range would take forever."""
        if self.motor.stroke is None:
            return
        xy = [c for p in self.joints.values() for c in p]
        size = max(max(xy) - min(xy), 1e-300)
        if max(abs(s) for s in self.motor.stroke) > MAX_STROKE * size:
            raise InputError(f"stroke {list(self.motor.stroke)} reaches beyond {MAX_STROKE:g}× the linkage's size "
                             f"({size:.4g}): it cannot stay assembled", field=("motor", "stroke"))

    def _check_coincident(self) -> None:
        """Joints closer than 1e-9 of the largest coordinate are one point: refused, as coinciding
        when they are (nearly) one point for the linkage's own size too, else as a linkage placed
        too far from the origin for double precision at its size."""
        names = list(self.joints)
        pts = [self.joints[n] for n in names]
        scale = max(abs(c) for p in pts for c in p) or 1.0  # relative: the same at any size
        seen: dict[tuple[int, int], str] = {}
        cell = scale * 1e-9
        size = max(max(p[0] for p in pts) - min(p[0] for p in pts), max(p[1] for p in pts) - min(p[1] for p in pts))
        for name, (x, y) in zip(names, pts):
            key = (math.floor(x / cell), math.floor(y / cell))
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    other = seen.get((key[0] + dx, key[1] + dy))
                    apart = math.inf if other is None else math.dist(self.joints[other], (x, y))
                    if apart > cell:
                        continue
                    if apart > 1e-9 * size:
                        raise InputError(
                            f"the linkage (size {size:.4g}) lies {scale:.4g} from the origin: beyond "
                            f"double precision for its size (joints {name!r} and {other!r}, {apart:.4g} apart, are "
                            "one point to 1e-9 of that distance); move it nearer the origin", field=("joints", name))
                    raise InputError(f"joint {name!r} coincides with joint {other!r}", field=("joints", name))
            seen[key] = name
