"""Slider rules and numeric groups (the plan's steps) as differentiable functions of the rest pose.

A step's constants (a slider's rod length and side, its slot line, a group's rows and branch)
come from the rest pose, so they are compiled again at every evaluation with the planar
engine's own :func:`~linkedit.planar.rules.compile_steps`, in the plan's normalized frame
(origin and unit of the *original* plan: constants, so a tangent only scales by 1/unit).
Positions come from the engine's rules (:meth:`~linkedit.planar.rules.Step.at_rest`); tangents
along every rest-pose direction at once from the implicit function theorem (:meth:`~linkedit.planar.rules.Step.rest_tangent`:
the rows' derivatives built once for all directions, one Jacobian, one batched solve); the guarded kinds (a slider, a joint in two slots, a turning slotted link) give the
tangent of ln d_s too (:meth:`~linkedit.planar.rules.Step.dlnds`), for the barrier. A numeric group has no barrier: the predicate
keeps it solvable and on its rest branch (sign of its Jacobian's determinant).
"""

from __future__ import annotations

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import order_joints
from linkedit.planar.plan import Plan
from linkedit.planar.rules import Step, compile_steps

class RestPoseSteps:
    """The steps of ``plan``, re-derived at any rest pose."""

    def __init__(self, plan: Plan) -> None:
        self.plan = plan
        self.origin, self.scale = plan.origin, plan.scale
        g = plan.graph
        o = np.array([self.origin.real, self.origin.imag])
        self.graph = g.with_rest((g.rest - o) / self.scale)
        ordering = order_joints(self.graph)
        self.rules = ordering.steps
        if [(r.kind, tuple(r.joints)) for r in self.rules] != [(s.kind, tuple(s.joints)) for s in plan.steps]:
            raise AssertionError("the ordering's steps differ from the plan's")  # pragma: no cover
        self.initial = set(g.ground) | ({g.motor} if g.pivot >= 0 else set())
        self.levels = {r.k: r.level for r in ordering.rules}
        self.guarded = np.array([s.guarded for s in plan.steps], dtype=bool)

    def normalized(self, rest: np.ndarray) -> np.ndarray:
        """Rest joints (J,) complex in the normalized frame."""
        return (rest - self.origin) / self.scale

    def compile(self, rest_n: np.ndarray) -> tuple[LinkageGraph, tuple[Step, ...]]:
        """Graph and steps at the normalized rest pose ``rest_n`` (J,) complex (MechanismError
        when a step cannot be built there, e.g. a rod perpendicular to its slot)."""
        graph = self.graph.with_rest(np.column_stack([rest_n.real, rest_n.imag]))
        return graph, compile_steps(graph, self.rules, self.initial, self.levels)

    def changed(self, steps: tuple[Step, ...]) -> str | None:
        """Why ``steps`` left the plan's assembly branch (a slider's side, a slotted link's side,
        a group's determinant sign), naming it; None if they kept it."""
        names = self.plan.joint_names
        for old, new in zip(self.plan.steps, steps):
            why = old.branch_change(new, names)
            if why is not None:
                return why
        return None


def check(plan: Plan, rest: np.ndarray) -> str | None:
    """Whether the steps of ``plan`` can be built at rest pose ``rest`` (J,) complex (world
    frame) on the plan's branch; the reason naming the step if not."""
    if not plan.steps:
        return None
    rps = RestPoseSteps(plan)
    try:
        _, steps = rps.compile(rps.normalized(rest))
    except MechanismError as exc:
        return str(exc)
    return rps.changed(steps)
