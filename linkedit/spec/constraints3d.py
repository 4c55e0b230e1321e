"""The constraints of a 3D mechanism spec: location, orientation, axis, on-plane, on-line, distance,
angle, parallel/perpendicular, the composites pin (revolute) and weld, groups, and custom Python
constraints (imported only when allowed)."""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import PYTHON_PATTERN, Count, Finite, Name, SpecModel, Vec3
from linkedit.spec.geometry3d import Direction, Length, Orientation, PointRef


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
