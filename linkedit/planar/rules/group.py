"""A complex loop (a class-III Assur group, a cylinder's barrel), solved numerically as one group.

Newton's method on the group's constraint rows at every sample (the samples are dense: see
:func:`linkedit.planar.kinematics.evaluate`), continued from the rest pose through a sample each
time its inputs have moved GROUP_STRIDE, then every sample polished at once from a predictor and
checked (:func:`~.general_group.solve_group`; a triad in its body's pose, :mod:`.triad`), keeping
the rest pose's branch (the sign of the group Jacobian's determinant never changes; a change
means the group passed a singular position, reported as a lock-up). Its singularity distance is
the Hadamard ratio (det J / ∏ ‖row‖)² of the group Jacobian J
(:func:`~.general_group.conditioning`: the dyad's sin²α generalized); its velocities
and accelerations come from the same Jacobian at the solution (the implicit function theorem on
the rows' :class:`~.general_group.RealForm`, built once per step: :meth:`Group.evaluate`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from linkedit.planar.constraints import Rows, linkage_rows
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.base import Frame, Step, loop_rows, solve, to_complex
from linkedit.planar.rules.continuation import trace
from linkedit.planar.rules.general_group import RealForm, conditioning, det_signs, solve_group, variables
from linkedit.planar.rules.triad import Body, Pose, Poses, Triad, pose, rates
from linkedit.planar.rules.triad import ds as triad_ds


@dataclass(frozen=True)
class Group(Step):
    """The joints of a complex loop, on the side ``det_sign`` of its Jacobian's determinant at rest.

    Its constants (:meth:`constants`) are its rows at each linkage's rest pose as a
    :class:`RealForm` (the link lengths live in its Q) and each one's determinant sign there: K
    linkages of one topology are solved in one :meth:`evaluate` (:func:`solve_group`)."""

    kind = "group"
    watched = True
    numeric = True

    det_sign: float = 1.0
    #: the linkage graph it was compiled from (its rows at other rest poses: :meth:`constants`)
    graph: LinkageGraph | None = field(default=None, compare=False, repr=False)

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Group":
        """The joints ``rule.joints`` with every row binding them to each other and to known joints."""
        rows, source, inputs = loop_rows(all_rows, known, rule.joints)
        joints, level = np.array(rule.joints, dtype=int), rule.level
        z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
        names = graph.joint_names
        return cls(level, joints, inputs, ", ".join(names[k] for k in joints), rows, source,
                   det_sign=float(det_signs(rows, z[:, None], joints)[0]), graph=graph)

    def what(self) -> str:
        return "numeric group"

    def label(self) -> str:
        return f"numeric group {self.name}"

    @cached_property
    def compiled(self) -> tuple[Any, ...]:
        """Its :meth:`constants` at the rest pose it was compiled at (one linkage)."""
        assert self.graph is not None
        return self.constants((self.graph.rest[:, 0] + 1j * self.graph.rest[:, 1])[:, None], False)

    @property
    def _columns(self) -> np.ndarray:
        return np.concatenate([self.joints, self.inputs])

    @cached_property
    def triad(self) -> Triad | None:
        """Its triad (:mod:`.triad`: solved as its body's pose) when it has that shape, else None."""
        assert self.graph is not None
        return Triad.of(self.rows, self.joints, self.inputs, self.graph.rest[:, 0] + 1j * self.graph.rest[:, 1])

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """(its :class:`RealForm` at each of the K rest poses ``z`` (P, K) complex, twice (K, m·W, W);
        the sign (K,) of its Jacobian's determinant at each, or for a triad None and its
        :class:`~.triad.Body` at each):
        each linkage's own rows and branch."""
        assert self.graph is not None
        rest = z[: self.graph.n_joints]
        rows = self.rows_at(linkage_rows(self.graph, rest=rest), rest)
        form = RealForm.of(rows.columns(self._columns))
        if self.triad is None:
            return form, det_signs(rows, rest[:, :, None], self.joints)
        body = self.triad.constants(rest, self.joints, self.inputs)
        turns = body.p * np.array([0.0, 1.0, 1j])  # the body about the origin, turned by u = 0, 1, i
        grad = form.gradient(variables(turns, np.zeros((self.inputs.size, *turns.shape[1:]))))
        return form, None, body.with_rows(grad[..., self.triad.body, : 2 * self.joints.size])

    def _parts(self, const: tuple[Any, ...]) -> tuple[RealForm, Any, Body | None]:
        """(form, signs (None for a triad: its body holds det M's), body) of ``const``, by default at the
        rest pose it was compiled at."""
        const = const or self.compiled
        return const[0], const[1], const[2] if len(const) > 2 else None

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        form, signs, body = self._parts(const)
        known, inputs, start = z[self.inputs][:, None], np.broadcast_to(s, (1, z.shape[-1])), rest[self.joints][:, None]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if body is not None:
                joints, now = self._solve_triad(body, known, inputs)
                return joints[:, 0], triad_ds(now, body)[0]
            x, det, placed = solve_group(form, signs, known, inputs, start)
        k = 2 * self.joints.size
        return to_complex(np.moveaxis(x[0, :, :k], -1, 0)), conditioning(form.gradient(x)[..., :k], det, placed)[0]

    def _solve_triad(self, body: Body, known: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, Pose]:
        """K linkages' triads (their ``body``, inputs ``known`` (J_in, K, T) complex, ``s`` (K, T)),
        continued in their bodies' poses (:func:`~.continuation.trace`, :class:`~.triad.Poses`).
        Returns the joints (3, K, T) complex (NaN from where a linkage fails) and the pose there."""
        assert self.triad is not None
        hung = known[self.triad.partner]
        poses = Poses(body, hung)
        X, det, placed = trace(poses, known, s)
        if poses.now is not None and not np.isnan(det).any():  # every sample placed by the polish
            return poses.now.joints, poses.now
        now = pose(body, hung, X[..., 0] + 1j * X[..., 1], X[..., 2])[0]
        return now.joints, now

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Place its joints in ``f`` (one linkage, or K: ``f.z`` (P, K, T), each with its own rows,
        branch and rest pose, ``const``), then their velocities and accelerations from the group's
        Jacobian at the solution (the same one as its d_s): J_S·ẋ_S = −J_K·ẋ_K + F_s·ṡ,
        J_S·ẍ_S = −J_K·ẍ_K − Ẋᵀ·2Q·Ẋ (:class:`RealForm`), two solves batched over (K·T) rows."""
        many = f.z.ndim > 2
        form, signs, body = self._parts(const)

        def lift(a: np.ndarray) -> np.ndarray:  # (…, T) → (…, K, T)
            return a if many else a[..., None, :]

        if body is not None:
            self._evaluate_triad(f, body, lift, rows)
            return
        zj, out = lift(f.z[f.joints]), f.joints[self.joints]
        K, T = zj.shape[1:]
        rest = f.rest[self.joints]
        x, det, placed = solve_group(form, signs, zj[self.inputs], np.broadcast_to(f.s, (K, T)),
                                     rest if many else rest[:, None])
        k = 2 * self.joints.size
        grad = form.gradient(x)  # (K, T, m, W): ∂F/∂X
        jac = grad[..., :k]

        def put(target: np.ndarray, xy: np.ndarray) -> None:  # (K, T, k) real → rows (n, *L, T)
            target[out] = to_complex(np.moveaxis(xy, -1, 0)) if many else to_complex(np.moveaxis(xy[0], -1, 0))

        put(f.z, x[..., :k])
        f.ds[rows] = conditioning(jac, det, placed) if many else conditioning(jac, det, placed)[0]
        if f.dz is None:
            return
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            dx = self._known(lift(f.dz[f.joints]), x.shape)
            rhs = form.drive * f.drive - (grad @ dx[..., None])[..., 0]
            dx[..., :k] = np.moveaxis(solve(jac, np.moveaxis(rhs, -1, 0)), 0, -1)
            put(f.dz, dx[..., :k])
            if f.ddz is None:
                return
            ddx = self._known(lift(f.ddz[f.joints]), x.shape)
            rhs = -(grad @ ddx[..., None])[..., 0] - form.quadratic(dx)
            put(f.ddz, np.moveaxis(solve(jac, np.moveaxis(rhs, -1, 0)), 0, -1))

    def _evaluate_triad(self, f: Frame, body: Body, lift: Any, rows: slice) -> None:
        """:meth:`evaluate` of a triad: its joints, d_s, velocities and accelerations from its
        body's pose (:mod:`.triad`)."""
        assert self.triad is not None
        many, out = f.z.ndim > 2, f.joints[self.joints]
        known = lift(f.z[f.joints[self.inputs]])
        K, T = known.shape[1:]
        joints, now = self._solve_triad(body, known, np.broadcast_to(f.s, (K, T)))

        def put(target: np.ndarray, value: np.ndarray) -> None:  # (3, K, T) → rows (3, *L, T)
            target[out] = value if many else value[:, 0]

        put(f.z, joints)
        ds = triad_ds(now, body)
        f.ds[rows] = ds if many else ds[0]
        if f.dz is None:
            return
        hung = f.joints[self.inputs[self.triad.partner]]
        first, second = rates(now, lift(f.dz[hung]), None if f.ddz is None else lift(f.ddz[hung]))
        put(f.dz, first)
        if second is not None and f.ddz is not None:
            put(f.ddz, second)

    def _known(self, dz: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """X-rows (K, T, W) of the known joints' derivatives ``dz`` (J, K, T) complex, the group's
        own columns and the last (the constant 1) zero."""
        k = 2 * self.joints.size
        out = np.zeros(shape)
        known = np.moveaxis(dz[self.inputs], 0, -1)
        out[..., k:-1:2], out[..., k + 1:-1:2] = known.real, known.imag
        return out

    def lockup(self, names: list[str], toggle: bool) -> str:
        return (f"the numeric group {self.name} cannot be assembled on its rest-pose branch "
                "(it reaches a singular position: its links cannot follow)")

    def branch_change(self, new: Step, names: list[str]) -> str | None:
        if isinstance(new, Group) and new.det_sign != self.det_sign:
            return f"numeric group {self.name} changes assembly branch at the rest pose"
        return None
