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
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Union

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import PYTHON_PATTERN, Count, Finite, Name, SpecModel, Vec3


def _unit(v: tuple[float, ...]) -> tuple[float, ...]:
    """``v`` (not all zero) scaled to length 1 without overflow or underflow: divided by its largest
    component first, so values near 1e308 and near 1e-308 (subnormals too) give the same direction."""
    big = max(abs(c) for c in v)
    scaled = [c / big for c in v]
    norm = math.sqrt(sum(c * c for c in scaled))
    return tuple(c / norm for c in scaled)


def _nonzero_quaternion(q: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    if not any(q):
        raise ValueError("zero quaternion: an orientation needs a unit quaternion [w, x, y, z]")
    return _unit(q)  # type: ignore[return-value]


def _nonzero_vector(v: tuple[float, float, float]) -> tuple[float, float, float]:
    if not any(v):
        raise ValueError("zero vector: an axis or normal needs a direction")
    return _unit(v)  # type: ignore[return-value]


#: [w, x, y, z], normalized when read
Quaternion = Annotated[tuple[Finite, Finite, Finite, Finite], pydantic.AfterValidator(_nonzero_quaternion)]
#: a nonzero direction, normalized when read
Direction = Annotated[Vec3, pydantic.AfterValidator(_nonzero_vector)]
#: a member point: a name from the member's shape, or coordinates in member space
PointRef = Union[Name, Vec3]
Window = tuple[Finite, Finite]
#: Largest coordinate of a shape point, a member position or a keyframe: squares of larger numbers
#: overflow (drawing extents, distances). Constraint targets may be larger: the solver reports them.
MAX_COORDINATE = 1e150
Coordinate = Annotated[Finite, pydantic.Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Point3 = tuple[Coordinate, Coordinate, Coordinate]


def load_function(ref: str, field: tuple) -> Any:
    """Import ``module:function`` (only ever called once Python code is allowed)."""
    import importlib

    module_name, _, attr = ref.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InputError(f"cannot import module {module_name!r}: {exc}", field=field) from None
    fn = getattr(module, attr, None)
    if not callable(fn):
        raise InputError(f"module {module_name!r} has no function {attr!r}", field=field)
    return fn


class AxisAngle(SpecModel):
    """A rotation by ``angle_deg`` degrees about ``axis``."""

    axis: Direction
    angle_deg: Finite


Orientation = Union[Quaternion, AxisAngle]


class Shape(SpecModel):
    """Named points in member space; ``lines`` are polylines of point names for drawing."""

    points: dict[Name, Point3] = pydantic.Field(min_length=1)
    lines: list[list[Name]] = pydantic.Field(default_factory=list)


class Member(SpecModel):
    """A rigid body: position, orientation and shape (a name from ``shapes`` or inline)."""

    position: Point3 = (0.0, 0.0, 0.0)
    orientation: Orientation = (1.0, 0.0, 0.0, 0.0)
    shape: Name | Shape | None = None


class Location(SpecModel):
    """Member point on a world point (``world``) or on another member's point (``other``, ``other_point``)."""

    type: Literal["location"]
    member: Name
    point: PointRef
    world: Vec3 | None = None
    other: Name | None = None
    other_point: PointRef | None = None


class OrientationC(SpecModel):
    """Member orientation equals a world orientation, or another member's composed with ``relative``
    (the member's orientation in the other's frame; default: as in the rest pose)."""

    type: Literal["orientation"]
    member: Name
    world: Orientation | None = None
    other: Name | None = None
    relative: Orientation | None = None


class AxisC(SpecModel):
    """Member axis (member space) aligned with a world axis or another member's axis."""

    type: Literal["axis"]
    member: Name
    axis: Direction
    world: Direction | None = None
    other: Name | None = None
    other_axis: Direction | None = None


class Plane(SpecModel):
    point: Vec3
    normal: Direction


class OnPlane(SpecModel):
    """Member point on a plane: in the world, or in another member's space (``other``)."""

    type: Literal["on_plane"]
    member: Name
    point: PointRef
    plane: Plane
    other: Name | None = None


class Line(SpecModel):
    point: Vec3
    direction: Direction


class OnLine(SpecModel):
    """Member point on a line: in the world, or in another member's space (``other``)."""

    type: Literal["on_line"]
    member: Name
    point: PointRef
    line: Line
    other: Name | None = None


#: a length in the spec's unit, > 0
Length = Annotated[Finite, pydantic.Field(gt=0.0, le=MAX_COORDINATE)]


class Distance(SpecModel):
    """Member point at distance ``value`` (spec unit) from a world point or another member's point."""

    type: Literal["distance"]
    member: Name
    point: PointRef
    value: Length
    world: Vec3 | None = None
    other: Name | None = None
    other_point: PointRef | None = None


class Angle(SpecModel):
    """Member axis at ``angle_deg`` (0 to 180) from a world axis or another member's axis."""

    type: Literal["angle"]
    member: Name
    axis: Direction
    angle_deg: Annotated[Finite, pydantic.Field(ge=0.0, le=180.0)]
    world: Direction | None = None
    other: Name | None = None
    other_axis: Direction | None = None


class Parallel(SpecModel):
    """Member axis parallel (either way) or perpendicular to a world axis or another member's axis."""

    type: Literal["parallel", "perpendicular"]
    member: Name
    axis: Direction
    world: Direction | None = None
    other: Name | None = None
    other_axis: Direction | None = None


class Pin(SpecModel):
    """Revolute joint = location + axis. ``axis`` is in member space (default z); the world or
    other member's axis defaults to the same line as in the rest pose."""

    type: Literal["pin", "revolute"]
    member: Name
    point: PointRef
    axis: Direction = (0.0, 0.0, 1.0)
    world: Vec3 | None = None
    world_axis: Direction | None = None
    other: Name | None = None
    other_point: PointRef | None = None
    other_axis: Direction | None = None


class Weld(SpecModel):
    """Location + orientation: the member is rigidly attached at ``point`` (orientation default:
    as in the rest pose)."""

    type: Literal["weld"]
    member: Name
    point: PointRef
    world: Vec3 | None = None
    world_orientation: Orientation | None = None
    other: Name | None = None
    other_point: PointRef | None = None
    relative: Orientation | None = None


class CustomC(SpecModel):
    """A Python residual function ``module:function(positions (k, 3), orientations (k, 4), t) ->
    residual (size,)`` on ``members``; runs only with ``--allow-python``."""

    type: Literal["custom"]
    python: Annotated[str, pydantic.StringConstraints(pattern=PYTHON_PATTERN)]
    members: list[Name] = pydantic.Field(min_length=1)
    size: Count = pydantic.Field(ge=1)


class Group(SpecModel):
    """A named set of constraints evaluated as their sum."""

    type: Literal["group"]
    constraints: dict[Name, "Constraint"] = pydantic.Field(min_length=1)


Constraint = Annotated[Union[Location, OrientationC, AxisC, OnPlane, OnLine, Distance, Angle, Parallel, Pin, Weld,
                             CustomC, Group],
                       pydantic.Field(discriminator="type")]
Group.model_rebuild()


class _InputBase(SpecModel):
    window: Window = (0.0, 1.0)
    #: keyframe times (inside the window, increasing); default: evenly spread over the window
    times: list[Finite] | None = None


class LocationInput(_InputBase):
    """A member point following keyframes: world points, or points in ``other``'s space."""

    type: Literal["location"]
    member: Name
    point: PointRef
    other: Name | None = None
    keyframes: list[Point3] = pydantic.Field(min_length=1)


class Rotation(SpecModel):
    """A turn about ``axis`` (world, or ``other``'s space) through ``angles_deg`` (linear in time;
    0 → 360 is one full turn), applied to ``base`` (default: the rest orientation)."""

    axis: Direction
    angles_deg: list[Finite] = pydantic.Field(min_length=1)
    base: Orientation | None = None


class OrientationInput(_InputBase):
    """Member orientation following keyframes (slerp) or a ``rotation``; relative to ``other``
    when given (keyframes are then the member's orientation in the other's frame)."""

    type: Literal["orientation"]
    member: Name
    other: Name | None = None
    keyframes: list[Orientation] | None = None
    rotation: Rotation | None = None


class AxisInput(_InputBase):
    """Member axis following direction keyframes (great-circle interpolation)."""

    type: Literal["axis"]
    member: Name
    axis: Direction
    other: Name | None = None
    keyframes: list[Direction] = pydantic.Field(min_length=1)


class DistanceInput(_InputBase):
    """A linear actuator: the distance from a member point to a world point or another member's
    point follows length keyframes (linear)."""

    type: Literal["distance"]
    member: Name
    point: PointRef
    world: Vec3 | None = None
    other: Name | None = None
    other_point: PointRef | None = None
    keyframes: list[Length] = pydantic.Field(min_length=1)


Input = Annotated[Union[LocationInput, OrientationInput, AxisInput, DistanceInput],
                  pydantic.Field(discriminator="type")]


#: the fixed frame in a joint's ``members``
WORLD = "world"


class _Joint(SpecModel):
    """A joint between ``members`` [m1, m2] (``world`` for the fixed frame), placed as in a
    drawing: ``at`` is a world point of the rest pose where the joint sits."""

    members: tuple[Name, Name]
    at: Point3


class RevoluteJoint(_Joint):
    """Turning about ``axis`` (world direction at rest) through ``at``: point + axis."""

    type: Literal["revolute"]
    axis: Direction


class PrismaticJoint(_Joint):
    """Sliding along ``axis`` through ``at``, no turning: line + orientation."""

    type: Literal["prismatic"]
    axis: Direction


class CylindricalJoint(_Joint):
    """Turning about and sliding along ``axis`` through ``at``: line + axis."""

    type: Literal["cylindrical"]
    axis: Direction


class UniversalJoint(_Joint):
    """A cross at ``at``: m1 turns about ``axes[0]``, m2 about ``axes[1]`` (world directions at
    rest), kept perpendicular: point + perpendicular."""

    type: Literal["universal"]
    axes: tuple[Direction, Direction]


class SphericalJoint(_Joint):
    """A ball at ``at``: point."""

    type: Literal["spherical"]


class PlanarJoint(_Joint):
    """m1 slides and turns on the plane through ``at`` with ``normal``: plane + axis."""

    type: Literal["planar"]
    normal: Direction


#: the constraints each joint type expands to, named ``joint.part``
JOINT_PARTS = {"revolute": ("point", "axis"), "prismatic": ("line", "orientation"), "cylindrical": ("line", "axis"),
               "universal": ("point", "perpendicular"), "spherical": ("point",), "planar": ("plane", "axis")}

Joint = Annotated[Union[RevoluteJoint, PrismaticJoint, CylindricalJoint, UniversalJoint, SphericalJoint,
                        PlanarJoint], pydantic.Field(discriminator="type")]


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
