"""What every planar rule of the non-revolute kinds shares: its rows, and derivatives from them.

A :class:`Step` writes some joints from joints known before it, over T samples at once. Each
kind (one module each: :mod:`.slider`, :mod:`.drive`, :mod:`.lines`, :mod:`.rotate`,
:mod:`.yoke`, :mod:`.group`) owns its closed form (or numeric solve) for the positions, its
singularity distance, how it explains a lock-up and how it leaves its rest branch. Velocities,
accelerations and rest tangents come from the step's constraint rows F(z) = 0 by the implicit
function theorem: J_S·ż_S = −dF[ż_K] + F_s·ṡ and J_S·z̈_S = −dF[z̈_K] − d²F[ż, ż] (the rows are
bilinear, see :mod:`linkedit.planar.constraints`), one small batched solve — the same for
every kind.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from linkedit.planar.constraints import Rows, linkage_rows_tangent, rows_rest_derivative
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule


@dataclass(frozen=True)
class Step:
    """One compiled rule of a non-revolute kind. Indices are joints (spec order)."""

    #: the kind's name, as written to result files and shown by ``validate``
    kind: ClassVar[str] = ""
    #: its singularity distance counts towards a motion's minimum (``Motion.min_singularity``)
    watched: ClassVar[bool] = False
    #: ``edit``'s singularity barrier guards it (it has :meth:`dlnds`)
    guarded: ClassVar[bool] = False

    level: int
    joints: np.ndarray  # (n,) joints written
    inputs: np.ndarray  # joints read
    name: str  # the slider's name, or the group's joints
    rows: Rows  # the rows the written joints satisfy (for derivatives and checks)
    #: rows of ``rows`` taken from :func:`~linkedit.planar.constraints.linkage_rows` (their
    #: indices there), −1 for the step's own row (a slider's rod)
    source: np.ndarray

    @classmethod
    def compile(cls, graph: LinkageGraph, rule: StepRule, all_rows: Rows, known: set[int]) -> "Step":
        """The step of the ordering's ``rule`` at ``graph``'s rest pose; ``all_rows`` the
        linkage's rows (:func:`~linkedit.planar.constraints.linkage_rows`), ``known`` the joints
        known before it."""
        raise NotImplementedError

    def what(self) -> str:
        """What the step is, for ``validate``: e.g. ``slider s``."""
        raise NotImplementedError

    def describe(self, names: list[str]) -> str:
        out = ", ".join(names[k] for k in self.joints)
        src = ", ".join(names[k] for k in self.inputs)
        return f"{out} ← ({src}) {self.what()}"

    def label(self) -> str:
        """The step as a failure names it: ``slider s``, ``sliders a and b``, ``numeric group …``."""
        return f"slider {self.name}"

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, T) of the step's joints and its singularity distance (T,) (< 0 or NaN:
        cannot place). ``z`` (J, T) complex joint positions (the step's inputs filled in), ``s``
        (T,) the linear input, ``rest`` (J,) complex rest joints (where a numeric group starts)."""
        raise NotImplementedError

    def lockup(self, names: list[str], toggle: bool) -> str:
        """Why the step cannot place its joint (``toggle``: its d_s is 0 within rounding)."""
        return f"slider {self.name} cannot place joint {names[self.joints[0]]}"

    def branch_change(self, new: "Step", names: list[str]) -> str | None:
        """Why ``new`` (this step compiled at another rest pose) left this one's assembly
        branch, naming it, or None."""
        return None

    def rows_tangent(self, graph: LinkageGraph, drest: np.ndarray) -> Rows:
        """d/dε of the step's rows when the rest pose moves along ``drest`` (J,) complex."""
        return linkage_rows_tangent(graph, drest).take(self.source[self.source >= 0])

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray) -> np.ndarray:
        """∂ln d_s (C, T) along the rest-pose directions ``drest`` (J, C) (``dzj`` (J, C, T) with the
        step's joints filled in); only for :attr:`guarded` kinds."""
        raise TypeError(f"a {self.kind} step has no singularity barrier")

    def velocity(self, z: np.ndarray, dz: np.ndarray, ds: float) -> np.ndarray:
        """ż of the step's joints (n, T) from the known joints' ż in ``dz`` (J, T) (own rows ignored)."""
        rows = self.rows
        known = dz.copy()
        known[self.joints] = 0.0
        rhs = -rows.first(z, known) + rows.drive[:, None] * ds
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))

    def acceleration(self, z: np.ndarray, dz: np.ndarray, ddz: np.ndarray) -> np.ndarray:
        """z̈ of the step's joints (n, T), given ż of all joints and z̈ of the known ones."""
        rows = self.rows
        known = ddz.copy()
        known[self.joints] = 0.0
        rhs = -rows.first(z, known) - rows.second(dz)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))

    def rest_tangent(self, graph: LinkageGraph, z: np.ndarray, dz: np.ndarray, drest: np.ndarray) -> np.ndarray:
        """Tangent (n, T) of the step's joints when the rest pose moves along ``drest`` (J,) complex.

        ``z`` (J, T): joint positions (the step's own filled in); ``dz`` (J, T): the tangents of the
        joints known before the step (its own rows ignored). By the implicit function theorem,
        J_S·ż_S = −dF[ż_K] − ∂F/∂r̄·ṙ: one batched solve; for the closed-form rules this is the
        exact derivative of their formulas, for a numeric group the derivative of its solution.
        Everything in the frame ``graph`` is given in (the plan's normalized frame for its steps).
        """
        rows = self.rows
        known = dz.copy()
        known[self.joints] = 0.0
        rhs = -rows.first(z, known) - rows_rest_derivative(rows, self.rows_tangent(graph, drest), z)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))


def slot_line(rows: Rows, r: int, k: int, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Point P and direction D (T,) of slot row ``r`` (joint ``k`` removed from E = z_k − P)."""
    d = rows.dc[r] @ z + rows.d0[r]
    ec = rows.ec[r].copy()
    ec[k] = 0.0
    return -(ec @ z + rows.e0[r]), d


def concat(a: Rows, b: Rows) -> Rows:
    """The rows of ``a`` then those of ``b``."""
    return Rows(np.concatenate([a.imag, b.imag]), np.vstack([a.dc, b.dc]), np.concatenate([a.d0, b.d0]),
                np.vstack([a.ec, b.ec]), np.concatenate([a.e0, b.e0]), np.concatenate([a.rhs, b.rhs]),
                np.concatenate([a.drive, b.drive]), a.joints + b.joints, a.labels + b.labels)


def solve(jac: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched least-squares solve: jac (T, m, k), rhs (m, T) → (k, T)."""
    if jac.shape[1] == jac.shape[2]:
        return np.linalg.solve(jac, rhs.T[..., None])[..., 0].T
    jt = np.swapaxes(jac, 1, 2)
    return np.linalg.solve(jt @ jac, (jt @ rhs.T[..., None]))[..., 0].T


def to_complex(xy: np.ndarray) -> np.ndarray:
    """Interleaved real rows (x₀, y₀, x₁, …) → complex rows."""
    return xy[0::2] + 1j * xy[1::2]


def loop_rows(all_rows: Rows, known: set[int], joints: tuple[int, ...]) -> tuple[Rows, np.ndarray, np.ndarray]:
    """The rows binding ``joints`` to each other and to ``known`` joints: (rows, their indices in
    ``all_rows``, the known joints they read)."""
    inside = known | set(joints)
    use = np.array([r for r, js in enumerate(all_rows.joints) if js <= inside and js & set(joints)])
    rows = all_rows.take(use)
    inputs = np.array(sorted(set().union(*rows.joints) - set(joints)), dtype=int)
    return rows, use, inputs


def labelled(all_rows: Rows, label: str) -> list[int]:
    """Indices of the rows called ``label`` (a slider's slot rows: ``slider NAME``)."""
    return [r for r, lab in enumerate(all_rows.labels) if lab == label]
