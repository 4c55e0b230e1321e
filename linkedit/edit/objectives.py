"""The objectives of one edit operation (LinkEdit Eqs. 3–5, 9) and its energy.

E(x̄) = μ_e·f_edit + μ_s·f_singularity + μ_r·f_regularization, with

* tracking ½·mean_t |p(t) − p̂(t)|² per track (preserve: p̂ = the curve at the start of the
  operation; retarget: that curve transformed about its centroid; drag: displaced with a
  Gaussian falloff in phase);
* displacement ½|x̄_i − x̂_i|² (rest pose) or ½|x_i(t) − x̂_i|² (at a phase); transforms are
  displacement targets for a set of joints;
* envelope ½·mean_t of the squared distance outside the box, per joint;
* regularization ½Σ(l_ij(x̄) − l̃_ij)² over joint pairs on one link, l̃ from the operation's start;
* the singularity barrier (:mod:`linkedit.edit.barrier`), summed over samples and triangles.

Tracking and envelope terms are means over samples, so their weights do not depend on the
sample count; the barrier is a sum (as in LinkEdit), so a single near-toggle sample counts. The energy is +inf where
the linkage cannot be assembled at some sample or a triangle of x̄ has flipped.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.edit.adjoint import Forward, RestPoseKinematics
from linkedit.edit.barrier import barrier
from linkedit.planar.plan import Plan
from linkedit.spec.edit_script import EditScript, Operation


@dataclass
class Tracking:
    """Follow a target curve (T,) complex with point row ``row``."""

    label: str
    row: int
    target: np.ndarray
    weight: float


@dataclass
class Displacement:
    """Joint ``joint`` (rest pose, or at sample column ``column``) to ``target``."""

    label: str
    joint: int
    target: complex
    weight: float
    column: int | None = None  # None: the rest pose


@dataclass
class EnvelopeTerm:
    rows: np.ndarray  # (N,) internal rows of the joints kept inside
    lo: complex  # xmin + i·ymin (−inf where open)
    hi: complex
    weight: float


@dataclass
class Problem:
    """Everything one operation's energy needs; ``x`` vectors are the free joint coordinates."""

    plan: Plan
    kin: RestPoseKinematics
    samples: int  # main samples (columns 0..T−1); extra columns are phases of displacements
    weights: tuple[float, float, float]  # μ_e, μ_s, μ_r
    eps: float
    free: np.ndarray  # (J, 2) bool: coordinates the optimizer may change
    x_fixed: np.ndarray  # (J, 2) the rest pose the free coordinates are inserted into
    pairs: np.ndarray  # (P, 2)
    ref_lengths: np.ndarray  # (P,)
    tracking: list[Tracking] = field(default_factory=list)
    displacements: list[Displacement] = field(default_factory=list)
    envelope: EnvelopeTerm | None = None

    def full(self, v: np.ndarray) -> np.ndarray:
        """Free coordinates (n,) → rest pose (J, 2)."""
        x = self.x_fixed.copy()
        x[self.free] = v
        return x

    def forward(self, v: np.ndarray) -> Forward | None:
        """The forward pass at ``v``, or None where the linkage is infeasible."""
        f = self.kin.forward(self.full(v))
        return f if f.assembled and f.orientation_ok else None

    def terms(self, f: Forward) -> dict[str, float]:
        """Unweighted objective values at a forward pass (for reports)."""
        out = {"edit": self._edit(f, None), "singularity": self._barrier(f, None)[0],
               "regularization": self._regularization(f.rest, None)}
        return out

    def energy(self, v: np.ndarray, with_gradient: bool = True) -> tuple[float, np.ndarray | None, Forward | None]:
        """(E, ∂E/∂v, forward); E = inf and no gradient where infeasible."""
        f = self.forward(v)
        if f is None:
            return np.inf, None, None
        me, ms, mr = self.weights
        if not with_gradient:
            e = me * self._edit(f, None) + ms * self._barrier(f, None)[0] + mr * self._regularization(f.rest, None)
            return e, None, f
        gz = np.zeros_like(f.z)
        grest = np.zeros(self.plan.n_joints, dtype=complex)
        e = me * self._edit(f, (gz, grest, me))
        fs, gds = self._barrier(f, ms)
        e += ms * fs
        e += mr * self._regularization(f.rest, (grest, mr))
        g = self.kin.gradient(f, gz, gds)
        g[:, 0] += grest.real
        g[:, 1] += grest.imag
        return e, g[self.free], f

    # -- the terms; each adds its gradient (times ``scale``) into ``grad`` when given ---------

    def _edit(self, f: Forward, grad: tuple | None) -> float:
        T = self.samples
        total = 0.0
        for tr in self.tracking:
            diff = f.z[tr.row, :T] - tr.target
            total += tr.weight * 0.5 * float(np.mean(diff.real ** 2 + diff.imag ** 2))
            if grad is not None:
                grad[0][tr.row, :T] += (grad[2] * tr.weight / T) * diff
        for d in self.displacements:
            if d.column is None:
                diff = f.rest[d.joint] - d.target
            else:
                diff = f.z[self.plan.row_of[d.joint], d.column] - d.target
            total += d.weight * 0.5 * abs(diff) ** 2
            if grad is not None:
                if d.column is None:
                    grad[1][d.joint] += grad[2] * d.weight * diff
                else:
                    grad[0][self.plan.row_of[d.joint], d.column] += grad[2] * d.weight * diff
        env = self.envelope
        if env is not None:
            z = f.z[env.rows, :T]
            over = (np.minimum(z.real - env.lo.real, 0.0) + np.maximum(z.real - env.hi.real, 0.0)
                    + 1j * (np.minimum(z.imag - env.lo.imag, 0.0) + np.maximum(z.imag - env.hi.imag, 0.0)))
            total += env.weight * 0.5 * float(np.sum(over.real ** 2 + over.imag ** 2)) / T
            if grad is not None:
                grad[0][env.rows, :T] += (grad[2] * env.weight / T) * over
        return total

    def _barrier(self, f: Forward, scale: float | None) -> tuple[float, list | None]:
        total, grads = 0.0, []
        T = f.z.shape[1]
        for ds in f.ds:
            if ds is None:
                grads.append(None)
                continue
            value, g = barrier(ds, self.eps, 1.0)
            total += value
            grads.append(None if scale is None else scale * g)
        return total, (grads if scale is not None else None)

    def _regularization(self, rest: np.ndarray, grad: tuple | None) -> float:
        d = rest[self.pairs[:, 1]] - rest[self.pairs[:, 0]]
        length = np.abs(d)
        diff = length - self.ref_lengths
        if grad is not None:
            g = grad[1] * diff * d / length
            np.add.at(grad[0], self.pairs[:, 1], g)
            np.add.at(grad[0], self.pairs[:, 0], -g)
        return 0.5 * float(diff @ diff)


def _phase_distance(t: np.ndarray, at: float) -> np.ndarray:
    d = np.abs(t - at) % 1.0
    return np.minimum(d, 1.0 - d)


def build_problem(plan: Plan, script: EditScript, op: Operation, x: np.ndarray, base_angle: float,
                  ref_lengths: np.ndarray) -> Problem:
    """The energy of operation ``op`` starting from rest pose ``x`` (J, 2).

    Samples are absolute motor angles ``base_angle + dir·2π·n/T``, fixed through the edit.
    """
    T = script.samples
    names = plan.joint_names
    index = {n: i for i, n in enumerate(names)}
    t = np.arange(T) / T
    displaces = op.listed("displace")
    extra = [d.at for d in displaces if d.at is not None]
    phases = np.concatenate([t, np.array(extra, dtype=float)])
    angle = base_angle + plan.direction * 2.0 * np.pi * phases
    kin = RestPoseKinematics(plan, angle)
    start = kin.forward(x)
    w = op.terms
    free = np.ones_like(x, dtype=bool)
    for name in script.lock:
        free[index[name]] = False
    problem = Problem(plan=plan, kin=kin, samples=T,
                      weights=(script.weights.edit, script.weights.singularity, script.weights.regularization),
                      eps=script.singularity_epsilon, free=free, x_fixed=x.copy(), pairs=plan.pairs,
                      ref_lengths=ref_lengths)
    track_row = {n: int(plan.row_of[p]) for n, p in zip(plan.track_names, plan.track_points)}

    def curve(name: str) -> np.ndarray:
        return start.z[track_row[name], :T].copy()

    for name in op.preserve:
        problem.tracking.append(Tracking(f"preserve {name}", track_row[name], curve(name), w.preserve))
    for r in op.listed("retarget"):
        p = curve(r.track)
        c = p.mean()
        q = (p - c).real * r.scale[0] + 1j * (p - c).imag * r.scale[1]
        target = c + complex(*r.translate) + np.exp(1j * np.radians(r.rotate_deg)) * q
        problem.tracking.append(Tracking(f"retarget {r.track}", track_row[r.track], target, w.retarget))
    for d in op.listed("drag"):
        falloff = np.exp(-0.5 * (_phase_distance(t, d.at) / d.radius) ** 2)
        target = curve(d.track) + complex(*d.by) * falloff
        problem.tracking.append(Tracking(f"drag {d.track}", track_row[d.track], target, w.drag))
    column = T
    for d in displaces:
        if d.at is None:
            problem.displacements.append(Displacement(f"displace {d.joint}", index[d.joint], complex(*d.to), w.displace))
        else:
            problem.displacements.append(Displacement(f"displace {d.joint} at {d.at:g}", index[d.joint],
                                                      complex(*d.to), w.displace, column))
            column += 1
    if op.transform is not None:
        tf = op.transform
        members = list(range(len(names))) if tf.joints == "all" else [index[n] for n in tf.joints]
        rest = x[:, 0] + 1j * x[:, 1]
        about = complex(*tf.about) if tf.about is not None else rest[members].mean()
        turn = tf.scale * np.exp(1j * np.radians(tf.rotate_deg))
        for m in members:
            target = about + complex(*tf.translate) + turn * (rest[m] - about)
            problem.displacements.append(Displacement(f"transform {names[m]}", m, target, w.transform))
    if op.envelope is not None:
        env = op.envelope
        members = range(len(names)) if not env.joints else [index[n] for n in env.joints]
        inf = np.inf
        problem.envelope = EnvelopeTerm(
            rows=plan.row_of[np.array(list(members))],
            lo=complex(-inf if env.xmin is None else env.xmin, -inf if env.ymin is None else env.ymin),
            hi=complex(inf if env.xmax is None else env.xmax, inf if env.ymax is None else env.ymax),
            weight=w.envelope)
    return problem
