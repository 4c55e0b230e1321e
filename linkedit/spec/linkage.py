"""The planar linkage spec (see ``specs/linkage.md``).

Shape and types are checked by pydantic; the cross-references (joint names in links, ground,
motor and tracks; coincident joints) by :meth:`LinkageSpec._check_references`, which names
the offending field so the loader can point at its line.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import Count, Finite, Name, SpecModel, Vec2
from linkedit.spec.lengths import LinkLengths, Placement, assemble


def _given(v: Any) -> Any:
    return v


#: In a YAML file a joint may be placed from link lengths and a link given by length
#: (:mod:`linkedit.spec.lengths`); the validated model always holds positions and joint lists.
RestPose = Annotated[dict[Name, Vec2], pydantic.BeforeValidator(_given, json_schema_input_type=dict[Name, Vec2 | Placement])]
Links = Annotated[dict[Name, list[Name]],
                  pydantic.BeforeValidator(_given, json_schema_input_type=dict[Name, list[Name] | LinkLengths])]


class Motor(SpecModel):
    """The driven joint rotates about a ground pivot; phase t ∈ [0, 1) is one revolution."""

    joint: Name
    pivot: Name
    direction: Literal["ccw", "cw"] = "ccw"
    #: Optional partial sweep, degrees of motor rotation from the rest pose: [start, end].
    #: Without it the motor makes a full revolution.
    range_deg: tuple[Finite, Finite] | None = None

    @pydantic.field_validator("range_deg")
    @classmethod
    def _range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (v[0] < v[1] <= v[0] + 360.0):
            raise ValueError("range_deg must be [start, end] with start < end <= start + 360")
        return v


class JointTrack(SpecModel):
    """Track the motion of a joint."""

    joint: Name


class LinkTrack(SpecModel):
    """Track a point rigidly attached to a link, given by its rest-pose position."""

    link: Name
    at: Vec2


class LinkageSpec(SpecModel):
    """A planar linkage: rest pose, ground, rigid links, one motor and tracked points."""

    name: Name
    units: Name
    description: str | None = None
    joints: RestPose = pydantic.Field(min_length=3)
    ground: list[Name] = pydantic.Field(min_length=1)
    links: Links = pydantic.Field(min_length=1)
    motor: Motor
    tracks: dict[Name, JointTrack | LinkTrack] = pydantic.Field(default_factory=dict)
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
        known(self.motor.joint, ("motor", "joint"))
        known(self.motor.pivot, ("motor", "pivot"))
        if self.motor.pivot not in self.ground:
            raise InputError(f"the motor pivot {self.motor.pivot!r} is not a ground joint", field=("motor", "pivot"))
        if self.motor.joint in self.ground:
            raise InputError(f"the motor joint {self.motor.joint!r} is a ground joint", field=("motor", "joint"))
        if not any(self.motor.joint in m and self.motor.pivot in m for m in self.links.values()):
            raise InputError("no link carries both the motor joint and its pivot (the crank)", field=("motor",))
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
        return self

    def _check_coincident(self) -> None:
        names = list(self.joints)
        pts = [self.joints[n] for n in names]
        scale = max(max(abs(c) for p in pts for c in p), 1.0)
        seen: dict[tuple[int, int], str] = {}
        cell = scale * 1e-9
        for name, (x, y) in zip(names, pts):
            key = (math.floor(x / cell), math.floor(y / cell))
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    other = seen.get((key[0] + dx, key[1] + dy))
                    if other is not None and math.dist(self.joints[other], (x, y)) <= cell:
                        raise InputError(f"joint {name!r} coincides with joint {other!r}", field=("joints", name))
            seen[key] = name
