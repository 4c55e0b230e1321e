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

from linkedit.edit.feasibility import failure
from linkedit.planar import law_of_cosines as loc
from linkedit.planar.plan import Plan


@dataclass
class Evaluation:
    """One evaluation at a rest pose.

    ``rest`` (J,) complex joints; ``z`` (P, T) complex points in internal rows; ``ds`` (R, T)
    singularity distance per rule (1 for rigid rules); with tangents, ``dz`` (P, C, T) and
    ``dlnds`` (R, C, T) = ∂ln d_s (dyad rules; 0 for rigid ones); ``why`` is None when the
    linkage works (:func:`linkedit.edit.feasibility.failure`).
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
    """Points of ``plan`` at motor rotations ``spin`` (T,) = exp(i·(angle − rest angle)).

    ``drest`` (J, C) complex: the rest-pose tangent in each direction (constant: the
    parametrization is affine); ``arm``: the crank's rest direction when its angle is fixed.
    """

    def __init__(self, plan: Plan, spin: np.ndarray, drest: np.ndarray, arm: complex | None = None) -> None:
        self.plan = plan
        self.spin = np.asarray(spin, dtype=complex)
        self.drest = drest
        self.turn_deg = np.degrees(np.angle(self.spin))  # (T,) for messages
        self.arm = arm  # the crank's rest direction when its angle is fixed
        self.J = plan.n_joints
        g = plan.graph
        self.ground = np.array(g.ground)
        self.motor, self.pivot = g.motor, g.pivot
        # tracked points on links keep their coefficient in the frame of their two joints
        coef = plan.geometry().coef
        self.fixed = [None if not b.rigid else np.where(b.k_point >= self.J, coef[n][:, 0], np.nan)
                      for n, b in enumerate(plan.batches)]

    @property
    def directions(self) -> int:
        return self.drest.shape[1]

    def evaluate(self, x: np.ndarray, tangents: bool = False) -> Evaluation:
        """Evaluate at rest pose ``x`` (J, 2); with ``tangents``, also ∂z and ∂ln d_s."""
        plan = self.plan
        rest = x[:, 0] + 1j * x[:, 1]
        T, C = self.spin.size, self.directions
        z = np.empty((plan.n_points, T), dtype=complex)
        ds = np.ones((len(plan.rules), T))
        dz = np.empty((plan.n_points, C, T), dtype=complex) if tangents else None
        dlnds = np.zeros((len(plan.rules), C, T)) if tangents else None
        D = self.drest
        z[plan.ground_rows] = rest[self.ground, None]
        arm = rest[self.motor] - rest[self.pivot]
        z[plan.motor_row] = rest[self.pivot] + arm * self.spin
        if tangents:
            dz[plan.ground_rows] = D[self.ground][:, :, None]
            darm = D[self.motor] - D[self.pivot]
            dz[plan.motor_row] = D[self.pivot][:, None] + darm[:, None] * self.spin
        with np.errstate(invalid="ignore", divide="ignore"):
            for n, b in enumerate(plan.batches):
                out = slice(b.start, b.stop)
                zi, zj = z[b.i], z[b.j]
                ri, rj = rest[b.i_point], rest[b.j_point]
                if b.rigid:
                    fixed = self.fixed[n]
                    joint = np.isnan(fixed)
                    rk = rest[np.where(joint, b.k_point, 0)]
                    c = np.where(joint, (rk - ri) / (rj - ri), fixed)
                    e = zj - zi
                    z[out] = zi + c[:, None] * e
                    if tangents:
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
                if tangents:
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
        why = failure(plan, rest, ds, self.turn_deg, self.arm)
        return Evaluation(rest=rest, z=z, ds=ds, dz=dz, dlnds=dlnds, why=why)
