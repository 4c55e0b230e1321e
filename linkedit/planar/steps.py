"""Rules of the new kinds: sliders, the linear input, translating links, numeric groups.

Each :class:`Step` writes some joints from joints known before it, over T samples at once:

* ``slider`` (circle–line): joint k on a known slot line (point P, unit direction D) at the
  fixed distance l from the known joint i: with q = z_i − P, a = Re(D̄q), p = Im(D̄q),
  z_k = P + D·(a + σ·sqrt(l² − p²)); σ = ±1 is the side taken at rest, never changed.
  l² < p² is a lock-up (the rod cannot reach the line); d_s = (l² − p²)/l² is 0 where the rod
  stands perpendicular to the line.
* ``drive``: the linearly driven joint, z_k = P + D·s.
* ``lines``: a joint in two slots whose lines (P₁, D₁), (P₂, D₂) are known: their crossing
  z_k = P₁ + D₁·Im(D̄₂(P₂ − P₁))/Im(D̄₂D₁); one solution, no branch. d_s = sin² of the angle
  between the lines: 0 where they are parallel (no single crossing: a lock-up naming both sliders).
* ``rotate`` / ``yoke``: a slotted link turning about its known joint / translating along the
  frame until its slot meets a known pin (see :func:`_slotted_positions`).
* ``group``: a complex loop: Newton's method on the group's constraint rows at every sample
  (the samples are dense: see :func:`linkedit.planar.kinematics.evaluate`), continued from the
  rest pose through every GROUP_STRIDE-th sample, the samples between polished all at once
  from a predictor and checked (:func:`solve_group`), keeping the rest pose's branch (the sign
  of the group Jacobian's determinant never changes; a change means the group passed a
  singular position, reported as a lock-up).

Velocities and accelerations of every step come from its constraint rows F(z) = 0 by the
implicit function theorem: J_S·ż_S = −dF[ż_K] + F_s·ṡ and J_S·z̈_S = −dF[z̈_K] − d²F[ż, ż]
(the rows are bilinear, see :mod:`linkedit.planar.constraints`), one small batched solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.constraints import Rows, _Builder, linkage_rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule

#: Newton's method stops when every row is within this of 0 (rows are in units of the
#: linkage's characteristic length, squared for distance rows)
GROUP_TOLERANCE = 1e-13
GROUP_ITERATIONS = 12
#: a numeric group is continued sequentially through every GROUP_STRIDE-th sample only; the
#: samples between are predicted from those and polished all at once
GROUP_STRIDE = 20


@dataclass(frozen=True)
class Step:
    """One compiled rule of a new kind (see module docstring). Indices are joints (spec order)."""

    kind: str
    level: int
    joints: np.ndarray  # (n,) joints written
    inputs: np.ndarray  # joints read
    name: str  # the slider's name, or the group's joints
    rows: Rows  # the rows the written joints satisfy (for derivatives and checks)
    i: int = -1  # slider: the joint at a fixed distance; rotate: the joint the link turns about
    l2: float = 0.0  # slider: squared rod length; rotate: the pin's rest offset h across the slot; yoke: Im(ū̄·g)
    sign: float = 1.0  # slider, rotate: which of the two solutions, taken at rest
    offsets: np.ndarray | None = None  # rotate: (n,) rest offsets z̄_n − z̄_i; yoke: rest positions z̄_n
    slider: int = -1  # rotate, yoke: index into graph.sliders
    pin: int = -1  # rotate, yoke: the known joint in the link's slot
    u: complex = 0j  # rotate, yoke: the slot's direction at rest
    g: complex = 0j  # yoke: the direction the link translates in
    at: complex = 0j  # yoke: the pin's rest position
    det_sign: float = 1.0  # group: sign of det J_S at rest
    #: rows of ``rows`` taken from :func:`~linkedit.planar.constraints.linkage_rows` (their
    #: indices there), −1 for the step's own row (a slider's rod)
    source: np.ndarray | None = None

    def describe(self, names: list[str]) -> str:
        out = ", ".join(names[k] for k in self.joints)
        src = ", ".join(names[k] for k in self.inputs)
        what = {"slider": f"slider {self.name}", "drive": f"linear input {self.name}",
                "lines": f"two slots, sliders {self.name}",
                "group": "numeric group",
                "rotate": f"slotted link turning, slider {self.name}",
                "yoke": f"slotted link translating (yoke), slider {self.name}"}[self.kind]
        return f"{out} ← ({src}) {what}"


def _line(rows: Rows, r: int, k: int, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Point P and direction D (T,) of slot row ``r`` (joint ``k`` removed from E = z_k − P)."""
    d = rows.dc[r] @ z + rows.d0[r]
    ec = rows.ec[r].copy()
    ec[k] = 0.0
    return -(ec @ z + rows.e0[r]), d


def compile_step(graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> Step:
    """Build the :class:`Step` of ``rule`` at ``graph``'s rest pose."""
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    names = graph.joint_names
    joints = np.array(rule.joints, dtype=int)
    if rule.kind in ("group", "rotate", "yoke"):
        inside = known | set(rule.joints)
        use = np.array([r for r, js in enumerate(all_rows.joints) if js <= inside and js & set(rule.joints)])
        rows = all_rows.take(use)
        inputs = sorted(set().union(*rows.joints) - set(rule.joints))
        if rule.kind != "group":
            return _slotted(graph, rule, rows, np.array(inputs, dtype=int), use, z)
        jac = rows.jacobian(z[:, None], joints)[0]
        det = np.linalg.det(jac) if jac.shape[0] == jac.shape[1] else 1.0
        return Step("group", rule.level, joints, np.array(inputs, dtype=int),
                    ", ".join(names[k] for k in rule.joints), rows, det_sign=float(np.sign(det)) or 1.0,
                    source=use)
    s = graph.sliders[rule.slider]
    own = [r for r, lab in enumerate(all_rows.labels) if lab == f"slider {s.name}"]
    b = _Builder(graph.n_joints)
    k = rule.joints[0]
    base = all_rows.take(np.array(own))
    if rule.kind == "lines":
        o = graph.sliders[rule.i]
        both = own + [r for r, lab in enumerate(all_rows.labels) if lab == f"slider {o.name}"]
        rows = all_rows.take(np.array(both))
        inputs = sorted(set().union(*rows.joints) - {k})
        return Step("lines", rule.level, joints, np.array(inputs, dtype=int), f"{s.name} and {o.name}", rows,
                    slider=rule.slider, source=np.array(both))
    if rule.kind == "drive":
        drive = [r for r, lab in enumerate(all_rows.labels) if lab == f"linear input {s.name}"]
        rows = all_rows.take(np.array(own + drive))
        inputs = sorted(set().union(*rows.joints) - {k})
        return Step("drive", rule.level, joints, np.array(inputs, dtype=int), s.name, rows,
                    source=np.array(own + drive))
    i = rule.i
    l2 = abs(z[k] - z[i]) ** 2
    b.add(False, {k: 1, i: -1}, 0j, {k: 1, i: -1}, 0j, f"slider {s.name} rod", rhs=l2)
    rows = _concat(base, b.build())
    p, d = _line(rows, 0, k, z[:, None])
    foot = (np.conj(d) * (z[i] - p)).real
    side = (np.conj(d) * (z[k] - p)).real - foot
    if abs(side[0]) <= 1e-9 * np.sqrt(l2):
        raise MechanismError(
            f"joint {names[k]} of slider {s.name}: the rod {names[i]}–{names[k]} stands perpendicular to "
            "the slot at the rest pose: which side it takes is undefined; move it off the perpendicular")
    inputs = sorted(set().union(*rows.joints) - {k})
    return Step("slider", rule.level, joints, np.array(inputs, dtype=int), s.name, rows, i=i,
                l2=float(l2), sign=float(np.sign(side[0])), source=np.array(own + [-1]))


def _slotted(graph: LinkageGraph, rule: StepRule, rows: Rows, inputs: np.ndarray, use: np.ndarray,
             z: np.ndarray) -> Step:
    """A ``rotate`` or ``yoke`` step (see :class:`~linkedit.planar.ordering.StepRule`)."""
    slot = graph.sliders[rule.slider]
    k = slot.joint
    u = np.exp(1j * slot.angle)
    joints = np.array(rule.joints, dtype=int)
    if rule.kind == "rotate":
        a = rule.i
        q = np.conj(u) * (z[k] - z[a])
        return Step("rotate", rule.level, joints, inputs, slot.name, rows, i=a, l2=float(q.imag),
                    sign=float(np.sign(q.real)) or 1.0, offsets=z[joints] - z[a], slider=rule.slider, source=use,
                    pin=k, u=complex(u))
    g = np.exp(1j * graph.sliders[rule.i].angle)
    cross = float((np.conj(u) * g).imag)
    if abs(cross) <= 1e-9:
        raise MechanismError(f"slider {slot.name}: the slot is parallel to the direction its link translates in: "
                             "the pin cannot move it")
    return Step("yoke", rule.level, joints, inputs, slot.name, rows, l2=cross, offsets=z[joints],
                slider=rule.slider, source=use, pin=k, u=complex(u), g=complex(g), at=complex(z[k]))


def _concat(a: Rows, b: Rows) -> Rows:
    return Rows(np.concatenate([a.imag, b.imag]), np.vstack([a.dc, b.dc]), np.concatenate([a.d0, b.d0]),
                np.vstack([a.ec, b.ec]), np.concatenate([a.e0, b.e0]), np.concatenate([a.rhs, b.rhs]),
                np.concatenate([a.drive, b.drive]), a.joints + b.joints, a.labels + b.labels)


def positions(step: Step, z: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n, T) of the step's joints and its singularity distance (T,) (< 0 or NaN: cannot place).

    ``z`` (J, T) complex joint positions (the step's inputs filled in), ``s`` (T,) the linear input.
    """
    if step.kind == "drive":
        p, d = _line(step.rows, 0, step.joints[0], z)
        return (p + d * s)[None], np.ones(z.shape[1])
    if step.kind == "lines":
        (p1, d1), (p2, d2) = _line(step.rows, 0, step.joints[0], z), _line(step.rows, 1, step.joints[0], z)
        cross = (np.conj(d2) * d1).imag
        with np.errstate(invalid="ignore", divide="ignore"):
            at = (np.conj(d2) * (p2 - p1)).imag / cross
        return (p1 + d1 * at)[None], cross * cross / ((d1 * np.conj(d1)).real * (d2 * np.conj(d2)).real)
    if step.kind == "slider":
        p, d = _line(step.rows, 0, step.joints[0], z)
        d = d / np.abs(d)
        q = np.conj(d) * (z[step.i] - p)
        h2 = step.l2 - q.imag * q.imag
        with np.errstate(invalid="ignore"):
            x = q.real + step.sign * np.sqrt(h2)
        return (p + d * x)[None], h2 / step.l2
    return _slotted_positions(step, z)


def _slotted_positions(step: Step, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``rotate``: the link turns about joint i by R = ū̄·w / (σ·sqrt(|w|² − h²) + i·h), w = z_pin − z_i,
    h the pin's rest offset across the slot; d_s = 1 − h²/|w|² (< 0: the slot cannot reach the pin).
    ``yoke``: it slides by λ·g, λ = Im(ū̄·(z_pin − z̄_pin)) / Im(ū̄·g); d_s = Im(ū̄·g)², constant."""
    offsets = step.offsets
    if offsets is None or step.kind not in ("yoke", "rotate"):
        raise ValueError(f"a {step.kind!r} step is not a slotted link")
    if step.kind == "yoke":
        along = (np.conj(step.u) * (z[step.pin] - step.at)).imag / step.l2
        return offsets[:, None] + along * step.g, np.full(z.shape[1], step.l2 * step.l2)
    w = z[step.pin] - z[step.i]
    w2 = w.real * w.real + w.imag * w.imag
    h = step.l2
    with np.errstate(invalid="ignore", divide="ignore"):
        rot = np.conj(step.u) * w / (step.sign * np.sqrt(w2 - h * h) + 1j * h)
        return z[step.i] + offsets[:, None] * rot, 1.0 - h * h / w2


@dataclass(frozen=True)
class RealForm:
    """The group's rows as real quadratics in X = (x_0, y_0, x_1, …) of its local joints:
    F(X) = Xᵀ·Q·X + g·X + c − drive·s; Q (m, 2L, 2L) symmetric, g (m, 2L), c, drive (m,)."""

    q: np.ndarray
    g: np.ndarray
    c: np.ndarray
    drive: np.ndarray

    @classmethod
    def of(cls, rows: Rows) -> "RealForm":
        def real_cols(coef: np.ndarray) -> np.ndarray:  # z_n = x_n + i·y_n
            out = np.empty((coef.shape[0], 2 * coef.shape[1]), dtype=complex)
            out[:, 0::2], out[:, 1::2] = coef, 1j * coef
            return out

        ad, ae = real_cols(rows.dc), real_cols(rows.ec)
        part = (lambda w: np.where(rows.imag.reshape((-1,) + (1,) * (w.ndim - 1)), w.imag, w.real))
        quad = part(np.conj(ad)[:, :, None] * ae[:, None, :])
        lin = part(np.conj(rows.d0)[:, None] * ae + rows.e0[:, None] * np.conj(ad))
        const = part(np.conj(rows.d0) * rows.e0) - rows.rhs
        return cls(q=np.ascontiguousarray(0.5 * (quad + np.swapaxes(quad, 1, 2))), g=lin, c=const, drive=rows.drive)

    def residual_jacobian(self, x: np.ndarray, s: float, unknowns: int) -> tuple[np.ndarray, np.ndarray]:
        """F (m,) and ∂F/∂X of the first ``unknowns`` real variables (m, unknowns) at X (2L,)."""
        m, width = self.g.shape
        qx = (self.q.reshape(m * width, width) @ x).reshape(m, width)
        return qx @ x + self.g @ x + self.c - self.drive * s, 2.0 * qx[:, :unknowns] + self.g[:, :unknowns]


def _newton(form: RealForm, x: np.ndarray, s: float, k: int) -> tuple[bool, float, np.ndarray]:
    """Newton's method on the first ``k`` real variables of X (updated in place).

    Returns (converged, size of the first step, last Jacobian)."""
    first = 0.0
    square = form.c.size == k
    jac = np.zeros((form.c.size, k))
    for it in range(GROUP_ITERATIONS):
        f, jac = form.residual_jacobian(x, s, k)
        if np.max(np.abs(f)) <= GROUP_TOLERANCE:
            return True, first, jac
        try:
            step = np.linalg.solve(jac, -f) if square else np.linalg.lstsq(jac, -f, rcond=None)[0]
        except np.linalg.LinAlgError:
            return False, first, jac
        if it == 0:
            first = float(np.abs(step).max())
        x[:k] += step
        if not np.all(np.isfinite(x[:k])):
            return False, first, jac
    return False, first, jac


def _accepted(moved: np.ndarray | float, first: np.ndarray | float) -> np.ndarray | bool:
    """Whether Newton ended close to where it started: within 1.5× its first step, itself at most
    0.1 (of the linkage's size): it converged to the solution nearest its predictor."""
    return (moved <= 1.5 * first + 1e-9) & (first <= 0.1)


def _continue(form: RealForm, step: Step, X: np.ndarray, s: np.ndarray, k: int, x: np.ndarray,
              path: np.ndarray, out: np.ndarray, jacs: np.ndarray) -> int:
    """Continue the group sequentially from X-row ``x`` (known at sample ``path[0]``) through the
    samples ``path`` in order, writing ``out``/``jacs`` rows. Each move from one sample to the next
    is a homotopy in the known joints (interpolated linearly); Newton's first step is the tangent
    predictor, and a move is accepted only when Newton converges close to it (:func:`_accepted`)
    without the Jacobian's determinant changing sign; otherwise it is halved (down to 1/256).
    Returns the position in ``path`` where it fails, or −1."""
    square = form.c.size == k
    x = x.copy()
    prev = path[0]
    for n, t in enumerate(path):
        done, piece = 0.0, 1.0
        jac = jacs[prev]
        while done < 1.0:
            f = min(done + piece, 1.0)
            trial = x.copy()
            trial[k:] = X[prev, k:] + f * (X[t, k:] - X[prev, k:])
            ok, first, jac = _newton(form, trial, s[prev] + f * (s[t] - s[prev]), k)
            if ok:
                ok = bool(_accepted(np.abs(trial[:k] - x[:k]).max(), first))
                if ok and square and np.sign(np.linalg.det(jac)) != step.det_sign:
                    ok = False  # passed a singular position: another assembly branch
            if ok:
                x, done = trial, f
                piece = min(2.0 * piece, 1.0)
            else:
                piece *= 0.5
                if piece < 1.0 / 256:
                    return n
        jacs[t] = jac
        out[t] = x[:k]
        prev = t
    return -1


def _polish(form: RealForm, step: Step, X: np.ndarray, s: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton's method on every row of X (T, W) at once, from the predictor in X[:, :k] (updated in
    place). Returns (accepted (T,) — converged, close to its predictor (:func:`_accepted`), on the
    rest pose's side of every singular position (sign of det J) — and the Jacobians (T, m, k) at
    the accepted rows)."""
    q, g, c, drive = form.q, form.g, form.c, form.drive
    m, W = g.shape
    flat = q.reshape(m * W, W).T
    square = c.size == k
    start = X[:, :k].copy()
    first = np.zeros(X.shape[0])
    done = np.zeros(X.shape[0], dtype=bool)
    jac = np.zeros((X.shape[0], m, k))
    live = np.arange(X.shape[0])
    with np.errstate(invalid="ignore", over="ignore"):
        for it in range(GROUP_ITERATIONS + 1):
            x = X[live]
            qx = (x @ flat).reshape(live.size, m, W)
            f = (qx @ x[:, :, None])[..., 0] + x @ g.T + c - drive * s[live, None]
            jac[live] = 2.0 * qx[:, :, :k] + g[:, :k]
            conv = np.abs(f).max(axis=1) <= GROUP_TOLERANCE
            done[live[conv]] = True
            live, f = live[~conv], f[~conv]
            if not live.size or it == GROUP_ITERATIONS:
                break
            a, b = jac[live], -f
            if not square:
                at = np.swapaxes(a, 1, 2)
                a, b = at @ a, (at @ b[..., None])[..., 0]
            try:
                delta = np.linalg.solve(a, b[..., None])[..., 0]
            except np.linalg.LinAlgError:  # an exactly singular row: left to the sequential fallback
                regular = np.abs(np.linalg.det(a)) > 0.0
                live, a, b = live[regular], a[regular], b[regular]
                delta = np.linalg.solve(a, b[..., None])[..., 0]
            if it == 0:
                first[live] = np.abs(delta).max(axis=1)
            X[live, :k] += delta
            live = live[np.isfinite(X[live, :k]).all(axis=1)]
    accept = done & _accepted(np.abs(X[:, :k] - start).max(axis=1), first)
    if square and accept.any():
        accept[accept] = np.sign(np.linalg.det(jac[accept])) == step.det_sign
    return accept, jac


def _predict(known: np.ndarray, solved: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Positions (len(want), k) at samples ``want`` by a cubic through the solved samples ``known``
    (indices, increasing) and their positions ``solved`` (len(known), k)."""
    if known.size == 1:
        return np.repeat(solved, want.size, axis=0)
    from scipy.interpolate import CubicSpline

    return CubicSpline(known, solved, axis=0)(want)


def solve_group(step: Step, z: np.ndarray, s: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Continue the group from ``start`` (n,) through the samples of ``z`` (J, T), in order.

    Every GROUP_STRIDE-th sample (and the last) is continued sequentially (:func:`_continue`); the
    samples between are predicted by a cubic through those and polished by Newton's method all at
    once (:func:`_polish`), each checked like a sequential move (converged near its predictor, the
    determinant's sign of the rest pose); a sample that fails the check is continued sequentially
    from the one before it. Returns positions (n, T) (NaN from the first sample where it fails),
    the singularity distance (T,) — (σ_min/σ_max)² of the row-scaled group Jacobian — and the
    index of the first failing sample (−1: none).
    """
    cols = np.concatenate([step.joints, step.inputs])
    form = RealForm.of(step.rows.columns(cols))
    n = step.joints.size
    k = 2 * n
    T = z.shape[1]
    known = z[cols[n:]]
    X = np.empty((T, 2 * cols.size))
    X[:, k::2], X[:, k + 1::2] = known.real.T, known.imag.T
    x0 = np.empty(2 * cols.size)
    start = np.asarray(start, dtype=complex)
    x0[0:k:2], x0[1:k:2] = start.real, start.imag
    x0[k:] = X[0, k:]
    out = np.full((T, k), np.nan)
    jacs = np.zeros((T, form.c.size, k))
    coarse = np.unique(np.append(np.arange(0, T, GROUP_STRIDE), T - 1))
    stop = _continue(form, step, X, s, k, x0, coarse, out, jacs)
    last = coarse[stop - 1] if stop > 0 else (coarse[-1] if stop < 0 else -1)
    fail = -1
    if last >= 0:
        inner = np.setdiff1d(np.arange(last + 1), coarse)
        if inner.size:
            solved = coarse[coarse <= last]
            polished = X[inner]
            polished[:, :k] = _predict(solved, out[solved], inner)
            accept, jac = _polish(form, step, polished, s[inner], k)
            rows = inner[accept]
            out[rows], jacs[rows] = polished[accept, :k], jac[accept]
            for t in inner[~accept]:  # a sequential move from the sample before
                if _continue(form, step, X, s, k, np.concatenate([out[t - 1], X[t - 1, k:]]),
                             np.array([t - 1, t]), out, jacs) >= 0:
                    fail = int(t)
                    break
    if fail < 0 and stop >= 0:  # the coarse continuation stopped: go on sample by sample
        x = x0 if last < 0 else np.concatenate([out[last], X[last, k:]])
        path = np.arange(max(last, 0), T)
        at = _continue(form, step, X, s, k, x, path, out, jacs)
        fail = int(path[at]) if at >= 0 else -1
    if fail >= 0:
        out[fail:] = np.nan
    ds = np.full(T, np.nan)
    _conditioning(jacs[: fail if fail >= 0 else T], ds)
    return (out[:, 0::2] + 1j * out[:, 1::2]).T, ds, fail


def _conditioning(jacs: np.ndarray, ds: np.ndarray) -> None:
    """ds[:t] = (σ_min/σ_max)² of each row-scaled Jacobian of ``jacs`` (t, m, k), batched."""
    if not len(jacs):
        return
    scaled = jacs / np.maximum(np.abs(jacs).max(axis=2, keepdims=True), 1e-300)
    eig = np.linalg.eigvalsh(np.swapaxes(scaled, 1, 2) @ scaled)  # σ², ascending
    ds[: len(jacs)] = np.maximum(eig[:, 0], 0.0) / eig[:, -1]


def _solve(jac: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched least-squares solve: jac (T, m, k), rhs (m, T) → (k, T)."""
    if jac.shape[1] == jac.shape[2]:
        return np.linalg.solve(jac, rhs.T[..., None])[..., 0].T
    jt = np.swapaxes(jac, 1, 2)
    return np.linalg.solve(jt @ jac, (jt @ rhs.T[..., None]))[..., 0].T


def _to_complex(xy: np.ndarray) -> np.ndarray:
    return xy[0::2] + 1j * xy[1::2]


def velocity(step: Step, z: np.ndarray, dz: np.ndarray, ds: float) -> np.ndarray:
    """ż of the step's joints (n, T) from the known joints' ż in ``dz`` (J, T) (own rows ignored)."""
    rows = step.rows
    known = dz.copy()
    known[step.joints] = 0.0
    rhs = -rows.first(z, known) + rows.drive[:, None] * ds
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _to_complex(_solve(rows.jacobian(z, step.joints), rhs))


def acceleration(step: Step, z: np.ndarray, dz: np.ndarray, ddz: np.ndarray) -> np.ndarray:
    """z̈ of the step's joints (n, T), given ż of all joints and z̈ of the known ones."""
    rows = step.rows
    known = ddz.copy()
    known[step.joints] = 0.0
    rhs = -rows.first(z, known) - rows.second(dz)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _to_complex(_solve(rows.jacobian(z, step.joints), rhs))


def _rod_tangent(graph: LinkageGraph, step: Step, drest: np.ndarray) -> Rows:
    """d/dε of a slider step's rod row (its squared length) along the rest tangent ``drest``."""
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    k, i = int(step.joints[0]), step.i
    b = _Builder(graph.n_joints)
    b.add(False, {}, 0j, {}, 0j, "rod", rhs=2.0 * float((np.conj(z[k] - z[i]) * (drest[k] - drest[i])).real))
    return b.build()


def rest_tangent(graph: LinkageGraph, step: Step, z: np.ndarray, dz: np.ndarray, drest: np.ndarray) -> np.ndarray:
    """Tangent (n, T) of the step's joints when the rest pose moves along ``drest`` (J,) complex.

    ``z`` (J, T): joint positions (the step's own filled in); ``dz`` (J, T): the tangents of the
    joints known before the step (its own rows ignored). By the implicit function theorem,
    J_S·ż_S = −dF[ż_K] − ∂F/∂r̄·ṙ: one batched solve; for the closed-form rules this is the
    exact derivative of their formulas, for a numeric group the derivative of its solution.
    Everything in the frame ``graph`` is given in (the plan's normalized frame for its steps).
    """
    from linkedit.planar.constraints import linkage_rows_tangent, rows_rest_derivative

    source = step.source
    assert source is not None  # compile_steps gives every step the rows of its slots (or none: empty)
    tangent = linkage_rows_tangent(graph, drest).take(source[source >= 0])
    if step.kind == "slider":  # its slot row, then its own rod row
        tangent = _concat(tangent, _rod_tangent(graph, step, drest))
    rows = step.rows
    known = dz.copy()
    known[step.joints] = 0.0
    rhs = -rows.first(z, known) - rows_rest_derivative(rows, tangent, z)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _to_complex(_solve(rows.jacobian(z, step.joints), rhs))


def compile_steps(graph: LinkageGraph, rules: tuple[StepRule, ...], known0: set[int],
                  revolute_levels: dict[int, int]) -> tuple[Step, ...]:
    """Compile the ordering's step rules (``known0``: joints known before any rule)."""
    all_rows = linkage_rows(graph)
    level_of = {k: 0 for k in known0} | revolute_levels
    out = []
    for rule in rules:
        known = {k for k, lv in level_of.items() if lv < rule.level}
        out.append(compile_step(graph, rule, all_rows, known))
        level_of.update({k: rule.level for k in rule.joints})
    return tuple(out)
