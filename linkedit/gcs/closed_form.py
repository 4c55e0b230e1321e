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
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form_rules import (PARALLEL, SIDED, Arm, Cone, Driven, Dyad, End, Hinged, Reach,
                                            Rule, Slider, Spun, Swing)
from linkedit.gcs.system import State, StepTable, System
from linkedit.planar.law_of_cosines import dyad

#: the largest difference (scaled) of the closed form's pose from a solved one for its rules to
#: hold there: √tol (a pose solved to the tolerance, 1e-12, is determined to about that even at
#: a singular pose, where J does not see one direction; rules that do not hold miss by far more)
REBUILT = 1e-6
#: Newton steps on a link's spin (:meth:`ClosedForm._spun`), at most, and the largest last one
#: (radians) for its pose to be rebuilt
SPIN_ITERATIONS, SPUN = 12, 1e-12


class ClosedForm:
    """The rules placing every member of a system in order (module docstring)."""

    def __init__(self, system: System, rules: list[Rule]) -> None:
        self.system = system
        self.rules = rules
        self._blocks = {blk.kind: blk for blk in system.blocks}
        #: whether a link spins freely (:class:`Spun`): its pose is the canonical one
        self.spins = any(isinstance(rule, Spun) for rule in rules)
        #: the driven member vectors and relative orientations: their columns in the step table
        self._driven = {int(g): j for j, g in enumerate(system.driven_vectors)}
        self._driven_rel = {int(i): j for j, i in enumerate(system.driven_rel)}

    @classmethod
    def compile(cls, system: System) -> "ClosedForm | None":
        """The rules in placing order, or None where some member has none (or the system has
        custom constraints)."""
        if system.customs:
            return None
        M = system.n_members
        driven = set(system.driven_vectors.tolist())
        ends: dict[str, dict[int, list[End]]] = {}
        for blk in system.blocks:
            per = ends.setdefault(blk.kind, {m: [] for m in range(M)})
            own_b = len(blk.vectors) > 1  # b's vector, which an input may drive: not a member's own then
            for i, (a, b) in enumerate(zip(blk.a, blk.b)):
                if a != b:
                    if a < M:
                        per[int(a)].append(End(i, True, int(b)))
                    if b < M and not (own_b and blk.vectors[1].start + i in driven):
                        per[int(b)].append(End(i, False, int(a)))
        none: dict[int, list[End]] = {m: [] for m in range(M)}
        pins, axes, turns, lines, planes = (ends.get(k, none)
                                            for k in ("location", "axis", "orientation", "line", "plane"))
        # the constraints each member takes part in (a link's are its two ball joints only)
        touching = np.bincount(np.concatenate([np.r_[blk.a, blk.b] for blk in system.blocks] or [np.zeros(0, int)]),
                               minlength=M + 1)
        form = cls(system, [])
        placed = {M}

        def first(found: list[End]) -> End | None:
            return next((e for e in found if e.other in placed), None)

        def direct(u: int) -> Rule | None:
            """A driven or hinged rule for member u."""
            pin, turn = first(pins[u]), first(turns[u])
            if pin is not None and turn is not None:
                return Driven(u, turn, pin)
            axis = first(axes[u])
            if pin is None or axis is None:
                return None
            other = next((e for e in pins[u] if e.other in placed and form._apart(pin, e)), None)
            return None if other is None else Hinged(u, (pin, other), axis, form._arm(axis, pin, other))

        def partners(u: int, apart: bool) -> Iterator[tuple[End, End, End, int, End]]:
            """Member u's first placed pin and axis, with each unplaced member w pinned to u (by
            ``joint`` seen from u, ``back`` seen from w) at another point of u than that pin
            (``apart``) or at the same one."""
            pin, axis = first(pins[u]), first(axes[u])
            if pin is None or axis is None:
                return
            for joint in pins[u]:
                w = joint.other
                if w not in placed and form._apart(pin, joint) == apart:
                    yield pin, axis, joint, w, End(joint.index, not joint.side_a, u)

        def dyad_of(u: int) -> Rule | None:
            """A dyad of member u and an unplaced member."""
            for pin, axis, joint, w, back in partners(u, True):
                pin_w, axis_w = first(pins[w]), first(axes[w])
                if back in pins[w] and pin_w is not None and axis_w is not None and form._apart(pin_w, back):
                    return Dyad((u, w), (pin, pin_w), (axis, axis_w), joint,
                                (form._arm(axis, pin, joint), form._arm(axis_w, pin_w, back)))
            return None

        def cone_of(u: int) -> Rule | None:
            """A spherical dyad of member u and an unplaced member."""
            for pin, axis, joint, w, back in partners(u, False):
                pin_w, axis_w = first(pins[w]), first(axes[w])
                if back not in pins[w] or pin_w is None or axis_w is None or form._apart(pin_w, back):
                    continue
                for hinge in (e for e in axes[u] if e.other == w):
                    other = End(hinge.index, not hinge.side_a, u)
                    arms = (form._arm(axis, hinge), form._arm(axis_w, other))
                    if other in axes[w] and min(a.length for a in arms) > PARALLEL:
                        return Cone((u, w), (pin, pin_w), (axis, axis_w), joint, hinge, arms)
            return None

        def slider_of(u: int) -> Rule | None:
            """A rod u pinned to a placed member and a slider on a placed member's line."""
            for pin, axis, joint, w, back in partners(u, True):
                turn = first(turns[w])
                line = next((e for e in lines[w] if e.side_a and e.other in placed), None)
                if turn is None or line is None or back not in pins[w]:
                    continue
                arm = Arm.of(form._mine("axis", axis), form._mine("location", pin), form._mine("location", joint))
                return Slider((u, w), pin, axis, turn, line, joint, arm,
                              form._mine("location", back) - form._mine("line", line))
            return None

        def link(u: int, joint: End) -> tuple[End, float] | None:
            """The link that u's location constraint ``joint`` pins it to (unplaced, held by
            that and one more location constraint alone, to a placed member at another of its
            points): that one (seen from the link) and the length between the two points."""
            w, back = joint.other, End(joint.index, not joint.side_a, u)
            if w in placed or touching[w] != 2 or back not in pins[w]:
                return None
            far = next((e for e in pins[w] if e != back and e.other in placed), None)
            if far is None or not form._apart(back, far):
                return None
            return far, float(np.linalg.norm(form._mine("location", far) - form._mine("location", back)))

        def swing_of(u: int) -> Rule | None:
            """A rocker u whose joint is a link's ball joint."""
            pin, axis = first(pins[u]), first(axes[u])
            if pin is None or axis is None:
                return None
            for joint in pins[u]:
                found = link(u, joint) if form._apart(pin, joint) else None
                if found is not None:
                    return Swing(u, pin, axis, form._arm(axis, pin, joint), joint, *found)
            return None

        def reach_of(u: int) -> Rule | None:
            """A slider u whose joint is a link's ball joint."""
            turn = first(turns[u])
            line = next((e for e in lines[u] if e.side_a and e.other in placed), None)
            flat = [e for e in planes[u] if e.side_a and e.other in placed]
            two = next(((p, q) for i, p in enumerate(flat) for q in flat[i + 1:]
                        if form._mine("plane", p).tolist() == form._mine("plane", q).tolist()), None)
            guide, kind = ((line,), "line") if line is not None else (two, "plane")
            if turn is None or guide is None:
                return None
            for joint in pins[u]:
                found = link(u, joint)
                if found is not None:
                    offset = form._mine("location", joint) - form._mine(kind, guide[0])
                    return Reach(u, turn, guide, kind, joint, *found, offset)
            return None

        def spun_of(u: int) -> Rule | None:
            """A link u between two placed ball joints."""
            held = [e for e in pins[u] if e.other in placed]
            if touching[u] != 2 or len(held) != 2 or not form._apart(*held):
                return None
            return Spun(u, (held[0], held[1]))

        while len(placed) <= M:
            # the members placed directly first, then dyads, spherical dyads, sliders, rockers
            # and sliders reaching a link, links between ball joints
            rule = None
            for find in (direct, dyad_of, cone_of, slider_of, swing_of, reach_of, spun_of):
                rule = next((r for u in range(M) if u not in placed for r in (find(u),) if r is not None), None)
                if rule is not None:
                    break
            if rule is None:
                return None
            form.rules.append(rule)
            form.spins |= isinstance(rule, Spun)
            placed |= set(rule.members) if isinstance(rule, SIDED) else {rule.member}
        return form

    def _arm(self, axis: End, start: End, end: End | None = None) -> Arm:
        """A member's arm from its point of the location constraint ``start`` to that of
        ``end`` across its axis of the axis constraint ``axis`` (all seen from it); with no
        ``end``, from its origin to its unit axis of the axis constraint ``start``."""
        if end is None:
            return Arm.of(self._mine("axis", axis), np.zeros(3), self._mine("axis", start))
        return Arm.of(self._mine("axis", axis), self._mine("location", start), self._mine("location", end))

    def _apart(self, a: End, b: End) -> bool:
        """Whether a member's points of the location constraints a and b (seen from it) differ."""
        return self._mine("location", a).tolist() != self._mine("location", b).tolist()

    # ---- the constraints' vectors and points ----------------------------------------------

    def _mine(self, kind: str, end: End) -> np.ndarray:
        """The member's own vector of a constraint seen from it (a point or axis in its space,
        (3,)): its ``sa``, or its ``sb`` (not driven: :meth:`compile` takes no such end)."""
        blk = self._blocks[kind]
        return blk.sa[end.index] if end.side_a else blk.sb[end.index]

    def _theirs(self, kind: str, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
        """The other member's vector of a constraint seen from a member: (3,), or (B, 3) at the
        table's ``steps`` where an input drives it."""
        blk = self._blocks[kind]
        if end.side_a:
            j = self._driven.get(blk.vectors[1].start + end.index)
            return blk.sb[end.index] if j is None else table.vectors[steps, j, :3]
        return blk.sa[end.index]

    def _point(self, P: np.ndarray, R: np.ndarray, end: End, table: StepTable, steps: np.ndarray,
               kind: str = "location") -> np.ndarray:
        """The other member's point of a location (or line) constraint in the world (B, 3),
        from the positions P (B, M+1, 3) and rotations R (B, M+1, 3, 3) placed."""
        return P[:, end.other] + _turn(R[:, end.other], self._theirs(kind, end, table, steps))

    def _axis(self, R: np.ndarray, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
        """The other member's axis of an axis constraint in the world, unit (B, 3)."""
        n = _turn(R[:, end.other], self._theirs("axis", end, table, steps))
        return n / np.sqrt(quat.dot(n, n))[:, None]

    def _direction(self, R: np.ndarray, end: End, kind: str = "line") -> np.ndarray:
        """The other member's direction of a line (or normal of a plane) constraint in the
        world, unit (B, 3)."""
        n = _turn(R[:, end.other], self._blocks[kind].nb[end.index])
        return n / np.sqrt(quat.dot(n, n))[:, None]

    def _turned(self, Q: np.ndarray, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
        """A member's quaternions (B, 4) set by the orientation constraint ``end`` (seen from
        it) from its other member's quaternions Q (B, M+1, 4)."""
        rel = self._rel(end, table, steps)
        return quat.multiply(Q[:, end.other], rel if end.side_a else quat.conjugate(rel))

    def _rel(self, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
        """The relative orientation of an orientation constraint at ``steps`` (B, 4)."""
        j = self._driven_rel.get(end.index)
        if j is None:
            return np.broadcast_to(self._blocks["orientation"].rel[end.index], (len(steps), 4))
        return quat.conjugate(table.rel_inverse[steps, j])

    # ---- poses ----------------------------------------------------------------------------

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
                    Q[:, u] = self._turned(Q, rule.turn, table, steps)
                    R[:, u] = quat.to_matrix(Q[:, u])
                    P[:, u] = self._point(P, R, rule.pin, table, steps) - R[:, u] @ self._mine("location", rule.pin)
                elif isinstance(rule, Hinged):
                    u, (one, two), arm = rule.member, rule.pins, rule.arm
                    n = self._axis(R, rule.axis, table, steps)
                    X1, X2 = self._point(P, R, one, table, steps), self._point(P, R, two, table, steps)
                    R[:, u] = _rotation(arm.frame, n, X2 - X1 - arm.height * n)
                    P[:, u] = X1 - R[:, u] @ self._mine("location", one)
                    Q[:, u] = quat.from_matrix(R[:, u])
                elif isinstance(rule, Dyad):
                    valid &= self._dyad(rule, P, R, table, steps, next(side))
                    Q[:, list(rule.members)] = quat.from_matrix(R[:, list(rule.members)])
                elif isinstance(rule, Cone):
                    valid &= self._cone(rule, P, R, table, steps, next(side))
                    Q[:, list(rule.members)] = quat.from_matrix(R[:, list(rule.members)])
                elif isinstance(rule, Swing):
                    valid &= self._swing(rule, P, R, table, steps, next(side))
                    Q[:, rule.member] = quat.from_matrix(R[:, rule.member])
                elif isinstance(rule, Reach):
                    w = rule.member
                    Q[:, w] = self._turned(Q, rule.turn, table, steps)
                    R[:, w] = quat.to_matrix(Q[:, w])
                    valid &= self._reach(rule, P, R, table, steps, next(side))
                elif isinstance(rule, Spun):
                    valid &= self._spun(rule, P, R, table, steps, rest)
                    Q[:, rule.member] = quat.from_matrix(R[:, rule.member])
                else:
                    u, w = rule.members
                    Q[:, w] = self._turned(Q, rule.turn, table, steps)
                    R[:, w] = quat.to_matrix(Q[:, w])
                    valid &= self._slider(rule, P, R, table, steps, next(side))
                    Q[:, u] = quat.from_matrix(R[:, u])
        Q = Q[:, :M]
        flip = np.sign(quat.dot(Q, np.concatenate([anchor[None], Q[:-1]])))
        Q *= np.cumprod(np.where(flip == 0.0, 1.0, flip), axis=0)[..., None]
        return P[:, :M], Q, valid & np.isfinite(P).all(axis=(1, 2)) & np.isfinite(Q).all(axis=(1, 2))

    def _dyad(self, rule: Dyad, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              sign: float) -> np.ndarray:
        """Place a dyad's members (into P (B, M+1, 3), R (B, M+1, 3, 3)) with their common
        joint on the side ``sign``; whether each step could (B,) (:meth:`_triangle`; the
        triangle closed: else NaN)."""
        X, A, axes, ok = self._triangle(rule, P, R, table, steps)
        n = axes[0]
        e = A[1] - A[0]
        e -= quat.dot(e, n)[:, None] * n
        d = np.sqrt(quat.dot(e, e))
        e1 = e / d[:, None]
        lu, lw = (arm.length for arm in rule.arms)
        z, _ = dyad(np.zeros((1, len(d)), dtype=complex), d[None] + 0j, np.array([[0.5 * (lu * lu - lw * lw)]]),
                    np.array([[lu * lu]]), np.array([[sign]]))
        J = A[0] + z.real.T * e1 + z.imag.T * quat.cross(n, e1)  # the common joint
        for m, pin, arm, Xm, Am, nm in zip(rule.members, rule.pins, rule.arms, X, A, axes):
            R[:, m] = _rotation(arm.frame, nm, J - Am)
            P[:, m] = Xm - R[:, m] @ self._mine("location", pin)
        return ok

    def _triangle(self, rule: Dyad, P: np.ndarray, R: np.ndarray, table: StepTable,
                  steps: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], np.ndarray]:
        """A dyad's placed joints X (B, 3) each; the same moved along its member's placed axis
        by the member's offset to the common joint (A: in the common joint's plane across the
        axes); the placed axes (B, 3) each, the members' axes turned onto them (the two either
        way along one line: a pin may give its axis either way); and whether the placed axes
        are one line and the A's in one plane across it (B,) (to :data:`PARALLEL`)."""
        axes = [self._axis(R, end, table, steps) for end in rule.axes]
        X = [self._point(P, R, pin, table, steps) for pin in rule.pins]
        A = [x + arm.height * n for x, arm, n in zip(X, rule.arms, axes)]
        c = quat.cross(*axes)
        reach = rule.arms[0].length + rule.arms[1].length
        ok = (np.sqrt(quat.dot(c, c)) <= PARALLEL) & (np.abs(quat.dot(A[1] - A[0], axes[0])) <= PARALLEL * reach)
        return X, A, axes, ok

    def _cone(self, rule: Cone, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              sign: float) -> np.ndarray:
        """Place a spherical dyad's members (into P, R as :meth:`_dyad`) with their hinge axis
        on the side ``sign`` of the plane of the placed axes; whether each step could (B,)
        (:meth:`_cones`)."""
        X, n, x, y, z2, ok = self._cones(rule, P, R, table, steps)
        across = quat.cross(n[0], n[1])
        c = x[:, None] * n[0] + y[:, None] * n[1] + (sign * np.sqrt(z2))[:, None] * across
        for m, pin, arm, Xm, nm in zip(rule.members, rule.pins, rule.arms, X, n):
            R[:, m] = _rotation(arm.frame, nm, c - arm.height * nm)
            P[:, m] = Xm - R[:, m] @ self._mine("location", pin)
        return ok

    def _cones(self, rule: Cone, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray, np.ndarray,
                                           np.ndarray]:
        """A spherical dyad's placed joints X (B, 3) each and placed axes n (B, 3) each; the
        hinge axis c = x n₁ + y n₂ + z n₁ × n₂ (c·nᵢ the cosines of the members' arms, |c| = 1):
        x, y and z² (B,) each (z² < 0: the cones do not meet); and whether the placed joints
        are one point (to :data:`PARALLEL` of the size) and the placed axes not along one line (B,)."""
        n = [self._axis(R, end, table, steps) for end in rule.axes]
        X = [self._point(P, R, pin, table, steps) for pin in rule.pins]
        c1, c2 = (arm.height for arm in rule.arms)
        g = quat.dot(n[0], n[1])
        sine2 = 1.0 - g * g
        x, y = (c1 - g * c2) / sine2, (c2 - g * c1) / sine2
        z2 = (1.0 - x * c1 - y * c2) / sine2
        gap = X[1] - X[0]
        ok = (np.sqrt(quat.dot(gap, gap)) <= PARALLEL * self.system.length_scale) & (sine2 > PARALLEL)
        return X, n, x, y, z2, ok

    def _slider(self, rule: Slider, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
                sign: float) -> np.ndarray:
        """Place a rod and its slider (into P, R as :meth:`_dyad`; the slider's rotation already
        placed) with the slider at the root ``sign`` of |c + s l|² = L² across the rod's axis
        (:meth:`_slide`); whether each step could (B,)."""
        u, w = rule.members
        X, A, n, L0, l, c, ok = self._slide(rule, P, R, table, steps)
        cn, ln = c - quat.dot(c, n)[:, None] * n, l - quat.dot(l, n)[:, None] * n
        a, b = quat.dot(ln, ln), quat.dot(cn, ln)
        s = (-b + sign * np.sqrt(b * b - a * (quat.dot(cn, cn) - rule.arm.length ** 2))) / a
        R[:, u] = _rotation(rule.arm.frame, n, cn + s[:, None] * ln)
        P[:, u] = X - R[:, u] @ self._mine("location", rule.pin)
        P[:, w] = L0 + s[:, None] * l - R[:, w] @ self._mine("line", rule.line)
        return ok

    def _slide(self, rule: Slider, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A rod's placed joint X (B, 3), the same moved along its placed axis n (B, 3) by its
        offset to the joint (A), the slider's line (a point L0 and unit direction l, (B, 3)
        each), c (B, 3): the joint with the slider's point on the line at L0, less A (the
        joint is c + s l from A with the slider's point at L0 + s l: the slider's rotation
        placed); and whether the line and c lie across the axis (to :data:`PARALLEL`) (B,)."""
        n = self._axis(R, rule.axis, table, steps)
        X = self._point(P, R, rule.pin, table, steps)
        A = X + rule.arm.height * n
        L0 = self._point(P, R, rule.line, table, steps, "line")
        l = self._direction(R, rule.line)
        c = L0 + _turn(R[:, rule.members[1]], rule.offset) - A
        ok = (np.abs(quat.dot(l, n)) <= PARALLEL) & (np.abs(quat.dot(c, n)) <= PARALLEL * self.system.length_scale)
        return X, A, n, L0, l, c, ok

    def _swing(self, rule: Swing, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
               sign: float) -> np.ndarray:
        """Place a rocker (into P, R as :meth:`_dyad`) with its joint where the circle of its
        arm about its placed axis meets the sphere of the link's length about the link's placed
        joint, on the side ``sign`` (:meth:`_circle`); whether each step could (B,) (else NaN)."""
        u, arm = rule.member, rule.arm
        X, n, C, across, k3, m = self._circle(rule, P, R, table, steps)
        c = k3 / m
        J = arm.length * (c[:, None] * across + (sign * np.sqrt(1.0 - c * c))[:, None] * quat.cross(n, across))
        R[:, u] = _rotation(arm.frame, n, J)
        P[:, u] = X - R[:, u] @ self._mine("location", rule.pin)
        return np.ones(len(steps), dtype=bool)

    def _circle(self, rule: Swing, P: np.ndarray, R: np.ndarray, table: StepTable,
                steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A rocker's placed joint X (B, 3) and axis n (B, 3), the centre C (B, 3) of its arm's
        circle, the unit direction (B, 3) across n from C to the link's placed joint D, and
        k3, m (B,): the joint J on the circle has (J − C)·(D − C) = rho k3, m = |D − C| across n."""
        n = self._axis(R, rule.axis, table, steps)
        X = self._point(P, R, rule.pin, table, steps)
        C = X + rule.arm.height * n
        D = self._point(P, R, rule.far, table, steps) - C
        rho = rule.arm.length
        k3 = (quat.dot(D, D) + rho * rho - rule.length ** 2) / (2.0 * rho)
        D -= quat.dot(D, n)[:, None] * n
        m = np.sqrt(quat.dot(D, D))
        return X, n, C, D / m[:, None], k3, m

    def _reach(self, rule: Reach, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
               sign: float) -> np.ndarray:
        """Place a slider (into P as :meth:`_dyad`; its rotation placed) with its joint at the
        link's length from the link's placed joint, on the side ``sign`` along its line;
        whether each step could (B,) (the line's planes not parallel; else NaN)."""
        w = rule.member
        L0, l, c, ok = self._guide(rule, P, R, table, steps)
        b = quat.dot(c, l)
        s = -b + sign * np.sqrt(b * b - quat.dot(c, c) + rule.length ** 2)
        P[:, w] = L0 + s[:, None] * l - R[:, w] @ self._mine(rule.kind, rule.guide[0])
        return ok

    def _guide(self, rule: Reach, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A slider's line (a point L0 and unit direction l, (B, 3) each: its line constraint's,
        or where its two planes meet), c (B, 3): its joint with its point of the line at L0,
        less the link's placed joint (the slider's rotation placed), and whether the planes
        meet in a line (B,) (to :data:`PARALLEL`)."""
        if rule.kind == "line":
            L0 = self._point(P, R, rule.guide[0], table, steps, "line")
            l = self._direction(R, rule.guide[0])
            ok = np.ones(len(steps), dtype=bool)
        else:
            # the point of both planes p·nᵢ = dᵢ on their line l = n₁ × n₂: (d₁ n₂ × l + d₂ l × n₁)/|l|²
            n1, n2 = (self._direction(R, e, "plane") for e in rule.guide)
            d1, d2 = (quat.dot(self._point(P, R, e, table, steps, "plane"), n) for e, n in zip(rule.guide, (n1, n2)))
            l = quat.cross(n1, n2)
            ll = quat.dot(l, l)
            L0 = (d1[:, None] * quat.cross(n2, l) + d2[:, None] * quat.cross(l, n1)) / ll[:, None]
            l = l / np.sqrt(ll)[:, None]
            ok = ll > PARALLEL ** 2
        c = L0 + _turn(R[:, rule.member], rule.offset) - self._point(P, R, rule.far, table, steps)
        return L0, l, c, ok

    def _spun(self, rule: Spun, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              rest: State) -> np.ndarray:
        """Place a link between two placed ball joints (into P, R as :meth:`_dyad`) at its
        canonical spin: the one minimizing its part of the scaled distance from ``rest``,
        f(θ) = |P − P_rest|²/L² + α² (α the angle of R R_restᵀ), by Newton's method on the
        angle θ about the line of its joints from its rest pose turned the least way onto that
        line (f is A cos θ + B sin θ plus α², cos α = (tr(R R_restᵀ) − 1)/2 also sinusoidal in
        θ); whether each step converged (B,)."""
        u, (one, two) = rule.member, rule.pins
        a1, a2 = self._mine("location", one), self._mine("location", two)
        X1 = self._point(P, R, one, table, steps)
        n = self._point(P, R, two, table, steps) - X1
        n /= np.sqrt(quat.dot(n, n))[:, None]
        Rr = quat.to_matrix(rest.orientation[u])
        v = Rr @ (a2 - a1) / np.linalg.norm(a2 - a1)
        k, cos = np.cross(v, n), n @ v
        K = _skew(k)
        S = np.eye(3) + K + K @ K / (1.0 + cos)[:, None, None]  # v onto n, the least turn
        R0 = S @ Rr
        w, c = R0 @ a1, X1 - rest.position[u]
        # the position part −2(kc cos theta + ks sin theta)/L², the trace t0 + tc cos theta + ts sin theta
        L2 = self.system.length_scale ** 2
        kc, ks = (quat.dot(c, w) - quat.dot(c, n) * quat.dot(n, w)) / L2, quat.dot(c, quat.cross(n, w)) / L2
        t0 = np.einsum("bi,bij,bj->b", n, S, n)
        tc, ts = np.einsum("bii->b", S) - t0, np.einsum("bij,bji->b", _skew(n), S)
        theta, step = np.zeros(len(steps)), np.ones(len(steps))
        for _ in range(SPIN_ITERATIONS):
            ctheta, stheta = np.cos(theta), np.sin(theta)
            ca = np.clip(0.5 * (t0 + tc * ctheta + ts * stheta - 1.0), -1.0, 1.0)
            alpha = np.arccos(ca)
            sa = np.sqrt(1.0 - ca * ca)
            # dg/dc and d²g/dc² of g = α² (c = cos α): the second by its series near α = 0,
            # where it cancels (it sets the rate of convergence only, not the root)
            small = sa < 1e-2
            gc = np.where(sa > 0.0, -2.0 * alpha / np.where(sa > 0.0, sa, 1.0), -2.0)
            gcc = np.where(small, 2.0 / 3.0 + 4.0 * alpha * alpha / 15.0,
                           2.0 * (sa - alpha * ca) / np.where(small, 1.0, sa) ** 3)
            c1, c2 = 0.5 * (ts * ctheta - tc * stheta), -0.5 * (tc * ctheta + ts * stheta)
            f1 = 2.0 * (kc * stheta - ks * ctheta) + gc * c1
            f2 = 2.0 * (kc * ctheta + ks * stheta) + gcc * c1 * c1 + gc * c2
            # Newton where f is convex there, else downhill by at most half a radian
            step = np.where(f2 > 0.0, np.clip(-f1 / np.where(f2 > 0.0, f2, 1.0), -0.5, 0.5), -0.5 * np.sign(f1))
            theta = theta + step
            if np.abs(step).max() <= 1e-15:
                break
        R[:, u] = _spin(n, theta) @ R0
        P[:, u] = X1 - R[:, u] @ a1
        return (np.abs(step) <= SPUN) & (f2 > 0.0)

    @property
    def spun(self) -> int:
        """The member of the (first) spun link (:class:`Spun`)."""
        return next(r.member for r in self.rules if isinstance(r, Spun))

    def spin_slope(self, P: np.ndarray, Q: np.ndarray, rest: State) -> np.ndarray:
        """The derivative (B,) of the scaled distance from ``rest`` (:meth:`_spun`'s f) of the
        spun link at positions P (B, 3), quaternions Q (B, 4) along its spin (unit rate about
        the line of its ball joints): zero at the canonical pose. Only the link's own pose
        enters (the line is its own: the spin leaves every constraint and every other member
        as it is); the rotation part is 2 φ·u (φ the rotation vector from rest, as
        (J_l⁻¹ φ)·u = φ·u)."""
        rule = next(r for r in self.rules if isinstance(r, Spun))
        u, (one, two) = rule.member, rule.pins
        a1 = self._mine("location", one)
        R = quat.to_matrix(Q)
        axis = R @ (self._mine("location", two) - a1)
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
                _, A, axes, _ = self._triangle(rule, P, R, table, steps)
                J = self._point(P, R, rule.joint, table, steps)  # w's point of the common joint
                side = quat.dot(quat.cross(A[1] - A[0], J - A[0]), axes[0])
            elif isinstance(rule, Cone):
                _, placed, _, _, _, _ = self._cones(rule, P, R, table, steps)
                c = _turn(R[:, rule.members[0]], self._mine("axis", rule.hinge))  # the hinge axis
                side = quat.dot(c, quat.cross(placed[0], placed[1]))
            elif isinstance(rule, Slider):
                _, foot, axis, _, line, _, _ = self._slide(rule, P, R, table, steps)
                J = self._point(P, R, rule.joint, table, steps)  # the slider's point of the joint
                side = quat.dot(J - foot, line - quat.dot(line, axis)[:, None] * axis)
            elif isinstance(rule, Swing):
                _, n, C, across, _, _ = self._circle(rule, P, R, table, steps)
                side = quat.dot(self._point(P, R, rule.joint, table, steps) - C, quat.cross(n, across))
            elif isinstance(rule, Reach):
                _, l, _, _ = self._guide(rule, P, R, table, steps)
                side = quat.dot(self._point(P, R, rule.joint, table, steps) - self._point(P, R, rule.far, table, steps), l)
            else:
                continue
            out.append(1.0 if float(side[0]) >= 0.0 else -1.0)
        return out


def _turn(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for rotations R (B, 3, 3) and vectors v (3,) or (B, 3): (B, 3)."""
    return R @ v if v.ndim == 1 else (R @ v[:, :, None])[:, :, 0]


def _skew(v: np.ndarray) -> np.ndarray:
    """The cross-product matrices [v]× (B, 3, 3) of vectors v (B, 3)."""
    K = np.zeros(v.shape + (3,))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    return K - np.swapaxes(K, 1, 2)


def _spin(n: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """The rotations (B, 3, 3) by the angles theta (B,) about the unit axes n (B, 3) (Rodrigues)."""
    K = _skew(n)
    return np.eye(3) + np.sin(theta)[:, None, None] * K + (1.0 - np.cos(theta))[:, None, None] * (K @ K)


def _rotation(frame: np.ndarray, n: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The rotations (B, 3, 3) taking a member's frame (:class:`Arm`: its axis and arm across
    it, rows (3, 3)) onto the unit axis n (B, 3) and the direction of j across n (B, 3)."""
    world = np.empty(n.shape + (3,))
    world[:, :, 0] = n
    world[:, :, 1] = j / np.sqrt(quat.dot(j, j))[:, None]
    world[:, :, 2] = quat.cross(n, world[:, :, 1])
    return world @ frame
