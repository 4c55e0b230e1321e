"""The rules of :mod:`linkedit.gcs.closed_form`: how each member is rebuilt from placed ones
(driven, hinged, dyad, cone, slider, swing, reach, spun; their docstrings), the constraint ends they read and a
member's arm across its axis."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: two placed axes are along one line where their cross product is at most this (radians), and
#: a dyad's two placed joints lie in one plane across it within this fraction of its arms
PARALLEL = 1e-9


@dataclass(frozen=True)
class End:
    """A constraint of a block seen from ``member``: its index in the block, whether the member
    is the constraint's side a (its vector ``sa``; else ``sb``), and the other member (M: the
    world)."""

    index: int
    side_a: bool
    other: int


@dataclass(frozen=True)
class Arm:
    """A member's arm from one of its points to another, across its axis (in its space): the
    unit axis (3,), the offset along it, the part across it (3,) and that part's length, and
    the member's frame — the axis, the arm across it and their cross product — as rows (3, 3)."""

    axis: np.ndarray
    height: float
    across: np.ndarray
    length: float
    frame: np.ndarray

    @classmethod
    def of(cls, axis: np.ndarray, start: np.ndarray, end: np.ndarray) -> "Arm":
        a = axis / np.sqrt(axis @ axis)
        arm = end - start
        height = float(arm @ a)
        across = arm - height * a
        length = float(np.sqrt(across @ across))
        p = across / length if length > 0.0 else across
        return cls(a, height, across, length, np.stack([a, p, np.cross(a, p)]))


@dataclass(frozen=True)
class Driven:
    """``member`` oriented by the orientation constraint ``turn`` and pinned by the location
    constraint ``pin`` to placed members."""

    member: int
    turn: End
    pin: End


@dataclass(frozen=True)
class Hinged:
    """``member`` pinned by the location constraints ``pins`` to placed members and aligned by
    the axis constraint ``axis`` with a placed member's axis; its ``arm`` from the first pin to
    the second."""

    member: int
    pins: tuple[End, End]
    axis: End
    arm: Arm


@dataclass(frozen=True)
class Dyad:
    """Members u and w, each pinned to a placed member (``pins``) and aligned with a placed
    member's axis (``axes``), and pinned to each other by ``joint`` (seen from u); their
    ``arms`` from their pins to the common joint."""

    members: tuple[int, int]
    pins: tuple[End, End]
    axes: tuple[End, End]
    joint: End
    arms: tuple[Arm, Arm]


@dataclass(frozen=True)
class Cone:
    """Members u and w, each pinned to a placed member (``pins``) and aligned with a placed
    member's axis (``axes``), and pinned to each other (``joint``, seen from u) at their points
    of those pins, their axes of ``hinge`` (seen from u) aligned: a spherical dyad. Each
    member's ``arms`` (:class:`Arm`) from its placed axis to its hinge axis (unit: the height is
    the cosine of the angle between them)."""

    members: tuple[int, int]
    pins: tuple[End, End]
    axes: tuple[End, End]
    joint: End
    hinge: End
    arms: tuple[Arm, Arm]


@dataclass(frozen=True)
class Slider:
    """Member u (a rod) pinned by ``pin`` to a placed member and aligned by ``axis`` with a
    placed member's axis, and member w (a slider) oriented by the orientation constraint
    ``turn`` from a placed member with its point of the line constraint ``line`` on a placed
    member's line, pinned to each other by ``joint`` (seen from u); the rod's ``arm`` from its
    pin to the joint, and the slider's ``offset`` (3,) from its point on the line to the joint
    (in its space)."""

    members: tuple[int, int]
    pin: End
    axis: End
    turn: End
    line: End
    joint: End
    arm: Arm
    offset: np.ndarray


@dataclass(frozen=True)
class Swing:
    """``member`` pinned by ``pin`` to a placed member and aligned by ``axis`` with a placed
    member's axis (a rocker), its point of ``joint`` (seen from it) a ball joint of a link:
    a member held by that and by ``far`` (seen from the link) alone, at its points ``length``
    apart, to a placed point (the link is :class:`Spun`, placed next); the member's ``arm`` from
    its pin to the joint."""

    member: int
    pin: End
    axis: End
    arm: Arm
    joint: End
    far: End
    length: float


@dataclass(frozen=True)
class Reach:
    """``member`` oriented by ``turn`` from a placed member, its point of ``guide`` on a placed
    member's line (one line constraint, or two plane constraints at that point: ``kind``) (a
    slider), and its point of ``joint`` a link's ball joint as :class:`Swing`'s (``far``,
    ``length``); its ``offset`` (3,) from its point on the line to the joint (in its space)."""

    member: int
    turn: End
    guide: tuple[End, ...]
    kind: str
    joint: End
    far: End
    length: float
    offset: np.ndarray


@dataclass(frozen=True)
class Spun:
    """``member`` held only by the location constraints ``pins`` at two of its points apart to
    placed members (a link with ball joints at both ends): free to spin about the line through
    them (a passive degree of freedom), placed at the spin nearest the rest pose in the scaled
    metric (the canonical pose of :mod:`linkedit.gcs.canonical`)."""

    member: int
    pins: tuple[End, End]


Rule = Driven | Hinged | Dyad | Cone | Slider | Swing | Reach | Spun
#: the rules placing two members, each on a side (:meth:`ClosedForm.signs`)
SIDED = (Dyad, Cone, Slider)
