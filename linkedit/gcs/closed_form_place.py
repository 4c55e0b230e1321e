"""The batched placement behind :mod:`linkedit.gcs.closed_form`: the constraints' vectors and
points seen from a member, and each rule (:mod:`linkedit.gcs.closed_form_rules`) placing its
member or members at many steps at once, as array code over the steps, with the geometry that
also gives a sided rule's side at a solved pose (:meth:`linkedit.gcs.closed_form.ClosedForm.signs`).
A member's rotation takes its frame (:class:`linkedit.gcs.closed_form_rules.Arm`) onto the
world axis and arm; its position puts its joint on the placed one."""

from __future__ import annotations

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.gcs.closed_form_rules import PARALLEL, Cone, Dyad, End, Reach, Slider, Spun, Swing
from linkedit.gcs.system import State, StepTable, System
from linkedit.planar import law_of_cosines

#: Newton steps on a link's spin (:meth:`Placement.spun`), at most, and the largest last one
#: (radians) for its pose to be rebuilt
SPIN_ITERATIONS, SPUN = 12, 1e-12


class Placement:
    """The constraints of a system as the closed form's rules read them, and the rules' placing
    of their members into positions P (B, M+1, 3) and rotations R (B, M+1, 3, 3) (index M: the
    world)."""

    def __init__(self, system: System) -> None:
        self.system = system
        self._blocks = {blk.kind: blk for blk in system.blocks}
        #: the driven member vectors and relative orientations: their columns in the step table
        self._driven = {int(g): j for j, g in enumerate(system.driven_vectors)}
        self._driven_rel = {int(i): j for j, i in enumerate(system.driven_rel)}

    def mine(self, kind: str, end: End) -> np.ndarray:
        """The member's own vector of a constraint seen from it (a point or axis in its space,
        (3,)): its ``sa``, or its ``sb`` (not driven:
        :func:`linkedit.gcs.closed_form_compile.find_rules` takes no such end)."""
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

    def point(self, P: np.ndarray, R: np.ndarray, end: End, table: StepTable, steps: np.ndarray,
               kind: str = "location") -> np.ndarray:
        """The other member's point of a location (or line) constraint in the world (B, 3),
        from the positions P (B, M+1, 3) and rotations R (B, M+1, 3, 3) placed."""
        return P[:, end.other] + quat.rotated(R[:, end.other], self._theirs(kind, end, table, steps))

    def axis(self, R: np.ndarray, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
        """The other member's axis of an axis constraint in the world, unit (B, 3)."""
        n = quat.rotated(R[:, end.other], self._theirs("axis", end, table, steps))
        return n / np.sqrt(quat.dot(n, n))[:, None]

    def direction(self, R: np.ndarray, end: End, kind: str = "line") -> np.ndarray:
        """The other member's direction of a line (or normal of a plane) constraint in the
        world, unit (B, 3)."""
        n = quat.rotated(R[:, end.other], self._blocks[kind].nb[end.index])
        return n / np.sqrt(quat.dot(n, n))[:, None]

    def turned(self, Q: np.ndarray, end: End, table: StepTable, steps: np.ndarray) -> np.ndarray:
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


    def dyad(self, rule: Dyad, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              sign: float) -> np.ndarray:
        """Place a dyad's members (into P (B, M+1, 3), R (B, M+1, 3, 3)) with their common
        joint on the side ``sign``; whether each step could (B,) (:meth:`triangle`; the
        triangle closed: else NaN)."""
        X, A, axes, ok = self.triangle(rule, P, R, table, steps)
        n = axes[0]
        e = A[1] - A[0]
        e -= quat.dot(e, n)[:, None] * n
        d = np.sqrt(quat.dot(e, e))
        e1 = e / d[:, None]
        lu, lw = (arm.length for arm in rule.arms)
        z, _ = law_of_cosines.dyad(np.zeros((1, len(d)), dtype=complex), d[None] + 0j, np.array([[0.5 * (lu * lu - lw * lw)]]),
                    np.array([[lu * lu]]), np.array([[sign]]))
        J = A[0] + z.real.T * e1 + z.imag.T * quat.cross(n, e1)  # the common joint
        for m, pin, arm, Xm, Am, nm in zip(rule.members, rule.pins, rule.arms, X, A, axes):
            R[:, m] = quat.frame_rotation(arm.frame, nm, J - Am)
            P[:, m] = Xm - R[:, m] @ self.mine("location", pin)
        return ok

    def triangle(self, rule: Dyad, P: np.ndarray, R: np.ndarray, table: StepTable,
                  steps: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], np.ndarray]:
        """A dyad's placed joints X (B, 3) each; the same moved along its member's placed axis
        by the member's offset to the common joint (A: in the common joint's plane across the
        axes); the placed axes (B, 3) each, the members' axes turned onto them (the two either
        way along one line: a pin may give its axis either way); and whether the placed axes
        are one line and the A's in one plane across it (B,) (to :data:`PARALLEL`)."""
        axes = [self.axis(R, end, table, steps) for end in rule.axes]
        X = [self.point(P, R, pin, table, steps) for pin in rule.pins]
        A = [x + arm.height * n for x, arm, n in zip(X, rule.arms, axes)]
        c = quat.cross(*axes)
        reach = rule.arms[0].length + rule.arms[1].length
        ok = (np.sqrt(quat.dot(c, c)) <= PARALLEL) & (np.abs(quat.dot(A[1] - A[0], axes[0])) <= PARALLEL * reach)
        return X, A, axes, ok

    def cone(self, rule: Cone, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              sign: float) -> np.ndarray:
        """Place a spherical dyad's members (into P, R as :meth:`dyad`) with their hinge axis
        on the side ``sign`` of the plane of the placed axes; whether each step could (B,)
        (:meth:`cones`)."""
        X, n, x, y, z2, ok = self.cones(rule, P, R, table, steps)
        across = quat.cross(n[0], n[1])
        c = x[:, None] * n[0] + y[:, None] * n[1] + (sign * np.sqrt(z2))[:, None] * across
        for m, pin, arm, Xm, nm in zip(rule.members, rule.pins, rule.arms, X, n):
            R[:, m] = quat.frame_rotation(arm.frame, nm, c - arm.height * nm)
            P[:, m] = Xm - R[:, m] @ self.mine("location", pin)
        return ok

    def cones(self, rule: Cone, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray, np.ndarray,
                                           np.ndarray]:
        """A spherical dyad's placed joints X (B, 3) each and placed axes n (B, 3) each; the
        hinge axis c = x n₁ + y n₂ + z n₁ × n₂ (c·nᵢ the cosines of the members' arms, |c| = 1):
        x, y and z² (B,) each (z² < 0: the cones do not meet); and whether the placed joints
        are one point (to :data:`PARALLEL` of the size) and the placed axes not along one line (B,)."""
        n = [self.axis(R, end, table, steps) for end in rule.axes]
        X = [self.point(P, R, pin, table, steps) for pin in rule.pins]
        c1, c2 = (arm.height for arm in rule.arms)
        g = quat.dot(n[0], n[1])
        sine2 = 1.0 - g * g
        x, y = (c1 - g * c2) / sine2, (c2 - g * c1) / sine2
        z2 = (1.0 - x * c1 - y * c2) / sine2
        gap = X[1] - X[0]
        ok = (np.sqrt(quat.dot(gap, gap)) <= PARALLEL * self.system.length_scale) & (sine2 > PARALLEL)
        return X, n, x, y, z2, ok

    def slider(self, rule: Slider, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
                sign: float) -> np.ndarray:
        """Place a rod and its slider (into P, R as :meth:`dyad`; the slider's rotation already
        placed) with the slider at the root ``sign`` of |c + s l|² = L² across the rod's axis
        (:meth:`slide`); whether each step could (B,)."""
        u, w = rule.members
        X, A, n, L0, l, c, ok = self.slide(rule, P, R, table, steps)
        cn, ln = c - quat.dot(c, n)[:, None] * n, l - quat.dot(l, n)[:, None] * n
        a, b = quat.dot(ln, ln), quat.dot(cn, ln)
        s = (-b + sign * np.sqrt(b * b - a * (quat.dot(cn, cn) - rule.arm.length ** 2))) / a
        R[:, u] = quat.frame_rotation(rule.arm.frame, n, cn + s[:, None] * ln)
        P[:, u] = X - R[:, u] @ self.mine("location", rule.pin)
        P[:, w] = L0 + s[:, None] * l - R[:, w] @ self.mine("line", rule.line)
        return ok

    def slide(self, rule: Slider, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A rod's placed joint X (B, 3), the same moved along its placed axis n (B, 3) by its
        offset to the joint (A), the slider's line (a point L0 and unit direction l, (B, 3)
        each), c (B, 3): the joint with the slider's point on the line at L0, less A (the
        joint is c + s l from A with the slider's point at L0 + s l: the slider's rotation
        placed); and whether the line and c lie across the axis (to :data:`PARALLEL`) (B,)."""
        n = self.axis(R, rule.axis, table, steps)
        X = self.point(P, R, rule.pin, table, steps)
        A = X + rule.arm.height * n
        L0 = self.point(P, R, rule.line, table, steps, "line")
        l = self.direction(R, rule.line)
        c = L0 + quat.rotated(R[:, rule.members[1]], rule.offset) - A
        ok = (np.abs(quat.dot(l, n)) <= PARALLEL) & (np.abs(quat.dot(c, n)) <= PARALLEL * self.system.length_scale)
        return X, A, n, L0, l, c, ok

    def swing(self, rule: Swing, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
               sign: float) -> np.ndarray:
        """Place a rocker (into P, R as :meth:`dyad`) with its joint where the circle of its
        arm about its placed axis meets the sphere of the link's length about the link's placed
        joint, on the side ``sign`` (:meth:`circle`); whether each step could (B,) (else NaN)."""
        u, arm = rule.member, rule.arm
        X, n, C, across, k3, m = self.circle(rule, P, R, table, steps)
        c = k3 / m
        J = arm.length * (c[:, None] * across + (sign * np.sqrt(1.0 - c * c))[:, None] * quat.cross(n, across))
        R[:, u] = quat.frame_rotation(arm.frame, n, J)
        P[:, u] = X - R[:, u] @ self.mine("location", rule.pin)
        return np.ones(len(steps), dtype=bool)

    def circle(self, rule: Swing, P: np.ndarray, R: np.ndarray, table: StepTable,
                steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A rocker's placed joint X (B, 3) and axis n (B, 3), the centre C (B, 3) of its arm's
        circle, the unit direction (B, 3) across n from C to the link's placed joint D, and
        k3, m (B,): the joint J on the circle has (J − C)·(D − C) = rho k3, m = |D − C| across n."""
        n = self.axis(R, rule.axis, table, steps)
        X = self.point(P, R, rule.pin, table, steps)
        C = X + rule.arm.height * n
        D = self.point(P, R, rule.far, table, steps) - C
        rho = rule.arm.length
        k3 = (quat.dot(D, D) + rho * rho - rule.length ** 2) / (2.0 * rho)
        D -= quat.dot(D, n)[:, None] * n
        m = np.sqrt(quat.dot(D, D))
        return X, n, C, D / m[:, None], k3, m

    def reach(self, rule: Reach, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
               sign: float) -> np.ndarray:
        """Place a slider (into P as :meth:`dyad`; its rotation placed) with its joint at the
        link's length from the link's placed joint, on the side ``sign`` along its line;
        whether each step could (B,) (the line's planes not parallel; else NaN)."""
        w = rule.member
        L0, l, c, ok = self.guide(rule, P, R, table, steps)
        b = quat.dot(c, l)
        s = -b + sign * np.sqrt(b * b - quat.dot(c, c) + rule.length ** 2)
        P[:, w] = L0 + s[:, None] * l - R[:, w] @ self.mine(rule.kind, rule.guide[0])
        return ok

    def guide(self, rule: Reach, P: np.ndarray, R: np.ndarray, table: StepTable,
               steps: np.ndarray) -> tuple[np.ndarray, ...]:
        """A slider's line (a point L0 and unit direction l, (B, 3) each: its line constraint's,
        or where its two planes meet), c (B, 3): its joint with its point of the line at L0,
        less the link's placed joint (the slider's rotation placed), and whether the planes
        meet in a line (B,) (to :data:`PARALLEL`)."""
        if rule.kind == "line":
            L0 = self.point(P, R, rule.guide[0], table, steps, "line")
            l = self.direction(R, rule.guide[0])
            ok = np.ones(len(steps), dtype=bool)
        else:
            # the point of both planes p·nᵢ = dᵢ on their line l = n₁ × n₂: (d₁ n₂ × l + d₂ l × n₁)/|l|²
            n1, n2 = (self.direction(R, e, "plane") for e in rule.guide)
            d1, d2 = (quat.dot(self.point(P, R, e, table, steps, "plane"), n) for e, n in zip(rule.guide, (n1, n2)))
            l = quat.cross(n1, n2)
            ll = quat.dot(l, l)
            L0 = (d1[:, None] * quat.cross(n2, l) + d2[:, None] * quat.cross(l, n1)) / ll[:, None]
            l = l / np.sqrt(ll)[:, None]
            ok = ll > PARALLEL ** 2
        c = L0 + quat.rotated(R[:, rule.member], rule.offset) - self.point(P, R, rule.far, table, steps)
        return L0, l, c, ok

    def spun(self, rule: Spun, P: np.ndarray, R: np.ndarray, table: StepTable, steps: np.ndarray,
              rest: State) -> np.ndarray:
        """Place a link between two placed ball joints (into P, R as :meth:`dyad`) at its
        canonical spin: the one minimizing its part of the scaled distance from ``rest``,
        f(θ) = |P − P_rest|²/L² + α² (α the angle of R R_restᵀ), by Newton's method on the
        angle θ about the line of its joints from its rest pose turned the least way onto that
        line (f is A cos θ + B sin θ plus α², cos α = (tr(R R_restᵀ) − 1)/2 also sinusoidal in
        θ); whether each step converged (B,)."""
        u, (one, two) = rule.member, rule.pins
        a1, a2 = self.mine("location", one), self.mine("location", two)
        X1 = self.point(P, R, one, table, steps)
        n = self.point(P, R, two, table, steps) - X1
        n /= np.sqrt(quat.dot(n, n))[:, None]
        Rr = quat.to_matrix(rest.orientation[u])
        v = Rr @ (a2 - a1) / np.linalg.norm(a2 - a1)
        k, cos = np.cross(v, n), n @ v
        K = quat.skew(k)
        S = np.eye(3) + K + K @ K / (1.0 + cos)[:, None, None]  # v onto n, the least turn
        R0 = S @ Rr
        w, c = R0 @ a1, X1 - rest.position[u]
        # the position part −2(kc cos theta + ks sin theta)/L², the trace t0 + tc cos theta + ts sin theta
        L2 = self.system.length_scale ** 2
        kc, ks = (quat.dot(c, w) - quat.dot(c, n) * quat.dot(n, w)) / L2, quat.dot(c, quat.cross(n, w)) / L2
        t0 = np.einsum("bi,bij,bj->b", n, S, n)
        tc, ts = np.einsum("bii->b", S) - t0, np.einsum("bij,bji->b", quat.skew(n), S)
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
        R[:, u] = quat.spin_matrix(n, theta) @ R0
        P[:, u] = X1 - R[:, u] @ a1
        return (np.abs(step) <= SPUN) & (f2 > 0.0)
