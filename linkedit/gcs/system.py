"""A compiled constraint system: members, elementary constraints, index arrays, evaluation.

Unknowns are the members' positions and orientations; a member's local coordinates are
``[dp (3), δθ (3)]`` (``p ← p + dp``, ``q ← exp(δθ) ⊗ q``, applied by the second-order
equivalent :func:`~linkedit.gcs.quaternions.turned`), so there are N = 6M unknowns and the
quaternions never drift. The world is an extra member (index M) with zero position and
identity orientation and no unknowns.

Every named constraint of a spec becomes one or more *elementary* constraints of the kinds in
:mod:`linkedit.gcs.constraints` (a pin is a location and an axis; a group is the union of its
parts). Compilation sorts them by kind into blocks of index arrays, and lists every member
vector the blocks turn into the world frame (points, axes, plane normals) in one table of
``(member, member-space vector)`` pairs, so an evaluation turns all of them with one batched
product and each kind is then a few array operations on slices, whatever the number of
constraints. Parameters driven by inputs are looked up once per time step
(:meth:`StepTable.at`). Custom (Python) constraints are evaluated one by one, with their own
Jacobian or central differences.

The Jacobian is kept per *group* of constraints — one group per block, one per custom
constraint: ``J`` (n, k, m, 6) holds the derivatives of each constraint's k rows with respect to
the local coordinates of its m members (m = 2 for the built-in kinds: a and b). The normal
matrix JᵀJ and the gradient Jᵀr are assembled from the groups with precomputed scatter indices
(:mod:`linkedit.gcs.linalg`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule
from linkedit.gcs.kernels import EVALUATE, Block, Custom, StepParameters, custom

WORLD = -1
_ORIGIN = np.zeros((1, 3))
_IDENTITY = np.array([[1.0, 0.0, 0.0, 0.0]])
_ONES = np.ones(3)
_ONES6 = np.ones(6)


@dataclass(frozen=True)
class Elementary:
    """One elementary constraint. ``b == WORLD`` for a fixed one (against the world).

    Parameters by kind — location: member points ``sa``, ``sb``; orientation: ``rel`` (a's
    orientation = b's ⊗ rel); axis: member axes ``sa``, ``sb``; plane: point ``sa``, plane point
    ``sb`` and unit normal ``nb`` in b's space; line: point ``sa``, line point ``sb`` and unit
    direction ``nb`` in b's space; distance: member points ``sa``, ``sb`` and the length
    ``value``; angle: member axes ``sa``, ``sb`` and the angle ``value`` (radians); parallel:
    member axes ``sa``, ``sb``. An input's ``schedule`` drives ``sb`` (or ``rel``; ``value`` for
    the kinds with a value).
    """

    kind: str
    owner: int  #: index of the named constraint it belongs to
    a: int
    b: int = WORLD
    sa: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sb: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rel: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    nb: tuple[float, float, float] = (0.0, 0.0, 1.0)
    value: float = 0.0
    schedule: Schedule | None = None


@dataclass
class StepTable:
    """Parameters driven by inputs, evaluated once for the whole run: per step, the driven
    member-space vectors (T, S, 9) (as :attr:`System.vectors`) and inverse relative
    orientations (T, S', 4); per block, the activity (T, n) of its constraints (None for a
    block without inputs), the rates of its driven ones and its values (T, n) (None unless
    an input drives a value), and (T,) whether any input is outside its window."""

    t: np.ndarray
    vectors: np.ndarray
    rel_inverse: np.ndarray
    active: list[np.ndarray | None]
    partial: np.ndarray
    system: "System" = field(repr=False)
    #: per block, the virtual velocities (T, S, 6) of its driven constraints (Schedule.rate), or None
    rates: list[np.ndarray | None] = field(default_factory=list, repr=False)
    #: per block, its values (T, n) when an input drives one of them, else None
    values: list[np.ndarray | None] = field(default_factory=list, repr=False)
    _last: tuple[int, StepParameters] | None = field(default=None, repr=False)

    def at(self, step: int) -> StepParameters:
        """The parameters at one step (kept for the next call: a solve evaluates one step many times)."""
        if self._last is not None and self._last[0] == step:
            return self._last[1]
        sys = self.system
        vectors, rel_inverse = sys.vectors, sys.rel_inverse
        if self.vectors.shape[1]:
            vectors = vectors.copy()
            vectors[sys.driven_vectors] = self.vectors[step]
        if self.rel_inverse.shape[1]:
            rel_inverse = rel_inverse.copy()
            rel_inverse[sys.driven_rel] = self.rel_inverse[step]
        active: list[np.ndarray | None] = [None] * len(sys.blocks)
        rows = np.zeros(0, dtype=int)
        if self.partial[step]:
            active = [None if act is None or act[step].all() else act[step] for act in self.active]
            rows = np.concatenate([blk.rows[~a].ravel() for blk, a in zip(sys.blocks, active) if a is not None])
        values = {blk.kind: blk.value if v is None else v[step] for blk, v in zip(sys.blocks, self.values)
                  if blk.kind in kinds.VALUE_KINDS}
        par = StepParameters(float(self.t[step]), vectors, rel_inverse, active, rows, values)
        self._last = (step, par)
        return par


@dataclass
class State:
    """Member positions (M, 3) and unit quaternions (M, 4)."""

    position: np.ndarray
    orientation: np.ndarray

    def copy(self) -> "State":
        return State(self.position.copy(), self.orientation.copy())

    def moved(self, delta: np.ndarray) -> "State":
        """The state after a step of local coordinates ``delta`` (6M,)."""
        d = delta.reshape(-1, 6)
        return State(self.position + d[:, :3], quat.turned(self.orientation, d[:, 3:]))

    def minus(self, other: "State") -> np.ndarray:
        """Local coordinates (6M,) from ``other`` to this state: position differences and the
        world-frame rotation vectors log(q ⊗ q_other⁻¹)."""
        phi = quat.log(quat.relative(self.orientation, other.orientation))
        return np.concatenate([self.position - other.position, phi], axis=1).ravel()


@dataclass
class Evaluation:
    """Residual (R,) and, when asked, the Jacobian per group: list of (n, k, m, 6) arrays."""

    r: np.ndarray
    jac: list[np.ndarray] | None = None

    def jacobians(self) -> list[np.ndarray]:
        """The Jacobian per group, (n, k, m, 6) each, of an evaluation with ``jacobian=True``."""
        if self.jac is None:
            raise ValueError("evaluated without the Jacobian")
        return self.jac


@dataclass(frozen=True)
class Group:
    """Constraints sharing a Jacobian layout: members (n, m) (WORLD as M) and residual rows (n, k)."""

    members: np.ndarray
    rows: np.ndarray


@dataclass
class System:
    """A compiled mechanism (see module docstring)."""

    member_names: list[str]
    constraint_names: list[str]  #: named constraints (owners), groups' parts as "group.part"
    constraint_inputs: np.ndarray  #: (C,) bool: the named constraint is an input
    rest: State
    length_scale: float
    blocks: list[Block]
    customs: list[Custom]
    n_rows: int
    row_owner: np.ndarray  #: (R,) named constraint of each residual row
    row_scale: np.ndarray  #: (R,) 1/length_scale for length rows, 1 for angle rows
    owner_equations: np.ndarray  #: (C,) independent equations of each named constraint
    groups: list[Group]  #: Jacobian layout, in evaluation order
    vector_member: np.ndarray  #: (K,) member (WORLD as M) of each member vector the blocks turn
    #: (K, 9) the member vectors in member space, each three times (once per rotation-matrix row)
    vectors: np.ndarray
    driven_vectors: np.ndarray  #: (S,) the vectors driven by inputs (StepTable.vectors)
    rel_inverse: np.ndarray  #: (n, 4) inverse relative orientations of the orientation block ((0, 4) without one)
    driven_rel: np.ndarray  #: (S',) the relative orientations driven by inputs (StepTable.rel_inverse)
    points: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  #: member → point name → (3,)
    lines: dict[str, list[list[str]]] = field(default_factory=dict)  #: member → polylines of point names

    @property
    def n_members(self) -> int:
        return len(self.member_names)

    @property
    def n_unknowns(self) -> int:
        return 6 * self.n_members

    # ---- construction ---------------------------------------------------------------------

    @classmethod
    def build(cls, member_names: list[str], rest: State, constraint_names: list[str],
              elementary: list[Elementary], customs: Sequence[Custom] = (), *,
              constraint_inputs: list[bool] | None = None, length_scale: float | None = None,
              points: dict[str, dict[str, np.ndarray]] | None = None,
              lines: dict[str, list[list[str]]] | None = None) -> "System":
        """Compile elementary constraints (member indices, WORLD = −1) into batched blocks."""
        M = len(member_names)
        if length_scale is None:
            length_scale = characteristic_length(rest, elementary, points or {}, member_names)
        blocks, row_owner, row_scale, groups = [], [], [], []
        vec_member: list[np.ndarray] = []
        vectors: list[np.ndarray] = []
        driven: list[np.ndarray] = []
        rel, driven_rel = np.zeros((0, 4)), np.zeros(0, dtype=int)
        n_rows = 0
        equations = np.zeros(len(constraint_names), dtype=int)
        for kind, k in kinds.ROWS.items():
            group = [e for e in elementary if e.kind == kind]
            if not group:
                continue
            n = len(group)
            rows = n_rows + np.arange(n * k).reshape(n, k)
            n_rows += n * k
            owner = np.array([e.owner for e in group], dtype=int)
            np.add.at(equations, owner, kinds.EQUATIONS[kind])
            a = np.array([e.a for e in group], dtype=int)
            b = np.array([M if e.b == WORLD else e.b for e in group], dtype=int)
            scheduled = np.array([i for i, e in enumerate(group) if e.schedule is not None], dtype=int)
            params = {p: np.array([getattr(e, p) for e in group], dtype=float)
                      for p in ("sa", "sb", "rel", "nb", "value")}
            slots = []
            for vec, side in kinds.VECTORS[kind]:
                start = sum(len(v) for v in vectors)
                slots.append(slice(start, start + n))
                vec_member.append(a if side == "a" else b)
                vectors.append(params[vec])
                if vec == "sb" and kind not in kinds.VALUE_KINDS:  # an input drives sb (or rel, or value)
                    driven.append(start + scheduled)
            if kind == "orientation":
                rel, driven_rel = params["rel"], scheduled
            blocks.append(Block(
                kind=kind, owner=owner, a=a, b=b, **params,
                rows=rows, start=int(rows[0, 0]), stop=int(rows[-1, -1]) + 1, scheduled=scheduled,
                schedules=tuple(group[i].schedule for i in scheduled), vectors=tuple(slots),
                on_world=bool(np.all(b == M))))
            row_owner.append(np.repeat(owner, k))
            row_scale.append(np.full(n * k, 1.0 / length_scale if kind in kinds.LENGTH_KINDS else 1.0))
            groups.append(Group(np.column_stack([a, b]), rows))
        for c in customs:
            custom_rows = n_rows + np.arange(c.size)
            n_rows += c.size
            equations[c.owner] += c.size
            row_owner.append(np.full(c.size, c.owner))
            row_scale.append(np.ones(c.size))
            groups.append(Group(np.array([c.members]), custom_rows[None, :]))
        cat = lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dtype=dt)  # noqa: E731
        return cls(
            member_names=list(member_names), constraint_names=list(constraint_names),
            constraint_inputs=np.array(constraint_inputs or [False] * len(constraint_names), dtype=bool),
            rest=rest, length_scale=float(length_scale), blocks=blocks, customs=list(customs),
            n_rows=n_rows, row_owner=cat(row_owner, int), row_scale=cat(row_scale, float),
            owner_equations=equations, groups=groups, vector_member=cat(vec_member, int),
            vectors=np.tile(np.concatenate(vectors), 3) if vectors else np.zeros((0, 9)),
            driven_vectors=cat(driven, int),
            rel_inverse=quat.conjugate(rel), driven_rel=driven_rel, points=points or {}, lines=lines or {})

    # ---- time -------------------------------------------------------------------------------

    def step_table(self, t: np.ndarray) -> StepTable:
        """Evaluate every input's schedule at the times ``t`` (T,) once, for the whole run."""
        t = np.asarray(t, dtype=float)
        vectors, rel_inverse, active, rates, driven_values = [], [], [], [], []
        partial = np.zeros(t.size, dtype=bool)
        for blk in self.blocks:
            act = rate = value = None
            if len(blk.scheduled):
                rate = np.stack([s.rate(t) for s in blk.schedules], axis=1)
                values = np.stack([s.evaluate(t) for s in blk.schedules], axis=1)
                if blk.kind in kinds.VALUE_KINDS:
                    value = np.tile(blk.value, (t.size, 1))
                    value[:, blk.scheduled] = values[..., 0]
                elif blk.kind == "orientation":
                    rel_inverse.append(quat.conjugate(values))
                else:
                    vectors.append(np.tile(values, 3))
                act = np.ones((t.size, len(blk.a)), dtype=bool)
                act[:, blk.scheduled] = np.stack([s.active(t) for s in blk.schedules], axis=1)
                partial |= ~act.all(axis=1)
            active.append(act)
            rates.append(rate)
            driven_values.append(value)
        stack = lambda xs, k: np.concatenate(xs, axis=1) if xs else np.zeros((t.size, 0, k))  # noqa: E731
        return StepTable(t=t, vectors=stack(vectors, 9), rel_inverse=stack(rel_inverse, 4), active=active,
                         partial=partial, system=self, rates=rates, values=driven_values)

    # ---- evaluation -------------------------------------------------------------------------

    def _extended(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """Positions (M+1, 3) and quaternions (M+1, 4) with the world appended as member M."""
        return (np.concatenate((state.position, _ORIGIN)), np.concatenate((state.orientation, _IDENTITY)))

    def evaluate(self, state: State, table: StepTable, step: int, jacobian: bool = False) -> Evaluation:
        """Residual (and Jacobian entries) at one time step of ``table``."""
        par = table.at(step)
        P, Q = self._extended(state)
        m = self.vector_member
        # every member vector in the world frame (W) and as a world point (X), (K, 3):
        # the rows of each member's rotation matrix times the vector, summed in threes
        R = quat.to_matrix(Q).reshape(-1, 9)
        W = ((R.take(m, axis=0) * par.vectors).reshape(-1, 3) @ _ONES).reshape(-1, 3)
        X = P.take(m, axis=0) + W
        r = np.empty(self.n_rows)
        jacs: list[np.ndarray] = []
        for blk, act in zip(self.blocks, par.active):
            out = r[blk.start:blk.stop].reshape(len(blk.a), -1)
            J = EVALUATE[blk.kind](blk, X, W, Q, par, out, jacobian)
            if J is not None:
                jacs.append(J if act is None else J * act[:, None, None, None])
        if len(par.inactive_rows):
            r[par.inactive_rows] = 0.0  # an input outside its window adds nothing
        row = self.blocks[-1].stop if self.blocks else 0
        for c in self.customs:
            members = list(c.members)
            res, jac = custom(c, self.constraint_names[c.owner], P[members], Q[members], par.t, jacobian)
            r[row:row + c.size] = res
            row += c.size
            if jac is not None:
                jacs.append(jac.reshape(1, c.size, len(members), 6))
        return Evaluation(r, jacs if jacobian else None)

    def time_derivative(self, state: State, table: StepTable, step: int, ev: Evaluation) -> np.ndarray:
        """∂r/∂t (R,) at fixed member states: each driven constraint's rows times its input's
        virtual velocity of member b (:meth:`~linkedit.gcs.inputs.Schedule.rate`, turned into
        the world frame), through the b columns of the Jacobian ``ev.jac``; for a driven value
        (a distance), minus the value's rate. Custom constraints that depend on t: central
        differences in t."""
        out = np.zeros(self.n_rows)
        for blk, jac, rate in zip(self.blocks, ev.jacobians(), table.rates):
            if rate is None:
                continue
            s = blk.scheduled
            if blk.kind in kinds.VALUE_KINDS:
                out[blk.rows[s]] = -rate[step]
                continue
            w = rate[step]  # (S, 6): u, ω in b's frame
            if not blk.on_world:
                Q = np.concatenate((state.orientation, _IDENTITY))
                Rb = quat.to_matrix(Q.take(blk.b[s], axis=0))  # (S, 3, 3)
                w = (w.reshape(-1, 2, 3) @ np.swapaxes(Rb, 1, 2)).reshape(-1, 6)  # R_b u, R_b ω
            out[blk.rows[s]] = (jac[s, :, 1, :] * w[:, None, :]) @ _ONES6  # (a batched matmul is slower)
        if self.customs:
            t = float(table.t[step])
            h = 1e-6
            row = self.blocks[-1].stop if self.blocks else 0
            P, Qe = self._extended(state)
            for c in self.customs:
                m = list(c.members)
                name = self.constraint_names[c.owner]
                hi = custom(c, name, P[m], Qe[m], t + h, False)[0]
                lo = custom(c, name, P[m], Qe[m], t - h, False)[0]
                out[row:row + c.size] = (hi - lo) / (2 * h)
                row += c.size
        return out

    def costs(self, r: np.ndarray) -> np.ndarray:
        """Per named constraint cost (sum of its squared residuals), (C,) — or (T, C) for r (T, R)."""
        r = np.asarray(r)
        C = len(self.constraint_names)
        if r.ndim == 1:
            return np.bincount(self.row_owner, r * r, minlength=C)
        out = np.zeros((r.shape[0], C))
        np.add.at(out.T, self.row_owner, (r * r).T)
        return out

    def dense_jacobian(self, ev: Evaluation) -> np.ndarray:
        """The Jacobian (R, 6M) from an evaluation with ``jacobian=True`` (world columns dropped)."""
        M = self.n_members
        J = np.zeros((self.n_rows, 6 * (M + 1)))
        for grp, jac in zip(self.groups, ev.jacobians()):
            n, k, m = jac.shape[:3]
            rows = np.broadcast_to(grp.rows[:, :, None, None], (n, k, m, 6))
            cols = 6 * grp.members[:, None, :, None] + np.arange(6)
            np.add.at(J, (rows, np.broadcast_to(cols, (n, k, m, 6))), jac)
        return J[:, : 6 * M]



def characteristic_length(rest: State, elementary: list[Elementary], points: dict[str, dict[str, np.ndarray]],
                          member_names: list[str]) -> float:
    """The size of a mechanism: the diagonal of the bounding box of everything it places at
    rest — member origins, shape points and constrained points turned into the world, world
    targets — so that it scales with the units and not with where the mechanism sits; at least
    the longest distance a distance constraint asks for. 1 when everything is at one point."""
    R = quat.to_matrix(rest.orientation)
    world = [rest.position]
    for m, name in enumerate(member_names):
        pts = np.array(list(points.get(name, {}).values()), dtype=float).reshape(-1, 3)
        world.append(rest.position[m] + pts @ R[m].T)
    for e in elementary:
        if e.kind in kinds.LENGTH_KINDS:
            world.append((rest.position[e.a] + R[e.a] @ np.asarray(e.sa))[None])
            if e.b == WORLD:
                world.append(np.asarray(e.sb, dtype=float)[None])
    X = np.concatenate(world)
    size = float(np.linalg.norm(X.max(axis=0) - X.min(axis=0))) if X.size else 0.0
    size = max([size] + [e.value for e in elementary if e.kind == "distance"])
    return size if size > 0.0 and np.isfinite(size) else 1.0
