"""The motion as a differentiable function of the rest pose, with its reverse-mode gradient.

:class:`RestPoseKinematics` evaluates every point at fixed absolute motor angles for a rest
pose x̄ (J, 2) — link lengths, rigid-link coefficients and the motor radius all come from x̄ —
and keeps the intermediate terms. :meth:`RestPoseKinematics.gradient` then pulls a gradient
with respect to the positions (and to the singularity distances) back to x̄ through the levels
in reverse order: the adjoint of the law of cosines. Its cost is about two forward passes.

Complex notation: a gradient with respect to a point z = x + iy is g = ∂E/∂x + i·∂E/∂y; for
w = a·b (complex), g_a = conj(b)·g_w; for a real r(z), g_z = g_r·(∂r/∂x + i ∂r/∂y).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar import law_of_cosines as loc
from linkedit.planar.plan import Plan


def _scatter(rows: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Unique rows and an incidence matrix M (U, R) so that ``G[u] += M @ g`` sums duplicates."""
    unique, inverse = np.unique(rows, return_inverse=True)
    m = np.zeros((unique.size, rows.size), dtype=complex)
    m[inverse, np.arange(rows.size)] = 1.0
    return unique, m


@dataclass
class Forward:
    """A forward pass: positions (P, T) complex (internal rows), per-batch terms, ds per dyad batch."""

    rest: np.ndarray  # (J,) complex rest pose
    z: np.ndarray
    terms: list  # per batch: DyadTerms, or e = z_j − z_i (rigid)
    ds: list  # per batch: (R, T) singularity distance (dyads) or None
    coef: list  # per batch: rigid coefficients (R, 1) or None
    lik2: list
    ljk2: list
    radius: float  # motor arm length
    assembled: bool  # every triangle closes at every sample
    orientation_ok: bool  # every dyad triangle of x̄ has the plan's orientation


class RestPoseKinematics:
    """Positions at fixed absolute motor angles ``angle`` (T,) as a function of x̄ (J, 2)."""

    def __init__(self, plan: Plan, angle: np.ndarray) -> None:
        self.plan = plan
        self.angle = np.asarray(angle, dtype=float)
        self.spin = np.exp(1j * self.angle)  # (T,)
        self.J = plan.n_joints
        g = plan.graph
        self.ground = np.array(g.ground)
        self.motor, self.pivot = g.motor, g.pivot
        original = plan.geometry()
        # tracked points attached to links keep their coefficient in the link frame
        self.fixed_coef = [c if c is not None and (b.k_point >= self.J).any() else None
                           for b, c in zip(plan.batches, original.coef)]
        self.scatter = [(_scatter(b.i, plan.n_points), _scatter(b.j, plan.n_points)) for b in plan.batches]
        # the same for the rest-pose points each batch's constants come from
        self.rest_scatter = [(_scatter(b.i_point, plan.n_points), _scatter(b.j_point, plan.n_points))
                             for b in plan.batches]
        dyads = [b for b in plan.batches if not b.rigid]
        self.dyad_i = np.concatenate([b.i_point for b in dyads]) if dyads else np.zeros(0, int)
        self.dyad_j = np.concatenate([b.j_point for b in dyads]) if dyads else np.zeros(0, int)
        self.dyad_k = np.concatenate([b.k_point for b in dyads]) if dyads else np.zeros(0, int)
        self.dyad_sign = np.concatenate([b.sign[:, 0] for b in dyads]) if dyads else np.zeros(0)

    def orientation_ok(self, rest: np.ndarray) -> bool:
        """Whether every dyad triangle of the rest pose ``rest`` (J,) complex keeps its orientation."""
        u = rest[self.dyad_j] - rest[self.dyad_i]
        v = rest[self.dyad_k] - rest[self.dyad_i]
        return bool(np.all((u.real * v.imag - u.imag * v.real) * self.dyad_sign > 0))

    def forward(self, x: np.ndarray) -> Forward:
        """Evaluate at rest pose ``x`` (J, 2)."""
        plan = self.plan
        rest = x[:, 0] + 1j * x[:, 1]
        T = self.angle.size
        z = np.empty((plan.n_points, T), dtype=complex)
        z[plan.ground_rows] = rest[self.ground, None]
        radius = float(abs(rest[self.motor] - rest[self.pivot]))
        z[plan.motor_row] = rest[self.pivot] + radius * self.spin
        terms, dss, coefs, lik2s, ljk2s = [], [], [], [], []
        ok = True
        with np.errstate(invalid="ignore", divide="ignore"):
            for n, b in enumerate(plan.batches):
                zi, zj = z[b.i], z[b.j]
                if b.rigid:
                    c = self.fixed_coef[n]
                    if c is None:
                        ri, rj, rk = rest[b.i_point, None], rest[b.j_point, None], rest[b.k_point, None]
                        c = (rk - ri) / (rj - ri)
                    e = zj - zi
                    z[b.start:b.stop] = zi + c * e
                    terms.append(e), dss.append(None), coefs.append(c), lik2s.append(None), ljk2s.append(None)
                    continue
                ri, rj, rk = rest[b.i_point, None], rest[b.j_point, None], rest[b.k_point, None]
                dik, djk = rk - ri, rk - rj
                lik2 = dik.real ** 2 + dik.imag ** 2
                ljk2 = djk.real ** 2 + djk.imag ** 2
                z[b.start:b.stop], t = loc.dyad(zi, zj, 0.5 * (lik2 - ljk2), lik2, b.sign)
                ds = loc.singularity_distance(t, lik2, ljk2)
                ok = ok and bool(np.all(ds > 0.0))
                terms.append(t), dss.append(ds), coefs.append(None), lik2s.append(lik2), ljk2s.append(ljk2)
        return Forward(rest=rest, z=z, terms=terms, ds=dss, coef=coefs, lik2=lik2s, ljk2=ljk2s,
                       radius=radius, assembled=ok, orientation_ok=self.orientation_ok(rest))

    def gradient(self, f: Forward, gz: np.ndarray, gds: list | None = None) -> np.ndarray:
        """Pull back ∂E/∂z (P, T) complex (consumed) and ∂E/∂d_s per dyad batch to ∂E/∂x̄ (J, 2)."""
        plan = self.plan
        G = gz
        grest = np.zeros(plan.n_points, dtype=complex)
        rest = f.rest
        for n in range(len(plan.batches) - 1, -1, -1):
            b = plan.batches[n]
            gk = G[b.start:b.stop]
            (ui, mi), (uj, mj) = self.scatter[n]
            if b.rigid:
                e, c = f.terms[n], f.coef[n]
                ge = np.conj(c) * gk
                G[ui] += mi @ (gk - ge)
                G[uj] += mj @ ge
                if self.fixed_coef[n] is None:
                    gc = np.einsum("rt,rt->r", np.conj(e), gk)
                    m = rest[b.j_point] - rest[b.i_point]
                    g_num = gc / np.conj(m)  # c = num / m, num = z̄k − z̄i
                    g_m = -gc * np.conj(c[:, 0] / m)
                    (ui_p, mi_p), (uj_p, mj_p) = self.rest_scatter[n]
                    grest[b.k_point] += g_num  # each point is rebuilt once: no duplicates
                    grest[ui_p] += mi_p @ (-g_num - g_m)
                    grest[uj_p] += mj_p @ g_m
                continue
            t = f.terms[n]
            lik2, ljk2 = f.lik2[n], f.ljk2[n]
            gw = np.conj(t.e) * gk
            ge = np.conj(t.w) * gk
            gbsq = gw.imag / (2.0 * t.b)  # B = s·sqrt(B²)
            gu = 0.0
            g_lik2 = g_ljk2 = 0.0
            if gds is not None and gds[n] is not None and gds[n].any():
                # d_s = B²/(u²·l_ik²·l_jk²): through B², and directly through u, l_ik², l_jk²
                gd_ds = gds[n] * f.ds[n]
                gbsq = gbsq + gd_ds / t.bsq
                gu = -2.0 * gd_ds / t.u
                direct = gd_ds.sum(axis=1)
                g_lik2 = -direct / lik2[:, 0]
                g_ljk2 = -direct / ljk2[:, 0]
            ga = gw.real - 2.0 * t.a * gbsq  # B² = l_ik²·u − A²
            gu = gu + gbsq * lik2 + ga * (0.5 * (lik2 - ljk2))  # A = ½ + (l_ik² − l_jk²)/2·u
            ge += (-2.0 * gu * t.u * t.u) * t.e  # u = 1/|e|²
            G[ui] += mi @ (gk - ge)
            G[uj] += mj @ ge
            gau = (ga * t.u).sum(axis=1)
            g_lik2 = g_lik2 + np.einsum("rt,rt->r", gbsq, t.u) + 0.5 * gau
            g_ljk2 = g_ljk2 - 0.5 * gau
            dik = rest[b.k_point] - rest[b.i_point]
            djk = rest[b.k_point] - rest[b.j_point]
            (ui_p, mi_p), (uj_p, mj_p) = self.rest_scatter[n]
            grest[b.k_point] += 2.0 * (g_lik2 * dik + g_ljk2 * djk)
            grest[ui_p] -= mi_p @ (2.0 * g_lik2 * dik)
            grest[uj_p] -= mj_p @ (2.0 * g_ljk2 * djk)
        # motor: z_m = z̄_p + |z̄_m − z̄_p|·exp(iφ)
        gm = G[plan.motor_row]
        g_radius = float(np.sum(gm.real * self.spin.real + gm.imag * self.spin.imag))
        arm = rest[self.motor] - rest[self.pivot]
        unit = arm / abs(arm)
        grest[self.motor] += g_radius * unit
        grest[self.pivot] += gm.sum() - g_radius * unit
        grest[self.ground] += G[plan.ground_rows].sum(axis=1)
        out = grest[: self.J]
        return np.column_stack([out.real, out.imag])
