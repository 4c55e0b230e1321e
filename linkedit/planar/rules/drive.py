"""The linearly driven joint (a cylinder's piston): z_k = P + D·s on its known slot line."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Slot, Step, labelled


@dataclass(frozen=True)
class Drive(Step):
    """The driven joint ``joints[0]`` at the stroke s along its slot."""

    kind = "drive"

    slot: Slot = Slot(-1, -1, -1, 1.0 + 0j)  # its slot line

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Drive":
        name = graph.sliders[rule.slider].name
        source = labelled(all_rows, f"slider {name}") + labelled(all_rows, f"linear input {name}")
        rows = all_rows.take(np.array(source))
        k = rule.joints[0]
        inputs = np.array(sorted(set().union(*rows.joints) - {k}), dtype=int)
        return cls(rule.level, np.array(rule.joints, dtype=int), inputs, name, rows, np.array(source),
                   slot=Slot.of(graph, rule.slider))

    def what(self) -> str:
        return f"linear input {self.name}"

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """The slot's (α, c) (:class:`Slot`) at rest points ``z`` (P, K)."""
        return self.slot.constants(z, many)

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        p, d = self.slot.line(z, const)
        out = p + d * s
        return out[None], np.ones(out.shape)
