"""A triad: the class-III Assur group of a complex-loop six-bar, solved as its body's pose.

A rigid body carrying three joints P_k, each hung by a binary link (length² r2_k) from a known
joint A_k (the rows that keep the body rigid: any, e.g. three distances, or a distance and a
rigid point). A numeric group (:class:`~linkedit.planar.rules.group.Group`) of this shape has
three unknowns, not six: the pose (G, θ) of its body, P_k = G + e^{iθ}·p_k (p_k: the joints
about their centroid at rest, so the body's rows hold exactly, whatever the pose). Its rows

    F_k = |P_k − A_k|² − r2_k = 0

have the Jacobian 2·M, M's row k = (Re d_k, Im d_k, c_k), d_k = P_k − A_k, c_k = Re(d̄_k·i·q_k),
q_k = P_k − G: every sample's 3×3 system is solved by Cramer's rule (M's cofactors, a few array
operations over all samples: no per-sample factorization). The same cofactors give the
velocities and accelerations of the body (ω, α: P_k' = G' + iω·q_k, P_k'' = G'' + (iα − ω²)·q_k)
and the group's singularity distance: the group Jacobian J (6×6: the binary rows J1, the
body's rows J2) has det J² = (8·det M)²·det(J2·J2ᵀ)/det(NᵀN), N the body's rigid motions
(det(NᵀN) = 9·Σ|p_k|²), so its Hadamard ratio (the group's d_s,
:func:`~linkedit.planar.rules.general_group.conditioning`) is

    d_s = det M² · det(J2·J2ᵀ) / (9·Σ|p_k|² · ∏|d_k|² · ∏ diag(J2·J2ᵀ)),

zero exactly where the three binary links' lines meet in one point. det M keeps its sign on an
assembly branch (det J's sign times a factor that never vanishes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.rules.continuation import GROUP_ITERATIONS, GROUP_TOLERANCE, accepted, advance, largest

#: Newton steps :func:`polish` takes on every sample at once: from :data:`~.continuation.STENCIL`'s
#: predictions (their rows ≈ 1e-4) two steps reach GROUP_TOLERANCE; a sample still off then goes on
#: alone, up to GROUP_ITERATIONS steps in all
BATCH_STEPS = 2


@dataclass(frozen=True)
class Triad:
    """Which of a group's inputs and rows make it a triad: ``partner`` (3,) the input (index in the
    group's inputs) each body joint is hung from by a binary link, ``body`` (3,) the group's rows
    keeping its body rigid."""

    partner: np.ndarray
    body: np.ndarray

    @classmethod
    def of(cls, rows: Rows, joints: np.ndarray, inputs: np.ndarray, rest: np.ndarray) -> "Triad | None":
        """The triad of a group (``rows`` over the linkage's joints, its ``joints`` and ``inputs``,
        the ``rest`` pose (J,) complex it was compiled at), or None when it has another shape."""
        if joints.size != 3 or rows.m != 6 or rows.drive.any() or rows.dc.ndim != 2:
            return None
        own, known = list(joints.tolist()), list(inputs.tolist())
        partner, body = [-1, -1, -1], []
        for r, js in enumerate(rows.joints):
            if js <= set(own):
                body.append(r)
                continue
            ends = sorted(js)
            if len(ends) != 2 or not _is_distance(rows, r, ends):
                return None
            inner = [j for j in ends if j in own]
            outer = [j for j in ends if j in known]
            if len(inner) != 1 or len(outer) != 1 or partner[own.index(inner[0])] >= 0:
                return None
            k = own.index(inner[0])
            partner[k] = known.index(outer[0])
        if min(partner) < 0 or len(body) != 3:
            return None
        points = rest[joints]
        span = np.abs(points - points[0]).max() ** 2
        if abs(((points[1] - points[0]).conjugate() * (points[2] - points[0])).imag) <= 1e-9 * span:
            return None  # a straight body: its rows may not hold it rigid
        moved = rest.copy()  # the body's rows hold at any pose of the body: they keep it rigid
        centre = points.mean()
        moved[joints] = centre + 0.3 + 0.2j + np.exp(0.7j) * (points - centre)
        size = 1.0 + float(np.abs(rest).max()) ** 2
        if np.abs(rows.take(np.array(body)).residual(moved[:, None])).max() > 1e-9 * size:
            return None
        return cls(np.array(partner), np.array(body))

    def constants(self, rest: np.ndarray, joints: np.ndarray, inputs: np.ndarray) -> "Body":
        """The body of each of K rest poses ``rest`` (J, K) complex."""
        points, hung = rest[joints], rest[inputs][self.partner]  # (3, K)
        centre = points.mean(axis=0)
        p = points - centre
        r2 = np.abs(points - hung) ** 2
        det = _system(_bars(points - hung), p)[2]
        sign = np.where(det < 0.0, -1.0, 1.0)
        return Body(p[..., None], r2[..., None], centre, sign, 9.0 * (np.abs(p) ** 2).sum(axis=0) * r2.prod(axis=0),
                    np.abs(p).max(axis=0)[:, None], np.zeros(0))


@dataclass(frozen=True)
class Body:
    """K linkages' triad bodies: joints ``p`` (3, K, 1) complex about their centroid and links' lengths²
    ``r2`` (3, K, 1) at rest, where the body's centroid is at rest (K,) complex, det M's ``sign`` there
    (K,) (±1), d_s's constant denominator ``spread`` = det(NᵀN)·∏ r2_k = 9·Σ|p_k|²·∏ r2_k (K,) (the
    binary rows' norms at a solution), its ``reach`` max |p_k| (K, 1) (a move of the body by a
    shift s and a turn φ moves no joint further than |s| + |φ|·reach: :func:`moved`), and the Gram
    matrix J2·J2ᵀ of the body's rows at a turn u = c + i·s as ``gram`` (K, 6, 6): its entries (00,
    11, 22, 01, 02, 12) on (1, c, s, c², cs, s²) (:meth:`with_rows`)."""

    p: np.ndarray
    r2: np.ndarray
    rest: np.ndarray
    sign: np.ndarray
    spread: np.ndarray
    reach: np.ndarray
    gram: np.ndarray

    def with_rows(self, gradient: np.ndarray) -> "Body":
        """The body with its rows' Gram matrix from their gradient J2 (K, 3, 3, 6) at the body turned
        by u = 0, 1, i about the origin: J2(u) = C0 + c·C1 + s·C2 (the rows hold under any rigid
        motion, so their gradient does not move with the centre, and it is linear in the joints)."""
        c = gradient[:, 0], gradient[:, 1] - gradient[:, 0], gradient[:, 2] - gradient[:, 0]
        a = [[ca @ np.swapaxes(cb, -1, -2) for cb in c] for ca in c]  # C_a·C_bᵀ (K, 3, 3)
        terms = [a[0][0], a[0][1] + a[1][0], a[0][2] + a[2][0], a[1][1], a[1][2] + a[2][1], a[2][2]]
        rows, cols = np.array([0, 1, 2, 0, 0, 1]), np.array([0, 1, 2, 1, 2, 2])
        return replace(self, gram=np.stack([t[:, rows, cols] for t in terms], axis=-1))

    def linkage(self, c: int) -> tuple[list[complex], list[float], float, float]:
        """Linkage ``c``'s body joints and lengths² as Python numbers, its det M sign and reach."""
        return ([complex(v) for v in self.p[:, c, 0]], [float(v) for v in self.r2[:, c, 0]], float(self.sign[c]),
                float(self.reach[c, 0]))


def _is_distance(rows: Rows, r: int, ends: list[int]) -> bool:
    """Whether row ``r`` is |z_a − z_b|² = l² between the joints ``ends``."""
    dc, ec = rows.dc[r], rows.ec[r]
    a, b = ends
    plain = np.delete(np.arange(dc.size), ends)
    return (not rows.imag[r] and rows.d0[r] == 0 and rows.e0[r] == 0 and abs(dc[a]) == 1.0 and dc[b] == -dc[a]
            and np.array_equal(dc, ec) and not dc[plain].any())


def _bars(d: np.ndarray) -> np.ndarray:
    """d̄_0, d̄_1, d̄_2, d̄_0, d̄_1 (5, …) complex from d_k (3, …): :func:`_system`'s cyclic neighbours
    as slices."""
    e = np.empty((5, *d.shape[1:]), dtype=complex)
    np.conjugate(d, out=e[:3])
    e[3:] = e[:2]
    return e


def _system(e: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M's cofactors and det M from d̄_k (``e`` (5, …) complex, :func:`_bars`) and q_k (3, …): M's row
    k is (x_k, y_k, c_k) = (Re d_k, Im d_k, Im(d_k·q̄_k)), and the cross products of its columns are
    M⁻¹'s rows times det M: W_k = (C × X)_k + i·(Y × C)_k = c_{k+1}·d̄_{k+2} − c_{k+2}·d̄_{k+1} (…)
    complex, V_k = (X × Y)_k (…) real, det M = Σ_k x_k·(Y × C)_k (:func:`_solve`)."""
    c = np.empty(e.shape)
    np.negative((e[:3] * q).imag, out=c[:3])
    c[3:] = c[:2]
    w = c[1:4] * e[2:5]
    w -= c[2:5] * e[1:4]
    x, y = e.real, e.imag  # y = −Im d
    v = x[2:5] * y[1:4]
    v -= x[1:4] * y[2:5]
    return w, v, (x[:3] * w.imag).sum(axis=0)


def _solve(now: "Pose", rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body's move (its centre's (…) complex, its turn's (…)) with M·(Re, Im of the centre's,
    the turn's) = ``rhs`` (3, …), by Cramer's rule from :func:`_system`'s cofactors."""
    s = (now.w * rhs).sum(axis=0)  # det M·(v + i·u) for the move u + i·v
    np.conjugate(s, out=s)
    s *= 1j
    s /= now.det
    turn = (now.v * rhs).sum(axis=0)
    turn /= now.det
    return s, turn


def newton(p: list[complex], r2: list[float], reach: float, hung: list[complex], centre: complex, turn: float,
           tol: float) -> tuple[bool, float, float, complex, float]:
    """Newton's method on one linkage's body pose (``centre``, ``turn``) at one sample, the links
    hung from ``hung`` (3 complex), until every row is within ``tol`` of 0: Python numbers (a
    few of them: numpy's per-call cost would be most of the time), M's cofactors written out.
    Returns (converged, size of the first step (:func:`moved` with the body's ``reach``), det M at
    the solution (0: failed), the pose)."""
    (p0, p1, p2), (l0, l1, l2), (h0, h1, h2) = p, r2, hung
    first = 0.0
    for it in range(GROUP_ITERATIONS):
        u = complex(math.cos(turn), math.sin(turn))
        q0, q1, q2 = u * p0, u * p1, u * p2
        d0, d1, d2 = centre + q0 - h0, centre + q1 - h1, centre + q2 - h2
        a0, b0, a1, b1, a2, b2 = d0.real, d0.imag, d1.real, d1.imag, d2.real, d2.imag
        f0, f1, f2 = l0 - a0 * a0 - b0 * b0, l1 - a1 * a1 - b1 * b1, l2 - a2 * a2 - b2 * b2  # −F_k
        c0, c1, c2 = b0 * q0.real - a0 * q0.imag, b1 * q1.real - a1 * q1.imag, b2 * q2.real - a2 * q2.imag
        y0, y1, y2 = b1 * c2 - b2 * c1, b2 * c0 - b0 * c2, b0 * c1 - b1 * c0
        det = a0 * y0 + a1 * y1 + a2 * y2
        if max(abs(f0), abs(f1), abs(f2)) <= tol:
            return True, first, det, centre, turn
        if not (det != 0.0 and math.isfinite(det) and math.isfinite(f0 + f1 + f2)):
            return False, first, 0.0, centre, turn
        h = 0.5 / det  # M·step = −F/2
        dx = (f0 * y0 + f1 * y1 + f2 * y2) * h
        dy = (f0 * (c1 * a2 - c2 * a1) + f1 * (c2 * a0 - c0 * a2) + f2 * (c0 * a1 - c1 * a0)) * h
        dt = (f0 * (a1 * b2 - a2 * b1) + f1 * (a2 * b0 - a0 * b2) + f2 * (a0 * b1 - a1 * b0)) * h
        if it == 0:
            first = math.hypot(dx, dy) + abs(dt) * reach
        centre += complex(dx, dy)
        turn += dt
    return False, first, 0.0, centre, turn


def follow(body: Body, c: int, hung: np.ndarray, x: np.ndarray, path: np.ndarray, out: np.ndarray,
           travel: np.ndarray, tol: float) -> int:
    """Continue linkage ``c``'s body from the pose ``x`` (the centre's x, y and the turn, at sample
    ``path[0]``) through the samples ``path`` in order, writing each pose in ``out`` (T, 3)
    (``hung`` (3, T) complex: where its links hang from; ``travel`` (T,) the inputs' travel).
    Each move is a homotopy in ``hung`` (interpolated linearly,
    :func:`~linkedit.planar.rules.continuation.advance`), accepted when Newton converged close to
    where it started (:func:`~linkedit.planar.rules.continuation.accepted`, the body's move as
    :func:`moved` measures it) with det M's sign of the rest pose. Its first attempt starts from the
    pose extrapolated from the last three in ``travel`` (a parabola; the general group's from the
    last pose, Newton's first step then being the tangent predictor), the others from the last pose.
    Returns the position in ``path`` where it fails, or −1 (Python numbers throughout: a few of them
    per sample)."""
    p, r2, sign, reach = body.linkage(c)
    goals, along = hung[:, path].T.tolist(), travel[path].tolist()
    centres, turns = [complex(x[0], x[1])], [float(x[2])]  # the poses reached, one per sample of path

    def move(start: complex, spin: float, at: list[complex]) -> tuple[complex, float] | None:
        """Newton from (start, spin) with the links hung from ``at``: its pose when accepted."""
        ok, first, det, g, th = newton(p, r2, reach, at, start, spin, tol)
        if not ok or det * sign <= 0.0:
            return None
        return (g, th) if accepted(abs(g - start) + abs(th - spin) * reach, first) else None

    failed = -1
    for n in range(len(goals)):
        centre, turn, goal = centres[-1], turns[-1], goals[n]
        start, spin = centre, turn
        guessed = n >= 3 and along[n - 1] > along[n - 2] > along[n - 3]
        if guessed:  # the parabola through the last three
            ta, tb, tc, tx = along[n - 3], along[n - 2], along[n - 1], along[n]
            wa, wb = (tx - tb) * (tx - tc) / ((ta - tb) * (ta - tc)), (tx - ta) * (tx - tc) / ((tb - ta) * (tb - tc))
            wc = 1.0 - wa - wb
            start = wa * centres[-3] + wb * centres[-2] + wc * centre
            spin = wa * turns[-3] + wb * turns[-2] + wc * turn
        reached = move(start, spin, goal)
        if reached is None and n:  # the homotopy from the last pose, in pieces
            prev, now = goals[n - 1], [(centre, turn)]

            def attempt(f: float) -> bool:
                at = goal if f == 1.0 else [a + f * (b - a) for a, b in zip(prev, goal)]
                step = move(*now[0], at)
                if step is not None:
                    now[0] = step
                return step is not None

            reached = now[0] if advance(attempt, 1.0 if guessed else 0.5) else None
        if reached is None:
            failed = n
            break
        centres.append(reached[0])
        turns.append(reached[1])
    done = len(centres) - 1
    if done:
        poses = np.array([centres[1:], turns[1:]])
        out[path[:done], 0], out[path[:done], 1], out[path[:done], 2] = poses[0].real, poses[0].imag, poses[1].real
    return failed


@dataclass
class Poses:
    """K linkages' triads continued in their bodies' poses (:class:`~.continuation.Continued`: the
    centre's x, y and the turn from rest, per sample), hung from ``hung`` (3, K, T) complex; the
    polish's pose of every sample (``now``) once it has run."""

    body: Body
    hung: np.ndarray
    width: int = 3
    now: "Pose | None" = None

    def start(self, c: int) -> np.ndarray:
        return np.array([self.body.rest[c].real, self.body.rest[c].imag, 0.0])

    def follow(self, c: int, x: np.ndarray, path: np.ndarray, out: np.ndarray, travel: np.ndarray,
               tol: float) -> int:
        return follow(self.body, c, self.hung[:, c], x, path, out, travel, tol)

    def polish(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`polish` from the poses X (K, T, 3); its value is det M."""
        self.now, turn, ok = polish(self.body, self.hung, X[..., 0] + 1j * X[..., 1], X[..., 2], GROUP_TOLERANCE)
        X[..., 0], X[..., 1], X[..., 2] = self.now.centre.real, self.now.centre.imag, turn
        return ok, np.where(ok, self.now.det, np.nan)


@dataclass
class Pose:
    """The triads of K linkages over T samples once solved: the body's centroid ``centre`` (K, T)
    complex and turn ``u`` = e^{iθ} (K, T) complex (from rest), its joints ``q`` = P_k − centre
    (3, K, T) complex, d̄_k = conj(P_k − A_k) (``e``, :func:`_bars`), M's cofactors ``w`` (3, K, T)
    complex and ``v`` (3, K, T) and determinant (K, T) there (:func:`_system`)."""

    centre: np.ndarray
    u: np.ndarray
    q: np.ndarray
    e: np.ndarray
    w: np.ndarray
    v: np.ndarray
    det: np.ndarray

    @property
    def joints(self) -> np.ndarray:
        """P_k (3, K, T) complex."""
        return self.centre + self.q


def pose(body: Body, hung: np.ndarray, centre: np.ndarray, turn: np.ndarray) -> tuple[Pose, np.ndarray]:
    """The pose of every sample at (``centre``, ``turn``) (K, T) and its rows F_k (3, K, T)."""
    u = np.empty(turn.shape, dtype=complex)
    np.cos(turn, out=u.real)
    np.sin(turn, out=u.imag)
    q = u * body.p
    d = q + centre
    d -= hung
    e = _bars(d)
    res = np.subtract((d * e[:3]).real, body.r2)  # |d_k|² − r2_k
    return Pose(centre, u, q, e, *_system(e, q)), res


def polish(body: Body, hung: np.ndarray, centre: np.ndarray, turn: np.ndarray,
           tol: float) -> tuple[Pose, np.ndarray, np.ndarray]:
    """Newton's method on every sample of K linkages at once from the predicted poses (``centre``
    (K, T) complex, ``turn`` (K, T)), until every row is within ``tol`` of 0: BATCH_STEPS steps on
    all of them, then the few samples still off (slow near a singular position, or never converging:
    a linkage that cannot be assembled there) on their own, so that they do not cost a step of every
    sample each. Returns the pose, its turn (K, T) and which samples (K, T) are accepted: converged,
    close to their predictor (:func:`~linkedit.planar.rules.continuation.accepted`), with det M's
    sign of their rest pose."""
    start, spun = centre, turn
    now, res, centre, turn, first = _steps(body, hung, centre, turn, tol, BATCH_STEPS)
    worst = _worst(res)
    off = worst > tol  # (NaN rows are left alone)
    if off.any():
        k, t = np.nonzero(off)
        alone = replace(body, p=body.p[:, k, 0][:, None], r2=body.r2[:, k, 0][:, None], reach=body.reach[k, 0][None])
        more = _steps(alone, hung[:, k, t][:, None], centre[k, t][None], turn[k, t][None], tol,
                      GROUP_ITERATIONS - BATCH_STEPS)
        centre, turn = centre.copy(), turn.copy()
        centre[k, t], turn[k, t] = more[2][0], more[3][0]
        now, res = pose(body, hung, centre, turn)
        worst = _worst(res)
    ok = (worst <= tol) & accepted(moved(body, centre - start, turn - spun), first)
    ok &= now.det * body.sign[:, None] > 0.0
    return now, turn, ok


def _steps(body: Body, hung: np.ndarray, centre: np.ndarray, turn: np.ndarray, tol: float,
           steps: int) -> tuple[Pose, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Up to ``steps`` Newton steps on the poses (``centre``, ``turn``) (K, T) together, until every
    row is within ``tol`` of 0. Returns the pose reached, its rows (3, K, T), its centre and turn, and
    the size of the first step (K, T) (:func:`moved`; 0 where none was taken)."""
    now, res = pose(body, hung, centre, turn)
    first = np.zeros(turn.shape)
    for it in range(steps):
        if not (np.abs(res) > tol).any():  # (NaN rows are left alone)
            break
        res *= -0.5
        shift, spin = _solve(now, res)
        if it == 0:
            first = moved(body, shift, spin)
        centre = centre + shift
        turn = turn + spin
        now, res = pose(body, hung, centre, turn)
    return now, res, centre, turn, first


def moved(body: Body, shift: np.ndarray, spin: np.ndarray) -> np.ndarray:
    """The most any joint of the body moves (K, T), at most, when it is shifted by ``shift`` (K, T)
    complex and turned by ``spin`` (K, T): |shift| + |spin|·reach (P_k moves by shift +
    (e^{i·spin} − 1)·q_k, |e^{i·spin} − 1| ≤ |spin|), the measure :func:`~.continuation.accepted`
    compares (Python's :func:`newton` and :func:`follow` take the same)."""
    out = np.abs(shift)
    out += np.abs(spin) * body.reach
    return out


def _worst(rows: np.ndarray) -> np.ndarray:
    """max |·| (K, T) over the three ``rows`` (3, K, T) (NaN where any is NaN)."""
    return largest(rows.reshape(3, -1).T).reshape(rows.shape[1:])


def ds(now: Pose, body: Body) -> np.ndarray:
    """The group's d_s (K, T) (the module docstring's formula) at the solution ``now``, |d_k|² = r2_k."""
    c, s = now.u.real, now.u.imag
    basis = np.empty((c.shape[0], 6, c.shape[1]))
    basis[:, 0], basis[:, 1], basis[:, 2] = 1.0, c, s
    np.multiply(c, c, out=basis[:, 3])
    np.multiply(c, s, out=basis[:, 4])
    np.multiply(s, s, out=basis[:, 5])
    g00, g11, g22, g01, g02, g12 = np.moveaxis(body.gram @ basis, 1, 0)  # (K, T) each
    det = g00 * (g11 * g22 - g12 * g12) - g01 * (g01 * g22 - g12 * g02) + g02 * (g01 * g12 - g11 * g02)
    rows = g00 * g11 * g22
    rows *= body.spread[:, None]
    return np.minimum(now.det * now.det * det / rows, 1.0)


def rates(now: Pose, dhung: np.ndarray, ddhung: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Velocities and accelerations (3, K, T) complex of the body's joints from those of the joints
    its links hang from (``dhung``, ``ddhung`` (3, K, T)): the rows' first and second derivatives,
    Re(d̄_k·(P_k' − A_k')) = 0 and Re(d̄_k·(P_k'' − A_k'')) + |P_k' − A_k'|² = 0, solved for the body's
    (G', ω) and (G'', α) by Cramer's rule."""
    e, q = now.e[:3], now.q
    velocity, omega = _solve(now, (e * dhung).real)
    iq = 1j * q
    first = velocity + omega * iq
    if ddhung is None:
        return first, None
    rel = first - dhung
    w2 = omega * omega
    rhs = (e * (ddhung + w2 * q)).real - (rel.real ** 2 + rel.imag ** 2)
    acceleration, alpha = _solve(now, rhs)
    return first, acceleration + alpha * iq - w2 * q
