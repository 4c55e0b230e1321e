"""Rigid rules: joint (or tracked point) k fixed in the frame of link (i, j), a level's batch at once.

z_k = z_i + c·(z_j − z_i) with the constant c = (z̄_k − z̄_i)/(z̄_j − z̄_i) of the rest pose;
the same line gives every derivative (positions, velocities and accelerations in one array
operation each). Exact by construction: its d_s is 1.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from linkedit.planar.rules.base import Frame, RestFrame
from linkedit.planar.rules.pool import Pool
from linkedit.planar.rules.triangles import Spread, Triangles, frozen


@dataclass(frozen=True, eq=False)
class Rigid(Triangles):
    """A level's rigid rules and the tracked points on links placed with them."""

    kind: ClassVar[str] = "rigid"
    exact: ClassVar[bool] = True

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """(c,): (R, 1) complex, (R, K, 1) with ``many``."""
        zi, zj, zk = z[self.i_point, :, None], z[self.j_point, :, None], z[self.k_point, :, None]
        c = (zk - zi) / (zj - zi)
        return (c,) if many else frozen(c[:, 0])

    def positions(self, work: Any) -> Callable[[tuple[Any, ...]], None]:
        """z_k = z_i + c·(z_j − z_i)."""
        zi, zj, gather = self.operands(work)
        r, subtract, multiply, add = self.stop - self.start, np.subtract, np.multiply, np.add
        e, out, spread = work.e[:r], work.z[self.start:self.stop], Spread(1, r, work.samples, complex)

        def kernel(const: tuple[Any, ...]) -> None:
            if gather is not None:
                gather()
            subtract(zj, zi, out=e)
            multiply(e, spread.of(const, const[0])[0], out=e)
            add(zi, e, out=out)
        return kernel

    def scratch(self, pool: Pool, Z: np.ndarray) -> Any:
        """The inputs (:meth:`Triangles.scratch`) and one linkage's c spread over the samples
        (:class:`Spread` (1, R, T), outside the pool, broadcast over the derivative orders; None for
        K linkages): an operand broadcast over the samples would cost numpy's general loop, several
        µs a call on a small batch."""
        zi, e = super().scratch(pool, Z)
        one = Z.ndim == 3 and pool.buffer is not None
        return zi, e, Spread(1, self.stop - self.start, Z.shape[-1], complex) if one else None

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Every derivative order at once: the rows of ``f.orders``."""
        zi, e, spread = f.scratch[id(self)]
        zi, out = self.inputs(f.orders, zi, e), f.orders[:, self.start:self.stop]
        c = const[0] if spread is None else spread.of(const, const[0])
        if self.grounded and len(e) > 1:  # z_i's derivatives are 0: z_k's are c·ė, written in place
            np.multiply(c, e, out=out)
            np.add(zi[0], out[0], out=out[0])
        else:
            np.multiply(c, e, out=e)
            np.add(zi, e, out=out)

    def at_rest(self, f: RestFrame, rows: slice) -> None:
        """Joints take c from the rest pose (its tangent from ``f.D``); tracked points keep
        the plan's (``f.fixed``: NaN for joints)."""
        out = slice(self.start, self.stop)
        zi, zj = f.z[self.i], f.z[self.j]
        ri, rj = f.rest[self.i_point], f.rest[self.j_point]
        fixed = f.fixed[id(self)]
        joint = np.isnan(fixed)
        rk = f.rest[np.where(joint, self.k_point, 0)]
        c = np.where(joint, (rk - ri) / (rj - ri), fixed)
        e = zj - zi
        f.z[out] = zi + c[:, None] * e
        if f.dz is not None:
            D = f.D
            Di, Dj = D[self.i_point], D[np.where(joint, self.j_point, 0)]
            Dk = D[np.where(joint, self.k_point, 0)]
            dc = np.where(joint[:, None], (Dk - Di - c[:, None] * (Dj - Di)) / (rj - ri)[:, None], 0.0)
            dzi, dzj = f.dz[self.i], f.dz[self.j]
            f.dz[out] = dzi + dc[:, :, None] * e[:, None, :] + c[:, None, None] * (dzj - dzi)

    def kept(self, const: tuple[Any, ...], joints: int) -> np.ndarray | None:
        """(R,) the plan's coefficients (``const[0]``) of its tracked points, NaN for joints."""
        return np.where(self.k_point >= joints, const[0][:, 0], np.nan)

    def move_tracks(self, old: np.ndarray, new: np.ndarray) -> None:
        m = ~self.listed
        if m.any():
            ip, jp, kp = self.i_point[m], self.j_point[m], self.k_point[m]
            coef = (old[kp] - old[ip]) / (old[jp] - old[ip])
            new[kp] = new[ip] + coef * (new[jp] - new[ip])
