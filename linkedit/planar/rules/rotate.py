"""A slotted link turning about its known joint until its slot meets a known pin (a slotted rocker).

The link turns about joint i by R = ū̄·w / (σ·sqrt(|w|² − h²) + i·h), w = z_pin − z_i, h the
pin's rest offset across the slot (u the slot's rest direction); d_s = 1 − h²/|w|² (< 0: the
slot cannot reach the pin).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from linkedit.planar.graph import LinkageGraph
from linkedit.planar.constraints import Rows
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Frame, InPlace, Step, keep, loop_rows


@dataclass(frozen=True)
class Rotate(Step):
    """The joints of a slotted link turning about joint ``i`` to keep pin ``pin`` in its slot."""

    kind = "rotate"
    watched = True
    guarded = True

    i: int = -1  # the joint the link turns about
    h: float = 0.0  # the pin's rest offset across the slot
    sign: float = 1.0  # which of the two solutions, taken at rest
    slider: int = -1  # index into graph.sliders
    pin: int = -1  # the known joint in the link's slot
    u: complex = 0j  # the slot's direction at rest

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Rotate":
        """The link of ``rule.joints`` turning about ``rule.i``, slider ``rule.slider``'s slot on it."""
        rows, source, inputs = loop_rows(all_rows, known, rule.joints)
        z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
        joints, i, slider, level = np.array(rule.joints, dtype=int), rule.i, rule.slider, rule.level
        name = graph.sliders[slider].name
        k = graph.sliders[slider].joint
        u = complex(np.exp(1j * graph.sliders[slider].angle))
        h, sign = _offset(z[k], z[i], u)
        return cls(level, joints, inputs, name, rows, source, i=i, h=float(h), sign=float(sign), slider=slider,
                   pin=k, u=u)

    def what(self) -> str:
        return f"slotted link turning, slider {self.name}"

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """(h, σ, the joints' offsets z̄_n − z̄_i): (K, 1), (K, 1), (n, K, 1) at rest points ``z`` (P, K)
        with ``many``, else (1,), (1,), (n, 1)."""
        zi = z[self.i, :, None]
        h, sign = _offset(z[self.pin, :, None], zi, self.u)
        return keep(h, many), keep(sign, many), keep(z[self.joints, :, None] - zi, many)

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        h, sign, offsets = const
        w = z[self.pin] - z[self.i]
        w2 = w.real * w.real + w.imag * w.imag
        with np.errstate(invalid="ignore", divide="ignore"):
            rot = np.conj(self.u) * w * ((sign * np.sqrt(w2 - h * h) - 1j * h) / w2)  # |σ√(w² − h²) + ih|² = w²
            return z[self.i] + offsets * rot, 1.0 - h * h / w2

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions by :meth:`place`; with derivatives, the link's rates in closed form (:meth:`_rates`),
        not by the generic Jacobian solves of :meth:`Step.velocity` (same values to rounding)."""
        if f.dz is None or self.rows.drive.any():
            super().evaluate(f, const, rows)
            return
        out_rows = f.joints[self.joints]
        out, f.ds[rows] = self.place(cast(np.ndarray, InPlace(f.z, f.joints)), f.s, f.rest, const)
        f.z[out_rows] = out
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            self._rates(f, const, out_rows)

    def _rates(self, f: Frame, const: tuple[Any, ...], out_rows: np.ndarray) -> None:
        """ż, z̈ of the link's joints into ``f``: it turns about z_i at the rate Ω, ż_n = ż_i + iΩ·(z_n − z_i),
        z̈_n = z̈_i + (iΩ̇ − Ω²)·(z_n − z_i). The slot (direction D) keeps the pin at its offset h:
        Im(D̄w) = h, w = z_pin − z_i, D̄w = κ = σ·sqrt(|w|² − h²) + ih; differentiated,
        Ω = Im(D̄ẇ)/Re κ and Ω̇ = (Im(D̄ẅ) − 2Ω·Re(D̄ẇ) − Ω²h)/Re κ, with D̄ = κ/w."""
        h, sign = const[0], const[1]
        dz, ddz, row = cast(np.ndarray, f.dz), f.ddz, f.joints
        i, pin = row[self.i], row[self.pin]
        w = f.z[pin] - f.z[i]
        across = sign * np.sqrt(w.real * w.real + w.imag * w.imag - h * h)  # Re κ
        turn = (across + 1j * h) / w  # D̄
        arm = f.z[out_rows] - f.z[i]
        slide = turn * (dz[pin] - dz[i])  # D̄ẇ
        omega = slide.imag / across
        dz[out_rows] = dz[i] + 1j * omega * arm
        if ddz is not None:
            spin = ((turn * (ddz[pin] - ddz[i])).imag - 2.0 * omega * slide.real - omega * omega * h) / across
            ddz[out_rows] = ddz[i] + (1j * spin - omega * omega) * arm

    def lockup(self, names: list[str], toggle: bool) -> str:
        return (f"slider {self.name}: the slot of the link carrying {names[self.joints[0]]} cannot reach the pin "
                f"{names[self.pin]} as it turns about {names[self.i]}")

    def branch_change(self, new: Step, names: list[str]) -> str | None:
        if isinstance(new, Rotate) and new.sign != self.sign:
            return (f"slider {self.name} changes branch: joint {names[self.joints[0]]} crossed to the other side "
                    "of the rest pose's")
        return None

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray,
              tangent: Rows) -> np.ndarray:
        """d_s = 1 − h²/|w|², w = z_pin − z_i, h = Im(ū·(r̄_pin − r̄_i)) (the slot's offset from i)."""
        w, dw = zj[self.pin] - zj[self.i], dzj[self.pin] - dzj[self.i]
        h = self.h
        dh = (np.conj(self.u) * (drest[self.pin] - drest[self.i])).imag[:, None]
        w2 = np.abs(w) ** 2
        ds = 1.0 - h * h / w2
        return (-2.0 * h * dh / w2 + 2.0 * h * h * (np.conj(w) * dw).real / (w2 * w2)) / ds


def _offset(pin: Any, zi: Any, u: complex) -> tuple[Any, Any]:
    """(h, σ) of the rest pose: the pin's offset across the slot (direction u) from joint i, and
    on which side of i along it (+1 when on it)."""
    q = np.conj(u) * (pin - zi)
    return q.imag, np.where(q.real < 0, -1.0, 1.0)
