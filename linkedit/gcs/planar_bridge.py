"""Planar linkages through the 3D solver: the "numeric kinematics" engine.

Each link becomes a member (origin at its first joint, identity orientation, its joints as
shape points at z = 0). A joint shared by links becomes pins (location + axis z) from the
first link holding it to each other one; a ground joint pins every link holding it to the
world. A pin in a slot is a ``line`` constraint (the joint on the line of its guide: a link's
member or the world), a translating link a ``line`` for its first joint and an ``orientation``
against its guide (it does not turn relative to it). The motor is an orientation input on the
crank: a turn about z from the rest pose, one revolution over t ∈ [0, 1) (or the spec's
``range_deg`` sweep); a linear input is a ``plane`` input: the driven joint on the plane across
its slot at the stroke s(t) from its rest position. Each step is solved from the previous ones
(:func:`linkedit.gcs.solve.solve_run`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from linkedit.errors import MechanismError
from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule
from linkedit.gcs.solve import Run, solve_run
from linkedit.gcs.structure import StructureCache
from linkedit.gcs.tolerances import CONVERGED, STATUS_NAMES, Options
from linkedit.gcs.system import WORLD, Elementary, State, System
from linkedit.gcs.outputs import velocity
from linkedit.planar.diagnostics import transmission_angle, triangle_orientation
from linkedit.planar.simulate import DEFAULT_SAMPLES, Motion, Track, motor_angles, motor_input
from linkedit.spec.linkage import JointTrack, LinkageSpec

if TYPE_CHECKING:
    from linkedit.planar import Plan


@dataclass(frozen=True)
class PlanarModel:
    """A linkage as a 3D system: where each joint is read from (member and member point)."""

    system: System
    joint_names: list[str]
    joint_member: np.ndarray  #: (J,) member carrying each joint, −1 for a ground joint
    joint_point: np.ndarray  #: (J, 3) member-space point (world point for ground joints)
    motor_rest_angle: float  #: radians (0 for a linear input)
    track_names: list[str]
    track_member: np.ndarray  #: (K,) member carrying each tracked point, −1 on the ground
    track_point: np.ndarray  #: (K, 3)
    #: what the waves compile for the system, kept for the model's later runs
    cache: StructureCache = field(init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "cache", StructureCache(self.system))


@dataclass
class NumericMotion:
    """Joint positions over the motor cycle and the solver's per-step diagnostics."""

    t: np.ndarray  #: (T,) motor phase
    motor_angle: np.ndarray  #: (T,) absolute motor angle, radians
    positions: np.ndarray  #: (T, J, 2)
    tracks: np.ndarray  #: (T, K, 2) tracked points in spec order
    out_of_plane: np.ndarray  #: (T,) largest |z| of any joint (0 for a consistent solve)
    status: np.ndarray  #: (T,) 0 converged, 1 inconsistent, 2 did not converge
    residual: np.ndarray  #: (T,) residual norm
    iterations: np.ndarray  #: (T,) linear solves per step
    factorizations: np.ndarray  #: (T,)
    seconds: float  #: wall time of the solve loop
    run: Run

    @property
    def ms_per_step(self) -> float:
        return 1e3 * self.seconds / max(self.t.size, 1)


#: what the 3D system of a planar linkage does not model yet
UNSUPPORTED = "oscillating inputs"


def supported(spec: LinkageSpec) -> bool:
    """Whether :func:`planar_model` models the linkage (no :data:`UNSUPPORTED`)."""
    return spec.motor.oscillate_deg is None


def planar_model(spec: LinkageSpec) -> PlanarModel:
    """Build the 3D system of a planar linkage (see module docstring); ValueError for what it
    does not model (:data:`UNSUPPORTED`)."""
    if not supported(spec):
        raise ValueError(f"the 3D system of a planar linkage has no {UNSUPPORTED} yet")
    joints = list(spec.joints)
    jindex = {n: i for i, n in enumerate(joints)}
    rest = np.array([spec.joints[n] for n in joints], dtype=float)
    ground = set(spec.ground)
    links = [(name, members) for name, members in spec.links.items() if not all(j in ground for j in members)]
    names = [name for name, _ in links]
    origin = np.array([rest[jindex[members[0]]] for _, members in links]).reshape(-1, 2)

    def local(li: int, joint: str) -> tuple[float, float, float]:
        x, y = rest[jindex[joint]] - origin[li]
        return (float(x), float(y), 0.0)

    cnames: list[str] = []
    elems: list[Elementary] = []
    z = (0.0, 0.0, 1.0)

    def pin(label: str, a: int, sa: tuple, b: int, sb: tuple) -> None:
        cnames.append(label)
        owner = len(cnames) - 1
        elems.append(Elementary("location", owner, a, b, sa=sa, sb=sb))
        elems.append(Elementary("axis", owner, a, b, sa=z, sb=z))

    holders: dict[str, list[int]] = {}
    for li, (_, members) in enumerate(links):
        for j in members:
            holders.setdefault(j, []).append(li)
    joint_member = np.full(len(joints), -1)
    joint_point = np.zeros((len(joints), 3))
    for j, held in holders.items():
        ji = jindex[j]
        if j in ground:
            joint_point[ji] = (*rest[ji], 0.0)
            for li in held:
                pin(f"pin {j} ({names[li]}–ground)", li, local(li, j), WORLD, (*rest[ji], 0.0))
        else:
            joint_member[ji] = held[0]
            joint_point[ji] = local(held[0], j)
            for li in held[1:]:
                pin(f"pin {j} ({names[held[0]]}–{names[li]})", held[0], local(held[0], j), li, local(li, j))
    for g in spec.ground:
        joint_point[jindex[g]] = (*rest[jindex[g]], 0.0)

    def member(link: str) -> int:  # the guide's member, WORLD for the frame (or a link of ground joints)
        return names.index(link) if link in names else WORLD

    def on(b: int, point: np.ndarray) -> tuple[float, float, float]:  # a world point at rest in b's space
        x, y = point - (origin[b] if b != WORLD else 0.0)
        return (float(x), float(y), 0.0)

    slots: dict[str, tuple[int, int, tuple[float, float, float], np.ndarray]] = {}
    for name, slider in spec.sliders.items():
        u = (float(np.cos(np.radians(slider.angle_deg))), float(np.sin(np.radians(slider.angle_deg))), 0.0)
        b = member(slider.guide)
        if slider.joint is not None and slider.joint not in holders:  # a ground joint in a moving slot
            # a sleeve: a block pinned at the joint, turning with the guide, its centre on the guide's line
            k = jindex[slider.joint]
            a = len(names)
            names.append(f"sleeve {name}")
            origin = np.vstack([origin, rest[k]])
            cnames.append(f"sleeve {name} ({slider.joint} on the ground)")
            elems.append(Elementary("location", len(cnames) - 1, a, WORLD, sa=(0.0, 0.0, 0.0), sb=(*rest[k], 0.0)))
            elems.append(Elementary("orientation", len(cnames) - 1, a, b))
            cnames.append(f"slider {name} ({slider.joint} in {slider.guide})")
            elems.append(Elementary("line", len(cnames) - 1, a, b, sa=(0.0, 0.0, 0.0), sb=on(b, rest[k]), nb=u))
            slots[name] = (a, b, u, rest[k])
        elif slider.joint is not None:  # a pin in a slot: the joint on the guide's line
            k = jindex[slider.joint]
            a = holders[slider.joint][0]
            cnames.append(f"slider {name} ({slider.joint} in {slider.guide})")
            elems.append(Elementary("line", len(cnames) - 1, a, b, sa=local(a, slider.joint), sb=on(b, rest[k]), nb=u))
            slots[name] = (a, b, u, rest[k])
        else:  # a translating link: its first joint on the line, no turn against the guide
            a = names.index(str(slider.link))
            first_joint = spec.links[str(slider.link)][0]
            cnames.append(f"slider {name} ({slider.link} along {slider.guide})")
            owner = len(cnames) - 1
            elems.append(Elementary("line", owner, a, b, sa=local(a, first_joint), sb=on(b, rest[jindex[first_joint]]),
                                    nb=u))
            elems.append(Elementary("orientation", owner, a, b))

    sign = 1.0 if spec.motor.direction == "ccw" else -1.0
    window_angles: tuple[float, float] = (0.0, 2.0 * np.pi)
    if spec.motor.linear:  # the driven joint on the plane across its slot at the stroke from rest
        drive = str(spec.motor.slider)
        a, b, u, at = slots[drive]
        s0, s1 = (float(v) for v in spec.motor.stroke or (0.0, 0.0))
        ends = np.array([on(b, at + s * np.asarray(u[:2])) for s in (s0, s1)])
        cnames.append(f"linear input {drive}")
        schedule = Schedule(mode="vector", window=(0.0, 1.0), times=np.array([0.0, 1.0]), values=ends)
        elems.append(Elementary("plane", len(cnames) - 1, a, b, sa=local(a, str(spec.sliders[drive].joint)),
                                sb=tuple(ends[0]), nb=u, schedule=schedule))
        arm = np.array([1.0, 0.0])  # no rest angle
    else:
        crank = next(li for li, (_, m) in enumerate(links) if spec.motor.joint in m and spec.motor.pivot in m)
        if spec.motor.range_deg is not None:
            window_angles = (float(np.radians(spec.motor.range_deg[0])), float(np.radians(spec.motor.range_deg[1])))
        cnames.append(f"motor {spec.motor.joint} about {spec.motor.pivot}")
        schedule = Schedule(mode="rotation", window=(0.0, 1.0), times=np.array([0.0, 1.0]),
                            values=sign * np.array(window_angles), axis=np.array(z), base=np.array([1.0, 0.0, 0.0, 0.0]))
        first = schedule.evaluate(np.zeros(1))[0]
        elems.append(Elementary("orientation", len(cnames) - 1, crank, WORLD, rel=tuple(first), schedule=schedule))
        arm = rest[jindex[str(spec.motor.joint)]] - rest[jindex[str(spec.motor.pivot)]]
    track_member, track_point = [], []
    for track in spec.tracks.values():
        if isinstance(track, JointTrack):
            track_member.append(joint_member[jindex[track.joint]])
            track_point.append(joint_point[jindex[track.joint]])
        elif track.link in names:
            li = names.index(track.link)
            track_member.append(li)
            track_point.append((*(np.asarray(track.at) - origin[li]), 0.0))
        else:  # a point on the ground link
            track_member.append(-1)
            track_point.append((*track.at, 0.0))
    P0 = np.column_stack([origin, np.zeros(len(origin))])
    Q0 = np.tile([1.0, 0.0, 0.0, 0.0], (len(origin), 1))
    system = System.build(names, State(P0, Q0), cnames, elems,
                          constraint_inputs=[False] * (len(cnames) - 1) + [True])
    return PlanarModel(system=system, joint_names=joints, joint_member=joint_member, joint_point=joint_point,
                       motor_rest_angle=float(np.arctan2(arm[1], arm[0])),
                       track_names=list(spec.tracks), track_member=np.array(track_member, dtype=int),
                       track_point=np.array(track_point, dtype=float).reshape(-1, 3))


def point_positions(member: np.ndarray, point: np.ndarray, position: np.ndarray,
                    orientation: np.ndarray) -> np.ndarray:
    """World positions (T, K, 3) of member points (K,), (K, 3) (member −1: a world point)."""
    T = position.shape[0]
    out = np.broadcast_to(point, (T,) + point.shape).copy()
    moving = member >= 0
    m = member[moving]
    R = quat.to_matrix(orientation[:, m])
    out[:, moving] = position[:, m] + np.einsum("tjab,jb->tja", R, point[moving])
    return out


#: largest motor rotation between two solved steps: continuation from the previous steps
#: stays on the rest pose's branch only if the steps are small (15° steps can jump branches)
MAX_STEP_DEG = 1.0
#: a linear input's largest stroke between two solved steps, in linkage sizes
MAX_STEP_LENGTH = 0.005


def refined_phases(t: np.ndarray, sweep_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Phases to solve so that no two consecutive ones are more than MAX_STEP_DEG apart.

    ``t`` (T,) increasing phases, ``sweep_deg`` motor degrees per unit of phase. Returns the
    refined phases (F,) ⊇ ``t`` and the index of each requested phase in them (T,).
    """
    if t.size < 2:
        return t, np.arange(t.size)
    gap = np.diff(t)
    parts = np.maximum(np.ceil(np.abs(gap) * sweep_deg / MAX_STEP_DEG - 1e-9), 1).astype(int)
    first = np.cumsum(parts) - parts  # index of each interval's start in the refined phases
    offset = np.arange(parts.sum()) - np.repeat(first, parts)
    fine = np.append(np.repeat(t[:-1], parts) + np.repeat(gap / parts, parts) * offset, t[-1])
    return fine, np.append(first, parts.sum())


def simulate_numeric(spec: LinkageSpec, t: np.ndarray, options: Options | None = None,
                     model: PlanarModel | None = None) -> NumericMotion:
    """Simulate a planar linkage at motor phases ``t`` (T,) with the 3D solver.

    Raises :class:`MechanismError` naming the unsatisfied constraint and the motor angle when
    the linkage cannot be assembled at some step. Between requested phases more than
    MAX_STEP_DEG apart, intermediate steps are solved (and not returned) so the continuation
    stays on the rest pose's branch.
    """
    model = model or planar_model(spec)
    t = np.asarray(t, dtype=float)
    system = model.system
    motor = spec.motor
    if motor.linear:  # MAX_STEP_LENGTH of the linkage's size a step, counted like degrees
        s0, s1 = motor.stroke or (0.0, 0.0)
        size = float(np.ptp(np.array(list(spec.joints.values()), dtype=float), axis=0).max())
        sweep = MAX_STEP_DEG * abs(s1 - s0) / (MAX_STEP_LENGTH * size)
    else:
        sweep = 360.0 if motor.range_deg is None else abs(motor.range_deg[1] - motor.range_deg[0])
    fine, keep = refined_phases(t, sweep)
    start = time.perf_counter()
    run = solve_run(system, fine, options, cache=model.cache)
    seconds = time.perf_counter() - start
    run = run.take(keep)
    value = motor_input(motor, t)  # the motor's turn from rest (radians) or the stroke (spec units)
    angle = value if motor.linear else model.motor_rest_angle + value
    bad = np.flatnonzero(run.status != CONVERGED)
    if bad.size:
        k = int(bad[0])
        costs = system.costs(run.residual[k])
        # the worst by its scaled cost (lengths over the linkage's size, angles): the same in any unit
        worst_index = int(np.argmax(system.costs(run.residual[k] * system.row_scale)))
        worst = system.constraint_names[worst_index]
        where = (f"stroke {angle[k]:.6g} {spec.units}" if motor.linear else
                 f"motor angle {np.degrees(angle[k]):.1f}°")
        raise MechanismError(
            f"{spec.name}: the linkage cannot be assembled at {where} "
            f"({STATUS_NAMES[run.status[k]]}): constraint '{worst}' is off by {np.sqrt(costs[worst_index]):.3g}")
    xyz = point_positions(model.joint_member, model.joint_point, run.position, run.orientation)
    tracks = point_positions(model.track_member, model.track_point, run.position, run.orientation)
    return NumericMotion(
        t=t, motor_angle=angle, positions=xyz[..., :2], tracks=tracks[..., :2],
        out_of_plane=np.abs(xyz[..., 2]).max(axis=1),
        status=run.status, residual=np.linalg.norm(run.residual, axis=1), iterations=run.iterations,
        factorizations=run.factorizations, seconds=seconds, run=run)


def numeric_motion(plan: "Plan", samples: int | None = None) -> "Motion":
    """A :class:`linkedit.planar.Motion` computed by the numeric engine (``simulate --engine numeric``).

    Positions come from the solver; velocities and accelerations (per radian of motor angle)
    are three-point parabola derivatives of the solved samples (wrapping around a full
    revolution), not the closed-form derivatives of the symbolic engine. The singularity
    distance, transmission angle and triangle orientation are measured on the solved positions.
    """
    spec = plan.spec
    samples = samples or spec.samples or DEFAULT_SAMPLES
    t, angle = motor_angles(spec, samples)
    nm = simulate_numeric(spec, t)
    period = plan.direction * 2.0 * np.pi if spec.motor.range_deg is None else None
    # an unwrapped angle (a range sweep includes both ends; a revolution does not repeat t = 1)
    x = np.asarray(angle, dtype=float)

    def derivatives(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        flat = p.reshape(p.shape[0], -1)
        v = velocity(x, flat, cyclic=False, period=period) if samples >= 3 else np.zeros_like(flat)
        a = velocity(x, v, cyclic=False, period=period) if samples >= 3 else np.zeros_like(flat)
        return v.reshape(p.shape), a.reshape(p.shape)

    vel, acc = derivatives(nm.positions)
    tv, ta = derivatives(nm.tracks)
    rules = plan.table.joints
    with np.errstate(invalid="ignore"):
        transmission = transmission_angle(nm.positions, rules, plan.table.rigid)
        orientation = triangle_orientation(nm.positions, rules)
    singularity = np.where(plan.table.rigid[None, :], 1.0, np.sin(transmission) ** 2)
    tracks = {name: Track(position=nm.tracks[:, i], velocity=tv[:, i], acceleration=ta[:, i])
              for i, name in enumerate(spec.tracks)}
    return Motion(plan=plan, t=t, motor_angle=angle, positions=nm.positions, velocity=vel, acceleration=acc,
                  tracks=tracks, singularity=singularity, orientation=orientation, transmission=transmission,
                  assembled=np.ones(t.size, dtype=bool))
