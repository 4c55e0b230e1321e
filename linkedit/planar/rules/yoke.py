"""A slotted link translating along the frame until its slot meets a known pin (a Scotch yoke).

It slides by λ·g, λ = Im(ū̄·(z_pin − z̄_pin)) / Im(ū̄·g) (u the slot's direction, g the direction
it translates in); d_s = Im(ū̄·g)², constant: 0 where the slot is parallel to g.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.constraints import Rows
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Frame, InPlace, Step, keep, loop_rows


@dataclass(frozen=True)
class Yoke(Step):
    """The joints of a translating slotted link keeping pin ``pin`` in its slot."""

    kind = "yoke"

    cross: float = 0.0  # Im(ū̄·g)
    slider: int = -1  # index into graph.sliders
    pin: int = -1  # the known joint in the link's slot
    u: complex = 0j  # the slot's direction at rest
    g: complex = 0j  # the direction the link translates in

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Yoke":
        """The link of ``rule.joints`` translating along slider ``rule.i``, slider ``rule.slider``'s slot on it."""
        rows, source, inputs = loop_rows(all_rows, known, rule.joints)
        joints, guide, slider, level = np.array(rule.joints, dtype=int), rule.i, rule.slider, rule.level
        name = graph.sliders[slider].name
        k = graph.sliders[slider].joint
        u = np.exp(1j * graph.sliders[slider].angle)
        g = np.exp(1j * graph.sliders[guide].angle)
        cross = float((np.conj(u) * g).imag)
        if abs(cross) <= 1e-9:
            raise MechanismError(f"slider {name}: the slot is parallel to the direction its link translates in: "
                                 "the pin cannot move it")
        return cls(level, joints, inputs, name, rows, source, cross=cross, slider=slider,
                   pin=k, u=complex(u), g=complex(g))

    def what(self) -> str:
        return f"slotted link translating (yoke), slider {self.name}"

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """(the joints' rest positions z̄_n, the pin's z̄_pin): (n, K, 1), (K, 1) at rest points ``z``
        (P, K) with ``many``, else (n, 1), (1,)."""
        return keep(z[self.joints, :, None], many), keep(z[self.pin, :, None], many)

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        offsets, at = const
        along = (np.conj(self.u) * (z[self.pin] - at)).imag / self.cross
        return offsets + along * self.g, np.full(along.shape, self.cross * self.cross)

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Positions by :meth:`place`; with derivatives, the link's ż = g·Im(ū̄·ż_pin)/Im(ū̄·g) and
        z̈ alike (λ is linear in z_pin), not by the generic Jacobian solves of :meth:`Step.velocity`."""
        if f.dz is None or self.rows.drive.any():
            super().evaluate(f, const, rows)
            return
        out_rows, pin = f.joints[self.joints], f.joints[self.pin]
        f.z[out_rows], f.ds[rows] = self.place(cast(np.ndarray, InPlace(f.z, f.joints)), f.s, f.rest, const)
        for d in (f.dz, f.ddz):
            if d is not None:
                d[out_rows] = (np.conj(self.u) * d[pin]).imag / self.cross * self.g

