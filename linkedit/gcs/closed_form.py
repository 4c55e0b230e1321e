"""Poses in closed form: members rebuilt from members already placed, as LinkEdit rebuilds
joints from known ones.

Where a system's members can be ordered so that each is rebuilt from placed ones (the world
first) by one of five rules —

* **driven**: an orientation constraint sets the member's orientation from a placed member's
  (an input's crank) and a location constraint pins it to a placed one;
* **hinged**: location constraints pin it at two points to placed members, and an axis
  constraint aligns it with a placed member's axis: it turns about that axis (a link between
  two known joints);
* **dyad**: two members pinned to each other and each to a placed member, each aligned with a
  placed member's axis, the two axes along one line n (a revolute dyad): their common joint is
  rebuilt across the axes by the law of cosines (:func:`linkedit.planar.law_of_cosines.dyad`),
  on the side of the line between the two placed joints that it is on at a solved pose;
* **cone**: the same two members pinned to their placed members and to each other all at one
  point (a spherical dyad: every axis through that point): the common axis is where the cones
  of its angles about the two placed axes meet, on the side of the plane of the placed axes
  that it is on at a solved pose;
* **slider**: a member pinned to a placed one about a placed axis (a rod) and a member oriented
  by an orientation constraint from a placed one with a point on a placed member's line (a
  slider), pinned to each other: the slider stands where the rod's joint is at its arm from its
  pin, on the side of the foot of the perpendicular from the pin to the line that it is on at
  a solved pose (a slider-crank's rod and slider);
* **swing** / **reach**: a member turning about a placed axis (a rocker) or oriented from a
  placed member with a point on a placed line or on two placed planes (a slider), whose joint
  is a ball joint of a link (a member held by two ball joints alone, the other at a placed
  point): the joint where the rocker's circle, or the slider's line, meets the sphere of the
  link's length about the link's placed joint, on the side it is on at a solved pose;
* **spun**: such a link, between two placed ball joints: its spin about the line through them
  is free (a passive degree of freedom), and it is placed at its canonical pose (the spin
  nearest the rest pose in the solver's scaled metric, :mod:`linkedit.gcs.canonical`) by
  Newton's method on the spin angle —

every member's pose at every step follows as array code over the steps. A member's rotation
is the one taking its local axis and the perpendicular part of its local arm (from its placed
joint to its other one) onto the world axis and arm; its position puts its joint on the placed one.

:class:`linkedit.gcs.waves.Waves` takes these poses as its predictions where every member has
a rule (:meth:`ClosedForm.compile`) and they reproduce a solved pose (:meth:`ClosedForm.poses`
at it): each is then solved and put to the continuation's acceptance test as any prediction
is, so a closed form that misleads (a dyad the continuation takes through its dead point onto
the other side, a mechanism only planar at some poses) costs time, never changes a result.

The rules are found by :mod:`linkedit.gcs.closed_form_compile` (the rule types:
:mod:`linkedit.gcs.closed_form_rules`) and placed at many steps at once by
:mod:`linkedit.gcs.closed_form_place`; this module orders them into poses, a solved pose's
sides and a spun link's slope.
"""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form_compile import find_rules
from linkedit.gcs.closed_form_place import Placement
from linkedit.gcs.closed_form_rules import Cone, Driven, Dyad, Hinged, Reach, Rule, Slider, Spun, Swing
from linkedit.gcs.system import State, StepTable, System

#: the largest difference (scaled) of the closed form's pose from a solved one for its rules to
#: hold there: √tol (a pose solved to the tolerance, 1e-12, is determined to about that even at
#: a singular pose, where J does not see one direction; rules that do not hold miss by far more)
REBUILT = 1e-6


class ClosedForm:
    """The rules placing every member of a system in order (module docstring)."""

    def __init__(self, system: System, rules: list[Rule]) -> None:
        self.system = system
        self.rules = rules
        self.place = Placement(system)
        #: whether a link spins freely (:class:`Spun`): its pose is the canonical one
        self.spins = any(isinstance(rule, Spun) for rule in rules)

    @classmethod
    def compile(cls, system: System) -> "ClosedForm | None":
        """The rules in placing order (:func:`linkedit.gcs.closed_form_compile.find_rules`), or
        None where some member has none (or the system has custom constraints)."""
        rules = find_rules(system)
        return None if rules is None else cls(system, rules)

    def poses(self, table: StepTable, steps: np.ndarray, anchor: np.ndarray, signs: list[float],
              rest: State | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (B, M, 3), quaternions (B, M, 4) (each of the sign nearest the step
        before it, the first nearest the quaternions ``anchor`` (M, 4)) and whether each pose
        could be rebuilt (B,), at the table's ``steps`` (B,), the dyads on the sides ``signs``
        (:meth:`signs`), links spun to the canonical pose about ``rest`` (default: the
        system's rest pose)."""
        rest = rest or self.system.rest
        B, M = len(steps), self.system.n_members
        P, R = np.zeros((B, M + 1, 3)), np.zeros((B, M + 1, 3, 3))
        Q = np.empty((B, M + 1, 4))
        R[:, M], Q[:, M] = np.eye(3), (1.0, 0.0, 0.0, 0.0)
        valid = np.ones(B, dtype=bool)
        side = iter(signs)
        with np.errstate(invalid="ignore", divide="ignore"):
            for rule in self.rules:
                if isinstance(rule, Driven):
                    u = rule.member
                    Q[:, u] = self.place.turned(Q, rule.turn, table, steps)
                    R[:, u] = quat.to_matrix(Q[:, u])
                    P[:, u] = self.place.point(P, R, rule.pin, table, steps) - R[:, u] @ self.place.mine("location", rule.pin)
                elif isinstance(rule, Hinged):
                    u, (one, two), arm = rule.member, rule.pins, rule.arm
                    n = self.place.axis(R, rule.axis, table, steps)
                    X1, X2 = self.place.point(P, R, one, table, steps), self.place.point(P, R, two, table, steps)
                    R[:, u] = quat.frame_rotation(arm.frame, n, X2 - X1 - arm.height * n)
                    P[:, u] = X1 - R[:, u] @ self.place.mine("location", one)
                    Q[:, u] = quat.from_matrix(R[:, u])
                elif isinstance(rule, Dyad):
                    valid &= self.place.dyad(rule, P, R, table, steps, next(side))
                    Q[:, list(rule.members)] = quat.from_matrix(R[:, list(rule.members)])
                elif isinstance(rule, Cone):
                    valid &= self.place.cone(rule, P, R, table, steps, next(side))
                    Q[:, list(rule.members)] = quat.from_matrix(R[:, list(rule.members)])
                elif isinstance(rule, Swing):
                    valid &= self.place.swing(rule, P, R, table, steps, next(side))
                    Q[:, rule.member] = quat.from_matrix(R[:, rule.member])
                elif isinstance(rule, Reach):
                    w = rule.member
                    Q[:, w] = self.place.turned(Q, rule.turn, table, steps)
                    R[:, w] = quat.to_matrix(Q[:, w])
                    valid &= self.place.reach(rule, P, R, table, steps, next(side))
                elif isinstance(rule, Spun):
                    valid &= self.place.spun(rule, P, R, table, steps, rest)
                    Q[:, rule.member] = quat.from_matrix(R[:, rule.member])
                else:
                    u, w = rule.members
                    Q[:, w] = self.place.turned(Q, rule.turn, table, steps)
                    R[:, w] = quat.to_matrix(Q[:, w])
                    valid &= self.place.slider(rule, P, R, table, steps, next(side))
                    Q[:, u] = quat.from_matrix(R[:, u])
        Q = Q[:, :M]
        flip = np.sign(quat.dot(Q, np.concatenate([anchor[None], Q[:-1]])))
        Q *= np.cumprod(np.where(flip == 0.0, 1.0, flip), axis=0)[..., None]
        return P[:, :M], Q, valid & np.isfinite(P).all(axis=(1, 2)) & np.isfinite(Q).all(axis=(1, 2))

    @property
    def spun(self) -> int:
        """The member of the (first) spun link (:class:`Spun`)."""
        return next(r.member for r in self.rules if isinstance(r, Spun))

    def spin_slope(self, P: np.ndarray, Q: np.ndarray, rest: State) -> np.ndarray:
        """The derivative (B,) of the scaled distance from ``rest``
        (:meth:`linkedit.gcs.closed_form_place.Placement.spun`'s f) of the spun link at
        positions P (B, 3), quaternions Q (B, 4) along its spin (unit rate about the line of its
        ball joints): zero at the canonical pose. Only the link's own pose
        enters (the line is its own: the spin leaves every constraint and every other member
        as it is); the rotation part is 2 φ·u (φ the rotation vector from rest, as
        (J_l⁻¹ φ)·u = φ·u)."""
        rule = next(r for r in self.rules if isinstance(r, Spun))
        u, (one, two) = rule.member, rule.pins
        a1 = self.place.mine("location", one)
        R = quat.to_matrix(Q)
        axis = R @ (self.place.mine("location", two) - a1)
        axis /= np.sqrt(quat.dot(axis, axis))[:, None]
        phi = quat.log(quat.multiply(Q, quat.conjugate(rest.orientation[u])))
        moving = quat.cross(R @ a1, axis)  # the link's origin about its first ball joint
        return 2.0 * (quat.dot(P - rest.position[u], moving) / self.system.length_scale ** 2 + quat.dot(phi, axis))

    def sides(self, position: np.ndarray, orientation: np.ndarray, table: StepTable, step: int,
              rest: State | None = None) -> list[float] | None:
        """The dyads' sides (:meth:`signs`) at a solved pose (positions (M, 3), quaternions
        (M, 4)) at the table's ``step``, or None where the closed form rebuilds another pose
        there (by more than :data:`REBUILT`) or finds a dyad's axes not along one line: its
        rules do not hold for the mechanism. (A dyad that cannot close there by rounding, at its
        dead point, tells nothing.)"""
        signs = self.signs(position, orientation, table, step)
        P, Q, valid = self.poses(table, np.array([step]), orientation, signs, rest)
        if not valid[0]:
            return signs if np.isnan(P[0]).any() else None
        error = max(np.abs(P[0] - position).max() / self.system.length_scale, np.abs(Q[0] - orientation).max())
        return signs if error <= REBUILT else None

    def signs(self, position: np.ndarray, orientation: np.ndarray, table: StepTable, step: int) -> list[float]:
        """The side (±1) of each dyad's common joint from the line between its placed joints,
        about n (a spherical dyad's hinge axis from the plane of its placed axes; a slider's
        joint from the foot of the perpendicular from its rod's pin to its line), at a solved pose (positions (M, 3), quaternions (M, 4)) at the table's
        ``step``."""
        P = np.concatenate([position, np.zeros((1, 3))])[None]
        R = np.concatenate([quat.to_matrix(orientation), np.eye(3)[None]])[None]
        steps = np.array([step])
        out = []
        for rule in self.rules:
            if isinstance(rule, Dyad):
                _, A, axes, _ = self.place.triangle(rule, P, R, table, steps)
                J = self.place.point(P, R, rule.joint, table, steps)  # w's point of the common joint
                side = quat.dot(quat.cross(A[1] - A[0], J - A[0]), axes[0])
            elif isinstance(rule, Cone):
                _, placed, _, _, _, _ = self.place.cones(rule, P, R, table, steps)
                c = quat.rotated(R[:, rule.members[0]], self.place.mine("axis", rule.hinge))  # the hinge axis
                side = quat.dot(c, quat.cross(placed[0], placed[1]))
            elif isinstance(rule, Slider):
                _, foot, axis, _, line, _, _ = self.place.slide(rule, P, R, table, steps)
                J = self.place.point(P, R, rule.joint, table, steps)  # the slider's point of the joint
                side = quat.dot(J - foot, line - quat.dot(line, axis)[:, None] * axis)
            elif isinstance(rule, Swing):
                _, n, C, across, _, _ = self.place.circle(rule, P, R, table, steps)
                side = quat.dot(self.place.point(P, R, rule.joint, table, steps) - C, quat.cross(n, across))
            elif isinstance(rule, Reach):
                _, l, _, _ = self.place.guide(rule, P, R, table, steps)
                side = quat.dot(self.place.point(P, R, rule.joint, table, steps) - self.place.point(P, R, rule.far, table, steps), l)
            else:
                continue
            out.append(1.0 if float(side[0]) >= 0.0 else -1.0)
        return out
