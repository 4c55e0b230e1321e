"""The 3D mechanism spec for ``linkedit solve3d`` (see ``specs/mechanism3d.md``).

Members (position, orientation, shape points) are held together by named constraints —
location, orientation, axis, on-plane, on-line, distance, angle, parallel, perpendicular, the
composites pin (revolute) and weld, groups, and custom Python constraints — and by joints
placed in the world as in a drawing (revolute, prismatic, cylindrical, universal, spherical,
planar: presets that expand to those constraints), and driven by inputs interpolated over time
windows. Outputs are tracked member points sampled at ``steps`` times in [0, 1].

A spec file is data: a ``custom`` constraint names a Python function (``python:
module:function``) that is imported only when the caller allows it (``--allow-python``, passed
to validation as ``context={"allow_python": True}``).

This module holds the spec and its cross-reference checks; the parts are in
:mod:`~linkedit.spec.geometry3d` (field types), :mod:`~linkedit.spec.constraints3d`,
:mod:`~linkedit.spec.joints3d` and :mod:`~linkedit.spec.inputs3d`.
"""

from __future__ import annotations

from typing import Any, ClassVar

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import Count, Name, SpecModel
from linkedit.spec.constraints3d import (Angle, AxisC, Constraint, CustomC, Distance, Group, Location, OnLine, OnPlane,
                                         OrientationC, Parallel, Pin, Weld, load_function)
from linkedit.spec.geometry3d import Orientation, Point3, PointRef
from linkedit.spec.inputs3d import DistanceInput, Input, OrientationInput
from linkedit.spec.joints3d import JOINT_PARTS, WORLD, Joint, UniversalJoint


class Shape(SpecModel):
    """Named points in member space; ``lines`` are polylines of point names for drawing."""

    points: dict[Name, Point3] = pydantic.Field(min_length=1)
    lines: list[list[Name]] = pydantic.Field(default_factory=list)


class Member(SpecModel):
    """A rigid body: position, orientation and shape (a name from ``shapes`` or inline)."""

    position: Point3 = (0.0, 0.0, 0.0)
    orientation: Orientation = (1.0, 0.0, 0.0, 0.0)
    shape: Name | Shape | None = None


class TrackSpec(SpecModel):
    """A tracked point: a member point (name or member-space coordinates)."""

    member: Name
    point: PointRef


#: most time steps a run may have (the arrays of a run grow with steps × members)
MAX_STEPS = 1_000_000


class Outputs(SpecModel):
    steps: Count = pydantic.Field(default=100, ge=2, le=MAX_STEPS)
    tracks: dict[Name, TrackSpec] = pydantic.Field(default_factory=dict)


class MechanismSpec(SpecModel):
    """A 3D mechanism: members, constraints, inputs and outputs."""

    spec_kind: ClassVar[str | None] = "3d"

    name: Name
    units: Name
    description: str | None = None
    shapes: dict[Name, Shape] = pydantic.Field(default_factory=dict)
    members: dict[Name, Member] = pydantic.Field(min_length=1)
    constraints: dict[Name, Constraint] = pydantic.Field(default_factory=dict)
    joints: dict[Name, Joint] = pydantic.Field(default_factory=dict)
    inputs: dict[Name, Input] = pydantic.Field(default_factory=dict)
    outputs: Outputs = pydantic.Field(default_factory=Outputs)

    def member_points(self, member: str) -> dict[str, tuple[float, float, float]]:
        """The named points of a member's shape (member space)."""
        shape = self.members[member].shape
        if shape is None:
            return {}
        return dict((self.shapes[shape] if isinstance(shape, str) else shape).points)

    def member_lines(self, member: str) -> list[list[str]]:
        shape = self.members[member].shape
        if shape is None:
            return []
        return list((self.shapes[shape] if isinstance(shape, str) else shape).lines)

    @pydantic.model_validator(mode="after")
    def _check_references(self, info: pydantic.ValidationInfo) -> "MechanismSpec":
        if not (self.constraints or self.joints or self.inputs):
            raise InputError("nothing holds or drives the members: give at least one constraint, joint or input",
                             field=("constraints",))
        for name, m in self.members.items():
            if isinstance(m.shape, str) and m.shape not in self.shapes:
                raise InputError(f"unknown shape {m.shape!r}", field=("members", name, "shape"))
        for name, shape in list(self.shapes.items()) + [
                (n, m.shape) for n, m in self.members.items() if isinstance(m.shape, Shape)]:
            for i, line in enumerate(shape.lines):
                for j, p in enumerate(line):
                    if p not in shape.points:
                        raise InputError(f"unknown point {p!r}", field=("shapes", name, "lines", i, j))
        allow = bool((info.context or {}).get("allow_python", False))
        for name, c in self.constraints.items():
            self._check_constraint(c, ("constraints", name), allow)
        for name, joint in self.joints.items():
            self._check_joint(joint, ("joints", name))
        for name, inp in self.inputs.items():
            self._check_input(inp, ("inputs", name))
        for name, tr in self.outputs.tracks.items():
            self._member(tr.member, ("outputs", "tracks", name, "member"))
            self._point(tr.member, tr.point, ("outputs", "tracks", name, "point"))
        return self

    def _member(self, name: str, field: tuple) -> None:
        if name not in self.members:
            raise InputError(f"unknown member {name!r}", field=field)

    def _point(self, member: str, point: Any, field: tuple) -> None:
        if isinstance(point, str) and point not in self.member_points(member):
            raise InputError(f"unknown point {point!r} of member {member!r}", field=field)

    def _sides(self, c: Any, field: tuple, target_fields: tuple[str, ...]) -> None:
        """Member references, and exactly one of a world target or ``other``."""
        self._member(c.member, field + ("member",))
        if hasattr(c, "point"):
            self._point(c.member, c.point, field + ("point",))
        other = getattr(c, "other", None)
        has_world = any(getattr(c, f, None) is not None for f in target_fields)
        if other is not None:
            self._member(other, field + ("other",))
            if other == c.member:
                raise InputError("a member cannot be constrained against itself", field=field + ("other",))
            if has_world:
                raise InputError(f"give either {target_fields[0]!r} (fixed) or 'other' (relative), not both",
                                 field=field + (target_fields[0],))
        elif not has_world and target_fields:
            raise InputError(f"give {target_fields[0]!r} (fixed, against the world) or 'other' (relative)",
                             field=field)

    def _check_constraint(self, c: Any, field: tuple, allow_python: bool) -> None:
        if isinstance(c, Group):
            for name, sub in c.constraints.items():
                self._check_constraint(sub, field + ("constraints", name), allow_python)
            return
        if isinstance(c, CustomC):
            for i, m in enumerate(c.members):
                self._member(m, field + ("members", i))
            if not allow_python:
                raise InputError("a custom constraint runs Python code: pass --allow-python to allow it",
                                 field=field + ("python",))
            load_function(c.python, field + ("python",))
            return
        targets = () if isinstance(c, (OnPlane, OnLine)) else ("world",)
        self._sides(c, field, targets)
        self._other_point(c, field)
        if isinstance(c, (AxisC, Angle, Parallel)) and c.other is not None and c.other_axis is None:
            raise InputError("a relative axis constraint needs 'other_axis'", field=field + ("other_axis",))
        if isinstance(c, OrientationC) and c.other is None and c.relative is not None:
            raise InputError("'relative' needs 'other'", field=field + ("relative",))

    def _other_point(self, c: Any, field: tuple) -> None:
        """A relative point-to-point constraint (or input) names the other member's point."""
        if isinstance(c, (Location, Pin, Weld, Distance, DistanceInput)) and c.other is not None:
            if c.other_point is None:
                raise InputError("a relative constraint needs 'other_point'", field=field + ("other_point",))
            self._point(c.other, c.other_point, field + ("other_point",))

    def _check_joint(self, joint: Any, field: tuple) -> None:
        for part in JOINT_PARTS[joint.type]:
            if f"{field[-1]}.{part}" in self.constraints or f"{field[-1]}.{part}" in self.inputs:
                raise InputError(f"its constraint {field[-1]}.{part!s} has the name of a constraint or input: "
                                 "rename one", field=field)
        if joint.members[0] == joint.members[1]:
            raise InputError("a joint needs two different members", field=field + ("members",))
        for i, m in enumerate(joint.members):
            if m == WORLD and WORLD in self.members:
                raise InputError("'world' in a joint is the fixed frame, and a member is named 'world' too: "
                                 "rename that member", field=field + ("members", i))
            if m != WORLD:
                self._member(m, field + ("members", i))
        if isinstance(joint, UniversalJoint):
            a, b = joint.axes
            if abs(sum(x * y for x, y in zip(a, b))) > 1e-9:
                raise InputError("the two axes of a universal joint must be perpendicular at rest",
                                 field=field + ("axes",))

    def _check_input(self, inp: Any, field: tuple) -> None:
        if field[-1] in self.constraints:
            raise InputError(f"{field[-1]!r} is also a constraint's name: results and diagnostics name each "
                             "constraint and input once; rename one", field=field)
        t0, t1 = inp.window
        if not (0.0 <= t0 < t1 <= 1.0):
            raise InputError("the window must be [t0, t1] with 0 <= t0 < t1 <= 1", field=field + ("window",))
        self._sides(inp, field, ("world",) if isinstance(inp, DistanceInput) else ())
        self._other_point(inp, field)
        if isinstance(inp, OrientationInput):
            if (inp.keyframes is None) == (inp.rotation is None):
                raise InputError("give either 'keyframes' or 'rotation'", field=field)
            if inp.keyframes is not None:
                count = len(inp.keyframes)
            else:
                assert inp.rotation is not None  # exactly one of them is given (checked above)
                count = len(inp.rotation.angles_deg)
        else:
            count = len(inp.keyframes)
        if inp.times is not None:
            if len(inp.times) != count:
                raise InputError(f"{len(inp.times)} times for {count} keyframes", field=field + ("times",))
            if any(b <= a for a, b in zip(inp.times, inp.times[1:])) or inp.times[0] < t0 or inp.times[-1] > t1:
                raise InputError("times must increase and lie inside the window", field=field + ("times",))
