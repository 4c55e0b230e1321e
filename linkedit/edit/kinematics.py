"""The motion as a differentiable function of the rest pose, in forward mode.

:class:`RestPoseKinematics` evaluates every point of a plan at motor phases for a rest pose x̄:
link lengths, rigid-link coefficients and the motor arm all come from x̄, and the motor turns
from the rest pose (phase 0 *is* x̄, exactly as in ``simulate``). With tangents, it also
propagates ∂z/∂x̄ through the levels in C directions at once, batched like the positions:
arrays (R, C, T) for R rules, C directions, T samples.

The directions are *coloured* columns of the rest-pose parametrization (see
:mod:`linkedit.edit.variables`): variables that never influence the same point share one
direction (the legs of a Strandbeest), so C is the size of the largest dependency set, not the
number of variables.

Complex notation: z = x + iy; a tangent Dz has the same shape with a direction axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.edit import steps as es
from linkedit.edit.feasibility import failure
from linkedit.errors import MechanismError
from linkedit.planar import law_of_cosines as loc
from linkedit.planar.kinematics import GROUP_STEP_DEG, GROUP_STEP_LENGTH, continuation_grid
from linkedit.planar.plan import Plan


@dataclass
class Evaluation:
    """One evaluation at a rest pose.

    ``rest`` (J,) complex joints; ``z`` (P, T) complex points in internal rows; ``ds`` (R + X, T)
    singularity distance per rule (1 for rigid rules), then per step of ``plan.steps``; with
    tangents, ``dz`` (P, C, T) and ``dlnds`` (R + X, C, T) = ∂ln d_s (rows the barrier guards,
    :attr:`RestPoseKinematics.guarded`; 0 elsewhere); ``why`` is None when the linkage works
    (:func:`linkedit.edit.feasibility.failure`).
    """

    rest: np.ndarray
    z: np.ndarray
    ds: np.ndarray
    dz: np.ndarray | None
    dlnds: np.ndarray | None
    why: str | None

    @property
    def works(self) -> bool:
        return self.why is None


class RestPoseKinematics:
    """Points of ``plan`` at inputs ``inputs`` (T,) from the rest pose: motor rotations
    (radians; spin = exp(i·rotation)) or, for a linear input, strokes (the driven joint's
    displacement along its slot, spec units: fixed in length, whatever the rest pose).

    ``drest`` (J, C) complex: the rest-pose tangent in each direction (constant: the
    parametrization is affine); ``arm``: the crank's rest direction when its angle is fixed.
    """

    def __init__(self, plan: Plan, inputs: np.ndarray, drest: np.ndarray, arm: complex | None = None) -> None:
        self.plan = plan
        inputs = np.asarray(inputs, dtype=float)
        self.linear = plan.linear
        self.spin = np.exp(1j * inputs) if not self.linear else np.ones(inputs.size, dtype=complex)
        self.stroke = inputs / plan.scale if self.linear else np.zeros(inputs.size)  # normalized frame
        self.drest = drest
        #: (T,) for messages: the rotation in degrees, or the stroke in spec units
        self.turn_deg = inputs if self.linear else np.degrees(np.angle(self.spin))
        self.arm = arm  # the crank's rest direction when its angle is fixed
        self.J = plan.n_joints
        g = plan.graph
        self.ground = np.array(g.ground)
        self.motor, self.pivot = g.motor, g.pivot
        # tracked points on links keep their coefficient in the frame of their two joints
        coef = plan.geometry().coef
        self.fixed = [None if not b.rigid else np.where(b.k_point >= self.J, coef[n][:, 0], np.nan)
                      for n, b in enumerate(plan.batches)]
        self.steps = es.RestPoseSteps(plan) if plan.steps else None
        #: (R + X,) rows of ``ds`` the barrier guards (dyad rules, slider rules) and the point row
        #: each depends through (its written joint)
        self.guarded = np.concatenate([~plan.rigid, self.steps.guarded if self.steps else np.zeros(0, bool)])
        self.guard_rows = np.concatenate([plan.row_of[plan.rules[:, 2]],
                                          [plan.row_of[s.joints[0]] for s in plan.steps]]).astype(int)
        # a numeric group is continued from the rest pose at most GROUP_STEP_DEG apart (as in simulate)
        self.keep = None
        if plan.has_groups and self.linear:
            self.stroke, self.keep = continuation_grid(0.0, self.stroke, GROUP_STEP_LENGTH)
            self.spin = np.ones(self.stroke.size, dtype=complex)
        elif plan.has_groups:
            turn = np.unwrap(np.concatenate([[0.0], np.angle(self.spin)]))[1:]
            fine, self.keep = continuation_grid(0.0, turn, np.radians(GROUP_STEP_DEG))
            self.spin = np.exp(1j * fine)
            self.stroke = np.zeros(fine.size)

    @property
    def directions(self) -> int:
        return self.drest.shape[1]

    def evaluate(self, x: np.ndarray, tangents: bool = False) -> Evaluation:
        """Evaluate at rest pose ``x`` (J, 2); with ``tangents``, also ∂z and ∂ln d_s."""
        plan = self.plan
        world = x[:, 0] + 1j * x[:, 1]
        rest = world if self.steps is None else self.steps.normalized(world)
        T, C = self.spin.size, self.directions
        R = len(plan.rules)
        alloc = np.zeros if plan.steps else np.empty  # steps' rows multiply unknown joints by 0
        z = alloc((plan.n_points, T), dtype=complex)
        ds = np.ones((R + len(plan.steps), T))
        dz = alloc((plan.n_points, C, T), dtype=complex) if tangents else None
        dlnds = np.zeros((R + len(plan.steps), C, T)) if tangents else None
        D = self.drest if self.steps is None else self.drest / self.steps.scale
        graph, why = None, None
        steps: tuple = ()
        if self.steps is not None:
            try:
                graph, steps = self.steps.compile(rest)
            except MechanismError as exc:
                why = str(exc)
            why = why or self.steps.changed(steps)
            if why is not None:
                return Evaluation(rest=world, z=z, ds=ds, dz=dz, dlnds=dlnds, why=why)
        z[plan.ground_rows] = rest[self.ground, None]
        if dz is not None:
            dz[plan.ground_rows] = D[self.ground][:, :, None]
        if not self.linear:  # a linear input's driven joint is placed by its step
            arm = rest[self.motor] - rest[self.pivot]
            z[plan.motor_row] = rest[self.pivot] + arm * self.spin
            if dz is not None:
                darm = D[self.motor] - D[self.pivot]
                dz[plan.motor_row] = D[self.pivot][:, None] + darm[:, None] * self.spin
        with np.errstate(invalid="ignore", divide="ignore"):
            for kind, n in plan.schedule or tuple(("batch", n) for n in range(len(plan.batches))):
                if kind == "step":
                    self._step(graph, steps[n], R + n, rest, z, ds, dz, dlnds, D)
                    continue
                b = plan.batches[n]
                out = slice(b.start, b.stop)
                zi, zj = z[b.i], z[b.j]
                ri, rj = rest[b.i_point], rest[b.j_point]
                if b.rigid:
                    fixed = self.fixed[n]
                    assert fixed is not None  # every rigid batch has its fixed coefficients
                    joint = np.isnan(fixed)
                    rk = rest[np.where(joint, b.k_point, 0)]
                    c = np.where(joint, (rk - ri) / (rj - ri), fixed)
                    e = zj - zi
                    z[out] = zi + c[:, None] * e
                    if dz is not None:
                        Di, Dj = D[b.i_point], D[np.where(joint, b.j_point, 0)]
                        Dk = D[np.where(joint, b.k_point, 0)]
                        dc = np.where(joint[:, None], (Dk - Di - c[:, None] * (Dj - Di)) / (rj - ri)[:, None], 0.0)
                        dzi, dzj = dz[b.i], dz[b.j]
                        dz[out] = dzi + dc[:, :, None] * e[:, None, :] + c[:, None, None] * (dzj - dzi)
                    continue
                rk = rest[b.k_point]
                lik2, ljk2 = np.abs(rk - ri) ** 2, np.abs(rk - rj) ** 2
                half = 0.5 * (lik2 - ljk2)
                z[out], t = loc.dyad(zi, zj, half[:, None], lik2[:, None], b.sign)
                ds[b.rule] = loc.singularity_distance(t, lik2[:, None], ljk2[:, None])
                if dz is not None and dlnds is not None:
                    Di, Dj, Dk = D[b.i_point], D[b.j_point], D[b.k_point]
                    dL = 2.0 * ((rk - ri).conj()[:, None] * (Dk - Di)).real  # (R, C)
                    dM = 2.0 * ((rk - rj).conj()[:, None] * (Dk - Dj)).real
                    dh = 0.5 * (dL - dM)
                    dzi, dzj = dz[b.i], dz[b.j]
                    de = dzj - dzi  # (R, C, T)
                    e, u, a = t.e[:, None, :], t.u[:, None, :], t.a[:, None, :]
                    du = -2.0 * (e.real * de.real + e.imag * de.imag) * u * u
                    da = dh[:, :, None] * u + half[:, None, None] * du
                    dbsq = dL[:, :, None] * u + lik2[:, None, None] * du - 2.0 * a * da
                    db = dbsq / (2.0 * t.b[:, None, :])
                    dz[out] = dzi + (da + 1j * db) * e + t.w[:, None, :] * de
                    dlnds[b.rule] = (dbsq / t.bsq[:, None, :] - 2.0 * du / u
                                     - (dL / lik2[:, None])[:, :, None] - (dM / ljk2[:, None])[:, :, None])
        if self.keep is not None:
            z, ds = z[:, self.keep], ds[:, self.keep]
            dz = None if dz is None else dz[..., self.keep]
            dlnds = None if dlnds is None else dlnds[..., self.keep]
        if self.steps is not None:
            z = self.steps.origin + self.steps.scale * z
            if dz is not None:
                dz *= self.steps.scale
        why = failure(plan, world, ds, self.turn_deg, self.arm)
        return Evaluation(rest=world, z=z, ds=ds, dz=dz, dlnds=dlnds, why=why)

    def _step(self, graph, step, r: int, rest: np.ndarray, z: np.ndarray, ds: np.ndarray,
              dz: np.ndarray | None, dlnds: np.ndarray | None, D: np.ndarray) -> None:
        """Evaluate one step in place (normalized frame): its joints' rows of ``z`` (and ``dz``),
        its d_s in row ``r`` of ``ds`` (and ∂ln d_s when guarded)."""
        rows = self.plan.row_of[: self.J]
        zj = z[rows]
        out, ds[r] = step.place(zj, self.stroke, rest)
        z[rows[step.joints]] = zj[step.joints] = out
        if dz is None:
            return
        dzj = dz[rows]
        dz[rows[step.joints]] = dzj[step.joints] = es.tangents(graph, step, zj, dzj, D)
        if step.guarded and dlnds is not None:
            dlnds[r] = step.dlnds(graph, zj, dzj, D)
