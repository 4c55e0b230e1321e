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
from linkedit.planar.rules.base import Frame, RestFrame
from linkedit.planar.rules.pool import Pool
from linkedit.planar.rules.triangles import Spread, Triangles, frozen


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
        return (*frozen(a[:, 0], c[:, 0], 0.5 * (a - c)[:, 0]), self.sign)

    def positions(self, work: Any) -> Callable[[tuple[Any, ...]], None]:
        """z_k = z_i + w·(z_j − z_i), w from :func:`~linkedit.planar.law_of_cosines.coefficient`."""
        r = self.stop - self.start
        zi, zj, gather = self.operands(work)
        e, w, out, subtract, multiply, add = work.e[:r], work.w[:r], work.z[self.start:self.stop], np.subtract, np.multiply, np.add
        coefficient = loc.coefficient(e, w, work.d2[:r], work.u[:r], work.a[:r], work.b[:r])
        spread = Spread(3, r, work.samples)

        def kernel(const: tuple[Any, ...]) -> None:
            if gather is not None:
                gather()
            subtract(zj, zi, out=e)
            half, lik2, sign = spread.of(const, const[2], const[0], const[3])
            coefficient(half, lik2, sign)
            multiply(e, w, out=e)
            add(zi, e, out=out)
        return kernel

    def scratch(self, pool: Pool, Z: np.ndarray) -> Any:
        """The inputs (:meth:`Triangles.scratch`), the joints' offsets from z_i: z_k − z_i and what
        the derivatives add, formed in the rule's own rows of ``Z`` (orders, R, *shape) complex (z_i is
        added last), w (complex), d², 1/d², B², A, B (real): (R, *shape) each, and the kernels of w (:func:`~linkedit.planar.law_of_cosines.coefficient`)
        and of the rates (:func:`~linkedit.planar.law_of_cosines.rates`, None without
        derivatives) on them; one linkage's constants spread over the samples (:class:`Spread`,
        with l_ik²·l_jk² for d_s) and its rates' iω (its zero real part then stays), both outside
        the pool (in it for K linkages, and no spread); None while the pool measures."""
        shape = Z.shape[2:]
        one, n, single, fk = (self.stop - self.start, *shape), Z.shape[0] - 1, len(shape) == 1, Z[:, self.start:self.stop]
        zi, e = super().scratch(pool, Z)
        w, d2, u, bsq = pool(one, complex), pool(one), pool(one), pool(one)
        a, b = pool(one), pool(one)
        c = None
        if n:  # one linkage's iω outside the pool, like its spread constants: its zero real part stays
            c = np.empty(one if pool.buffer is not None else 0, complex) if single else pool(one, complex)
        if pool.buffer is None:  # measuring: the arrays are empty
            return None
        rates = None
        if c is not None:  # e's positions row, w, B (s = u/B in place), B² and d² are spent before the rates: they
            # hold g = z_k − z_j, ġ, s, g·f, |ġ|²; the products g·ė (, g·ë) go where their rates go (each is spent
            # before its rate is written)
            rates = loc.rates(e, fk[0], u, a, b, fk[1:], loc.Rates(e[0], c, w, fk[1:], b, bsq, d2, kept=single))
        spread = Spread(4, one[0], shape[0], derive=_lengths) if single else None
        return zi, e, fk, w, d2, u, bsq, loc.coefficient(e[0], w, d2, u, a, b, bsq), rates, spread

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions, d_s and the derivatives of ``f.orders``, each one array operation over the batch."""
        zi, e, fk, w, d2, u, bsq, coefficient, rates, spread = f.scratch[id(self)]
        if spread is None:
            lik2, ljk2, half, sign = const
            lengths = lik2 * ljk2
        else:
            lik2, half, sign, lengths = spread.of(const, const[0], const[2], const[3], const[1])
        Z = f.orders
        zi = self.inputs(Z, zi, e)
        coefficient(half, lik2, sign)
        np.multiply(w, e[0], out=fk[0])
        if f.distances:
            loc.singularity_distance(bsq, u, lengths, d2, f.ds[rows])
        if rates is not None:
            rates(lik2)
        if self.grounded:
            np.add(zi[0], fk[0], out=fk[0])
        else:
            np.add(zi, fk, out=fk)

    def at_rest(self, f: RestFrame, rows: slice) -> None:
        """Lengths from the rest pose ``f.rest``; with tangents, ∂z_k and ∂ln d_s along ``f.D``."""
        out = slice(self.start, self.stop)
        zi, zj = f.z[self.i], f.z[self.j]
        ri, rj, rk = f.rest[self.i_point], f.rest[self.j_point], f.rest[self.k_point]
        lik2, ljk2 = np.abs(rk - ri) ** 2, np.abs(rk - rj) ** 2
        half = 0.5 * (lik2 - ljk2)
        f.z[out], t = loc.dyad(zi, zj, half[:, None], lik2[:, None], self.sign)
        loc.singularity_distance(t.bsq, t.u, (lik2 * ljk2)[:, None], np.empty_like(t.u), f.ds[rows])
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


def _lengths(tiles: np.ndarray) -> None:
    """The spread constants' l_ik²·l_jk², d_s's denominator: tile 3 (l_jk²) times tile 0 (l_ik²)."""
    np.multiply(tiles[0], tiles[3], out=tiles[3])
