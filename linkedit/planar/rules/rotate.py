"""A slotted link turning about its known joint until its slot meets a known pin (a slotted rocker).

The link turns about joint i by R = ū̄·w / (σ·sqrt(|w|² − h²) + i·h), w = z_pin − z_i, h the
pin's rest offset across the slot (u the slot's rest direction); d_s = 1 − h²/|w|² (< 0: the
slot cannot reach the pin).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.planar.graph import LinkageGraph
from linkedit.planar.constraints import Rows
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Step, loop_rows


@dataclass(frozen=True)
class Rotate(Step):
    """The joints of a slotted link turning about joint ``i`` to keep pin ``pin`` in its slot."""

    kind = "rotate"
    watched = True
    guarded = True

    i: int = -1  # the joint the link turns about
    h: float = 0.0  # the pin's rest offset across the slot
    sign: float = 1.0  # which of the two solutions, taken at rest
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))  # (n,) z̄_n − z̄_i
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
        u = np.exp(1j * graph.sliders[slider].angle)
        q = np.conj(u) * (z[k] - z[i])
        return cls(level, joints, inputs, name, rows, source, i=i, h=float(q.imag),
                   sign=float(np.sign(q.real)) or 1.0, offsets=z[joints] - z[i], slider=slider, pin=k, u=complex(u))

    def what(self) -> str:
        return f"slotted link turning, slider {self.name}"

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = z[self.pin] - z[self.i]
        w2 = w.real * w.real + w.imag * w.imag
        h = self.h
        with np.errstate(invalid="ignore", divide="ignore"):
            rot = np.conj(self.u) * w / (self.sign * np.sqrt(w2 - h * h) + 1j * h)
            return z[self.i] + self.offsets[:, None] * rot, 1.0 - h * h / w2

    def lockup(self, names: list[str], toggle: bool) -> str:
        return (f"slider {self.name}: the slot of the link carrying {names[self.joints[0]]} cannot reach the pin "
                f"{names[self.pin]} as it turns about {names[self.i]}")

    def branch_change(self, new: Step, names: list[str]) -> str | None:
        if isinstance(new, Rotate) and new.sign != self.sign:
            return (f"slider {self.name} changes branch: joint {names[self.joints[0]]} crossed to the other side "
                    "of the rest pose's")
        return None

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray) -> np.ndarray:
        """d_s = 1 − h²/|w|², w = z_pin − z_i, h = Im(ū·(r̄_pin − r̄_i)) (the slot's offset from i)."""
        w, dw = zj[self.pin] - zj[self.i], dzj[self.pin] - dzj[self.i]
        h = self.h
        dh = (np.conj(self.u) * (drest[self.pin] - drest[self.i])).imag[:, None]
        w2 = np.abs(w) ** 2
        ds = 1.0 - h * h / w2
        return (-2.0 * h * dh / w2 + 2.0 * h * h * (np.conj(w) * dw).real / (w2 * w2)) / ds
