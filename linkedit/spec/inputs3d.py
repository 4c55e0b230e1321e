"""The inputs of a 3D mechanism spec: member points, orientations, axes and distances following
keyframes interpolated over a time window."""

from __future__ import annotations

from typing import Annotated, Literal, Union

import pydantic

from linkedit.spec.common import Finite, Name, SpecModel, Vec3
from linkedit.spec.geometry3d import Direction, Length, Orientation, Point3, PointRef, Window


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


#: Largest rotation input angle, degrees (1,000 turns, like a planar stroke's 1,000 sizes): the solver follows
#: every turn (36,000° takes ~10 s), and 1e300° is no angle a double can step through.
MAX_ANGLE_DEG = 360_000.0
Angle = Annotated[Finite, pydantic.Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG)]


class Rotation(SpecModel):
    """A turn about ``axis`` (world, or ``other``'s space) through ``angles_deg`` (linear in time;
    0 → 360 is one full turn), applied to ``base`` (default: the rest orientation)."""

    axis: Direction
    angles_deg: list[Angle] = pydantic.Field(min_length=1)
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
