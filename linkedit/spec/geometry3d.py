"""The 3D spec's geometric field types: quaternions, directions, member points, coordinates and
lengths (bounded so their squares do not overflow), and axis–angle orientations."""

from __future__ import annotations

import math
from typing import Annotated, Union

import pydantic

from linkedit.spec.common import Finite, Name, SpecModel, Vec3


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
#: a length in the spec's unit, > 0
Length = Annotated[Finite, pydantic.Field(gt=0.0, le=MAX_COORDINATE)]


class AxisAngle(SpecModel):
    """A rotation by ``angle_deg`` degrees about ``axis``."""

    axis: Direction
    angle_deg: Finite


Orientation = Union[Quaternion, AxisAngle]
