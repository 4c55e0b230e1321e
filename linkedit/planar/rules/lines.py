"""A joint in two known slots: their crossing, in closed form, one solution and no branch.

With the lines (P₁, D₁), (P₂, D₂): z_k = P₁ + D₁·Im(D̄₂(P₂ − P₁))/Im(D̄₂D₁). d_s = sin² of the
angle between the lines: 0 where they are parallel (no single crossing: a lock-up naming both
sliders).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Frame, InPlace, Slot, Step, labelled


@dataclass(frozen=True)
class Lines(Step):
    """Joint ``joints[0]`` where its two slots cross."""

    kind = "lines"
    watched = True
    guarded = True

    slots: tuple[Slot, ...] = ()  # its two slot lines

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Lines":
        """Joint ``rule.joints[0]`` in the slots of sliders ``rule.slider`` and ``rule.i``."""
        a, b = graph.sliders[rule.slider].name, graph.sliders[rule.i].name
        source = labelled(all_rows, f"slider {a}") + labelled(all_rows, f"slider {b}")
        rows = all_rows.take(np.array(source))
        k = rule.joints[0]
        inputs = np.array(sorted(set().union(*rows.joints) - {k}), dtype=int)
        return cls(rule.level, np.array(rule.joints, dtype=int), inputs, f"{a} and {b}", rows, np.array(source),
                   slots=(Slot.of(graph, rule.slider), Slot.of(graph, rule.i)))

    def what(self) -> str:
        return f"two slots, sliders {self.name}"

    def label(self) -> str:
        return f"sliders {self.name}"

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """Each slot's (α, c) (:class:`Slot`) at rest points ``z`` (P, K)."""
        return tuple(slot.constants(z, many) for slot in self.slots)

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        (p1, d1), (p2, d2) = (slot.line(z, c) for slot, c in zip(self.slots, const))
        cross = (np.conj(d2) * d1).imag
        with np.errstate(invalid="ignore", divide="ignore"):
            at = (np.conj(d2) * (p2 - p1)).imag / cross
        return (p1 + d1 * at)[None], cross * cross / ((d1 * np.conj(d1)).real * (d2 * np.conj(d2)).real)

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions by :meth:`place`; with derivatives, the crossing's differentiated in closed form
        (:meth:`_rates`), not by the generic Jacobian solves of :meth:`Step.velocity`."""
        if f.dz is None or self.rows.drive.any():
            super().evaluate(f, const, rows)
            return
        k = f.joints[self.joints[0]]
        out, f.ds[rows] = self.place(cast(np.ndarray, InPlace(f.z, f.joints)), f.s, f.rest, const)
        f.z[k] = out[0]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            self._rates(f, const, k)

    def _rates(self, f: Frame, const: tuple[Any, ...], k: int) -> None:
        """ż_k (, z̈_k) into ``f``: z_k = P₁ + D₁·t, t = N/X, N = Im(D̄₂(P₂ − P₁)), X = Im(D̄₂D₁),
        differentiated once (twice) by the product rule. A slot's P and D are linear in its guide's
        joints (:meth:`Slot.line`), so their rates are the line of the joints' rates (0 on the frame)."""
        def lines(z: np.ndarray, moving: bool) -> list[tuple[Any, Any]]:
            at = cast(np.ndarray, InPlace(z, f.joints))
            return [slot.line(at, c) if slot.a >= 0 or not moving else (0.0, 0.0) for slot, c in zip(self.slots, const)]

        def im(a: Any, b: Any) -> Any:  # Im(ā·b)
            return (np.conj(a) * b).imag
        (p1, d1), (p2, d2) = lines(f.z, False)
        (v1, e1), (v2, e2) = lines(cast(np.ndarray, f.dz), True)
        x = im(d2, d1)
        t = im(d2, p2 - p1) / x
        dx = im(e2, d1) + im(d2, e1)
        dt = (im(e2, p2 - p1) + im(d2, v2 - v1) - t * dx) / x
        cast(np.ndarray, f.dz)[k] = v1 + e1 * t + d1 * dt
        if f.ddz is None:
            return
        (a1, g1), (a2, g2) = lines(f.ddz, True)
        ddx = im(g2, d1) + 2.0 * im(e2, e1) + im(d2, g1)
        ddt = (im(g2, p2 - p1) + 2.0 * im(e2, v2 - v1) + im(d2, a2 - a1) - 2.0 * dt * dx - t * ddx) / x
        f.ddz[k] = a1 + g1 * t + 2.0 * e1 * dt + d1 * ddt

    def lockup(self, names: list[str], toggle: bool) -> str:
        return (f"sliders {self.name}: the two slots of joint {names[self.joints[0]]} are parallel (d_s = 0): "
                "they do not cross at one point")

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray,
              tangent: Rows) -> np.ndarray:
        """d_s = Im(D̄₂D₁)² / (|D₁|²|D₂|²), D_r = dc_r·z + d0_r of its two slot rows."""
        rows = self.rows
        d = [rows.dc[r] @ zj + rows.d0[r] for r in (0, 1)]
        dd = [np.einsum("j,jct->ct", rows.dc[r], dzj) for r in (0, 1)]
        slots, _ = tangent.take(self.source).terms(zj)
        for r in (0, 1):
            dd[r] += slots[r]
        cross = (np.conj(d[1]) * d[0]).imag
        dcross = (np.conj(dd[1]) * d[0] + np.conj(d[1]) * dd[0]).imag
        return 2.0 * dcross / cross - sum(2.0 * (np.conj(d[r]) * dd[r]).real / np.abs(d[r]) ** 2 for r in (0, 1))
