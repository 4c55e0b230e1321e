"""Slider rules and numeric groups (the plan's steps) as differentiable functions of the rest pose.

A step's constants (a slider's rod length and side, its slot line, a group's rows and branch)
come from the rest pose, so they are compiled again at every evaluation with the planar
engine's own :func:`~linkedit.planar.steps.compile_steps`, in the plan's normalized frame
(origin and unit of the *original* plan: constants, so a tangent only scales by 1/unit).
Positions come from the engine's rules; tangents along each rest-pose direction from the
implicit function theorem (:func:`~linkedit.planar.steps.rest_tangent`: one batched solve per
direction); a slider's d_s = Re(D̄·w)²/(|D|²·|w|²) (w the rod, D the slot direction: 0 where
the rod stands perpendicular to its slot), a joint in two slots' d_s = sin² of the angle between
them and a turning slotted link's d_s = 1 − h²/|w|² come
with the tangent of ln d_s, for the barrier. A numeric group has no barrier: the predicate
keeps it solvable and on its rest branch (sign of its Jacobian's determinant).
"""

from __future__ import annotations

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar import steps as st
from linkedit.planar.constraints import linkage_rows_tangent
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import order_joints
from linkedit.planar.plan import Plan

#: step kinds whose singularity distance the barrier guards
GUARDED = ("slider", "rotate", "lines")


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
        self.guarded = np.array([s.kind in GUARDED for s in plan.steps], dtype=bool)

    def normalized(self, rest: np.ndarray) -> np.ndarray:
        """Rest joints (J,) complex in the normalized frame."""
        return (rest - self.origin) / self.scale

    def compile(self, rest_n: np.ndarray) -> tuple[LinkageGraph, tuple[st.Step, ...]]:
        """Graph and steps at the normalized rest pose ``rest_n`` (J,) complex (MechanismError
        when a step cannot be built there, e.g. a rod perpendicular to its slot)."""
        graph = self.graph.with_rest(np.column_stack([rest_n.real, rest_n.imag]))
        return graph, st.compile_steps(graph, self.rules, self.initial, self.levels)

    def changed(self, steps: tuple[st.Step, ...]) -> str | None:
        """Why ``steps`` left the plan's assembly branch (a slider's side, a slotted link's side,
        a group's determinant sign), naming it; None if they kept it."""
        names = self.plan.joint_names
        for old, new in zip(self.plan.steps, steps):
            if old.kind in ("slider", "rotate") and new.sign != old.sign:
                return (f"slider {old.name} changes branch: joint {names[old.joints[0]]} crossed to the other side "
                        "of the rest pose's")
            if old.kind == "group" and new.det_sign != old.det_sign:
                return f"numeric group {old.name} changes assembly branch at the rest pose"
        return None


def place(step: st.Step, zj: np.ndarray, rest_n: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n, T) of the step's joints and its d_s (T,) (NaN or ≤ 0: cannot place).

    ``zj`` (J, T): normalized joint positions, the step's inputs known (others 0); ``s`` (T,)
    the linear input's stroke (normalized; 0 for a rotary motor); a group is continued from its
    rest position through the samples in order (the rest pose first).
    """
    if step.kind == "group":
        out, ds, _ = st.solve_group(step, zj, s, rest_n[step.joints])
        return out, ds
    return st.positions(step, zj, s)


def tangents(graph: LinkageGraph, step: st.Step, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray) -> np.ndarray:
    """Tangents (n, C, T) of the step's joints: ``dzj`` (J, C, T) of the known joints, ``drest``
    (J, C) the rest-pose directions (both normalized)."""
    return np.stack([st.rest_tangent(graph, step, zj, dzj[:, c], drest[:, c]) for c in range(drest.shape[1])], axis=1)


def dlnds(graph: LinkageGraph, step: st.Step, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray) -> np.ndarray:
    """∂ln d_s (C, T) of a guarded step (``dzj`` (J, C, T) with the step's joints filled in)."""
    source = step.source
    assert source is not None  # guarded steps (slider, lines) know the rows of their slots
    if step.kind == "lines":  # d_s = Im(D̄₂D₁)² / (|D₁|²|D₂|²), D_r = dc_r·z + d0_r of its two slot rows
        rows = step.rows
        d = [rows.dc[r] @ zj + rows.d0[r] for r in (0, 1)]
        dd = [np.einsum("j,jct->ct", rows.dc[r], dzj) for r in (0, 1)]
        for c in range(drest.shape[1]):
            slots = linkage_rows_tangent(graph, drest[:, c]).take(source)
            for r in (0, 1):
                dd[r][c] += slots.dc[r] @ zj + slots.d0[r]
        cross = (np.conj(d[1]) * d[0]).imag
        dcross = (np.conj(dd[1]) * d[0] + np.conj(d[1]) * dd[0]).imag
        return 2.0 * dcross / cross - sum(2.0 * (np.conj(d[r]) * dd[r]).real / np.abs(d[r]) ** 2 for r in (0, 1))
    if step.kind == "slider":  # d_s = Re(D̄w)² / (|D|²|w|²), w = z_k − z_i, D = dc·z + d0
        k, i = step.joints[0], step.i
        rows = step.rows
        d = rows.dc[0] @ zj + rows.d0[0]
        w, dw = zj[k] - zj[i], dzj[k] - dzj[i]
        dd = np.einsum("j,jct->ct", rows.dc[0], dzj)
        for c in range(drest.shape[1]):
            if source[0] >= 0:
                slot = linkage_rows_tangent(graph, drest[:, c]).take(np.array([source[0]]))
                dd[c] += slot.dc[0] @ zj + slot.d0[0]
        a = (np.conj(d) * w).real
        da = (np.conj(dd) * w + np.conj(d) * dw).real
        return 2.0 * da / a - 2.0 * (np.conj(d) * dd).real / np.abs(d) ** 2 - 2.0 * (np.conj(w) * dw).real / np.abs(w) ** 2
    # rotate: d_s = 1 − h²/|w|², w = z_pin − z_i, h = Im(ū·(r̄_pin − r̄_i)) (the slot's offset from i)
    u = step.u
    w, dw = zj[step.pin] - zj[step.i], dzj[step.pin] - dzj[step.i]
    h = step.l2
    dh = (np.conj(u) * (drest[step.pin] - drest[step.i])).imag[:, None]
    w2 = np.abs(w) ** 2
    ds = 1.0 - h * h / w2
    return (-2.0 * h * dh / w2 + 2.0 * h * h * (np.conj(w) * dw).real / (w2 * w2)) / ds


def dependencies(plan: Plan, step: st.Step) -> np.ndarray:
    """Joints (indices) whose rest positions a step's constants depend on."""
    rows = set().union(*step.rows.joints) if step.rows.m else set()
    return np.array(sorted(rows | set(step.joints.tolist()) | set(step.inputs.tolist())), dtype=int)


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
