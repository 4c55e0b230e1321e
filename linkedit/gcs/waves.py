"""Many time steps solved at once, each kept only where the step-by-step continuation would
have accepted it.

The continuation of :mod:`linkedit.gcs.continuation` pays Python's per-call cost at every step.
Where the scaled Jacobian has full column rank (nothing free to keep still), the pose at a
time is the root of the constraints nearest its prediction whatever the anchor, so a *block*
of steps can be solved together:

1. every few steps first (:data:`STRIDE`, adapted to the prediction error, up to
   :data:`WIDEST_STRIDE`), roughly, in *waves* of up to :data:`WIDEST` steps: each predicted
   by the osculating polynomial through the last :data:`NODES` such poses and their
   velocities (within ~1e-9 of the size one stride ahead), then :data:`CORRECTIONS`
   Gauss–Newton steps for all of them at once (the error after each about the square of the
   one before: ~1e-10 of the size or better), and the velocity from the last linearization —
   leaving out the parts of J that stay still (:class:`Compiled`: a planar linkage's
   out-of-plane unknowns, whose rows and time derivatives are zero to rounding) and the
   constraint groups that are theirs alone (a planar linkage's axis alignments): step 3
   checks every row and pivot;
2. then all the steps of the block at once: the rough ones from where they are, the ones
   between from the osculating polynomial through the rough poses around them (typically
   within 1e-10 of the size);
3. Gauss–Newton on all of them as array operations to convergence: the elementary kinds'
   kernels of :data:`linkedit.gcs.system.EVALUATE` run on B times their constraints, the
   scaled Jacobians are placed straight from the kernels' arrays into dense blocks
   (B × rows × unknowns, one per diagonal block of J where it decouples, as a planar
   linkage's in-plane and out-of-plane unknowns do) and factorized by a batched Cholesky; a
   factorization is kept while it contracts the residual (chord) and serves the exact
   velocity (J v = −∂r/∂t at the solved pose): as is where it is of that pose, by iterative
   refinement where the pose moved little since;
4. each step is put to the continuation's own acceptance test, taken from the step before it:
   converged (largest scaled residual row ≤ ``tol``), no small pivot, J zero off its blocks
   (to :data:`TIED`) at the solved pose, within
   ``predictor_tol`` of the tangent prediction x_{k−1} ⊕ h·v_{k−1} and moving at most
   ``max_motion``. The accepted run of steps is kept — the poses the continuation accepts (the
   same branch, equal to rounding) — and the continuation solves the first rejected step
   (sub-steps, Levenberg–Marquardt), after which blocks resume (:data:`SHORTEST` steps,
   doubling).

**Closed-form predictions.** Where every member of the system is rebuilt in closed form from
placed ones (:mod:`linkedit.gcs.closed_form`: a crank set by its input, revolute dyads about
parallel axes — planar linkages, in any plane — and links pinned between placed members) and
the rebuilt pose reproduces the solved one before the block (:meth:`ClosedForm.sides`), steps 1
and 2 are replaced by the closed form's poses (exact to rounding: most converge at their first
evaluation), in chunks, each up to the first step it cannot rebuild (a dyad that cannot close)
or that the poses show would fail the acceptance test (:meth:`Waves._screened`: left to the
continuation, not solved in vain); steps 3 and 4 are as above, so a closed form that misleads
costs time, never a result.

**A free direction** (one passive degree of freedom: J has rank N − 1, such as an RSSR
coupler's idle spin): the corrections are least norm (nothing along J's null vector, taken by
inverse iteration as the continuation does), and the steps are moved along their null vectors
to their canonical pose, the one nearest the rest pose (:meth:`Waves.canonical`: the
continuation's Newton step of :mod:`linkedit.gcs.canonical`, for all of them at once, then
solved again: converging quadratically over a few passes), with its velocity the canonical
pose's tangent; the acceptance test adds that the last move is at most ``still_tol``. The rough
steps are moved there by one Newton step, and the polynomials go through poses only (a rough
pose's velocity is taken before that move).

What this needs beyond the system — J's diagonal blocks and the parts that stay still (found
before the first wave from :data:`SPLIT_FROM` poses along the tangent of the last solved one,
:meth:`Waves._survey`, or else from the first batch of as many), where each Jacobian entry
goes, the layouts per batch size — is built at a system's first run and kept on it for the
later ones (:attr:`System.batched`), as the system itself is compiled once. They are guesses
that cost time only when wrong (every solved step is checked on every row and pivot, and on J
zero off its blocks) and they correct themselves: blocks that a run's solved poses tie
(entries off them beyond rounding, :data:`TIED`) are merged from its next block on, and still
parts whose rows a block's poses do not satisfy (an input held when they were found moves)
are still no longer. The rough steps' predictions hold the still parts where they are:
extrapolation from the last pose keeps equal coordinates exact, and where the poses before
differ there by rounding (steps solved step by step) they are held explicitly
(:meth:`Waves._held`), or the extrapolation would amplify it wave after wave.

Steps with an input outside its window, systems with custom constraints, more free
directions, and runs that ask for accelerations go step by step; so do systems with the sparse
factorization (above 120 unknowns) unless the closed form rebuilds them: their rebuilt poses
are then evaluated together and each factorized as the continuation's step is
(:meth:`Waves.verify`), instead of step 3.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.csgraph

from linkedit.gcs import accept
from linkedit.gcs import canonical as canon
from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.acceleration import advanced
from linkedit.gcs.closed_form import ClosedForm
from linkedit.gcs.continuation import Solver
from linkedit.gcs.linalg import probes
from linkedit.gcs.system import EVALUATE, Block, Evaluation, State, StepParameters, StepTable
from linkedit.gcs.tolerances import DAMPING, FREE_PIVOT, NULL_APART, NULL_CLEAN, TIED

#: steps of a block after a rejected step (doubling after each block accepted whole); the
#: first block is the whole run
SHORTEST = 16
#: a block solves steps STRIDE apart first (from extrapolation), then the ones between; the
#: spacing adapts to the extrapolation's error, up to WIDEST_STRIDE
STRIDE = 8
WIDEST_STRIDE = 8
#: Gauss–Newton iterations of a block's steps
ITERATIONS = 8
#: steps of the widest wave
WIDEST = 16
#: Gauss–Newton steps of a wave's rough poses, and the largest last one (scaled) for a pose to
#: be predicted from
CORRECTIONS = 2
ROUGH = 1e-4
#: passes moving the poses to their canonical pose along a free direction (:meth:`Waves.canonical`)
CANONICAL_PASSES = 4
#: the largest prediction error (scaled) a wave's width aims for, and the first prediction
#: error of a wave below which the spacing doubles and above which it halves; where J has a
#: free direction (predictions from poses only, rough poses kept whatever their first error) the
#: second ones
REACH, LOW, HIGH = 1e-4, 1e-9, 1e-6
REACH_FREE, LOW_FREE, HIGH_FREE = 1e-1, 1e-7, 1e-4
#: solved poses (and their velocities) the polynomial extrapolation goes through
NODES = 4
#: ... where J has a free direction: poses only, for the polynomial through them (a rough
#: pose's velocity is taken before its move to the canonical pose)
VALUES = 6
#: converged steps a block starts from
START = 2
#: largest scaled move of a pose since its factorization for the factorization to serve its
#: velocity (by two refinements: error ~REFINE³ relative); at most FRESH, one refinement; none
#: where the factorization is of the pose itself
REFINE = 1e-5
FRESH = 1e-9
#: J's diagonal blocks (:attr:`Waves.parts`) are found from the first batch of at least this
#: many poses (no accidental zeros)
SPLIT_FROM = 64
#: the chunks of a sparse system's closed-form poses (:meth:`Waves.rebuilt`): its evaluation's
#: arrays take ~0.3 MB per pose for 726 unknowns
CHUNK = 256
#: batches of at most this many poses solve their triangular systems pose by pose
FEW = 24
#: the layouts of this many batch sizes, of at most KEPT_POSES poses, are kept on the system
#: for its later runs (the last built)
KEPT_LAYOUTS, KEPT_POSES = 16, 1024

_potrs = scipy.linalg.get_lapack_funcs("potrs", dtype=np.float64)


@dataclasses.dataclass
class Solved:
    """A block's result for B steps: positions (B, M, 3), quaternions (B, M, 4), residuals
    (B, R), scaled velocities (B, N), linear solves and factorizations (B, 2), and how many
    steps, from the first, pass the continuation's acceptance test (``accepted``)."""

    position: np.ndarray
    orientation: np.ndarray
    residual: np.ndarray
    velocity: np.ndarray
    work: np.ndarray
    accepted: int
    #: the rank of J at each step where it was read pose by pose (:meth:`Waves.verify`), else
    #: None (full column rank less the free directions)
    rank: np.ndarray | None = None


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
class Factors:
    """Factorizations of B poses' scaled JᵀJ + μI, block by block of ``parts`` (B, Np, Np)
    each (the other unknowns are not solved for: zero), whether each is sound (B,), and J's
    unit null vectors (B, N) where it has a free direction."""

    factors: list[np.ndarray]
    sound: np.ndarray
    null: np.ndarray | None
    parts: list[Part]

    def take(self, idx: np.ndarray) -> "Factors":
        return Factors([_take(L, idx) for L in self.factors], _take(self.sound, idx),
                       None if self.null is None else _take(self.null, idx), self.parts)


@dataclasses.dataclass
class _Layout:
    """An evaluation's fixed parts for B poses, member-major (member or vector i of pose b at
    i·B + b, so each kernel sees B times its constraints, constraint-major): the blocks with
    spread indices, the member of each member vector (K·B,), the member vectors (K, B, 9) and
    the inverse relative orientations (n, B, 4)."""

    blocks: list[Block]
    member: np.ndarray
    vectors: np.ndarray
    rel_inverse: np.ndarray


@dataclasses.dataclass
class Compiled:
    """What batched evaluation of one system needs beyond the system itself, built at first
    use and kept on it (:attr:`System.batched`) for every later run, as the system is compiled
    once: the diagonal blocks of J that solve apart (``parts``: a planar linkage's in-plane
    and out-of-plane unknowns; one block until a batch of :data:`SPLIT_FROM` poses was seen,
    ``decided``), the parts that stay still (``quiet``: their rows and time derivatives exactly
    zero, to :data:`TIED`, over the batch that found them, such as a planar linkage's
    out-of-plane part), the rows that are theirs or empty (``still``, (R,)) and the
    groups all of whose rows are (``skip``), per group where a pose's Jacobian entries go and
    their scales, where the blocks and the off-block slots end and which blocks each off-block
    slot ties (``places``, ``ends``, ``ties`` (S, 2): :meth:`Waves._place`), and the layouts
    per batch size (:meth:`Waves._layout`); ``key``: a digest of what it was built from
    (:meth:`System.digest`). Blocks a run's poses tie together are merged (:meth:`Waves._merge`).
    A run changes a copy of its own and keeps a copy of that on the system after each block,
    so that runs of one system in several threads do not see each other's halfway changes."""

    parts: list[Part]
    key: bytes = b""
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


class Waves:
    """Batched evaluation and solution of one system over a step table (module docstring)."""

    def __init__(self, solver: Solver, table: StepTable) -> None:
        self.solver = solver
        self.system = solver.system
        self.table = table
        s = self.system
        kept, key = s.batched.get("waves"), s.digest()
        # (a system copied or changed in place since keeps what its first run compiled: not used)
        if kept is not None and kept.key == key:
            self.compiled = kept.copy()
        else:
            self.compiled = Compiled([self._whole()], key, closed=ClosedForm.of(s))
        #: the closed form predicting this run's poses (None: the waves' own predictions)
        self.closed = self.compiled.closed
        #: layouts of more poses than are kept on the system, for this run
        self._layouts: dict[int, _Layout] = {}
        #: pairs of blocks (K, 2) that Jacobian entries of this run's poses tied: merged before
        #: the next block
        self.tied = np.zeros((0, 2), dtype=int)
        #: free directions of J at every pose (0, or 1: a passive degree of freedom, canonical)
        self.free = 0

    def _whole(self) -> Part:
        s = self.system
        return Part(np.arange(s.n_rows), np.arange(s.n_unknowns))

    @property
    def parts(self) -> list[Part]:
        """The diagonal blocks of J that solve apart (:class:`Compiled`)."""
        return self.compiled.parts

    @staticmethod
    def applies(solver: Solver) -> bool:
        """Whether the system's structure allows waves (see the module docstring; the rank is
        checked at the first pose by the caller)."""
        o, s, normal = solver.options, solver.system, solver.normal
        return (o.solver == "lm" and not o.accelerations and not s.customs
                and (normal.unique_entries if not normal.sparse else ClosedForm.of(s) is not None))

    # ---- batched evaluation ---------------------------------------------------------------

    def _layout(self, B: int) -> "_Layout":
        """What an evaluation of B poses needs that does not change between calls: kept on the
        system for the :data:`KEPT_LAYOUTS` batch sizes of at most :data:`KEPT_POSES` poses last
        built (a few MB at most), else for this run."""
        layouts = self.compiled.layouts if B <= KEPT_POSES else self._layouts
        lay = layouts.get(B)
        if lay is None:
            s = self.system
            lanes = np.arange(B)
            spread = lambda idx: (idx[:, None] * B + lanes).ravel()  # noqa: E731
            blocks = [dataclasses.replace(blk, a=spread(blk.a), b=spread(blk.b),
                                          vectors=tuple(slice(v.start * B, v.stop * B) for v in blk.vectors))
                      for blk in s.blocks]
            lay = layouts[B] = _Layout(blocks, spread(s.vector_member), np.repeat(s.vectors[:, None], B, axis=1),
                                       np.repeat(s.rel_inverse[:, None], B, axis=1))
            for old in list(layouts)[:-KEPT_LAYOUTS]:  # (a copy of the keys: other runs may add)
                layouts.pop(old, None)
        return lay

    def evaluate(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray, jacobian: bool,
                 skip: tuple[int, ...] = (), table: StepTable | None = None) -> tuple[np.ndarray, list[np.ndarray | None]]:
        """Residuals (B, R) at positions P (B, M, 3) and quaternions Q (B, M, 4) at the
        ``steps`` (B,) of the run's table (or of ``table``), and with ``jacobian`` the Jacobian
        per group (B, n, k, 2, 6); the groups ``skip`` are not evaluated (rows zero, Jacobian
        None)."""
        s, tab = self.system, table or self.table
        B, M = P.shape[0], s.n_members
        lay = self._layout(B)
        # member-major layouts (M + 1, B, ·), the world last
        members_p, members_q = np.empty((M + 1, B, 3)), np.empty((M + 1, B, 4))
        members_p[:M], members_p[M] = np.swapaxes(P, 0, 1), 0.0
        members_q[:M], members_q[M] = np.swapaxes(Q, 0, 1), (1.0, 0.0, 0.0, 0.0)
        Pm, Qm = members_p.reshape(-1, 3), members_q.reshape(-1, 4)
        V = lay.vectors
        if tab.vectors.shape[1]:
            V = V.copy()
            V[s.driven_vectors] = np.swapaxes(tab.vectors[steps], 0, 1)
        R = quat.to_matrix(Qm).reshape(-1, 9)
        W = np.einsum("nij,nj->ni", R.take(lay.member, axis=0).reshape(-1, 3, 3), V.reshape(-1, 9)[:, :3])
        X = Pm.take(lay.member, axis=0) + W
        rel = lay.rel_inverse
        if tab.rel_inverse.shape[1]:
            rel = rel.copy()
            rel[s.driven_rel] = np.swapaxes(tab.rel_inverse[steps], 0, 1)
        values = {blk.kind: np.repeat(blk.value, B) if v is None else v[steps].T.ravel()
                  for blk, v in zip(s.blocks, tab.values) if blk.kind in kinds.VALUE_KINDS}
        # the kernels read only the relative orientations and the values; every input is active
        par = StepParameters(0.0, np.zeros((0, 9)), rel.reshape(-1, 4), [None] * len(s.blocks),
                             np.zeros(0, dtype=int), values)
        r = np.empty((B, s.n_rows))
        jacs: list[np.ndarray | None] = []
        for i, (blk, wide) in enumerate(zip(s.blocks, lay.blocks)):
            if i in skip:
                r[:, blk.start:blk.stop] = 0.0
                jacs.append(None)
                continue
            n, k = blk.rows.shape
            out = np.empty((n * B, k))
            J = EVALUATE[blk.kind](wide, X, W, Qm, par, out, jacobian)
            r[:, blk.start:blk.stop] = np.swapaxes(out.reshape(n, B, k), 0, 1).reshape(B, -1)
            if J is not None:
                jacs.append(np.swapaxes(J.reshape((n, B) + J.shape[1:]), 0, 1))
        return r, jacs

    def time_derivative(self, Q: np.ndarray, steps: np.ndarray, jacs: list[np.ndarray | None]) -> np.ndarray:
        """∂r/∂t (B, R) at quaternions Q (B, M, 4) (as :meth:`System.time_derivative`, batched)."""
        s = self.system
        B = Q.shape[0]
        out = np.zeros((B, s.n_rows))
        for blk, jac, rate in zip(s.blocks, jacs, self.table.rates):
            if rate is None or jac is None:
                continue
            sel = blk.scheduled
            if blk.kind in kinds.VALUE_KINDS:
                out[:, blk.rows[sel]] = -rate[steps]
                continue
            w = rate[steps]  # (B, S, 6): u, ω in b's frame
            if not blk.on_world:
                Qe = np.concatenate([Q, np.tile([1.0, 0.0, 0.0, 0.0], (B, 1, 1))], axis=1)
                Rb = quat.to_matrix(Qe[:, blk.b[sel]])  # (B, S, 3, 3)
                w = (w.reshape(B, -1, 2, 3) @ np.swapaxes(Rb, 2, 3)).reshape(B, -1, 6)
            out[:, blk.rows[sel]] = (jac[:, sel][..., 1, :] * w[:, :, None, :]).sum(axis=3)
        return out

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

    # ---- a block of steps -----------------------------------------------------------------

    def block(self, k: int, stop: int, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray, first: int) -> Solved:
        """Solve the steps k … stop − 1 given the accepted ones before k (positions (T, M, 3),
        quaternions (T, M, 4), real velocities (T, M, 6) of the run, converged from step
        ``first`` on, k − first ≥ :data:`START`): steps about :data:`STRIDE` apart (and the
        last) first, roughly (:meth:`correct`), in waves from the osculating polynomial through
        the poses before them (where J has a free direction, the polynomial through
        :data:`VALUES` poses); then all of them at once, the steps between from the polynomial
        through the poses around them, and where J has a free direction, passes moving them to
        their canonical pose (:meth:`canonical`, converging quadratically: at most
        :data:`CANONICAL_PASSES`); then the continuation's acceptance test."""
        col, M = self.solver.col, self.system.n_members
        if self.solver.normal.sparse:  # the closed form's poses, or none
            rebuilt = self.rebuilt(k, stop, pos, ori, vel) if self.closed is not None else None
            return rebuilt or Solved(np.zeros((0, M, 3)), np.zeros((0, M, 4)), np.zeros((0, self.system.n_rows)),
                                     np.zeros((0, self.system.n_unknowns)), np.zeros((0, 2), dtype=np.int32), 0)
        if self.tied.size:  # the blocks kept on the system do not hold for this run's poses
            self._merge()
        if not self.compiled.decided and not self.free and np.abs(vel[k - 1]).max() > 0.0:
            self._survey(pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col, k - 1)
        if self.closed is not None and not self.free:
            rebuilt = self.rebuilt(k, stop, pos, ori, vel)
            if rebuilt is not None:
                return rebuilt
        t = self.table.t
        coarse: list[np.ndarray] = []
        rough: list[tuple[np.ndarray, np.ndarray]] = []
        # where J has a free direction, the poses only (the rough poses' velocities are not
        # quite their canonical motion's: taken before their last move along it)
        count = VALUES if self.free else NODES
        prior = np.unique(np.clip(k - 1 - STRIDE * np.arange(count), first, None))
        node_t = list(t[prior])
        v = vel[prior]
        # the rough steps leave what stays still as predicted: predictions must not move it —
        # by the rounding of the velocities before, or of the poses before (amplified by the
        # extrapolation, wave after wave), where they are not exact (steps solved step by step)
        hold = False
        if self._moving():
            still = self._still_cols()
            P0, Q0 = (np.broadcast_to(x[prior[-1]], x[prior].shape) for x in (pos, ori))
            hold = bool(self.displacement(pos[prior], ori[prior], P0, Q0)[:, still].any())
            v = v.copy()
            v.reshape(len(prior), -1)[:, still] = 0.0
        z, dz = flat(pos[prior], ori[prior], v)
        node_z, node_dz = list(z), list(dz)
        reach, low, high = (REACH_FREE, LOW_FREE, HIGH_FREE) if self.free else (REACH, LOW, HIGH)
        here, stride, width = k - 1, STRIDE, 1 if len(prior) < count else 4
        while here < stop - 1:
            ahead = np.unique(np.minimum(here + stride * np.arange(1, width + 1), stop - 1))
            if 0 < stop - 1 - ahead[-1] <= stride // 2:  # the block's last step, within half a stride: now
                ahead = np.append(ahead, stop - 1)
            if self.free:
                P, Q = self._split(lagrange(np.array(node_t[-count:]), np.array(node_z[-count:]),
                                            np.zeros(len(ahead), dtype=int), t[ahead], count))
            else:
                P, Q = self.extrapolated(np.array(node_t[-count:]), np.array(node_z[-count:]),
                                         np.array(node_dz[-count:]), t[ahead])
            if hold:
                last = self._split(node_z[-1][None])
                P, Q = self._held(P, Q, last[0][0], last[1][0])
            v, error, good = self.correct(P, Q, ahead)
            n = int(np.argmin(good)) if not good.all() else len(ahead)
            if n == 0:
                if len(ahead) == 1 and stride == 1:
                    break  # the block ends here
                stride, width = max(1, stride // 2), 1
                continue
            coarse.append(ahead[:n])
            rough.append((P[:n], Q[:n]))
            node_t += list(t[ahead[:n]])
            z, dz = flat(P[:n], Q[:n], (v[:n] * col).reshape(n, M, 6))
            node_z += list(z)
            node_dz += list(dz)
            here = int(ahead[n - 1])
            # the spacing keeps the first prediction's error between low and high (of the size)
            if error > high:
                stride = max(1, stride // 2)
            elif error < low:
                stride = min(2 * stride, WIDEST_STRIDE)
            # as many steps as the extrapolation reaches within ``reach`` of the size (its error
            # grows about as the fifth power of the distance)
            far = (reach / max(error, 1e-16)) ** 0.2 * (1 if error > high else 0.5 if error < low else 1)
            width = int(np.clip(far, 1, WIDEST))
        if not coarse:
            self.system.batched["waves"] = self.compiled.copy()
            return Solved(np.zeros((0, M, 3)), np.zeros((0, M, 4)), np.zeros((0, self.system.n_rows)),
                          np.zeros((0, self.system.n_unknowns)), np.zeros((0, 2), dtype=np.int32), 0)
        at = np.concatenate(coarse) - k
        steps = np.arange(k, k + int(at[-1]) + 1)
        B = steps.size
        P, Q = np.empty((B, M, 3)), np.empty((B, M, 4))
        P[at], Q[at] = np.concatenate([x[0] for x in rough]), np.concatenate([x[1] for x in rough])
        fine = np.setdiff1d(np.arange(B), at)
        if fine.size:
            # each from the osculating polynomial through the NODES poses around it
            nt, nz, ndz = np.array(node_t), np.array(node_z), np.array(node_dz)
            right = np.searchsorted(nt, t[k + fine])  # the node after each fine step
            around = np.clip(right - count // 2, 0, max(len(nt) - count, 0))
            if self.free:
                P[fine], Q[fine] = self._split(lagrange(nt, nz, around, t[k + fine], count))
            else:
                P[fine], Q[fine] = self.osculating(nt, nz, ndz, around, t[k + fine])
        R, V, work, ok, null = self.solve(P, Q, steps)
        work[at] += CORRECTIONS  # the rough corrections: a linear solve and a factorization each
        for i in range(CANONICAL_PASSES if self.free else 0):
            # the free direction moved to the canonical pose, then solved again there (until
            # the move is at most still_tol; the velocities the canonical pose's tangent)
            V, move = self.canonical(P, Q, V, steps)
            if np.abs(move).max() <= self.solver.options.still_tol or i == CANONICAL_PASSES - 1:
                # the last moves need no correction (the constraints change by |move|²)
                last = np.abs(move).max(axis=1) <= self.solver.options.still_tol
                P[:], Q[:] = self.moved(P, Q, move * last[:, None])
                R[last] = self.evaluate(P[last], Q[last], steps[last], False)[0]
                ok &= last
                break
            P[:], Q[:] = self.moved(P, Q, move)
            R, V, again, ok, null = self.solve(P, Q, steps)
            work += again
        before = (pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col)
        n = self.accepted(P, Q, V, ok, steps, before, float(t[k - 1]))
        self.system.batched["waves"] = self.compiled.copy()  # for later runs (Compiled)
        return Solved(P, Q, R, V, work, n)

    def rebuilt(self, k: int, stop: int, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray) -> Solved | None:
        """Solve the steps k … stop − 1 as :meth:`block` does, from the closed form's poses
        (:mod:`linkedit.gcs.closed_form`: exact to rounding, so most steps converge at once), in
        chunks (a dense system's of :data:`KEPT_POSES` steps; a sparse one's, each pose
        factorized, of :data:`CHUNK`)
        up to the first step it cannot rebuild, that fails the acceptance test, or that clearly
        would (:meth:`_screened`: no pose is solved in vain); None where it solves none — or
        does not reproduce the solved pose k − 1 (:meth:`ClosedForm.sides`): its rules do not
        hold for this mechanism (this run's later blocks and the system's later runs go
        without it)."""
        closed, col, t = self.closed, self.solver.col, self.table.t
        assert closed is not None
        signs = closed.sides(pos[k - 1], ori[k - 1], self.table, k - 1)
        if signs is None:
            self.closed = self.compiled.closed = None
            return None
        sparse = self.solver.normal.sparse
        before = (pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col)
        t_before = float(t[k - 1])
        chunk, here = CHUNK if sparse else KEPT_POSES, k
        kept: list[tuple[np.ndarray, ...]] = []
        ranks: list[np.ndarray] = []
        while here < stop:
            steps = np.arange(here, min(stop, here + chunk))
            P, Q, valid = closed.poses(self.table, steps, before[1], signs)
            n = self._screened(P, Q, valid, steps, before, t_before)
            if n == 0:
                break
            steps, P, Q = steps[:n], P[:n], Q[:n]
            if sparse:
                R, V, work, ok, rank = self.verify(P, Q, steps, before[2])
            else:
                R, V, work, ok, _ = self.solve(P, Q, steps)
            a = self.accepted(P, Q, V, ok, steps, before, t_before)
            kept.append((P[:a], Q[:a], R[:a], V[:a], work[:a]))
            if sparse:
                ranks.append(rank[:a])
            if a < len(valid):
                break
            before, t_before, here = (P[-1], Q[-1], V[-1]), float(t[steps[-1]]), int(steps[-1]) + 1
        if not kept:
            return None
        self.system.batched["waves"] = self.compiled.copy()  # for later runs (Compiled)
        P, Q, R, V, work = (np.concatenate([part[i] for part in kept]) for i in range(5))
        return Solved(P, Q, R, V, work, len(P), np.concatenate(ranks) if sparse else None)

    def _screened(self, P: np.ndarray, Q: np.ndarray, valid: np.ndarray, steps: np.ndarray,
                  before: tuple[np.ndarray, np.ndarray, np.ndarray], t_before: float) -> int:
        """How many of the closed form's consecutive poses P (B, M, 3), Q (B, M, 4) at the
        table's ``steps`` (B,), after the solved pose ``before`` (position, quaternions, scaled
        velocity) at ``t_before``, are rebuilt (``valid`` (B,)) and pass the acceptance test
        (:meth:`accepted`) with the velocity before each taken from the poses around it
        (secant over two steps; the first's exact): a step that fails it so is left to the
        continuation, not factorized first (the test proper comes after the solve)."""
        opt = self.solver.options
        n = accept.leading(valid)
        if n == 0:
            return 0
        P0 = np.concatenate([before[0][None], P[:n - 1]])
        Q0 = np.concatenate([before[1][None], Q[:n - 1]])
        moved = self.displacement(P[:n], Q[:n], P0, Q0)  # (n, N)
        h = np.diff(np.concatenate([[t_before], self.table.t[steps[:n]]]))
        v = np.empty_like(moved)
        v[0] = before[2]
        v[1:] = (moved[:-1] + moved[1:]) / (h[:-1] + h[1:])[:, None]
        return accept.leading(accept.passes(moved, h, v, opt))

    def verify(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray,
               incoming: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The closed form's poses P (B, M, 3), Q (B, M, 4) at the table's ``steps`` (B,) of a
        system with the sparse factorization: residuals and Jacobians evaluated for all at
        once, then each pose that converged as it is (largest scaled residual row ≤ ``tol``)
        linearized, factorized and given its exact velocity as the continuation's step does
        (:meth:`Solver.linearize`: the same pivots, null space and rank). Returns the residuals
        (B, R), scaled velocities (B, N), linear solves and factorizations (B, 2), whether each
        is solved with no free direction (B,), and J's rank (B,) (−1 where the pivots cannot
        tell, as for the continuation's steps). At a singular pose (a change point) the velocity
        is the one nearest the step's before (``incoming``, scaled (N,): the solved pose's
        before the first), as the continuation's (:meth:`Linear.continued`)."""
        solver, B = self.solver, len(steps)
        r, jacs = self.evaluate(P, Q, steps, True)
        rt = self.time_derivative(Q, steps, jacs)
        velocity = np.zeros((B, self.system.n_unknowns))
        work = np.zeros((B, 2), dtype=np.int32)
        ok = np.abs(r * solver.row).max(axis=1) <= solver.options.tol
        rank = np.full(B, -1)
        for b in np.flatnonzero(ok):
            ev = Evaluation(r[b], [J[b] for J in jacs if J is not None])
            linear = solver.linearize(State(P[b], Q[b]), self.table, int(steps[b]), ev)
            velocity[b] = incoming = linear.continued(-rt[b] * solver.row, incoming)
            ok[b], rank[b] = linear.null is None, linear.rank
            work[b] = 1
        return r, velocity, work, ok, rank

    def canonical(self, P: np.ndarray, Q: np.ndarray, v0: np.ndarray, steps: np.ndarray,
                  known: tuple["Jacobians", "Factors"] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """For B solved poses (P (B, M, 3), Q (B, M, 4)) with one free direction, at the table's
        ``steps`` (B,), with least-norm scaled velocities v0 (B, N): the canonical pose's
        velocities (B, N) and the Newton moves (B, N) along J's null vectors towards it
        (:mod:`linkedit.gcs.canonical`; zero at the canonical pose), as the continuation's
        :meth:`Solver.canonical` and :meth:`Solver.velocity` take them; J and its
        factorization at the poses are evaluated, or ``known`` (a rough pose's, nearby)."""
        if known is None:
            J = self.jacobian(self.evaluate(P, Q, steps, True)[1])
            F = self._factor(J)
        else:
            J, F = known
        assert F.null is not None
        n = F.null
        B = len(steps)
        ref = self.solver.reference
        d = self.displacement(P, Q, np.broadcast_to(ref.position, P.shape), np.broadcast_to(ref.orientation, Q.shape))
        # λ = J⁺ᵀ d, block by block
        flat = d - n * (n * d).sum(axis=1)[:, None]
        y = self.least_norm(F, [flat[:, p.cols] for p in F.parts])
        lam = [(Jp @ y[:, p.cols, None])[..., 0] for p, Jp in zip(F.parts, J.blocks)]
        # λᵀ J̇ n by central differences along n, then along v0 with the inputs advanced in
        # time, all 4B poses in one evaluation
        hn = np.full(B, canon.STEP)
        hv = canon.STEP / np.maximum(1.0, np.abs(v0).max(axis=1))
        h = np.concatenate([hn, -hn, hv, -hv])
        moves = np.concatenate([n, n, v0, v0]) * h[:, None]
        four = np.tile(steps, 4)
        Pm, Qm = self.moved(np.tile(P, (4, 1, 1)), np.tile(Q, (4, 1, 1)), moves)
        tab = advanced(self.table, four, np.concatenate([0.0 * hn, 0.0 * hn, hv, -hv]))
        Jm = self.jacobian(self.evaluate(Pm, Qm, np.arange(4 * B), True, table=tab)[1])
        n4 = np.tile(n, (4, 1))
        seen = sum(((np.tile(lp, (4, 1))[:, :, None] * Jp).sum(axis=1) * n4[:, p.cols]).sum(axis=1)
                   for lp, p, Jp in zip(lam, J.parts, Jm.blocks)).reshape(4, B)
        null = n[:, :, None]
        G = canon.hessian(null, d, ((seen[0] - seen[1]) / (2 * hn))[:, None, None])
        velocity = canon.velocity(v0, null, d, G, ((seen[2] - seen[3]) / (2 * hv))[:, None])
        return velocity, canon.step(null, d, G)

    def correct(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """Rough poses at the table's ``steps`` (B,) from predictions P (B, M, 3), Q (B, M, 4)
        (moved in place), good enough to predict from: :data:`CORRECTIONS` least-norm
        Gauss–Newton steps (the error after each about the square of the one before); where J
        has a free direction, then one Newton step along it towards the canonical pose
        (:meth:`canonical`, with the last linearization). Returns the scaled velocities (B, N)
        at the last linearization (exact to about the size of the last correction), the first
        pose's prediction error (its first correction, or its move along the free direction),
        and which poses are good (B,): a sound factorization (:meth:`_factor`) and a last
        correction (or the square of that move: what it leaves) of at most :data:`ROUGH`."""
        row, c = self.solver.row, self.compiled
        # rough poses need not move what stays still (the block's solve checks all of it)
        moving = self._moving()
        quick = bool(moving)
        error = np.inf
        for i in range(CORRECTIONS):
            r, jacs = self.evaluate(P, Q, steps, True, c.skip if quick else ())
            J = self.jacobian(jacs)
            if quick:
                J = J.only(moving)
            F = self._factor(J)
            step = -self.least_norm(F, self._gradient(J, r * row))
            size = np.abs(step).max(axis=1)
            error = float(size[0]) if i == 0 else error
            if i == CORRECTIONS - 1:
                rt = self.time_derivative(Q, steps, jacs)
            P[:], Q[:] = self.moved(P, Q, step)
        velocity = self.least_norm(F, self._gradient(J, -rt * row))
        if F.null is not None:  # along the free direction, the canonical pose and its tangent
            velocity, move = self.canonical(P, Q, velocity, steps, (J, F))
            P[:], Q[:] = self.moved(P, Q, move)
            # the prediction's error along it; a Newton move leaves about its square
            along = np.abs(move).max(axis=1)
            error = max(error, float(along[0]))
            size = np.maximum(size, along * along)
        return velocity, error, F.sound & (size <= ROUGH)

    # ---- poses ------------------------------------------------------------------------------

    def moved(self, P: np.ndarray, Q: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses after scaled local steps e (B, N) (as :meth:`State.moved`)."""
        B, M = P.shape[:2]
        d = (e * self.solver.col).reshape(B, M, 6)
        return P + d[..., :3], quat.turned(Q.reshape(-1, 4), d[..., 3:].reshape(-1, 3)).reshape(B, M, 4)

    def displacement(self, P: np.ndarray, Q: np.ndarray, P0: np.ndarray, Q0: np.ndarray) -> np.ndarray:
        """Scaled local coordinates (B, N) from poses 0 to poses (as :meth:`State.minus`)."""
        B, M = P.shape[:2]
        phi = quat.log(quat.multiply(Q.reshape(-1, 4), quat.conjugate(Q0.reshape(-1, 4)))).reshape(B, M, 3)
        return np.concatenate([P - P0, phi], axis=2).reshape(B, 6 * M) / self.solver.col

    def _factor(self, J: Jacobians) -> "Factors":
        """Cholesky factors (B, Np, Np) of the scaled JᵀJ + μI, block by block (μ as the
        continuation's: 1e-13 of the largest diagonal entry, at least 1e-13), and whether each
        pose's is sound (B,): positive definite with exactly :attr:`free` pivots below
        :data:`FREE_PIVOT` of that entry (no other free or singular direction) and, where J has
        a free direction, its null vector (:meth:`_null`) clean (J zero off its blocks is
        checked at the solved pose: :meth:`_apart`)."""
        normal = [np.swapaxes(Jp, 1, 2) @ Jp for Jp in J.blocks]
        B = len(J.leaves)
        top = np.ones(B)
        for H in normal:
            np.maximum(top, np.diagonal(H, axis1=1, axis2=2).max(axis=1), out=top)
        factors = []
        sound = np.ones(B, dtype=bool)
        small = np.zeros(B, dtype=int)
        for H in normal:
            n = H.shape[1]
            H.reshape(B, n * n)[:, ::n + 1] += (DAMPING * top)[:, None]
            try:
                L = np.linalg.cholesky(H)
            except np.linalg.LinAlgError:  # some pose is not positive definite: one by one
                L = np.tile(np.eye(n), (B, 1, 1))
                for i, h in enumerate(H):
                    try:
                        L[i] = np.linalg.cholesky(h)
                    except np.linalg.LinAlgError:
                        sound[i] = False
            factors.append(L)
            small += (np.diagonal(L, axis1=1, axis2=2) ** 2 < FREE_PIVOT * top[:, None]).sum(axis=1)
        sound &= small == self.free
        null = None
        if self.free:
            null, clean = self._null(factors, J, top)
            sound &= clean
            weak = np.flatnonzero(small == self.free + 1)  # a direction J sees weakly besides
            if weak.size:
                null[weak], clean = self._null_apart([L[weak] for L in factors], J.take(weak), top[weak])
                sound[weak] = clean
        return Factors(factors, sound, null, J.parts)

    def _null(self, factors: list[np.ndarray], J: Jacobians, top: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit null vectors (B, N) of J where it has one free direction, as the continuation
        takes them: two inverse iterations with the factorization from a fixed random vector
        (μ sets the null eigenvalue apart by FREE_PIVOT / 1e-13 at least); and whether each is
        clean (B,): |J n| at most NULL_CLEAN of √(largest diagonal of JᵀJ)."""
        B, N = len(top), self.system.n_unknowns
        probe = probes(N, 1)[:, 0]  # as the continuation's
        parts = self.parts
        y = self._assemble(self._solve(factors, [np.broadcast_to(probe[p.cols], (B, len(p.cols))) for p in parts]),
                           parts)
        y = self._assemble(self._solve(factors, [y[:, p.cols] for p in parts]), parts)
        y /= np.sqrt((y * y).sum(axis=1))[:, None]
        seen = sum(((Jp @ y[:, p.cols, None])[..., 0] ** 2).sum(axis=1) for p, Jp in zip(self.parts, J.blocks))
        return y, np.sqrt(seen) <= NULL_CLEAN * np.sqrt(top)

    def _null_apart(self, factors: list[np.ndarray], J: Jacobians, top: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`_null` where two pivots are small (a direction J sees weakly besides the
        free one), as the continuation takes it: two inverse iterations from two fixed random
        vectors span both; of the two directions of that span, the one J does not see is the
        null vector, clean when J's two singular values there are at most NULL_CLEAN and at
        least NULL_APART of √(largest diagonal of JᵀJ)."""
        B, N = len(top), self.system.n_unknowns
        start = probes(N, 2)  # as the continuation's
        Y = np.empty((B, N, 2))
        for j in range(2):
            y = self._assemble(self._solve(factors, [np.broadcast_to(start[p.cols, j], (B, len(p.cols)))
                                                     for p in self.parts]), self.parts)
            Y[:, :, j] = self._assemble(self._solve(factors, [y[:, p.cols] for p in self.parts]), self.parts)
        # an orthonormal basis of the span (Gram–Schmidt), J on it (B, R, 2) and its 2 × 2 Gram matrix
        Y[:, :, 0] /= np.sqrt((Y[:, :, 0] ** 2).sum(axis=1))[:, None]
        Y[:, :, 1] -= Y[:, :, 0] * (Y[:, :, 0] * Y[:, :, 1]).sum(axis=1)[:, None]
        Y[:, :, 1] /= np.sqrt((Y[:, :, 1] ** 2).sum(axis=1))[:, None]
        JY = np.concatenate([Jp @ Y[:, p.cols] for p, Jp in zip(self.parts, J.blocks)], axis=1)
        values, vectors = np.linalg.eigh(np.swapaxes(JY, 1, 2) @ JY)  # ascending
        scale = np.sqrt(top)
        sv = np.sqrt(np.maximum(values, 0.0))
        clean = (sv[:, 0] <= NULL_CLEAN * scale) & (sv[:, 1] >= NULL_APART * scale)
        return (Y @ vectors[:, :, :1])[..., 0], clean

    def _apart(self, J: Jacobians, idx: np.ndarray) -> np.ndarray:
        """Whether the solved poses ``idx`` of J have J zero off its blocks (to :data:`TIED`)
        (B',); the blocks that the others' entries tie are merged before the next block."""
        off = J.off[idx]
        tied = off.any(axis=0)
        if tied.any() and self.compiled.ties is not None:
            self.tied = np.concatenate([self.tied, self.compiled.ties[tied]])
        return np.asarray(~off.any(axis=1))

    def _assemble(self, x: list[np.ndarray], parts: list[Part]) -> np.ndarray:
        """One vector (B, N) from its blocks (B, Np) of ``parts`` (zero elsewhere)."""
        full = len(parts) == len(self.parts)
        out = (np.empty if full else np.zeros)((len(x[0]), self.system.n_unknowns))
        for p, xp in zip(parts, x):
            out[:, p.cols] = xp
        return out

    def least_norm(self, F: "Factors", b: list[np.ndarray]) -> np.ndarray:
        """y (B, N) of (JᵀJ + μI) y = b (blocks (B, Np)) without its component along J's null
        vector (there it is rounding amplified by 1/μ): the least-norm solution."""
        y = self._assemble(self._solve(F.factors, b), F.parts)
        return y if F.null is None else y - F.null * (F.null * y).sum(axis=1)[:, None]

    @staticmethod
    def _solve(factors: list[np.ndarray], b: list[np.ndarray]) -> list[np.ndarray]:
        """x of L Lᵀ x = b block by block: factors (B, Np, Np) and right-hand sides (B, Np)."""
        return [cholesky_solve(L, bp) if bp.any() else np.zeros_like(bp)  # a planar linkage's out-of-plane
                for L, bp in zip(factors, b)]                                 # part rarely is

    @staticmethod
    def _gradient(J: Jacobians, r: np.ndarray) -> list[np.ndarray]:
        """Jᵀ r block by block (B, Np) for residual rows r (B, R)."""
        return [(r[:, p.rows][:, None, :] @ Jp)[:, 0] for p, Jp in zip(J.parts, J.blocks)]

    def solve(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray, budget: int = ITERATIONS,
              velocities: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Least-norm Gauss–Newton at the table's ``steps`` (B,) from poses P (B, M, 3),
        Q (B, M, 4) (moved in place). A pose's JᵀJ + μI is factorized at its first iterate and
        again only where a step reusing it (chord) contracted the residual less than tenfold;
        every step contracts it twofold at least. The exact velocity at the solved pose
        (J v = −∂r/∂t, least norm, J evaluated there) is solved with the kept factorization —
        as is where it is of that pose (as the continuation solves it), else refined against
        that J: once where the factorization is of a pose at most :data:`FRESH` away, twice
        otherwise (it is at most :data:`REFINE` away, so each refinement contracts the error by
        that much), or with a fresh one. Returns the residuals
        (B, R), the scaled velocities (B, N), the linear solves and factorizations (B, 2),
        whether each step converged with a sound factorization (:meth:`_factor`) (B,), and J's
        unit null vectors there (B, N) where it has a free direction (else zeros), after at
        most ``budget`` steps; without ``velocities``, the velocities are left zero."""
        solver, tol = self.solver, self.solver.options.tol
        row = solver.row
        B, N = len(steps), self.system.n_unknowns
        r = np.empty((B, self.system.n_rows))
        velocity = np.zeros((B, N))
        null = np.zeros((B, N))
        work = np.zeros((B, 2), dtype=np.int32)  # linear solves, factorizations
        done = np.zeros(B, dtype=bool)
        kept: Factors | None = None  # per pose, once the blocks are known
        have = np.zeros(B, dtype=bool)  # a factorization is kept
        since = np.zeros(B)  # largest scaled move since it was taken
        last = np.full(B, np.inf)  # residual norm before the last step
        newton = np.zeros(B, dtype=bool)  # the last step used a factorization of its own iterate
        live = np.arange(B)  # still iterating
        for _ in range(budget + 1):
            rl, jacs = self.evaluate(_take(P, live), _take(Q, live), _take(steps, live), True)
            r[live] = rl
            rs = rl * row
            norm = np.sqrt((rs * rs).sum(axis=1))
            J = self.jacobian(jacs)
            parts, compiled = self.parts, self.compiled
            if compiled.decided and compiled.quiet is None and len(live) >= SPLIT_FROM and not self.free:
                self._settle(rl, self.time_derivative(_take(Q, live), _take(steps, live), jacs), J)
            elif kept is None and compiled.quiet is not None:
                self._stir(rs)
            if kept is None:
                kept = Factors([np.zeros((B, len(p.cols), len(p.cols))) for p in parts], np.zeros(B, dtype=bool),
                               null if self.free else None, parts)
            converged = np.abs(rs).max(axis=1) <= tol
            slow = norm > 0.1 * last[live]
            # a Newton step must contract twofold; a chord step that did not is retried afresh
            going = ~converged & np.isfinite(norm) & ((norm < 0.5 * last[live]) | ~newton[live])
            fresh = going & (~have[live] | slow) | converged & (~have[live] | (since[live] > REFINE))
            if fresh.any():
                f = np.flatnonzero(fresh)
                new = self._factor(J.take(f))
                for L, Lf in zip(kept.factors, new.factors):
                    L[live[f]] = Lf
                kept.sound[live[f]] = new.sound
                if new.null is not None:
                    null[live[f]] = new.null
                have[live[f]], since[live[f]] = True, 0.0
                work[live[f], 1] += 1
            newton[live] = fresh
            if converged.any() and not velocities:
                done[live[converged]] = kept.sound[live[converged]] & self._apart(J, np.flatnonzero(converged))
            elif converged.any():
                c = np.flatnonzero(converged)
                lc = live[c]
                Jc, Fc = J.take(c), kept.take(lc)
                rt = self.time_derivative(_take(Q, lc), steps[lc], [None if j is None else _take(j, c) for j in jacs])
                b = self._gradient(Jc, -rt * row)
                v = self.least_norm(Fc, b)
                moved_since = since[lc].max()  # none where every factorization is of its own pose
                # refinement against this J
                for _ in range(0 if moved_since == 0.0 else 1 if moved_since <= FRESH else 2):
                    v += self.least_norm(Fc, [bp - ((Jp @ v[:, p.cols, None])[..., 0][:, None, :] @ Jp)[:, 0]
                                              for p, bp, Jp in zip(parts, b, Jc.blocks)])
                velocity[lc] = v
                done[lc] = kept.sound[lc] & self._apart(J, c)
                work[lc, 0] += 1
            g = np.flatnonzero(going)
            if not g.size:
                break
            lg = live[g]
            step = -self.least_norm(kept.take(lg), self._gradient(J.take(g), _take(rs, g)))
            last[lg] = norm[g]
            since[lg] += np.abs(step).max(axis=1)
            work[lg, 0] += 1
            P[lg], Q[lg] = self.moved(_take(P, lg), _take(Q, lg), step)
            live = lg
        return r, velocity, work, done, null

    def accepted(self, P: np.ndarray, Q: np.ndarray, velocity: np.ndarray, done: np.ndarray,
                 steps: np.ndarray, before: tuple[np.ndarray, np.ndarray, np.ndarray], t_before: float) -> int:
        """How many of the consecutive ``steps`` (B,), solved (P, Q, scaled velocities,
        ``done``: converged, and where J has a free direction at the canonical pose), pass the
        continuation's acceptance test, each from the step before it; the first from ``before``
        (position (M, 3), quaternions (M, 4), scaled velocity (N,)) at ``t_before``."""
        opt = self.solver.options
        P0 = np.concatenate([before[0][None], P[:-1]])
        Q0 = np.concatenate([before[1][None], Q[:-1]])
        v0 = np.concatenate([before[2][None], velocity[:-1]])
        h = np.diff(np.concatenate([[t_before], self.table.t[steps]]))
        moved = self.displacement(P, Q, P0, Q0)
        return accept.leading(done & accept.passes(moved, h, v0, opt))

    # ---- predictions ----------------------------------------------------------------------

    def osculating(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray, around: np.ndarray,
                   t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (B, M, 3) and quaternions (B, M, 4) at times ``t`` (B,), each from the
        osculating polynomial (degree 2k − 1) through k consecutive ones of n solved poses
        (the first of them ``around`` (B,)) and their time derivatives: times (n,), flat poses
        and derivatives (n, 7M) (:func:`flat`; quaternions component-wise, then normalized)."""
        k = min(NODES, len(t_nodes))
        x, which, idx, tau, half = _windows(t_nodes, around, t, k)
        # the interpolant's weights on the node values and rates: w A = (1, τ, τ², …) at τ
        w = (tau[:, None] ** np.arange(2 * k))[:, None, :] @ np.linalg.inv(_hermite(x))[which]  # (B, 1, 2k)
        around = nodes[idx]  # (B, k, 7M), from the first: coordinates equal at every pose stay exactly so
        Z = around[:, :1] + w[:, :, :k] @ (around - around[:, :1]) + (w[:, :, k:] * half[:, None, None]) @ rates[idx]
        return self._split(Z[:, 0])

    def extrapolated(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray,
                     t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`osculating`, every time from the same k poses: times (k,), flat poses and
        their time derivatives (k, 7M), normalized by the farthest time."""
        t0, k = t_nodes[-1], len(t_nodes)
        span = max(float(np.ptp(t_nodes)), float(np.abs(t - t0).max()))
        A = _hermite((t_nodes - t0) / span)
        w = np.linalg.solve(A.T, ((t - t0) / span) ** np.arange(2 * k)[:, None])  # (2k, B)
        # from the last pose: coordinates equal at every pose stay exactly so
        return self._split(nodes[-1] + w[:k].T @ (nodes - nodes[-1]) + (span * w[k:].T) @ rates)

    def _split(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        M = self.system.n_members
        return Z[:, :3 * M].reshape(-1, M, 3), quat.normalize(Z[:, 3 * M:].reshape(-1, M, 4))


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The connected component (n,) of each of n nodes linked in pairs a[i], b[i]."""
    graph = scipy.sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return scipy.sparse.csgraph.connected_components(graph, directed=False)[1]


def lagrange(t_nodes: np.ndarray, nodes: np.ndarray, around: np.ndarray, t: np.ndarray, k: int) -> np.ndarray:
    """Flat poses (B, 7M) at times t (B,), each from the polynomial (degree k − 1) through k
    consecutive of n flat poses (times (n,), poses (n, 7M)), the first of them ``around`` (B,)."""
    k = min(k, len(t_nodes))
    x, which, idx, tau, _ = _windows(t_nodes, around, t, k)
    # the weights on the node values: w A = (1, τ, τ², …) at τ, A the nodes' powers
    w = (tau[:, None] ** np.arange(k))[:, None, :] @ np.linalg.inv(x[..., None] ** np.arange(k))[which]
    return (w @ nodes[idx])[:, 0]


def _windows(t_nodes: np.ndarray, around: np.ndarray, t: np.ndarray,
             k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The windows of k consecutive nodes (times (n,)) that times t (B,) are predicted from,
    the first of each ``around`` (B,), with each window's times centred and scaled onto
    [−1, 1] (well-conditioned systems): the distinct windows' node times so scaled (W, k),
    which window each time uses (B,), its node indices (B, k), the time so scaled (B,), and
    the half width (B,) of its window."""
    first, which = np.unique(around, return_inverse=True)
    window = first[:, None] + np.arange(k)  # (W, k)
    tw = t_nodes[window]
    mid, half = 0.5 * (tw[:, 0] + tw[:, -1]), np.maximum(0.5 * np.ptp(tw, axis=1), np.finfo(float).tiny)
    return (tw - mid[:, None]) / half[:, None], which, window[which], (t - mid[which]) / half[which], half[which]


def _hermite(x: np.ndarray) -> np.ndarray:
    """The osculating interpolation matrices (..., 2k, 2k) at normalized node times x (..., k):
    rows the values then the derivatives of the monomials 1, x, …, x^(2k−1)."""
    powers = np.arange(2 * x.shape[-1])
    return np.concatenate([x[..., None] ** powers, powers * x[..., None] ** np.maximum(powers - 1, 0)], axis=-2)


def flat(P: np.ndarray, Q: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses as flat states (B, 7M) — positions (B, M, 3) then quaternions (B, M, 4) — and their
    time derivatives (B, 7M) from the real velocities V (B, M, 6): ṗ, and q̇ = ½ (0, ω) ⊗ q."""
    B, M = P.shape[:2]
    w = np.concatenate([np.zeros(V.shape[:2] + (1,)), V[..., 3:]], axis=2)
    dq = 0.5 * quat.multiply(w.reshape(-1, 4), Q.reshape(-1, 4)).reshape(B, 4 * M)
    return (np.concatenate([P.reshape(B, 3 * M), Q.reshape(B, 4 * M)], axis=1),
            np.concatenate([V[..., :3].reshape(B, 3 * M), dq], axis=1))


def cholesky_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x (B, N) of L Lᵀ x = b for lower-triangular L (B, N, N) and b (B, N): forward and back
    substitution, each a loop over the N unknowns of array operations over B (LAPACK's potrs
    pose by pose for at most :data:`FEW` poses, where that loop's fixed cost dominates)."""
    if len(L) <= FEW:
        return np.array([_potrs(c, x, lower=True)[0] for c, x in zip(L, b)]).reshape(b.shape)
    n = L.shape[1]
    d = np.diagonal(L, axis1=1, axis2=2)
    y = np.empty_like(b)
    for i in range(n):
        y[:, i] = (b[:, i] - np.einsum("bj,bj->b", L[:, i, :i], y[:, :i])) / d[:, i]
    x = np.empty_like(b)
    for i in range(n - 1, -1, -1):
        x[:, i] = (y[:, i] - np.einsum("bj,bj->b", L[:, i + 1:, i], x[:, i + 1:])) / d[:, i]
    return x


def _take(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """a[idx] for sorted distinct indices ``idx`` into a's first axis: a itself (no copy) when
    they are all of them."""
    return a if len(idx) == len(a) else a[idx]
