"""The joints of a 3D mechanism spec, placed in the world as in a drawing: revolute, prismatic,
cylindrical, universal, spherical and planar; each expands to named constraints (:data:`JOINT_PARTS`)."""

from __future__ import annotations

from typing import Annotated, Literal, Union

import pydantic

from linkedit.spec.common import Name, SpecModel
from linkedit.spec.geometry3d import Direction, Point3


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
