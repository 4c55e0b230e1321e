"""What every planar rule shares (:class:`Rule`), and the rows the non-revolute kinds share.

A plan is one sequence of :class:`Rule` objects in evaluation order; each writes some points'
rows of the arrays one evaluation fills (:class:`Frame`, or :class:`RestFrame` for ``edit``'s
rest-pose tangents) and its own rows of the singularity distance d_s. The revolute kinds
(:mod:`.dyad`, :mod:`.rigid`) are one object per level holding that level's whole batch, so a
level costs one array operation per kind. A :class:`Step` writes some joints from joints known before it, over T samples at once. Each
kind (one module each: :mod:`.slider`, :mod:`.drive`, :mod:`.lines`, :mod:`.rotate`,
:mod:`.yoke`, :mod:`.group`) owns its closed form (or numeric solve) for the positions, its
singularity distance, how it explains a lock-up and how it leaves its rest branch. Velocities,
accelerations and rest tangents come from the step's constraint rows F(z) = 0 by the implicit
function theorem: J_S·ż_S = −dF[ż_K] + F_s·ṡ and J_S·z̈_S = −dF[z̈_K] − d²F[ż, ż] (the rows are
bilinear, see :mod:`linkedit.planar.constraints`), one small batched solve — the same for
every kind.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, cast

import numpy as np

from linkedit.planar.constraints import Rows, linkage_rows_tangent, rows_rest_derivative
from linkedit.planar.graph import LinkageGraph
from linkedit.planar.ordering import StepRule
from linkedit.planar.rules.pool import Pool


@dataclass
class Frame:
    """The arrays one evaluation fills, rows in the plan's internal order: ``z``, ``dz``, ``ddz``
    (P, *L, T) complex (L: an optional linkage axis), ``ds`` (N, *L, T) d_s per rule row (1 where
    a rule has none; < 0 or NaN: cannot place)."""

    z: np.ndarray
    dz: np.ndarray | None
    ddz: np.ndarray | None
    ds: np.ndarray
    joints: np.ndarray  #: (J,) internal row of each joint
    s: np.ndarray  #: (T,) the linear input (zeros for a rotary one)
    drive: float  #: ds/dinput: 1 for a linear input, 0 for a rotary one
    rest: np.ndarray  #: (J,) complex rest joints (where a numeric group starts)
    #: (n+1, P, *L, T) complex: ``z`` and its n derivatives stacked (``z``, ``dz``, ``ddz`` are its views)
    orders: np.ndarray
    #: each rule's scratch buffers (:meth:`Rule.scratch`), by ``id`` of the rule
    scratch: dict[int, Any] = field(default_factory=dict)
    #: K linkages' derivatives: each step's rows at every linkage's rest (:meth:`Step.rows_at`), by ``id``
    rows: dict[int, Rows] = field(default_factory=dict)
    #: whether the dyads form their d_s rows (False: positions alone are wanted, ``ds`` is scratch)
    distances: bool = True


@dataclass
class RestFrame:
    """The arrays of ``edit``'s evaluation from a rest pose (:mod:`linkedit.edit.kinematics`):
    ``z`` (P, T), ``ds`` (N, T) as in :class:`Frame`; with tangents ``dz`` (P, C, T) and
    ``dlnds`` (N, C, T) along the rest-pose directions ``D`` (J, C) complex."""

    z: np.ndarray
    ds: np.ndarray
    dz: np.ndarray | None
    dlnds: np.ndarray | None
    rest: np.ndarray  #: (J,) complex rest joints (normalized frame when the plan has steps)
    D: np.ndarray  #: (J, C) rest-pose directions
    joints: np.ndarray  #: (J,) internal row of each joint
    s: np.ndarray  #: (T,) the linear input
    graph: LinkageGraph | None  #: the graph at ``rest`` (steps only)
    #: the plan's steps compiled again at ``rest``, by ``id`` of the plan's (steps only)
    steps: dict[int, "Step"]
    #: rigid rules: coefficients of tracked points kept in their link's frame, by ``id`` of the rule
    fixed: dict[int, np.ndarray]
    #: the linkage's rows' derivatives along ``D`` (:meth:`tangent`), built once for all steps
    tangents: Rows | None = None

    def tangent(self) -> Rows:
        """:func:`~linkedit.planar.constraints.linkage_rows_tangent` at ``graph`` along ``D`` (steps only)."""
        if self.tangents is None:
            assert self.graph is not None
            self.tangents = linkage_rows_tangent(self.graph, self.D)
        return self.tangents


class Rule:
    """One rule of a plan: writes its points from points written before it (see module docstring).

    ``rows`` below is the rule's slice of the d_s rows (``Plan.ds_rows``); ``const`` its part of
    a :class:`~linkedit.planar.plan.Geometry` (:meth:`constants`).
    """

    #: the kind's name, as result files and ``validate`` give it
    kind: ClassVar[str] = ""
    #: its d_s rows count towards a motion's minimum (``Motion.min_singularity``)
    watched: ClassVar[bool] = False
    #: ``edit``'s singularity barrier guards its d_s rows
    guarded: ClassVar[bool] = False
    #: exact by construction: its d_s rows are 1, never checked
    exact: ClassVar[bool] = False
    #: solved numerically (Newton's method from the rest pose): one linkage at a time, at the rest pose it was compiled at
    numeric: ClassVar[bool] = False
    level: int

    def ds_count(self) -> int:
        """How many rows of d_s the rule owns."""
        return 1

    def written(self) -> np.ndarray:
        """(n,) point ids the rule writes (joints, then tracked points J..)."""
        raise NotImplementedError

    def placed(self) -> np.ndarray:
        """(ds_count,) the joint each of its d_s rows places (named by messages)."""
        raise NotImplementedError

    def constants(self, z: np.ndarray, many: bool) -> tuple[Any, ...]:
        """Its constants at rest points ``z`` (P, K) complex (``many``: keep the linkage axis)."""
        return ()

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Write its points (and derivatives) and its d_s rows of ``f``."""
        raise NotImplementedError

    def scratch(self, pool: Pool, Z: np.ndarray) -> Any:
        """Its scratch buffers for :meth:`evaluate` from ``pool``, for the stacked orders ``Z``
        (1 + derivative order, P, *L, T) it writes (:attr:`Frame.orders`); None when it needs none."""
        return None

    def batch_rows(self) -> int:
        """Rows of :meth:`positions`' shared buffers it needs (a level's revolute batch: its size)."""
        return 0

    def table_entries(self) -> np.ndarray:
        """The triangle table's entries (``Plan.table``) its d_s rows are, in order (revolute kinds)."""
        return np.zeros(0, dtype=int)

    def kept(self, const: tuple[Any, ...], joints: int) -> np.ndarray | None:
        """What :meth:`at_rest` keeps of the plan's own constants ``const`` at any rest pose (a rigid
        batch: its tracked points' coefficients in their link's frame), or None."""
        return None

    def positions(self, work: Any) -> Callable[[tuple[Any, ...]], None]:
        """Its positions-only kernel, compiled once per :class:`~linkedit.planar.kinematics.Workspace`
        ``work``: called with the geometry's constants, it writes its rows of ``work.z`` (P, T) into
        the workspace's buffers (no allocation, every view and index bound); the revolute kinds only."""
        raise TypeError(f"a {type(self).__name__} rule is placed by evaluate()")

    def at_rest(self, f: RestFrame, rows: slice) -> None:
        """Write its points, d_s, and with tangents ∂z and ∂ln d_s of ``f``."""
        raise NotImplementedError

    def depend(self, row_of: np.ndarray, dep: np.ndarray, uses: np.ndarray) -> None:
        """Fill ``dep`` (P, n) bool, the variables each point row depends on, for its points
        (``uses`` (J, n): the variables each joint's rest position depends on)."""
        raise NotImplementedError

    def lines(self, names: list[str]) -> list[tuple[tuple[int, int, int], str]]:
        """What it does, for ``validate``: (sort key within the listing, line) per entry."""
        raise NotImplementedError

    def explain(self, names: list[str], n: int, f: "Failure", t: int) -> tuple[str, tuple[str, str], bool, str]:
        """Why its d_s row ``n`` (0-based within the rule) fails at sample ``t``: (joint,
        inputs, stretched, what), as :func:`linkedit.planar.diagnostics.lockups` takes it."""
        raise NotImplementedError

    def inputs_placed(self, finite: np.ndarray) -> np.ndarray:
        """(T, ds_count) whether the joints each of its d_s rows reads are placed, from
        ``finite`` (T, J) bool (a row failing with its inputs placed fails on its own)."""
        raise NotImplementedError

    def culprit(self, names: list[str], n: int) -> str:
        """Its d_s row ``n`` as a failure names it: ``joint X``, ``slider s``, …"""
        raise NotImplementedError

    def move_tracks(self, old: np.ndarray, new: np.ndarray) -> None:
        """Carry tracked points it writes from rest points ``old`` to ``new`` (P,) complex, in place."""


@dataclass
class Failure:
    """A cycle's samples for lock-up explanations: positions ``p`` (T, J, 2) and the rule's d_s
    rows ``ds`` (T, n), normalized frame; ``rest`` (J, 2) normalized rest joints."""

    p: np.ndarray
    ds: np.ndarray
    rest: np.ndarray
    toggle: float


@dataclass(frozen=True)
class Step(Rule):
    """One compiled rule of a non-revolute kind. Indices are joints (spec order). Its one d_s row;
    a :attr:`guarded` kind has :meth:`dlnds`."""

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

    def written(self) -> np.ndarray:
        return self.joints

    def placed(self) -> np.ndarray:
        return self.joints[:1]

    def evaluate(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """Place its joints in ``f``, then their derivatives by :meth:`velocity` and
        :meth:`acceleration` (K linkages: with each linkage's rows, ``f.rows``); K linkages'
        positions alone read their joints in place."""
        out_rows = f.joints[self.joints]
        if f.z.ndim > 2 and f.dz is None:
            self.place_in(f, const, rows)
            return
        zj = f.z[f.joints]
        out, f.ds[rows] = self.place(zj, f.s, f.rest, const)
        f.z[out_rows] = zj[self.joints] = out
        if f.dz is not None:
            own = f.rows.get(id(self), self.rows)
            dzj = f.dz[f.joints]
            f.dz[out_rows] = dzj[self.joints] = self.velocity(zj, dzj, f.drive, own)
            if f.ddz is not None:
                f.ddz[out_rows] = self.acceleration(zj, dzj, f.ddz[f.joints], own)

    def place_in(self, f: Frame, const: tuple[Any, ...], rows: slice) -> None:
        """K linkages' positions alone: :meth:`place` reading its joints where ``f`` holds them (the
        closed-form kinds read z[k] only), writing its rows of ``f.z`` and ``f.ds``."""
        joints = cast(np.ndarray, InPlace(f.z, f.joints))
        out, f.ds[rows] = self.place(joints, f.s, f.rest, const)
        f.z[f.joints[self.joints]] = out

    def at_rest(self, f: RestFrame, rows: slice) -> None:
        """Place its joints by the step compiled at ``f.rest``; tangents along every direction at
        once by :meth:`rest_tangent`, ∂ln d_s by :meth:`dlnds` when guarded."""
        new = f.steps[id(self)]
        zj = f.z[f.joints]
        out, f.ds[rows] = new.place(zj, f.s, f.rest, new.constants(f.rest[:, None], False))
        f.z[f.joints[self.joints]] = zj[self.joints] = out
        if f.dz is None or f.graph is None:
            return
        dzj = f.dz[f.joints]
        f.dz[f.joints[self.joints]] = dzj[self.joints] = new.rest_tangent(f.graph, zj, dzj, f.D, f.tangent())
        if self.guarded and f.dlnds is not None:
            f.dlnds[rows] = new.dlnds(f.graph, zj, dzj, f.D, f.tangent())

    def needs(self) -> np.ndarray:
        """Joints (indices) whose rest positions its constants depend on."""
        rows = set().union(*self.rows.joints) if self.rows.m else set()
        return np.array(sorted(rows | set(self.joints.tolist()) | set(self.inputs.tolist())), dtype=int)

    def depend(self, row_of: np.ndarray, dep: np.ndarray, uses: np.ndarray) -> None:
        needs = self.needs()
        dep[row_of[self.joints]] = (dep[row_of[needs]].any(axis=0) | uses[needs].any(axis=0))[None]

    def lines(self, names: list[str]) -> list[tuple[tuple[int, int, int], str]]:
        return [((self.level, 1, 0), self.describe(names))]

    def inputs_placed(self, finite: np.ndarray) -> np.ndarray:
        return np.all(finite[:, self.inputs], axis=1, keepdims=True)

    def explain(self, names: list[str], n: int, f: "Failure", t: int) -> tuple[str, tuple[str, str], bool, str]:
        return names[self.joints[0]], ("", ""), False, self.lockup(names, abs(f.ds[t, n]) <= f.toggle)

    def culprit(self, names: list[str], n: int) -> str:
        return self.label()

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

    def place(self, z: np.ndarray, s: np.ndarray, rest: np.ndarray,
              const: tuple[Any, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, *L, T) of the step's joints and its singularity distance (*L, T) (< 0 or
        NaN: cannot place). ``z`` (J, *L, T) complex joint positions (the step's inputs filled in;
        L: an optional linkage axis), ``s`` (*L, T) the linear input, ``rest`` (J,) complex rest
        joints (where a numeric group starts), ``const`` the step's :meth:`constants` (the
        closed-form kinds: of each linkage)."""
        raise NotImplementedError

    def lockup(self, names: list[str], toggle: bool) -> str:
        """Why the step cannot place its joint (``toggle``: its d_s is 0 within rounding)."""
        return f"slider {self.name} cannot place joint {names[self.joints[0]]}"

    def closure(self, first: np.ndarray, last: np.ndarray, scale: float, units: str) -> str | None:
        """Why its joints ``last`` (n,) complex after one full cycle are not back at ``first`` (n,)
        (normalized frame; ``scale`` its unit in ``units``), or None. A closed form is back by
        construction; a numeric group, continued along the cycle, is back unless it changed branch."""
        if not (np.isfinite(first).all() and np.isfinite(last).all()):
            return None  # a lock-up, reported as such
        gap = float(np.abs(last - first).max())
        if gap <= 1e-7:
            return None
        return f"the {self.label()} does not return to its start after one cycle (off by {gap * scale:.3g} {units})"

    def branch_change(self, new: "Step", names: list[str]) -> str | None:
        """Why ``new`` (this step compiled at another rest pose) left this one's assembly
        branch, naming it, or None."""
        return None

    def rows_at(self, all_rows: Rows, rest: np.ndarray) -> Rows:
        """Its rows at K rest poses: ``all_rows`` the linkage's rows there
        (``linkage_rows(graph, rest=rest)``), ``rest`` (J, K) complex joints."""
        return all_rows.take(self.source[self.source >= 0])

    def rows_tangent(self, graph: LinkageGraph, drest: np.ndarray, tangent: Rows) -> Rows:
        """d/dε of the step's rows (direction axis (C,)) when the rest pose moves along each of
        ``drest`` (J, C) complex; ``tangent``: the linkage's rows' (``linkage_rows_tangent(graph, drest)``)."""
        return tangent.take(self.source[self.source >= 0])

    def dlnds(self, graph: LinkageGraph, zj: np.ndarray, dzj: np.ndarray, drest: np.ndarray,
              tangent: Rows) -> np.ndarray:
        """∂ln d_s (C, T) along the rest-pose directions ``drest`` (J, C) (``dzj`` (J, C, T) with the
        step's joints filled in; ``tangent`` as in :meth:`rows_tangent`); only for :attr:`guarded` kinds."""
        raise TypeError(f"a {self.kind} step has no singularity barrier")

    def velocity(self, z: np.ndarray, dz: np.ndarray, ds: float, rows: Rows | None = None) -> np.ndarray:
        """ż of the step's joints (n, *L, T) from the known joints' ż in ``dz`` (J, *L, T) (own
        rows ignored); ``rows``: its rows at each linkage's rest (:meth:`rows_at`), default its own."""
        rows = self.rows if rows is None else rows
        known = dz.copy()
        known[self.joints] = 0.0
        rhs = -rows.first(z, known) + rows.drive.reshape(-1, *(1,) * (z.ndim - 1)) * ds
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))

    def acceleration(self, z: np.ndarray, dz: np.ndarray, ddz: np.ndarray, rows: Rows | None = None) -> np.ndarray:
        """z̈ of the step's joints (n, *L, T), given ż of all joints and z̈ of the known ones."""
        rows = self.rows if rows is None else rows
        known = ddz.copy()
        known[self.joints] = 0.0
        rhs = -rows.first(z, known) - rows.second(dz)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))

    def rest_tangent(self, graph: LinkageGraph, z: np.ndarray, dz: np.ndarray, drest: np.ndarray,
                     tangent: Rows | None = None) -> np.ndarray:
        """Tangents (n, C, T) of the step's joints when the rest pose moves along each of the C
        directions ``drest`` (J, C) complex.

        ``z`` (J, T): joint positions (the step's own filled in); ``dz`` (J, C, T): the tangents of
        the joints known before the step (its own rows ignored); ``tangent``: the linkage's rows'
        along ``drest`` when already built (:func:`~linkedit.planar.constraints.linkage_rows_tangent`).
        By the implicit function theorem, J_S·ż_S = −dF[ż_K] − ∂F/∂r̄·ṙ: the rows' derivatives
        built once for all directions, the Jacobian once, one batched solve (each direction's
        tangent the same, bit for bit, as along it alone); for the closed-form rules this is
        the exact derivative of their formulas, for a numeric group the derivative of its solution.
        Everything in the frame ``graph`` is given in (the plan's normalized frame for its steps).
        """
        rows = self.rows
        tangent = linkage_rows_tangent(graph, drest) if tangent is None else tangent
        known = np.moveaxis(dz, 1, 0).copy()  # (C, J, T): a matrix product per direction
        known[:, self.joints] = 0.0
        rhs = -rows.first(z, known, along=True) - rows_rest_derivative(rows, self.rows_tangent(graph, drest, tangent), z)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return to_complex(solve(rows.jacobian(z, self.joints), rhs))


class InPlace:
    """Joint positions read where a :class:`Frame` holds them: ``z[k]`` is joint k's (*L, T) row
    of ``z`` (P, *L, T) (no copy of every joint's rows per step)."""

    def __init__(self, z: np.ndarray, joints: np.ndarray) -> None:
        self.z, self.joints = z, joints

    def __getitem__(self, k: int) -> np.ndarray:
        return self.z[self.joints[k]]


def keep(a: np.ndarray, many: bool) -> np.ndarray:
    """A constant (..., K, 1) of K linkages as :meth:`Rule.constants` returns it: as is with
    ``many``, else (..., 1) (one linkage: broadcasts over the samples)."""
    return a if many else a[..., 0, :]


@dataclass(frozen=True)
class Slot:
    """A pin slider's slot line: through its joint's rest point in the direction ``u`` at rest,
    carried by its guide's frame pair (a, b) (a = −1: the frame)."""

    joint: int
    a: int
    b: int
    u: complex

    @classmethod
    def of(cls, graph: LinkageGraph, n: int) -> "Slot":
        """The slot of slider ``n`` (a pin slider) of ``graph``."""
        s = graph.sliders[n]
        a, b = (-1, -1) if graph.fixed(s.guide) else graph.frame_pair(s.guide)
        return cls(s.joint, a, b, complex(np.exp(1j * s.angle)))

    def constants(self, z: np.ndarray, many: bool) -> tuple[np.ndarray, np.ndarray]:
        """(α, c) at rest points ``z`` (P, K): the line is P = z_a + c·(z_b − z_a), D = α·(z_b − z_a)
        with α = u/(z̄_b − z̄_a), c = (z̄_joint − z̄_a)/(z̄_b − z̄_a); on the frame P = c = z̄_joint, D = α = u."""
        point = z[self.joint, :, None]
        if self.a < 0:
            return keep(np.full_like(point, self.u), many), keep(point, many)
        za, m = z[self.a, :, None], z[self.b, :, None] - z[self.a, :, None]
        return keep(self.u / m, many), keep((point - za) / m, many)

    def line(self, z: np.ndarray, const: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Point P and direction D (*L, T) of the line at joint positions ``z`` (J, *L, T)."""
        alpha, c = const
        if self.a < 0:
            return c, alpha
        e = z[self.b] - z[self.a]
        return z[self.a] + c * e, alpha * e


def concat(a: Rows, b: Rows) -> Rows:
    """The rows of ``a`` then those of ``b``."""
    return Rows(np.concatenate([a.imag, b.imag]), np.vstack([a.dc, b.dc]), np.concatenate([a.d0, b.d0]),
                np.vstack([a.ec, b.ec]), np.concatenate([a.e0, b.e0]), np.concatenate([a.rhs, b.rhs]),
                np.concatenate([a.drive, b.drive]), a.joints + b.joints, a.labels + b.labels)


def solve(jac: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched least-squares solve: jac (*L, T, m, k), rhs (m, *L, T) → (k, *L, T); or C
    right-hand sides rhs (m, C, T) of one jac (T, m, k) → (k, C, T), jac broadcast over them:
    each solved bit for bit as alone (one factorization with C right-hand sides changes the last
    bits, and with them ``edit``'s iteration counts)."""
    b = np.moveaxis(rhs, 0, -1)[..., None]
    if jac.shape[-2] == jac.shape[-1]:
        return np.moveaxis(np.linalg.solve(jac, b)[..., 0], -1, 0)
    jt = np.swapaxes(jac, -1, -2)
    return np.moveaxis(np.linalg.solve(jt @ jac, jt @ b)[..., 0], -1, 0)


def to_complex(xy: np.ndarray) -> np.ndarray:
    """Interleaved real rows (x₀, y₀, x₁, …) → complex rows (written into their parts: no
    complex temporaries)."""
    out = np.empty((xy.shape[0] // 2, *xy.shape[1:]), dtype=complex)
    out.real, out.imag = xy[0::2], xy[1::2]
    return out


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
