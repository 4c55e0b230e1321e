"""Dyad rules: joint k at fixed distances from two known joints i, j, a level's batch at once.

The law of cosines (:mod:`linkedit.planar.law_of_cosines`, the one place it is written) on the
triangle (i, j, k), on the side it has at rest; d_s = sin²α, α the angle at k (LinkEdit Eq. 6);
velocities, accelerations and ``edit``'s rest-pose tangents differentiate the same formula.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from linkedit.planar import law_of_cosines as loc
from linkedit.planar.rules.base import Frame, Pool, RestFrame
from linkedit.planar.rules.triangles import Triangles


@dataclass(frozen=True, eq=False)
class Dyad(Triangles):
    """A level's dyads, each on the side ``sign`` of its rest triangle."""

    kind: ClassVar[str] = "dyad"
    watched: ClassVar[bool] = True
    guarded: ClassVar[bool] = True

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """(l_ik², l_jk², (l_ik² − l_jk²)/2, sign): (R, 1) each, (R, K, 1) with ``many`` (then each
        linkage's own rest orientation)."""
        zi, zj, zk = z[self.i_point, :, None], z[self.j_point, :, None], z[self.k_point, :, None]
        a, c = np.abs(zk - zi) ** 2, np.abs(zk - zj) ** 2
        if many:
            return a, c, 0.5 * (a - c), np.sign(((zj - zi).conjugate() * (zk - zi)).imag)
        return a[:, 0], c[:, 0], 0.5 * (a - c)[:, 0], self.sign

    def positions(self, work: Any) -> Callable[[tuple[Any, ...]], None]:
        """z_k = z_i + w·(z_j − z_i), w from :func:`~linkedit.planar.law_of_cosines.dyad_coefficient`."""
        r, i, j = self.stop - self.start, self.i, self.j
        zi, zj, e, w, d2, u = work.zi[:r], work.zj[:r], work.e[:r], work.w[:r], work.d2[:r], work.u[:r]
        a, b = w.real, w.imag
        out, take, coefficient, subtract, multiply, add = (work.z[self.start:self.stop], work.z.take,
                                                           loc.dyad_coefficient, np.subtract, np.multiply, np.add)

        def kernel(const: tuple[Any, ...]) -> None:
            take(i, 0, zi, "clip")
            take(j, 0, zj, "clip")
            subtract(zj, zi, out=e)
            lik2, _, half, sign = const
            coefficient(e, half, lik2, sign, None, d2, u, a, b)
            multiply(e, w, out=e)
            add(zi, e, out=out)
        return kernel

    def scratch(self, pool: Pool, orders: int, shape: tuple[int, ...]) -> Any:
        """The inputs (:meth:`Triangles.scratch`), w and z_k − z_i (complex), d², 1/d², A, B, B²
        (real), and :func:`~linkedit.planar.law_of_cosines.dyad_rates`' buffers: (R, *shape) each."""
        one, n = (self.stop - self.start, *shape), orders - 1
        rates = loc.Rates(pool(one, complex), pool(one, complex), pool(one, complex), pool((n, *one), complex),
                          *(pool(one) for _ in range(4))) if n else None
        return (*super().scratch(pool, orders, shape), pool(one, complex), pool(one, complex),
                *(pool(one) for _ in range(5)), rates)

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions, d_s and the derivatives of ``f.orders``, each one array operation over the batch."""
        lik2, ljk2, half, sign = const
        zi, e, w, fk, d2, u, a, b, bsq, rates = f.scratch[id(self)]
        Z = f.orders
        zi = self.inputs(Z, zi, e)
        loc.dyad_coefficient(e[0], half, lik2, sign, w, d2, u, a, b, bsq)
        np.multiply(w, e[0], out=fk)
        np.add(zi[0], fk, out=Z[0, self.start:self.stop])
        if f.distances:
            loc.singularity_distance(bsq, u, lik2, ljk2, d2, f.ds[rows])
        if rates is not None:
            loc.dyad_rates(e, zi, fk, u, a, b, lik2, Z[1:, self.start:self.stop], rates)

    def at_rest(self, f: RestFrame, rows: slice) -> None:
        """Lengths from the rest pose ``f.rest``; with tangents, ∂z_k and ∂ln d_s along ``f.D``."""
        out = slice(self.start, self.stop)
        zi, zj = f.z[self.i], f.z[self.j]
        ri, rj, rk = f.rest[self.i_point], f.rest[self.j_point], f.rest[self.k_point]
        lik2, ljk2 = np.abs(rk - ri) ** 2, np.abs(rk - rj) ** 2
        half = 0.5 * (lik2 - ljk2)
        f.z[out], t = loc.dyad(zi, zj, half[:, None], lik2[:, None], self.sign)
        loc.singularity_distance(t.bsq, t.u, lik2[:, None], ljk2[:, None], np.empty_like(t.u), f.ds[rows])
        if f.dz is None or f.dlnds is None:
            return
        D = f.D
        Di, Dj, Dk = D[self.i_point], D[self.j_point], D[self.k_point]
        dL = 2.0 * ((rk - ri).conj()[:, None] * (Dk - Di)).real  # (R, C)
        dM = 2.0 * ((rk - rj).conj()[:, None] * (Dk - Dj)).real
        dh = 0.5 * (dL - dM)
        dzi, dzj = f.dz[self.i], f.dz[self.j]
        de = dzj - dzi  # (R, C, T)
        e, u, a = t.e[:, None, :], t.u[:, None, :], t.a[:, None, :]
        du = -2.0 * (e.real * de.real + e.imag * de.imag) * u * u
        da = dh[:, :, None] * u + half[:, None, None] * du
        dbsq = dL[:, :, None] * u + lik2[:, None, None] * du - 2.0 * a * da
        db = dbsq / (2.0 * t.b[:, None, :])
        f.dz[out] = dzi + (da + 1j * db) * e + t.w[:, None, :] * de
        f.dlnds[rows] = (dbsq / t.bsq[:, None, :] - 2.0 * du / u
                         - (dL / lik2[:, None])[:, :, None] - (dM / ljk2[:, None])[:, :, None])
