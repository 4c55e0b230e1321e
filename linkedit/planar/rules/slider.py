"""A pin in a slot at a fixed distance from a known joint: circle–line, in closed form.

Joint k lies on a known slot line (point P, unit direction D) at the fixed distance l from the
known joint i: with q = z_i − P, a = Re(D̄q), p = Im(D̄q), z_k = P + D·(a + σ·sqrt(l² − p²));
σ = ±1 is the side taken at rest, never changed. l² < p² is a lock-up (the rod cannot reach the
line); d_s = (l² − p²)/l² is 0 where the rod stands perpendicular to the line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.constraints import Rows, _Builder, _product
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Frame, InPlace, Slot, Step, concat, keep, labelled
from linkedit.planar.rules.pool import Pool


@dataclass(frozen=True)
class Slider(Step):
    """Joint ``joints[0]`` in its slot at its rest distance from joint ``i``, on side ``sign``."""

    kind = "slider"
    watched = True
    guarded = True

    i: int = -1  # the joint at a fixed distance
    sign: float = 1.0  # which of the two crossings, taken at rest
    slot: Slot = Slot(-1, -1, -1, 1.0 + 0j)  # its slot line

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Slider":
        """Joint ``rule.joints[0]`` on its slot at its rest distance from ``rule.i``."""
        z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
        name = graph.sliders[rule.slider].name
        source = labelled(all_rows, f"slider {name}")
        slot = all_rows.take(np.array(source))
        k, i, level = rule.joints[0], rule.i, rule.level
        l2 = abs(z[k] - z[i]) ** 2
        rows = concat(slot, _rod(graph.n_joints, k, i, f"slider {name} rod", l2))
        line = Slot.of(graph, rule.slider)
        side = _side(z[k], z[i], line.u)
        if abs(side) <= 1e-9 * np.sqrt(l2):
            names = graph.joint_names
            raise MechanismError(
                f"joint {names[k]} of slider {name}: the rod {names[i]}–{names[k]} stands perpendicular to "
                "the slot at the rest pose: which side it takes is undefined; move it off the perpendicular")
        inputs = sorted(set().union(*rows.joints) - {k})
        return cls(level, np.array([k]), np.array(inputs, dtype=int), name, rows, np.array(source + [-1]),
                   i=i, sign=float(np.sign(side)), slot=line)

    def what(self) -> str:
        return f"slider {self.name}"

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """The slot's (α, c) (:class:`Slot`), the rod's squared length and the side: (K, 1) each
        at rest points ``z`` (P, K) with ``many``, else (1,)."""
        zk, zi = z[self.joints[0], :, None], z[self.i, :, None]
        l2 = np.abs(zk - zi) ** 2
        return (*self.slot.constants(z, many), keep(l2, many), keep(np.sign(_side(zk, zi, self.slot.u)), many))

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        shape = np.broadcast_shapes(np.shape(z[self.i]), np.shape(const[1]))
        out, ds = np.empty((1, *shape), dtype=complex), np.empty(shape)
        with np.errstate(invalid="ignore"):
            self._circle_line(z, const, out[0], ds, (np.empty(shape, dtype=complex), np.empty(shape)))
        return out, ds

    def scratch(self, pool: Pool, Z: np.ndarray) -> Any:
        """:meth:`_circle_line`'s buffers: q (complex) and x (real), (*L, T) each."""
        return pool(Z.shape[2:], complex), pool(Z.shape[2:])

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions by :meth:`place`; with derivatives, ż_k and z̈_k in closed form (:meth:`_rates`),
        not by the generic Jacobian solves of :meth:`Step.velocity` (same values to rounding)."""
        if f.dz is None:
            super().evaluate(f, const, rows)
            return
        k, joints = f.joints[self.joints[0]], cast(np.ndarray, InPlace(f.z, f.joints))
        out, f.ds[rows] = self.place(joints, f.s, f.rest, const)
        f.z[k] = out[0]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            self._rates(f, const, k, joints)

    def _rates(self, f: Frame, const: tuple[Any, ...], k: int, joints: np.ndarray) -> None:
        """ż_k (, z̈_k) into ``f`` (*L, T): z_k = G + D·x, G the point of the guide under z_k, D the slot's
        unit direction, x real. G moves with the guide (a, b): Ġ = ż_a + γ·ė, G̈ = z̈_a + γ·ë with
        e = z_b − z_a, γ = (z_k − z_a)/e; Ḋ = D·ė/e. The rod r = z_k − z_i keeps its length (r·ṙ = 0,
        r·r̈ = −|ṙ|², · the plane's dot product): ẋ = r·(ż_i − Ġ)/(r·D) and
        ẍ = (r·(z̈_i − G̈ − 2Ḋẋ) − |ṙ|²)/(r·D); ż_k = Ġ + D·ẋ, z̈_k = G̈ + 2Ḋẋ + D·ẍ. On the frame
        Ġ = G̈ = Ḋ = 0. ``joints`` reads f.z by joint (:class:`InPlace`)."""
        dz, ddz, row = cast(np.ndarray, f.dz), f.ddz, f.joints
        i, slot = row[self.i], self.slot
        r = np.conj(f.z[k] - f.z[i])
        d = slot.line(joints, const[:2])[1]
        d = d / np.abs(d)
        across = (r * d).real  # r·D
        carried: Callable[[np.ndarray], Any] = lambda z: 0.0  # the guide's point under z_k: Ġ or G̈
        spin: Any = 0.0  # ė/e
        if slot.a >= 0:
            a, b = row[slot.a], row[slot.b]
            e = f.z[b] - f.z[a]
            gamma = (f.z[k] - f.z[a]) / e
            carried, spin = (lambda z: z[a] + gamma * (z[b] - z[a])), (dz[b] - dz[a]) / e
        moving = carried(dz)
        dx = (r * (dz[i] - moving)).real / across
        dz[k] = moving + d * dx
        if ddz is not None:
            push = carried(ddz) + 2.0 * spin * d * dx  # G̈ + 2Ḋẋ
            ddz[k] = push + d * (((r * (ddz[i] - push)).real - np.abs(dz[k] - dz[i]) ** 2) / across)

    def place_in(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Into ``f``'s rows through its scratch (no allocation)."""
        self._circle_line(InPlace(f.z, f.joints), const, f.z[f.joints[self.joints[0]]], f.ds[rows.start],
                          f.scratch[id(self)])

    def _circle_line(self, z: Any, const: tuple[Any, ...], out: np.ndarray, ds: np.ndarray,
                     buffers: tuple[np.ndarray, np.ndarray]) -> None:
        """The module docstring's z_k into ``out`` and d_s into ``ds`` (*L, T) from joints ``z``
        (z[k]: (*L, T) complex), through ``buffers`` (q complex, x real, that shape)."""
        alpha, c, l2, sign = const
        q, x = buffers
        p, d = self.slot.line(z, (alpha, c))
        d = d / np.abs(d)
        np.subtract(z[self.i], p, out=q)
        np.multiply(np.conj(d), q, out=q)
        np.multiply(q.imag, q.imag, out=ds)
        np.subtract(l2, ds, out=ds)  # h² = l² − p²
        np.sqrt(ds, out=x)
        np.multiply(sign, x, out=x)
        np.add(q.real, x, out=x)
        np.multiply(d, x, out=out)
        np.add(p, out, out=out)
        np.divide(ds, l2, out=ds)

    def lockup(self, names: list[str], toggle: bool) -> str:
        k = names[self.joints[0]]
        if toggle:
            return (f"slider {self.name} reaches a toggle position: the rod {names[self.i]}–{k} stands "
                    "perpendicular to the slot line (d_s = 0)")
        return f"slider {self.name} cannot place joint {k}: the rod {names[self.i]}–{k} does not reach the slot line"

    def branch_change(self, new: Step, names: list[str]) -> str | None:
        if isinstance(new, Slider) and new.sign != self.sign:
            return (f"slider {self.name} changes branch: joint {names[self.joints[0]]} crossed to the other side "
                    "of the rest pose's")
        return None

    def rows_at(self, all_rows: Rows, rest: np.ndarray) -> Rows:
        """The slot's rows, then the rod's at each rest pose."""
        k, i = int(self.joints[0]), self.i
        rod = _rod(rest.shape[0], k, i, self.rows.labels[-1], np.abs(rest[k] - rest[i]) ** 2)
        return concat(super().rows_at(all_rows, rest), rod)

    def rows_tangent(self, graph: LinkageGraph, drest: np.ndarray, tangent: Rows) -> Rows:
        """The slot row's tangent, then the rod's: d/dε of its squared length."""
        z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
        k, i = int(self.joints[0]), self.i
        b = _Builder(graph.n_joints, drest.shape[1:])
        b.add(False, {}, 0j, {}, 0j, "rod", rhs=2.0 * _product(np.conj(z[k] - z[i]), drest[k] - drest[i]).real)
        return concat(super().rows_tangent(graph, drest, tangent), b.build())

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray,
              tangent: Rows) -> np.ndarray:
        """d_s = Re(D̄w)² / (|D|²|w|²), w = z_k − z_i, D = dc·z + d0 (0: the rod perpendicular to the slot)."""
        k, i = self.joints[0], self.i
        rows, source = self.rows, self.source
        d = rows.dc[0] @ zj + rows.d0[0]
        w, dw = zj[k] - zj[i], dzj[k] - dzj[i]
        dd = np.einsum("j,jct->ct", rows.dc[0], dzj)
        if source[0] >= 0:
            dd += tangent.take(np.array([source[0]])).terms(zj)[0][0]
        a = (np.conj(d) * w).real
        da = (np.conj(dd) * w + np.conj(d) * dw).real
        return 2.0 * da / a - 2.0 * (np.conj(d) * dd).real / np.abs(d) ** 2 - 2.0 * (np.conj(w) * dw).real / np.abs(w) ** 2


def _rod(n_joints: int, k: int, i: int, label: str, l2: Any) -> Rows:
    """The rod's row |z_k − z_i|² = l2 (one linkage's, or (K,) of K linkages')."""
    b = _Builder(n_joints, np.shape(l2))
    b.add(False, {k: 1, i: -1}, 0j, {k: 1, i: -1}, 0j, label, rhs=l2)
    return b.build()


def _side(zk: Any, zi: Any, u: complex) -> Any:
    """Re(ū·(z_k − z_i)): which side of the rod's foot on the slot (direction u at rest) joint k takes."""
    return (np.conj(u) * (zk - zi)).real
