"""The goals of an edit as residual blocks: follow a curve (tracking), move a joint (displacement),
stay inside a box (envelope). Each block is (r, ∂r, columns) over the sample's variables."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linkedit.curves.polyline import arc_resample
from linkedit.edit.kinematics import Evaluation

Block = tuple[np.ndarray, np.ndarray | None, np.ndarray]  # r (m,), ∂r (m, C) per colour, columns (m, C)
#: A curve goal's target from the track's curve (N,) complex at the start of the operation, sampled
#: at the phases t (N,): the same goal at any sampling (the final check's too).
Aim = Callable[[np.ndarray, np.ndarray], np.ndarray]


def as_real(values: np.ndarray) -> np.ndarray:
    """Complex (…) → real (2·…): real parts, then imaginary parts, along the first axis."""
    return np.concatenate([values.real, values.imag])


def closest(points: np.ndarray, a: np.ndarray, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each of ``points`` (N,) complex against the segments from ``a`` (M,) by ``seg`` (M,) complex: the
    offset (N,) complex from its nearest point on them to it, that segment k (N,) and its place u ∈ [0, 1] (N,)
    along it."""
    rel = points[:, None] - a[None, :]
    u = np.clip((rel * seg.conj()).real / np.maximum(np.abs(seg) ** 2, 1e-300), 0.0, 1.0)
    k = np.argmin(np.abs(rel - u * seg), axis=1)
    rows = np.arange(points.size)
    return rel[rows, k] - u[rows, k] * seg[k], k, u[rows, k]


@dataclass
class Track:
    """Follow a target curve (T,) complex with point row ``row`` over samples ``select``: track
    ``track``'s, aimed at ``aim`` (its curve at the start) over the phase window ``phases``."""

    label: str
    row: int
    target: np.ndarray
    weight: float
    select: np.ndarray
    timing: bool = True
    cyclic: bool = True
    size: float = 0.0  # size of the track's curve at the start of the operation (for reports)
    shape: np.ndarray | None = None  # the polyline for ``timing: false`` when not ``target`` itself
    track: str = ""
    aim: Aim | None = None
    phases: tuple[float, float] | None = None

    def deviation(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(signed deviation (S,) complex or real, unit direction) of the selected samples."""
        p = z[self.row, self.select]
        if self.timing:
            return p - self.target[self.select], np.ones(p.size, dtype=complex)
        line = self.target if self.shape is None else self.shape
        a = line if self.cyclic else line[:-1]
        b = np.roll(line, -1) if self.cyclic else line[1:]
        seg = b - a
        d, k, _ = closest(p, a, seg)  # from the nearest point of the curve to p
        normal = 1j * seg[k] / np.maximum(np.abs(seg[k]), 1e-300)
        side = np.where((d * normal.conj()).real < 0.0, -1.0, 1.0)
        dist = np.abs(d)
        # the distance to the curve, signed by the side: continuous; its direction, the normal on the curve
        direction = np.where(dist > 0.0, side * d / np.where(dist > 0.0, dist, 1.0), normal)
        return side * dist, direction

    @property
    def both_ways(self) -> bool:
        """A shape over the whole cycle (``timing: false``, no window): measured both ways, as the goal is."""
        return not self.timing and self.phases is None

    def back(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The way back: the target's points, as many as the samples, evenly by arc length, to the curve of
        the selected samples (closed over a cycle). Returns (distance (N,), unit direction
        from the curve's nearest point to the target point (N,) complex (0 on the curve), that point's
        segment k (N,) from sample k to k + 1, and its place on it u ∈ [0, 1] (N,))."""
        p = z[self.row, self.select]
        line = self.target if self.shape is None else self.shape
        q = arc_resample(line, p.size, self.cyclic and self.shape is None)
        seg = np.roll(p, -1) - p
        if not (self.cyclic or self.shape is not None):
            seg[-1] = 0.0  # an open curve (a sweep): no segment back to its start
        d, k, u = closest(q, p, seg)
        dist = np.abs(d)
        return dist, np.where(dist > 0.0, d / np.where(dist > 0.0, dist, 1.0), 0.0), k, u

    def rms(self, ev: Evaluation) -> float:
        d, _ = self.deviation(ev.z)
        out = float(np.sqrt(np.mean(np.abs(d) ** 2)))
        return max(out, float(np.sqrt(np.mean(self.back(ev.z)[0] ** 2)))) if self.both_ways else out

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float) -> Block:
        """The residuals; a whole-cycle shape both ways (the curve's samples to the target, then the
        target's points to the curve): a curve shrunk onto a part of its target is not a match."""
        d, normal = self.deviation(ev.z)
        s = np.sqrt(self.weight / self.select.size) * scale
        dz = None if ev.dz is None else ev.dz[self.row][:, self.select].T  # (S, C)
        if self.timing:
            r, D = s * as_real(d), None if dz is None else s * as_real(dz)
        else:
            r, D = s * d, None if dz is None else s * (normal.conj()[:, None] * dz).real
        if self.both_ways:
            dist, unit, k, u = self.back(ev.z)
            r = np.concatenate([r, s * dist])
            if D is not None and dz is not None:  # the nearest point p_k + u·(p_k+1 − p_k) moves, the target's does not
                near = (1.0 - u)[:, None] * dz[k] + u[:, None] * dz[(k + 1) % dz.shape[0]]
                D = np.concatenate([D, -s * (unit.conj()[:, None] * near).real])
        return r, D, np.broadcast_to(cols[self.row], (r.size, cols.shape[1]))


@dataclass
class Displacement:
    """Point row ``row`` at sample column ``column`` (the rest column for the rest pose) to ``target``."""

    label: str
    row: int
    column: int
    target: complex
    weight: float

    def error(self, ev: Evaluation) -> float:
        return float(abs(ev.z[self.row, self.column] - self.target))

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float) -> Block:
        s = np.sqrt(self.weight) * scale
        r = s * as_real(np.atleast_1d(ev.z[self.row, self.column] - self.target))
        D = None if ev.dz is None else s * as_real(ev.dz[self.row][None, :, self.column])
        return r, D, np.broadcast_to(cols[self.row], (2, cols.shape[1]))


@dataclass
class Envelope:
    """Keep point rows ``rows`` inside the box lo–hi (complex corners, ±inf where open)."""

    rows: np.ndarray
    lo: complex
    hi: complex
    weight: float

    def outside(self, z: np.ndarray, T: int) -> np.ndarray:
        p = z[self.rows, :T]
        return (np.minimum(p.real - self.lo.real, 0.0) + np.maximum(p.real - self.hi.real, 0.0)
                + 1j * (np.minimum(p.imag - self.lo.imag, 0.0) + np.maximum(p.imag - self.hi.imag, 0.0)))

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float, T: int) -> Block:
        over = self.outside(ev.z, T)
        s = np.sqrt(self.weight / T) * scale
        rs, Ds, cs = [], [], []
        for part in ("real", "imag"):
            n, t = np.nonzero(getattr(over, part))
            rs.append(s * getattr(over, part)[n, t])
            cs.append(cols[self.rows[n]])
            if ev.dz is not None:
                Ds.append(s * getattr(ev.dz[self.rows[n], :, t], part))
        return np.concatenate(rs), (np.concatenate(Ds) if ev.dz is not None else None), np.concatenate(cs)
