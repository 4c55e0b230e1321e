"""Compile a :class:`~linkedit.spec.mechanism3d.MechanismSpec` into a :class:`System`.

Members keep their spec order. Each named constraint (and each input) becomes one or more
elementary constraints owned by its name: pin = location + axis, weld = location +
orientation, a group = all its parts under the group's name; perpendicular = an angle of 90°,
an angle of 0° or 180° = an axis constraint (aligned or opposite). Each joint becomes named
constraints ``joint.part`` (:data:`~linkedit.spec.joints3d.JOINT_PARTS`), its world
placement turned into each member's space at rest (the world always second). Defaults that
refer to "the rest pose" (a weld's relative orientation, a pin's other axis, a rotation
input's base) are taken from the members' spec positions and orientations.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from linkedit.errors import InputError
from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule, half_turn_keyframe
from linkedit.gcs.kernels import Custom
from linkedit.gcs.system import WORLD, Elementary, State, System
from linkedit.spec import constraints3d as sc
from linkedit.spec import geometry3d as sg
from linkedit.spec import inputs3d as si
from linkedit.spec import joints3d as sj
from linkedit.spec import mechanism3d as ms


@dataclass(frozen=True)
class TrackDef:
    """A tracked point: member index and member-space point (3,)."""

    name: str
    member: int
    point: np.ndarray


def orientation_quaternion(o: Any) -> np.ndarray:
    """A spec orientation ([w, x, y, z] or axis + angle_deg) as a unit quaternion (4,)."""
    if isinstance(o, sg.AxisAngle):
        axis = np.asarray(o.axis, dtype=float)
        return quat.from_axis_angle(axis / np.linalg.norm(axis), np.radians(o.angle_deg))
    q = np.asarray(o, dtype=float)
    return q / np.linalg.norm(q)


def _unit(v: Any) -> tuple[float, float, float]:
    a = np.asarray(v, dtype=float)
    return tuple(a / np.linalg.norm(a))


class _Builder:
    def __init__(self, spec: ms.MechanismSpec, allow_python: bool) -> None:
        self.spec = spec
        self.allow_python = allow_python
        self.index = {n: i for i, n in enumerate(spec.members)}
        self.P0 = np.array([m.position for m in spec.members.values()], dtype=float).reshape(-1, 3)
        self.Q0 = np.array([orientation_quaternion(m.orientation) for m in spec.members.values()]).reshape(-1, 4)
        self.R0 = quat.to_matrix(self.Q0)
        self.names: list[str] = []
        self.is_input: list[bool] = []
        self.elems: list[Elementary] = []
        self.customs: list[Custom] = []

    def point(self, member: str, ref: Any) -> tuple[float, float, float]:
        if isinstance(ref, str):
            return _vec3(self.spec.member_points(member)[ref])
        return _vec3(ref)

    def rest_relative(self, member: str, other: str) -> np.ndarray:
        """The member's rest orientation in the other's frame: q_other⁻¹ ⊗ q_member."""
        return quat.multiply(quat.conjugate(self.Q0[self.index[other]]), self.Q0[self.index[member]])

    def axis_target(self, member: str, axis: tuple, other: str | None, given: Any) -> tuple[float, float, float]:
        """A pin's world / other axis: as given, else the member axis's line at rest."""
        if given is not None:
            return _unit(given)
        world = self.R0[self.index[member]] @ np.asarray(axis)
        if other is None:
            return tuple(world)
        return tuple(self.R0[self.index[other]].T @ world)

    def owner(self, name: str, is_input: bool = False) -> int:
        self.names.append(name)
        self.is_input.append(is_input)
        return len(self.names) - 1

    def add(self, kind: str, owner: int, member: str, other: str | None, **params: Any) -> None:
        b = WORLD if other is None else self.index[other]
        self.elems.append(Elementary(kind=kind, owner=owner, a=self.index[member], b=b, **params))

    def constraint(self, c: Any, owner: int) -> None:
        if isinstance(c, sc.Group):
            for sub in c.constraints.values():
                self.constraint(sub, owner)
            return
        if isinstance(c, sc.CustomC):
            if not self.allow_python:
                raise InputError("a custom constraint runs Python code: pass --allow-python to allow it",
                                 field=("constraints", self.names[owner], "python"))
            fn = sc.load_function(c.python, ("constraints", self.names[owner], "python"))
            self.customs.append(Custom(owner=owner, members=tuple(self.index[m] for m in c.members),
                                       fn=fn, size=c.size))
            return
        other = c.other
        if isinstance(c, (sc.Location, sc.Pin, sc.Weld)):
            sb = c.world if other is None else self.point(other, c.other_point)
            self.add("location", owner, c.member, other, sa=self.point(c.member, c.point), sb=_vec3(sb))
        if isinstance(c, sc.Pin):
            axis = _unit(c.axis)
            target = self.axis_target(c.member, axis, other, c.world_axis if other is None else c.other_axis)
            self.add("axis", owner, c.member, other, sa=axis, sb=target)
        if isinstance(c, (sc.OrientationC, sc.Weld)):
            world = c.world if isinstance(c, sc.OrientationC) else c.world_orientation
            given = world if other is None else c.relative
            if given is not None:
                rel = orientation_quaternion(given)
            elif other is None:
                rel = self.Q0[self.index[c.member]]
            else:
                rel = self.rest_relative(c.member, other)
            self.add("orientation", owner, c.member, other, rel=tuple(rel))
        if isinstance(c, sc.AxisC):
            self.add("axis", owner, c.member, other, sa=_unit(c.axis),
                     sb=_unit(c.world if other is None else c.other_axis))
        if isinstance(c, sc.OnPlane):
            self.add("plane", owner, c.member, other, sa=self.point(c.member, c.point),
                     sb=tuple(float(x) for x in c.plane.point), nb=_unit(c.plane.normal))
        if isinstance(c, sc.OnLine):
            self.add("line", owner, c.member, other, sa=self.point(c.member, c.point),
                     sb=tuple(float(x) for x in c.line.point), nb=_unit(c.line.direction))
        if isinstance(c, sc.Distance):
            sb = c.world if other is None else self.point(other, c.other_point)
            self.add("distance", owner, c.member, other, sa=self.point(c.member, c.point), sb=_vec3(sb),
                     value=float(c.value))
        if isinstance(c, (sc.Angle, sc.Parallel)):
            sa, sb = _unit(c.axis), _unit(c.world if other is None else c.other_axis)
            degrees = 90.0 if c.type == "perpendicular" else getattr(c, "angle_deg", None)
            if degrees is None:
                self.add("parallel", owner, c.member, other, sa=sa, sb=sb)
            elif degrees in (0.0, 180.0):
                self.add("axis", owner, c.member, other, sa=sa, sb=sb if degrees == 0.0 else tuple(-x for x in sb))
            else:
                self.add("angle", owner, c.member, other, sa=sa, sb=sb, value=float(np.radians(degrees)))

    def joint(self, name: str, j: Any) -> None:
        """The named constraints ``name.part`` of a joint placed in the world at rest."""
        m1, m2 = j.members
        axes = tuple(getattr(j, "axes", ()))
        if m1 == sj.WORLD:
            m1, m2, axes = m2, m1, axes[::-1]
        other = None if m2 == sj.WORLD else m2

        def point(member: str | None) -> tuple[float, float, float]:
            if member is None:
                return _vec3(j.at)
            i = self.index[member]
            return tuple(self.R0[i].T @ (np.asarray(j.at, dtype=float) - self.P0[i]))

        def direction(member: str | None, v: Any) -> tuple[float, float, float]:
            return _unit(v) if member is None else tuple(self.R0[self.index[member]].T @ np.asarray(_unit(v)))

        def part(suffix: str, kind: str, **params: Any) -> None:
            self.add(kind, self.owner(f"{name}.{suffix}"), m1, other, **params)

        kind = j.type
        if kind in ("revolute", "universal", "spherical"):
            part("point", "location", sa=point(m1), sb=point(other))
        if kind in ("prismatic", "cylindrical"):
            part("line", "line", sa=point(m1), sb=point(other), nb=direction(other, j.axis))
        if kind == "planar":
            part("plane", "plane", sa=point(m1), sb=point(other), nb=direction(other, j.normal))
        if kind in ("revolute", "cylindrical", "planar"):
            v = j.normal if kind == "planar" else j.axis
            part("axis", "axis", sa=direction(m1, v), sb=direction(other, v))
        if kind == "prismatic":
            rel = self.Q0[self.index[m1]] if other is None else self.rest_relative(m1, other)
            part("orientation", "orientation", rel=tuple(rel))
        if kind == "universal":
            part("perpendicular", "angle", sa=direction(m1, axes[0]), sb=direction(other, axes[1]),
                 value=0.5 * np.pi)

    def input(self, inp: Any, owner: int) -> None:
        name = self.names[owner]
        t0, t1 = inp.window
        other = inp.other
        if isinstance(inp, si.OrientationInput) and inp.rotation is not None:
            rot = inp.rotation
            if rot.base is not None:
                base = orientation_quaternion(rot.base)
            elif other is None:
                base = self.Q0[self.index[inp.member]]
            else:
                base = self.rest_relative(inp.member, other)
            values = np.radians(np.asarray(rot.angles_deg, dtype=float))
            sched = dict(mode="rotation", values=values, axis=np.asarray(_unit(rot.axis)), base=base)
            count = len(values)
        elif isinstance(inp, si.OrientationInput) and inp.keyframes is not None:
            values = np.array([orientation_quaternion(o) for o in inp.keyframes])
            sched = dict(mode="orientation", values=values)
            count = len(values)
        elif isinstance(inp, si.AxisInput):
            values = np.array([_unit(v) for v in inp.keyframes])
            sched = dict(mode="direction", values=values)
            count = len(values)
        elif isinstance(inp, si.DistanceInput):
            values = np.asarray(inp.keyframes, dtype=float)[:, None]
            sched = dict(mode="scalar", values=values)
            count = len(values)
        else:
            values = np.asarray(inp.keyframes, dtype=float)
            sched = dict(mode="vector", values=values)
            count = len(values)
        k = half_turn_keyframe(sched["mode"], values)
        if k is not None:
            raise InputError(f"keyframes {k} and {k + 1} are half a turn apart: the direction of turning is "
                             "undefined; add a keyframe between them", field=("inputs", name, "keyframes", k + 1))
        times = np.asarray(inp.times, dtype=float) if inp.times is not None else (
            np.linspace(t0, t1, count) if count > 1 else np.array([t0]))
        schedule = Schedule(window=(t0, t1), times=times, **sched)
        first = schedule.evaluate(np.array([t0]))[0]
        if isinstance(inp, si.OrientationInput):
            self.add("orientation", owner, inp.member, other, rel=tuple(first), schedule=schedule)
        elif isinstance(inp, si.AxisInput):
            self.add("axis", owner, inp.member, other, sa=_unit(inp.axis), sb=tuple(first), schedule=schedule)
        elif isinstance(inp, si.DistanceInput):
            sb = inp.world if other is None else self.point(other, inp.other_point)
            self.add("distance", owner, inp.member, other, sa=self.point(inp.member, inp.point), sb=_vec3(sb),
                     value=float(first[0]), schedule=schedule)
        else:
            self.add("location", owner, inp.member, other, sa=self.point(inp.member, inp.point),
                     sb=tuple(first), schedule=schedule)


def compile_mechanism(spec: ms.MechanismSpec, allow_python: bool = False) -> tuple[System, list[TrackDef]]:
    """The compiled system and the tracked points of a spec."""
    b = _Builder(spec, allow_python)
    for name, c in spec.constraints.items():
        b.constraint(c, b.owner(name))
    for name, j in spec.joints.items():
        b.joint(name, j)
    for name, inp in spec.inputs.items():
        b.input(inp, b.owner(name, is_input=True))
    points = {m: {p: np.asarray(v, dtype=float) for p, v in spec.member_points(m).items()} for m in spec.members}
    system = System.build(list(spec.members), State(b.P0, b.Q0), b.names, b.elems, b.customs,
                          constraint_inputs=b.is_input, points=points,
                          lines={m: spec.member_lines(m) for m in spec.members})
    tracks = [TrackDef(name, b.index[tr.member], np.asarray(b.point(tr.member, tr.point)))
              for name, tr in spec.outputs.tracks.items()]
    return system, tracks


def _vec3(v: Iterable[float] | None) -> tuple[float, float, float]:
    """Three floats from a 3-vector of the spec (which validation guarantees is given here)."""
    if v is None:
        raise ValueError("a 3-vector the spec requires is missing")
    x, y, z = (float(c) for c in v)
    return (x, y, z)
