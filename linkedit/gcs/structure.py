"""What batched solving needs beyond the system: the diagonal blocks of J that solve apart, the
parts that stay still, where each Jacobian entry goes (:class:`Compiled`), found from poses and
corrected by them (:class:`Blocks`) — guesses that cost time only when wrong (the waves check
every solved step on every row and pivot)."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph

from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs import quaternions as quat
from linkedit.gcs.evaluate import BatchedEvaluation, _Layout
from linkedit.gcs.system import System
from linkedit.gcs.tolerances import TIED

#: a block solves steps STRIDE apart first (from extrapolation), then the ones between; the
#: spacing adapts to the extrapolation's error, up to WIDEST_STRIDE
STRIDE = 8
WIDEST_STRIDE = 8
#: J's diagonal blocks (:attr:`Waves.parts`) are found from the first batch of at least this
#: many poses (no accidental zeros)
SPLIT_FROM = 64


@dataclasses.dataclass
class Part:
    """A diagonal block of the Jacobian: its residual rows (Rp,) and unknowns (Np,)."""

    rows: np.ndarray
    cols: np.ndarray


@dataclasses.dataclass
class Jacobians:
    """Scaled Jacobians of B poses, block by block of ``parts`` (:attr:`Waves.parts`, or some
    of them): (B, Rp, Np) each, and which of its entries off the blocks exceed :data:`TIED`
    (``off``, (B, S), one per off-block slot of :meth:`Waves._place`)."""

    blocks: list[np.ndarray]
    off: np.ndarray
    parts: list[Part]

    @property
    def leaves(self) -> np.ndarray:
        """Whether each pose's J has entries off the blocks (B,)."""
        return np.asarray(self.off.any(axis=1))

    def take(self, idx: np.ndarray) -> "Jacobians":
        return Jacobians([_take(J, idx) for J in self.blocks], _take(self.off, idx), self.parts)

    def only(self, which: list[int]) -> "Jacobians":
        """The blocks ``which`` (indices into ``parts``)."""
        return Jacobians([self.blocks[i] for i in which], self.off, [self.parts[i] for i in which])


@dataclasses.dataclass
class Compiled:
    """What batched evaluation of one system needs beyond the system itself, built at first
    use and kept by the caller (:class:`StructureCache`) for its later runs of that system: the
    diagonal blocks of J that solve apart (``parts``: a planar linkage's in-plane
    and out-of-plane unknowns; one block until a batch of :data:`SPLIT_FROM` poses was seen,
    ``decided``), the parts that stay still (``quiet``: their rows and time derivatives exactly
    zero, to :data:`TIED`, over the batch that found them, such as a planar linkage's
    out-of-plane part), the rows that are theirs or empty (``still``, (R,)) and the
    groups all of whose rows are (``skip``), per group where a pose's Jacobian entries go and
    their scales, where the blocks and the off-block slots end and which blocks each off-block
    slot ties (``places``, ``ends``, ``ties`` (S, 2): :meth:`Waves._place`), and the layouts
    per batch size (:meth:`Waves._layout`). Blocks a run's poses tie together are merged
    (:meth:`Waves._merge`). A run changes a copy of its own and leaves a copy of that in the
    cache after each block, so that runs of one system in several threads sharing a cache do not
    see each other's halfway changes."""

    parts: list[Part]
    decided: bool = False
    quiet: np.ndarray | None = None
    still: np.ndarray | None = None
    skip: tuple[int, ...] = ()
    places: list[tuple[np.ndarray, np.ndarray]] | None = None
    ends: list[int] = dataclasses.field(default_factory=list)
    ties: np.ndarray | None = None
    layouts: dict[int, _Layout] = dataclasses.field(default_factory=dict)
    closed: ClosedForm | None = None

    def copy(self) -> "Compiled":
        """A copy to change (the layouts shared: each is never changed, only added or dropped)."""
        return dataclasses.replace(self, quiet=None if self.quiet is None else self.quiet.copy(),
                                   still=None if self.still is None else self.still.copy())


class StructureCache:
    """What solving one system compiles beyond the system — the waves' :class:`Compiled` and the
    closed form's rules (:meth:`ClosedForm.compile`) — owned by the caller, who passes it to each
    run of that system (``solve_run(system, t, cache=cache)``) so later runs start warm; the
    system holds no solver state. It belongs to one system, unchanged since it was made (a
    copy, or a system changed in place, needs a cache of its own)."""

    def __init__(self, system: System) -> None:
        self.system = system
        #: the waves' compilation left by the last block solved (None: none yet)
        self.waves: Compiled | None = None
        self._closed: tuple[ClosedForm | None] | None = None  # compiled at first use

    def closed_form(self) -> ClosedForm | None:
        """The system's closed form (None: some member has none), compiled at first use."""
        if self._closed is None:
            self._closed = (ClosedForm.compile(self.system),)
        return self._closed[0]


class Blocks(BatchedEvaluation):
    """J's blocks and still parts for a run (:class:`Compiled`), as the waves find and correct them."""

    compiled: Compiled
    free: int
    #: pairs of blocks (K, 2) that Jacobian entries of this run's poses tied: merged before the next block
    tied: np.ndarray

    @property
    def parts(self) -> list[Part]:
        """The diagonal blocks of J that solve apart (:class:`Compiled`)."""
        return self.compiled.parts

    def jacobian(self, jacs: list[np.ndarray | None]) -> Jacobians:
        """The scaled Jacobians, dense block by block of :attr:`parts`, from the groups'
        (B, n, k, 2, 6) as :meth:`evaluate` returns them (views of the kernels'
        constraint-major arrays, put in place as they lie; the blocks are found from the first
        call with at least :data:`SPLIT_FROM` poses)."""
        B, c = next(J for J in jacs if J is not None).shape[0], self.compiled
        if c.places is None:
            c.places, c.ends, c.ties = self._place()
        # the blocks, then a slot for each entry off them, then a dump for the world's entries
        ends = c.ends
        flat = np.zeros((B, ends[-1] + 1))
        for J, (at, scale) in zip(jacs, c.places):
            if J is not None:
                flat[:, at] = J.reshape((B,) + at.shape) * scale
        blocks = [flat[:, e - len(p.rows) * len(p.cols):e].reshape(B, len(p.rows), len(p.cols))
                  for p, e in zip(self.parts, ends)]
        off = np.abs(flat[:, ends[-2]:ends[-1]]) > TIED
        if not c.decided and B >= SPLIT_FROM:  # many poses: no accidental zeros
            c.decided = True
            if self._decouple(blocks[0]):
                c.places = None
                return self.jacobian(jacs)
        return Jacobians(blocks, off, self.parts)

    def _place(self) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[int], np.ndarray]:
        """Per group: where a pose's Jacobian entries (n, k·12) go in its flat Jacobian — the
        blocks of :attr:`parts` one after the other, then a slot for each entry off them, then
        a dump for the world's — and their scales (n, k·12); where the blocks and the off-block
        slots end; and the blocks of each off-block slot's row and column (S, 2)."""
        s, ne = self.system, self.solver.normal
        R, N, M = s.n_rows, s.n_unknowns, s.n_members
        if ne.group_scale is None:
            raise ValueError("the solver's normal equations are built with their scale")
        part_row, part_col = np.empty(R, dtype=int), np.empty(N + 1, dtype=int)
        at_row, at_col = np.empty(R, dtype=int), np.empty(N + 1, dtype=int)
        for i, p in enumerate(self.parts):
            part_row[p.rows], at_row[p.rows] = i, np.arange(len(p.rows))
            part_col[p.cols], at_col[p.cols] = i, np.arange(len(p.cols))
        part_col[N], at_col[N] = -1, 0  # the world
        ends = list(np.cumsum([len(p.rows) * len(p.cols) for p in self.parts]))
        width = np.array([len(p.cols) for p in self.parts])
        start = np.array(ends) - width * np.array([len(p.rows) for p in self.parts])
        places, off, ties = [], ends[-1], []
        for grp, sc in zip(s.groups, ne.group_scale):
            n, k = grp.rows.shape
            member = grp.members[:, None, :, None]  # (n, 1, 2, 1)
            col = np.broadcast_to(np.where(member >= M, N, 6 * member + np.arange(6)), (n, k, 2, 6))
            row = np.broadcast_to(grp.rows[:, :, None, None], (n, k, 2, 6))
            part = part_row[row]
            at = np.where(part == part_col[col], start[part] + at_row[row] * width[part] + at_col[col], -1)
            stray = (at < 0) & (col < N)
            at[stray] = off + np.arange(int(stray.sum()))
            off += int(stray.sum())
            places.append(at)
            ties.append(np.column_stack([part[stray], part_col[col][stray]]))
        ends.append(off)  # the dump follows
        return ([(np.where(at < 0, off, at).reshape(len(at), -1), np.broadcast_to(sc, at.shape).reshape(len(at), -1))
                 for at, sc in zip(places, ne.group_scale)], ends, np.concatenate(ties))

    def _decouple(self, J: np.ndarray) -> bool:
        """Split :attr:`parts` (one block) by Jacobians J (B, R, N): the unknowns that no
        residual row ties together solve apart (a row without entries goes with the first
        unknown); whether it split."""
        rows, cols = np.nonzero((np.abs(J) > TIED).any(axis=0))
        R, N = J.shape[1:]
        label = _components(N + R, cols, N + rows)
        col_label, row_label = label[:N], label[N:]
        row_label[np.setdiff1d(np.arange(R), rows)] = col_label[0]
        groups = np.unique(col_label)
        if len(groups) == 1:
            return False
        self.compiled.parts = [Part(np.flatnonzero(row_label == g), np.flatnonzero(col_label == g)) for g in groups]
        return True

    def _survey(self, P: np.ndarray, Q: np.ndarray, v: np.ndarray, step: int) -> None:
        """Find J's diagonal blocks and the parts that stay still (:class:`Compiled`) before a
        system's first wave, from :data:`SPLIT_FROM` poses along the tangent of a solved pose
        (P (M, 3), Q (M, 4), scaled velocity v (N,), at the table's ``step``): x ⊕ s·v, s spread
        over ±:data:`STRIDE` steps — off the motion by O(s²) but of its structure (a planar
        linkage's stay planar), with no accidental zeros. A wrong guess costs time only: the
        block's solve checks every row and pivot, and the guess corrects itself (module
        docstring)."""
        t = self.table.t
        h = abs(float(t[min(step + 1, len(t) - 1)] - t[max(step - 1, 0)])) / 2
        s = np.linspace(-1.0, 1.0, SPLIT_FROM) * STRIDE * h
        B = len(s)
        Ps, Qs = self.moved(np.broadcast_to(P, (B,) + P.shape), np.broadcast_to(Q, (B,) + Q.shape), s[:, None] * v)
        steps = np.full(B, step)
        r, jacs = self.evaluate(Ps, Qs, steps, True)
        J = self.jacobian(jacs)  # decides the blocks (B ≥ SPLIT_FROM)
        if self.compiled.quiet is None:
            self._settle(r, self.time_derivative(Qs, steps, jacs), J)

    def _stir(self, rs: np.ndarray) -> None:
        """The still parts (:class:`Compiled`) with rows above :data:`TIED` in scaled residuals
        rs (B, R) (an input held when they were found moves; rounding does not count) are still
        no longer."""
        c = self.compiled
        assert c.quiet is not None and c.still is not None
        moving = (np.abs(rs) > TIED).any(axis=0)  # (R,)
        loud = [i for i, (p, q) in enumerate(zip(c.parts, c.quiet)) if q and moving[p.rows].any()]
        if not loud:
            return
        c.quiet[loud] = False
        for i in loud:
            c.still[c.parts[i].rows] &= ~moving[c.parts[i].rows]
        self._skips()

    def _settle(self, r: np.ndarray, rt: np.ndarray, J: Jacobians) -> None:
        """Find the quiet parts (:class:`Compiled`) from the residuals r, time derivatives rt
        (B, R) and Jacobians J of a batch (zero: at most :data:`TIED`, scaled), and the groups
        all of whose rows are theirs or empty (zero, with zero time derivatives and Jacobian
        rows, such as the component of an axis constraint along the aligned axes)."""
        c, s = self.compiled, self.system
        row = self.solver.row
        zero = np.asarray(~((np.abs(r * row) > TIED) | (np.abs(rt * row) > TIED)).any(axis=0))  # (R,)
        c.quiet = np.array([zero[p.rows].all() for p in c.parts])
        c.still = np.zeros(s.n_rows, dtype=bool)
        for p, q, Jp in zip(c.parts, c.quiet, J.blocks):
            c.still[p.rows] = q | (zero[p.rows] & ~(np.abs(Jp) > TIED).any(axis=(0, 2)))
        self._skips()

    def _held(self, P: np.ndarray, Q: np.ndarray, P0: np.ndarray, Q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses P (B, M, 3), Q (B, M, 4) with the still parts' coordinates (:class:`Compiled`)
        those of the pose P0 (M, 3), Q0 (M, 4): the others' exact local coordinates from it
        (rotation vectors by log and exp)."""
        B, M = P.shape[:2]
        d = self.displacement(P, Q, np.broadcast_to(P0, P.shape), np.broadcast_to(Q0, Q.shape))
        d[:, self._still_cols()] = 0.0
        e = (d * self.solver.col).reshape(B, M, 6)
        turn = quat.exp(e[..., 3:].reshape(-1, 3))
        return P0 + e[..., :3], quat.multiply(turn, np.broadcast_to(Q0, Q.shape).reshape(-1, 4)).reshape(B, M, 4)

    def _still_cols(self) -> np.ndarray:
        """The unknowns of the still parts (:class:`Compiled`)."""
        return np.concatenate([p.cols for p, q in zip(self.parts, self._quiet()) if q])

    def _quiet(self) -> np.ndarray:
        quiet = self.compiled.quiet
        assert quiet is not None
        return quiet

    def _moving(self) -> list[int]:
        """The parts that the rough steps solve where some stay still (:class:`Compiled`), else
        none (they solve them all: no still part known, a free direction, or nothing moves)."""
        quiet = self.compiled.quiet
        if quiet is None or self.free or quiet.all() or not quiet.any():
            return []
        return [i for i, q in enumerate(quiet) if not q]

    def _skips(self) -> None:
        """The groups all of whose rows are still (:class:`Compiled`)."""
        c = self.compiled
        assert c.still is not None
        c.skip = tuple(i for i, blk in enumerate(self.system.blocks) if c.still[blk.start:blk.stop].all())

    def _merge(self) -> None:
        """Merge the blocks that this run's poses tied (:attr:`tied`) — for later runs too: a
        merged block is still only if all its blocks were, and its rows are not taken as empty."""
        c = self.compiled
        label = _components(len(c.parts), self.tied[:, 0], self.tied[:, 1])
        self.tied = np.zeros((0, 2), dtype=int)
        merged = [np.flatnonzero(label == g) for g in np.unique(label)]
        parts = [Part(np.sort(np.concatenate([c.parts[i].rows for i in m])),
                      np.sort(np.concatenate([c.parts[i].cols for i in m]))) for m in merged]
        if c.quiet is not None and c.still is not None:
            c.quiet = np.array([c.quiet[m].all() for m in merged])
            for p, q in zip(parts, c.quiet):
                c.still[p.rows] &= q
        c.parts, c.places = parts, None
        if c.still is not None:
            self._skips()

    def _apart(self, J: Jacobians, idx: np.ndarray) -> np.ndarray:
        """Whether the solved poses ``idx`` of J have J zero off its blocks (to :data:`TIED`)
        (B',); the blocks that the others' entries tie are merged before the next block."""
        off = J.off[idx]
        tied = off.any(axis=0)
        if tied.any() and self.compiled.ties is not None:
            self.tied = np.concatenate([self.tied, self.compiled.ties[tied]])
        return np.asarray(~off.any(axis=1))


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The connected component (n,) of each of n nodes linked in pairs a[i], b[i]."""
    graph = scipy.sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return scipy.sparse.csgraph.connected_components(graph, directed=False)[1]


def _take(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """a[idx] for sorted distinct indices ``idx`` into a's first axis: a itself (no copy) when
    they are all of them."""
    return a if len(idx) == len(a) else a[idx]
