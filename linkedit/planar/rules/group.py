"""A complex loop (a class-III Assur group, a cylinder's barrel), solved numerically as one group.

Newton's method on the group's constraint rows at every sample (the samples are dense: see
:func:`linkedit.planar.kinematics.evaluate`), continued from the rest pose through every
GROUP_STRIDE-th sample, the samples between polished all at once from a predictor and checked
(:func:`solve_group`), keeping the rest pose's branch (the sign of the group Jacobian's
determinant never changes; a change means the group passed a singular position, reported as a
lock-up). Its singularity distance is (σ_min/σ_max)² of the row-scaled group Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Step, loop_rows

#: Newton's method stops when every row is within this of 0 (rows are in units of the
#: linkage's characteristic length, squared for distance rows)
GROUP_TOLERANCE = 1e-13
GROUP_ITERATIONS = 12
#: a numeric group is continued sequentially through every GROUP_STRIDE-th sample only; the
#: samples between are predicted from those and polished all at once
GROUP_STRIDE = 20


@dataclass(frozen=True)
class Group(Step):
    """The joints of a complex loop, on the side ``det_sign`` of its Jacobian's determinant at rest."""

    kind = "group"
    watched = True

    det_sign: float = 1.0

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Group":
        """The joints ``rule.joints`` with every row binding them to each other and to known joints."""
        rows, source, inputs = loop_rows(all_rows, known, rule.joints)
        joints, level = np.array(rule.joints, dtype=int), rule.level
        z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
        jac = rows.jacobian(z[:, None], joints)[0]
        det = np.linalg.det(jac) if jac.shape[0] == jac.shape[1] else 1.0
        names = graph.joint_names
        return cls(level, joints, inputs, ", ".join(names[k] for k in joints), rows, source,
                   det_sign=float(np.sign(det)) or 1.0)

    def what(self) -> str:
        return "numeric group"

    def label(self) -> str:
        return f"numeric group {self.name}"

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        out, ds, _ = solve_group(self, z, s, rest[self.joints])
        return out, ds

    def lockup(self, names: list[str], toggle: bool) -> str:
        return (f"the numeric group {self.name} cannot be assembled on its rest-pose branch "
                "(it reaches a singular position: its links cannot follow)")

    def branch_change(self, new: Step, names: list[str]) -> str | None:
        if isinstance(new, Group) and new.det_sign != self.det_sign:
            return f"numeric group {self.name} changes assembly branch at the rest pose"
        return None


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


def _continue(form: RealForm, step: "Group", X: np.ndarray, s: np.ndarray, k: int, x: np.ndarray,
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


def _polish(form: RealForm, step: "Group", X: np.ndarray, s: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
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


def solve_group(step: "Group", z: np.ndarray, s: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
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
