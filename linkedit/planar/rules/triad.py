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
:func:`~linkedit.planar.rules.group.conditioning`) is

    d_s = det M² · det(J2·J2ᵀ) / (9·Σ|p_k|² · ∏|d_k|² · ∏ diag(J2·J2ᵀ)),

zero exactly where the three binary links' lines meet in one point. det M keeps its sign on an
assembly branch (det J's sign times a factor that never vanishes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.rules.continuation import GROUP_ITERATIONS, accepted, largest

_NEXT, _AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])  # k + 1, k + 2 (mod 3)


@dataclass(frozen=True)
class Triad:
    """Which of a group's inputs and rows make it a triad: ``partner`` (3,) the input (index in the
    group's inputs) each body joint is hung from, ``binary`` (3,) and ``body`` (3,) the group's rows
    of its binary links (by body joint) and of its body."""

    partner: np.ndarray
    binary: np.ndarray
    body: np.ndarray

    @classmethod
    def of(cls, rows: Rows, joints: np.ndarray, inputs: np.ndarray, rest: np.ndarray) -> "Triad | None":
        """The triad of a group (``rows`` over the linkage's joints, its ``joints`` and ``inputs``,
        the ``rest`` pose (J,) complex it was compiled at), or None when it has another shape."""
        if joints.size != 3 or rows.m != 6 or rows.drive.any() or rows.dc.ndim != 2:
            return None
        own, known = list(joints.tolist()), list(inputs.tolist())
        partner, binary, body = [-1, -1, -1], [-1, -1, -1], []
        for r, js in enumerate(rows.joints):
            if js <= set(own):
                body.append(r)
                continue
            ends = sorted(js)
            if len(ends) != 2 or not _is_distance(rows, r, ends):
                return None
            inner = [j for j in ends if j in own]
            outer = [j for j in ends if j in known]
            if len(inner) != 1 or len(outer) != 1 or binary[own.index(inner[0])] >= 0:
                return None
            k = own.index(inner[0])
            partner[k], binary[k] = known.index(outer[0]), r
        if min(binary) < 0 or len(body) != 3:
            return None
        points = rest[joints]
        if abs(((points[1] - points[0]).conjugate() * (points[2] - points[0])).imag) <= 1e-9 * np.abs(points - points[0]).max() ** 2:
            return None  # a straight body: its rows may not hold it rigid
        moved = rest.copy()  # the body's rows hold at any pose of the body: they keep it rigid
        centre = points.mean()
        moved[joints] = centre + 0.3 + 0.2j + np.exp(0.7j) * (points - centre)
        size = 1.0 + float(np.abs(rest).max()) ** 2
        if np.abs(rows.take(np.array(body)).residual(moved[:, None])).max() > 1e-9 * size:
            return None
        return cls(np.array(partner), np.array(binary), np.array(body))

    def constants(self, rest: np.ndarray, joints: np.ndarray, inputs: np.ndarray) -> "Body":
        """The body of each of K rest poses ``rest`` (J, K) complex."""
        points, hung = rest[joints], rest[inputs][self.partner]  # (3, K)
        centre = points.mean(axis=0)
        p = points - centre
        r2 = np.abs(points - hung) ** 2
        m = _matrix(points - hung, p)
        det = (m[0] * _cofactors(m)[0]).sum(axis=0)
        sign = np.where(det < 0.0, -1.0, 1.0)
        return Body(p[..., None], r2[..., None], centre, sign, 9.0 * (np.abs(p) ** 2).sum(axis=0), np.zeros(0))


@dataclass(frozen=True)
class Body:
    """K linkages' triad bodies: joints ``p`` (3, K, 1) complex about their centroid and links' lengths²
    ``r2`` (3, K, 1) at rest, where the body's centroid is at rest (K,) complex, det M's ``sign`` there
    (K,) (±1), det(NᵀN) = 9·Σ|p_k|² (K,), and the gradient J2 (3, 6) of the body's rows at a turn u:
    C0 + Re(u)·C1 + Im(u)·C2, ``gradient`` (C0, C1, C2) (3, K, 3, 6) (the rows hold under any
    rigid motion: their gradient does not move with the body's centre, and it is linear in its
    joints; :meth:`~linkedit.planar.rules.group.Group.constants` fills it in)."""

    p: np.ndarray
    r2: np.ndarray
    rest: np.ndarray
    sign: np.ndarray
    spread: np.ndarray
    gradient: np.ndarray

    def linkage(self, c: int) -> tuple[list[complex], list[float], float]:
        """Linkage ``c``'s body joints and lengths² as Python numbers, and its det M sign."""
        return [complex(v) for v in self.p[:, c, 0]], [float(v) for v in self.r2[:, c, 0]], float(self.sign[c])


def _is_distance(rows: Rows, r: int, ends: list[int]) -> bool:
    """Whether row ``r`` is |z_a − z_b|² = l² between the joints ``ends``."""
    dc, ec = rows.dc[r], rows.ec[r]
    a, b = ends
    plain = np.delete(np.arange(dc.size), ends)
    return (not rows.imag[r] and rows.d0[r] == 0 and rows.e0[r] == 0 and abs(dc[a]) == 1.0 and dc[b] == -dc[a]
            and np.array_equal(dc, ec) and not dc[plain].any())


def _matrix(d: np.ndarray, q: np.ndarray) -> np.ndarray:
    """M (column, row k, …): its columns Re d_k, Im d_k, c_k = Re(d̄_k·i·q_k) from d_k and q_k (3, …)."""
    m = np.empty((3, *d.shape))
    x, y = d.real, d.imag
    m[0], m[1] = x, y
    np.multiply(y, q.real, out=m[2])
    m[2] -= x * q.imag
    return m


def _cofactors(m: np.ndarray) -> np.ndarray:
    """M's cofactors (column j, row k, …): the cross product of its columns j + 1 and j + 2, so
    that Σ_k cof[j, k]·M[i, k] = δ_ij·det M (M⁻¹'s rows times det M)."""
    a, b = m[:, _NEXT], m[:, _AFTER]  # rows k + 1, k + 2
    return a[_NEXT] * b[_AFTER] - b[_NEXT] * a[_AFTER]


def _solve(cof: np.ndarray, det: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """(u, v, w) (3, …) with M·(u, v, w) = rhs (3, …), by Cramer's rule from M's cofactors and determinant."""
    return (cof * rhs).sum(axis=1) / det


def newton(p: list[complex], r2: list[float], hung: list[complex], centre: complex, turn: float,
           tol: float) -> tuple[bool, float, float, complex, float]:
    """Newton's method on one linkage's body pose (``centre``, ``turn``) at one sample, the links
    hung from ``hung`` (3 complex), until every row is within ``tol`` of 0: Python numbers (a
    few of them: numpy's per-call cost would be most of the time). Returns (converged, size of
    the first step (its largest joint move), det M at the solution (0: failed), the pose)."""
    first = 0.0
    for it in range(GROUP_ITERATIONS):
        u = complex(math.cos(turn), math.sin(turn))
        m, worst = [], 0.0
        for k in range(3):
            q = u * p[k]
            d = centre + q - hung[k]
            res = d.real * d.real + d.imag * d.imag - r2[k]
            m.append((d.real, d.imag, d.imag * q.real - d.real * q.imag, -0.5 * res, q))
            worst = max(worst, abs(res))
        (a0, b0, c0, f0, _), (a1, b1, c1, f1, _), (a2, b2, c2, f2, _) = m
        yc = (b1 * c2 - b2 * c1, b2 * c0 - b0 * c2, b0 * c1 - b1 * c0)
        det = a0 * yc[0] + a1 * yc[1] + a2 * yc[2]
        if worst <= tol:
            return True, first, det, centre, turn
        if not (worst < math.inf and det != 0.0 and math.isfinite(det)):
            return False, first, 0.0, centre, turn
        cx = (c1 * a2 - c2 * a1, c2 * a0 - c0 * a2, c0 * a1 - c1 * a0)
        xy = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)
        dx = (f0 * yc[0] + f1 * yc[1] + f2 * yc[2]) / det
        dy = (f0 * cx[0] + f1 * cx[1] + f2 * cx[2]) / det
        dt = (f0 * xy[0] + f1 * xy[1] + f2 * xy[2]) / det
        if it == 0:
            first = max(max(abs(dx - dt * q.imag), abs(dy + dt * q.real)) for *_, q in m)
        centre += complex(dx, dy)
        turn += dt
    return False, first, 0.0, centre, turn


def follow(body: Body, c: int, hung: np.ndarray, path: np.ndarray, tol: float) -> tuple[np.ndarray, int]:
    """Continue linkage ``c``'s body from its rest pose through the samples ``path`` in order
    (``hung`` (3, T) complex: where its links hang from). Each move is a homotopy in ``hung``
    (interpolated linearly), accepted only when Newton converges close to where it started
    (:func:`~linkedit.planar.rules.continuation.accepted`, the largest joint move) with det M's
    sign of the rest pose, else halved (down to 1/256). Returns the poses (len(path), 3): the
    centre's x, y and the turn, and the position in ``path`` where it fails, or −1."""
    p, r2, sign = body.linkage(c)
    centre, turn = complex(body.rest[c]), 0.0
    out = np.full((path.size, 3), np.nan)
    prev = [complex(v) for v in hung[:, path[0]]]
    for n, t in enumerate(path.tolist()):
        goal = [complex(v) for v in hung[:, t]]
        done, piece = 0.0, 1.0
        while done < 1.0:
            f = min(done + piece, 1.0)
            at = goal if f == 1.0 else [a + f * (b - a) for a, b in zip(prev, goal)]
            ok, first, det, g, th = newton(p, r2, at, centre, turn, tol)
            if ok:
                u, v = complex(math.cos(turn), math.sin(turn)), complex(math.cos(th), math.sin(th))
                moved = max(max(abs(w.real), abs(w.imag)) for w in (g + v * pk - centre - u * pk for pk in p))
                ok = bool(accepted(moved, first)) and det * sign > 0.0
            if ok:
                centre, turn, done = g, th, f
                piece = min(2.0 * piece, 1.0)
            else:
                piece *= 0.5
                if piece < 1.0 / 256:
                    return out, n
        out[n] = centre.real, centre.imag, turn
        prev = goal
    return out, -1


def at(body: Body, joints: np.ndarray, hung: np.ndarray) -> "Pose":
    """The pose of the triads whose joints are at ``joints`` (3, K, T) complex (NaN: not placed)."""
    centre = joints.mean(axis=0)
    q = joints - centre
    d = joints - hung
    m = _matrix(d, q)
    cof = _cofactors(m)
    u = (body.p.conj() * q).sum(axis=0) / (body.spread[:, None] / 9.0)
    return Pose(centre, u, q, d, cof, (m[0] * cof[0]).sum(axis=0))


@dataclass
class Pose:
    """The triads of K linkages over T samples once solved: the body's centroid ``centre`` (K, T)
    complex and turn ``u`` = e^{iθ} (K, T) complex (from rest), its joints ``q`` = P_k − centre
    (3, K, T) complex, d_k = P_k − A_k (3, K, T) complex, M's cofactors (3, 3, K, T) and determinant
    (K, T) there."""

    centre: np.ndarray
    u: np.ndarray
    q: np.ndarray
    d: np.ndarray
    cof: np.ndarray
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
    d = centre + q - hung
    res = d.real * d.real + d.imag * d.imag - body.r2
    m = _matrix(d, q)
    cof = _cofactors(m)
    return Pose(centre, u, q, d, cof, (m[0] * cof[0]).sum(axis=0)), res


def polish(body: Body, hung: np.ndarray, centre: np.ndarray, turn: np.ndarray, tol: float) -> tuple[Pose, np.ndarray]:
    """Newton's method on every sample of K linkages at once from the predicted poses (``centre``
    (K, T) complex, ``turn`` (K, T)), until every row is within ``tol`` of 0. Returns the pose and
    which samples (K, T) are accepted: converged, close to their predictor
    (:func:`~linkedit.planar.rules.continuation.accepted`), with det M's sign of their rest pose."""
    now, res = pose(body, hung, centre, turn)
    start, first = now.joints, np.zeros(turn.shape)
    for it in range(GROUP_ITERATIONS):
        size = _worst(res)
        if not (size > tol).any():
            break
        step = _solve(now.cof, now.det, -0.5 * res)
        if it == 0:
            first = _worst(step[0] - step[2] * now.q.imag, step[1] + step[2] * now.q.real)
        centre = centre + (step[0] + 1j * step[1])
        turn = turn + step[2]
        now, res = pose(body, hung, centre, turn)
    moved = now.joints - start
    ok = (_worst(res) <= tol) & accepted(_worst(moved.real, moved.imag), first) & (now.det * body.sign[:, None] > 0.0)
    return now, ok


def _worst(*parts: np.ndarray) -> np.ndarray:
    """max |·| (K, T) over the three rows (3, K, T) of each of ``parts`` (NaN where any is NaN)."""
    out = np.abs(parts[0][0])
    for part in parts:
        for k in range(3):
            if part is not parts[0] or k:
                np.maximum(out, np.abs(part[k]), out=out)
    return out


def ds(now: Pose, body: Body) -> np.ndarray:
    """The group's d_s (K, T) (the module docstring's formula) at the solution ``now``."""
    c0, c1, c2 = body.gradient[:, :, None]
    j2 = c0 + now.u.real[..., None, None] * c1 + now.u.imag[..., None, None] * c2  # (K, T, 3, 6)
    g = j2 @ np.swapaxes(j2, -1, -2)
    det = (g[..., 0, 0] * (g[..., 1, 1] * g[..., 2, 2] - g[..., 1, 2] * g[..., 2, 1])
           - g[..., 0, 1] * (g[..., 1, 0] * g[..., 2, 2] - g[..., 1, 2] * g[..., 2, 0])
           + g[..., 0, 2] * (g[..., 1, 0] * g[..., 2, 1] - g[..., 1, 1] * g[..., 2, 0]))
    rows = g[..., 0, 0] * g[..., 1, 1] * g[..., 2, 2] * body.spread[:, None]
    d2 = now.d.real ** 2 + now.d.imag ** 2
    rows = rows * d2[0] * d2[1] * d2[2]
    return np.minimum(now.det ** 2 * det / np.maximum(rows, 1e-300), 1.0)


def rates(now: Pose, dhung: np.ndarray, ddhung: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Velocities and accelerations (3, K, T) complex of the body's joints from those of the joints
    its links hang from (``dhung``, ``ddhung`` (3, K, T)): the rows' first and second derivatives,
    Re(d̄_k·(P_k' − A_k')) = 0 and Re(d̄_k·(P_k'' − A_k'')) + |P_k' − A_k'|² = 0, solved for the body's
    (G', ω) and (G'', α) by Cramer's rule."""
    d, q = now.d, now.q
    vx, vy, omega = _solve(now.cof, now.det, (d.conj() * dhung).real)
    iq = 1j * q
    first = (vx + 1j * vy) + omega * iq
    if ddhung is None:
        return first, None
    rel = first - dhung
    w2 = omega * omega
    rhs = (d.conj() * (ddhung + w2 * q)).real - (rel.real ** 2 + rel.imag ** 2)
    ax, ay, alpha = _solve(now.cof, now.det, rhs)
    return first, (ax + 1j * ay) + alpha * iq - w2 * q
