"""Simulate a planar linkage over a motor cycle: the library's main entry point.

``simulate(spec_or_plan, samples)`` returns a :class:`Motion` with positions, velocities and
accelerations of every joint and track (derivatives with respect to the motor angle), and the
per-sample diagnostics. It raises :class:`MechanismError` when the linkage locks up anywhere,
unless ``partial=True``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.diagnostics import LockUp, lockups, transmission_angle, triangle_orientation
from linkedit.planar.kinematics import evaluate
from linkedit.planar.plan import Geometry, Plan, compile_plan
from linkedit.spec.linkage import LinkageSpec, Motor

DEFAULT_SAMPLES = 360


@dataclass(frozen=True)
class Track:
    """Motion of one tracked point: (T, 2) arrays; derivatives per radian of motor angle."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


@dataclass
class Motion:
    """A simulated cycle. T samples, J joints, R rules (see ``plan.rules``)."""

    plan: Plan
    t: np.ndarray  #: (T,) motor phase: fraction of a revolution, or of the sweep for ``range_deg``
    motor_angle: np.ndarray  #: (T,) absolute motor (crank) angle, radians
    positions: np.ndarray  #: (T, J, 2)
    velocity: np.ndarray  #: (T, J, 2) d position / d motor angle
    acceleration: np.ndarray  #: (T, J, 2)
    tracks: dict[str, Track]
    singularity: np.ndarray  #: (T, R) d_s = sin²α per rule; 1 for rigid rules
    orientation: np.ndarray  #: (T, R) int8 orientation sign of each rule's triangle
    transmission: np.ndarray  #: (T, R) angle at the rebuilt joint, radians
    assembled: np.ndarray  #: (T,) bool
    lockups: list[LockUp] = field(default_factory=list)

    @property
    def cyclic(self) -> bool:
        return self.plan.spec.motor.range_deg is None

    def min_singularity(self) -> tuple[float, str, float] | None:
        """(min d_s over dyad rules and assembled samples, its joint, motor angle in degrees)."""
        dyads = ~self.plan.rigid
        if not dyads.any() or not self.assembled.any():
            return None
        ds = np.where(self.assembled[:, None], self.singularity, np.inf)[:, dyads]
        t, r = np.unravel_index(np.argmin(ds), ds.shape)
        rule = np.flatnonzero(dyads)[r]
        return float(ds[t, r]), self.plan.joint_names[self.plan.rules[rule, 2]], float(np.degrees(self.motor_angle[t]))

    def summary(self) -> dict:
        """Key figures for printing or JSON."""
        out: dict = {
            "name": self.plan.spec.name, "samples": int(self.t.size), "joints": self.plan.n_joints,
            "rules": int(len(self.plan.rules)), "levels": int(self.plan.level.max(initial=0)),
            "mobility": self.plan.mobility.rank, "assembled": bool(self.assembled.all()),
        }
        worst = self.min_singularity()
        if worst:
            out["min_singularity"] = {"value": worst[0], "joint": worst[1], "motor_angle_deg": worst[2]}
            dyads = ~self.plan.rigid
            dev = np.abs(np.where(self.assembled[:, None], self.transmission, np.pi / 2)[:, dyads] - np.pi / 2)
            out["worst_transmission_angle_deg"] = float(90.0 - np.degrees(dev.max()))
        if self.lockups:
            out["lockups"] = [lk.describe() for lk in self.lockups]
        return out


def motor_phases(spec: LinkageSpec, samples: int) -> np.ndarray:
    """Phases t (T,): a full revolution samples t = n/T (the end is the start); a
    ``range_deg`` sweep includes both of its ends."""
    if spec.motor.range_deg is None:
        return np.arange(samples) / samples
    return np.linspace(0.0, 1.0, samples) if samples > 1 else np.zeros(1)


def motor_turn(motor: Motor, t: np.ndarray) -> np.ndarray:
    """Motor rotation from the rest pose at phases ``t`` (T,), radians (signed by direction).

    The one time axis of linkedit: phase 0 of a full revolution is the rest pose.
    """
    sign = 1.0 if motor.direction == "ccw" else -1.0
    if motor.range_deg is None:
        return sign * 2.0 * np.pi * t
    a, b = np.radians(motor.range_deg)
    return sign * (a + (b - a) * t)


def motor_angles(spec: LinkageSpec, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Phases t (T,) and absolute motor angles (T,) in radians for ``samples`` samples."""
    rest = np.arctan2(*(np.subtract(spec.joints[spec.motor.joint], spec.joints[spec.motor.pivot])[::-1]))
    t = motor_phases(spec, samples)
    return t, rest + motor_turn(spec.motor, t)


def _joint_order(plan: Plan, z: np.ndarray) -> np.ndarray:
    """Internal complex rows (P, T) → joint positions (T, J, 2)."""
    zj = z[plan.row_of[: plan.n_joints]].T
    return np.stack([zj.real, zj.imag], axis=-1)


def _check_link_lengths(plan: Plan, p: np.ndarray, ok: np.ndarray, angle: np.ndarray) -> None:
    """Every joint pair on a link must keep its rest distance; only redundant (over-constrained)
    pairs can fail here, and then the linkage cannot move as specified."""
    pairs = plan.pairs
    rest = np.linalg.norm(plan.graph.rest[pairs[:, 0]] - plan.graph.rest[pairs[:, 1]], axis=-1)
    now = np.linalg.norm(p[ok][:, pairs[:, 0]] - p[ok][:, pairs[:, 1]], axis=-1)
    err = np.abs(now - rest)
    scale = np.abs(plan.graph.rest).max()
    if err.size and err.max() > 1e-7 * scale:
        t, q = np.unravel_index(np.argmax(err), err.shape)
        a, b = (plan.joint_names[x] for x in pairs[q])
        raise MechanismError(
            f"joints {a} and {b} cannot keep their distance at motor angle {np.degrees(angle[ok][t]):.1f}° "
            f"(off by {err[t, q]:.3g}): the linkage is over-constrained ({plan.mobility.describe()})")


def simulate(linkage: LinkageSpec | Plan, samples: int | None = None, *, partial: bool = False,
             geometry: Geometry | None = None) -> Motion:
    """Simulate one motor cycle with ``samples`` samples (default: the spec's, else 360).

    With ``partial=True`` a linkage that locks up somewhere is still returned; its positions
    are NaN where ``assembled`` is False and ``lockups`` says where and why.
    """
    plan = linkage if isinstance(linkage, Plan) else compile_plan(linkage)
    spec = plan.spec
    samples = samples or spec.samples or DEFAULT_SAMPLES
    t, angle = motor_angles(spec, samples)
    geom = geometry or plan.geometry()
    state = evaluate(plan, geom, angle, order=2)

    p = _joint_order(plan, state.z)
    rules = plan.rules
    ds = state.ds.T.copy()
    ok = np.isfinite(p).all(axis=(1, 2)) & (ds >= 0.0).all(axis=1)
    found: list[LockUp] = []
    if not ok.all():
        d = np.linalg.norm(p[:, rules[:, 1]] - p[:, rules[:, 0]], axis=-1) if len(rules) else np.zeros((samples, 0))
        rest = plan.graph.rest
        lik = np.linalg.norm(rest[rules[:, 2]] - rest[rules[:, 0]], axis=-1)
        ljk = np.linalg.norm(rest[rules[:, 2]] - rest[rules[:, 1]], axis=-1)
        found = lockups(ds, d, lik, ljk, rules, np.degrees(angle), plan.joint_names, cyclic=spec.motor.range_deg is None)
        if not partial or not ok.any():
            raise MechanismError(f"{spec.name}: " + "; ".join(lk.describe() for lk in found))
    _check_link_lengths(plan, p, ok, angle)

    def rows(a: np.ndarray) -> np.ndarray:
        return _joint_order(plan, a)

    v, acc = rows(state.dz), rows(state.ddz)
    bad = ~ok
    for arr in (p, v, acc):
        arr[bad] = np.nan
    tracks = {}
    for name, point in zip(plan.track_names, plan.track_points):
        r = plan.row_of[point]

        def xy(a: np.ndarray) -> np.ndarray:
            out = np.stack([a[r].real, a[r].imag], axis=-1)
            out[bad] = np.nan
            return out

        tracks[name] = Track(position=xy(state.z), velocity=xy(state.dz), acceleration=xy(state.ddz))
    with np.errstate(invalid="ignore"):
        transmission = transmission_angle(p, rules)
        orientation = triangle_orientation(p, rules)
    return Motion(plan=plan, t=t, motor_angle=angle, positions=p, velocity=v, acceleration=acc,
                  tracks=tracks, singularity=np.where(ok[:, None], ds, np.nan), orientation=orientation,
                  transmission=transmission, assembled=ok, lockups=found)
