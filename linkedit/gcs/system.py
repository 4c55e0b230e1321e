"""A compiled constraint system: members, elementary constraints, index arrays, evaluation.

Unknowns are the members' positions and orientations; a member's local coordinates are
``[dp (3), δθ (3)]`` (``p ← p + dp``, ``q ← exp(δθ) ⊗ q``), so there are N = 6M unknowns and
the quaternions never drift. The world is an extra member (index M) with zero position and
identity orientation and no unknowns.

Every named constraint of a spec becomes one or more *elementary* constraints of the kinds in
:mod:`linkedit.gcs.constraints` (a pin is a location and an axis; a group is the union of its
parts). Compilation sorts them by kind into blocks of index arrays, so evaluation is a few
batched array operations per kind whatever the number of constraints. Custom (Python)
constraints are evaluated one by one, with their own Jacobian or central differences.

The Jacobian is kept per *group* of constraints — one group per block, one per custom
constraint: ``J`` (n, k, m, 6) holds the derivatives of each constraint's k rows with respect to
the local coordinates of its m members (m = 2 for the built-in kinds: a and b). The normal
matrix JᵀJ and the gradient Jᵀr are assembled from the groups with precomputed scatter indices
(:mod:`linkedit.gcs.linalg`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule

WORLD = -1


@dataclass(frozen=True)
class Elementary:
    """One elementary constraint. ``b == WORLD`` for a fixed one (against the world).

    Parameters by kind — location: member points ``sa``, ``sb``; orientation: ``rel`` (a's
    orientation = b's ⊗ rel); axis: member axes ``sa``, ``sb``; plane: point ``sa``, plane point
    ``sb`` and unit normal ``nb`` in b's space. An input's ``schedule`` drives ``sb`` (or ``rel``).
    """

    kind: str
    owner: int  #: index of the named constraint it belongs to
    a: int
    b: int = WORLD
    sa: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sb: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rel: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    nb: tuple[float, float, float] = (0.0, 0.0, 1.0)
    schedule: Schedule | None = None


#: custom residual: fn(positions (k, 3), orientations (k, 4), t) -> residual (m,)
CustomFn = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


@dataclass(frozen=True)
class Custom:
    """A custom constraint on ``members``: a Python residual function (and optional Jacobian
    ``jac(positions, orientations, t) -> (m, 6k)`` in the members' local coordinates)."""

    owner: int
    members: tuple[int, ...]
    fn: CustomFn
    size: int
    jac: Callable[[np.ndarray, np.ndarray, float], np.ndarray] | None = None


@dataclass
class Block:
    """Elementary constraints of one kind: index and parameter arrays, (n,) / (n, 3) / (n, 4)."""

    kind: str
    owner: np.ndarray
    a: np.ndarray
    b: np.ndarray  # WORLD mapped to M
    sa: np.ndarray
    sb: np.ndarray
    rel: np.ndarray
    nb: np.ndarray
    rows: np.ndarray  # (n, k) residual row indices (contiguous)
    start: int
    stop: int
    scheduled: np.ndarray  # positions (in this block) of constraints driven by an input
    schedules: tuple[Schedule, ...]


@dataclass
class StepTable:
    """Per-step parameters of the blocks driven by inputs: (T, n, 3|4) values, (T, n) active."""

    t: np.ndarray
    values: list[np.ndarray | None]
    active: list[np.ndarray | None]


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
        q = quat.multiply(quat.exp(d[:, 3:]), self.orientation)
        return State(self.position + d[:, :3], quat.normalize(q))


@dataclass
class Evaluation:
    """Residual (R,) and, when asked, the Jacobian per group: list of (n, k, m, 6) arrays."""

    r: np.ndarray
    jac: list[np.ndarray] | None = None


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
              elementary: list[Elementary], customs: list[Custom] = (), *,
              constraint_inputs: list[bool] | None = None, length_scale: float | None = None,
              points: dict[str, dict[str, np.ndarray]] | None = None,
              lines: dict[str, list[list[str]]] | None = None) -> "System":
        """Compile elementary constraints (member indices, WORLD = −1) into batched blocks."""
        M = len(member_names)
        if length_scale is None:
            coords = [np.abs(rest.position).max(initial=0.0)]
            coords += [np.abs(np.array([e.sa, e.sb])).max() for e in elementary if e.kind in ("location", "plane")]
            length_scale = max(1.0, float(max(coords)))
        blocks, row_owner, row_scale, groups = [], [], [], []
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
            blocks.append(Block(
                kind=kind, owner=owner, a=a, b=b,
                sa=np.array([e.sa for e in group], dtype=float), sb=np.array([e.sb for e in group], dtype=float),
                rel=np.array([e.rel for e in group], dtype=float), nb=np.array([e.nb for e in group], dtype=float),
                rows=rows, start=int(rows[0, 0]), stop=int(rows[-1, -1]) + 1, scheduled=scheduled, schedules=tuple(group[i].schedule for i in scheduled)))
            row_owner.append(np.repeat(owner, k))
            row_scale.append(np.full(n * k, 1.0 / length_scale if kind in kinds.LENGTH_KINDS else 1.0))
            groups.append(Group(np.column_stack([a, b]), rows))
        for c in customs:
            rows = n_rows + np.arange(c.size)
            n_rows += c.size
            equations[c.owner] += c.size
            row_owner.append(np.full(c.size, c.owner))
            row_scale.append(np.ones(c.size))
            groups.append(Group(np.array([c.members]), rows[None, :]))
        cat = lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dtype=dt)  # noqa: E731
        return cls(
            member_names=list(member_names), constraint_names=list(constraint_names),
            constraint_inputs=np.array(constraint_inputs or [False] * len(constraint_names), dtype=bool),
            rest=rest, length_scale=float(length_scale), blocks=blocks, customs=list(customs),
            n_rows=n_rows, row_owner=cat(row_owner, int), row_scale=cat(row_scale, float),
            owner_equations=equations, groups=groups,
            points=points or {}, lines=lines or {})

    # ---- time -------------------------------------------------------------------------------

    def step_table(self, t: np.ndarray) -> StepTable:
        """Evaluate every input's schedule at the times ``t`` (T,) once, for the whole run: per
        block with inputs, the full driven parameter array ((T, n, 3) ``sb`` or (T, n, 4) ``rel``)
        and the activity (T, n) of its constraints."""
        t = np.asarray(t, dtype=float)
        values, active = [], []
        for blk in self.blocks:
            if not len(blk.scheduled):
                values.append(None)
                active.append(None)
                continue
            base = blk.rel if blk.kind == "orientation" else blk.sb
            full = np.repeat(base[None], t.size, axis=0)
            full[:, blk.scheduled] = np.stack([s.evaluate(t) for s in blk.schedules], axis=1)
            act = np.ones((t.size, len(blk.a)), dtype=bool)
            act[:, blk.scheduled] = np.stack([s.active(t) for s in blk.schedules], axis=1)
            values.append(full)
            active.append(act)
        return StepTable(t=t, values=values, active=active)

    # ---- evaluation -------------------------------------------------------------------------

    def _extended(self, state: State) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, quaternions and rotation matrices with the world appended as member M."""
        M = self.n_members
        P = np.zeros((M + 1, 3))
        Q = np.empty((M + 1, 4))
        P[:M] = state.position
        Q[:M] = state.orientation
        Q[M] = (1.0, 0.0, 0.0, 0.0)
        return P, Q, quat.to_matrix(Q)

    def evaluate(self, state: State, table: StepTable, step: int, jacobian: bool = False) -> Evaluation:
        """Residual (and Jacobian entries) at one time step of ``table``."""
        P, Q, R = self._extended(state)
        r = np.empty(self.n_rows)
        jacs: list[np.ndarray] = []
        t = float(table.t[step])
        for bi, blk in enumerate(self.blocks):
            sb, rel, act = blk.sb, blk.rel, None
            if table.values[bi] is not None:
                if blk.kind == "orientation":
                    rel = table.values[bi][step]
                else:
                    sb = table.values[bi][step]
                act = table.active[bi][step]
                if act.all():
                    act = None
            a, b = blk.a, blk.b
            if blk.kind == "location":
                out = kinds.location(P[a], R[a], blk.sa, P[b], R[b], sb, jacobian)
            elif blk.kind == "orientation":
                out = kinds.orientation(Q[a], Q[b], rel, jacobian)
            elif blk.kind == "axis":
                out = kinds.axis(R[a], blk.sa, R[b], sb, jacobian)
            else:
                out = kinds.plane(P[a], R[a], blk.sa, P[b], R[b], sb, blk.nb, jacobian)
            res = out[0] if jacobian else out
            if act is not None:
                res = res * act[:, None]  # an input outside its window adds nothing
            r[blk.start:blk.stop] = res.ravel()
            if jacobian:
                J = out[1]
                jacs.append(J if act is None else J * act[:, None, None, None])
        row = sum(blk.rows.size for blk in self.blocks)
        for c in self.customs:
            m = list(c.members)
            res, jac = _custom(c, P[m], Q[m], t, jacobian)
            r[row:row + c.size] = res
            row += c.size
            if jacobian:
                jacs.append(jac.reshape(1, c.size, len(m), 6))
        return Evaluation(r, jacs if jacobian else None)

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
        for grp, jac in zip(self.groups, ev.jac):
            n, k, m = jac.shape[:3]
            rows = np.broadcast_to(grp.rows[:, :, None, None], (n, k, m, 6))
            cols = 6 * grp.members[:, None, :, None] + np.arange(6)
            np.add.at(J, (rows, np.broadcast_to(cols, (n, k, m, 6))), jac)
        return J[:, : 6 * M]



def _custom(c: Custom, P: np.ndarray, Q: np.ndarray, t: float, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Residual of a custom constraint and its Jacobian (given, or by central differences)."""
    res = np.asarray(c.fn(P, Q, t), dtype=float).reshape(-1)
    if res.size != c.size:
        from linkedit.errors import MechanismError

        raise MechanismError(f"custom constraint returned {res.size} values, expected {c.size}")
    if not jacobian:
        return res, None
    if c.jac is not None:
        return res, np.asarray(c.jac(P, Q, t), dtype=float).reshape(c.size, 6 * len(P))
    h = 1e-6
    k = len(P)
    jac = np.empty((c.size, 6 * k))
    for i in range(6 * k):
        cols = []
        for sgn in (1.0, -1.0):
            d = np.zeros((k, 6))
            d[i // 6, i % 6] = sgn * h
            q = quat.normalize(quat.multiply(quat.exp(d[:, 3:]), Q))
            cols.append(np.asarray(c.fn(P + d[:, :3], q, t), dtype=float).reshape(-1))
        jac[:, i] = (cols[0] - cols[1]) / (2 * h)
    return res, jac
