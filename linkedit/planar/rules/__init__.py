"""The planar rule vocabulary, one module per kind, and how a plan compiles the non-revolute ones.

Every rule is a :class:`Rule` (:mod:`.base`). :class:`Dyad` (the law of cosines,
:mod:`linkedit.planar.law_of_cosines`) and :class:`Rigid` hold a whole level's batch each
(:class:`Triangles`); every other kind is a :class:`Step` subclass:
:class:`Slider` (circle–line), :class:`Drive` (the linear input), :class:`Lines` (two slots),
:class:`Rotate` (a slotted rocker), :class:`Yoke` (a translating slotted link) and
:class:`Group` (a complex loop solved numerically). A new kind is one class in one module,
listed in :data:`KINDS`.
"""

from __future__ import annotations

from linkedit.planar.constraints import linkage_rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Failure, Frame, RestFrame, Rule, Step
from linkedit.planar.rules.drive import Drive
from linkedit.planar.rules.dyad import Dyad
from linkedit.planar.rules.group import Group
from linkedit.planar.rules.lines import Lines
from linkedit.planar.rules.rotate import Rotate
from linkedit.planar.rules.rigid import Rigid
from linkedit.planar.rules.slider import Slider
from linkedit.planar.rules.triangles import Triangles
from linkedit.planar.rules.yoke import Yoke

#: the class of each kind the ordering (:mod:`linkedit.planar.ordering`) names
KINDS: dict[str, type[Step]] = {cls.kind: cls for cls in (Slider, Drive, Lines, Rotate, Yoke, Group)}

__all__ = ["KINDS", "Drive", "Dyad", "Failure", "Frame", "Group", "Lines", "RestFrame", "Rigid", "Rotate", "Rule",
           "Slider", "Step", "Triangles", "Yoke", "compile_steps"]


def compile_steps(graph: LinkageGraph, rules: tuple[StepRule, ...], known0: set[int],
                  revolute_levels: dict[int, int]) -> tuple[Step, ...]:
    """Compile the ordering's step rules at ``graph``'s rest pose (``known0``: joints known
    before any rule; ``revolute_levels``: the level of each joint a dyad or rigid rule writes)."""
    all_rows = linkage_rows(graph)
    level_of = {k: 0 for k in known0} | revolute_levels
    out = []
    for rule in rules:
        known = {k for k, lv in level_of.items() if lv < rule.level}
        out.append(KINDS[rule.kind].compile(graph, rule, all_rows, known))
        level_of.update({k: rule.level for k in rule.joints})
    return tuple(out)
