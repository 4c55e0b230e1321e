"""The linearly driven joint (a cylinder's piston): z_k = P + D·s on its known slot line."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.constraints import Rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Step, labelled, slot_line


@dataclass(frozen=True)
class Drive(Step):
    """The driven joint ``joints[0]`` at the stroke s along its slot."""

    kind = "drive"

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Drive":
        name = graph.sliders[rule.slider].name
        source = labelled(all_rows, f"slider {name}") + labelled(all_rows, f"linear input {name}")
        rows = all_rows.take(np.array(source))
        k = rule.joints[0]
        inputs = np.array(sorted(set().union(*rows.joints) - {k}), dtype=int)
        return cls(rule.level, np.array(rule.joints, dtype=int), inputs, name, rows, np.array(source))

    def what(self) -> str:
        return f"linear input {self.name}"

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, d = slot_line(self.rows, 0, self.joints[0], z)
        return (p + d * s)[None], np.ones(z.shape[1])
