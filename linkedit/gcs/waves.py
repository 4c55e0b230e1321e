"""Many time steps solved at once, each kept only where the step-by-step continuation would
have accepted it.

The continuation of :mod:`linkedit.gcs.solver` pays Python's per-call cost at every step.
Where the scaled Jacobian has full column rank (nothing free to keep still), the pose at a
time is the root of the constraints nearest its prediction whatever the anchor, so a *block*
of steps can be solved together:

1. every few steps first (:data:`STRIDE`, adapted to the prediction error, up to
   :data:`WIDEST_STRIDE`), roughly, in *waves* of up to :data:`WIDEST` steps: each predicted
   by the osculating polynomial through the last :data:`NODES` such poses and their
   velocities (within ~1e-9 of the size one stride ahead), then :data:`CORRECTIONS`
   Gauss–Newton steps for all of them at once (the error after each about the square of the
   one before: ~1e-10 of the size or better), and the velocity from the last linearization;
2. then all the steps of the block at once: the rough ones from where they are, the ones
   between from the osculating polynomial through the rough poses around them (typically
   within 1e-10 of the size);
3. Gauss–Newton on all of them as array operations to convergence: the elementary kinds'
   kernels of :data:`linkedit.gcs.system.EVALUATE` run on B times their constraints, the
   scaled Jacobians are placed straight from the kernels' arrays into dense blocks
   (B × rows × unknowns, one per diagonal block of J where it decouples, as a planar
   linkage's in-plane and out-of-plane unknowns do) and factorized by a batched Cholesky; a
   factorization is kept while it contracts the residual (chord) and serves the exact
   velocity (J v = −∂r/∂t at the solved pose) by iterative refinement when the pose moved
   little since;
4. each step is put to the continuation's own acceptance test, taken from the step before it:
   converged (largest scaled residual row ≤ ``tol``), no small pivot, within
   ``predictor_tol`` of the tangent prediction x_{k−1} ⊕ h·v_{k−1} and moving at most
   ``max_motion``. The accepted run of steps is kept — the poses the continuation accepts (the
   same branch, equal to rounding) — and the continuation solves the first rejected step
   (sub-steps, Levenberg–Marquardt), after which blocks resume (:data:`SHORTEST` steps,
   doubling).

Steps with an input outside its window, systems with custom constraints, a null space or the
sparse factorization, and runs that ask for accelerations go step by step.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.solver import FREE_PIVOT, Solver
from linkedit.gcs.system import EVALUATE, Block, StepParameters, StepTable

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
#: the largest prediction error (scaled) a wave's width aims for
REACH = 1e-4
#: the first prediction error of a wave (scaled) below which the spacing doubles, and above
#: which it halves
LOW, HIGH = 1e-9, 1e-6
#: solved poses (and their velocities) the polynomial extrapolation goes through
NODES = 4
#: converged steps a block starts from
START = 2
#: largest scaled move of a pose since its factorization for the factorization to serve its
#: velocity (by two refinements: error ~REFINE³ relative)
REFINE = 1e-5
FRESH = 1e-9
#: J's diagonal blocks (:attr:`Waves.parts`) are found from the first batch of at least this
#: many poses (no accidental zeros)
SPLIT_FROM = 64
#: batches of at most this many poses solve their triangular systems pose by pose
FEW = 24

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


@dataclasses.dataclass
class Part:
    """A diagonal block of the Jacobian: its residual rows (Rp,) and unknowns (Np,)."""

    rows: np.ndarray
    cols: np.ndarray


@dataclasses.dataclass
class Jacobians:
    """Scaled Jacobians of B poses, block by block of :attr:`Waves.parts`: (B, Rp, Np) each,
    and whether a pose's J has entries off the blocks (``leaves``, (B,))."""

    blocks: list[np.ndarray]
    leaves: np.ndarray

    def take(self, idx: np.ndarray) -> "Jacobians":
        return Jacobians([_take(J, idx) for J in self.blocks], _take(self.leaves, idx))


@dataclasses.dataclass
class _Layout:
    """An evaluation's fixed parts for B poses, member-major (member or vector i of pose b at
    i·B + b, so each kernel sees B times its constraints, constraint-major): the blocks with
    spread indices, the member of each member vector (K·B,), the member vectors (K, B, 9), the
    inverse relative orientations (n, B, 4), and buffers for positions (M + 1, B, 3) and
    quaternions (M + 1, B, 4), the world last."""

    blocks: list[Block]
    member: np.ndarray
    vectors: np.ndarray
    rel_inverse: np.ndarray
    position: np.ndarray
    orientation: np.ndarray


class Waves:
    """Batched evaluation and solution of one system over a step table (module docstring)."""

    def __init__(self, solver: Solver, table: StepTable) -> None:
        self.solver = solver
        self.system = solver.system
        self.table = table
        self._layouts: dict[int, _Layout] = {}
        #: per group, where a pose's Jacobian entries go and their scales; where the blocks
        #: and the off-block slots end (:meth:`_place`)
        self._places: list[tuple[np.ndarray, np.ndarray]] | None = None
        self._ends: list[int] = []
        #: the diagonal blocks of J that solve apart (a planar linkage's in-plane and
        #: out-of-plane unknowns), one block until a batch of SPLIT_FROM poses was seen
        self.parts = [Part(np.arange(self.system.n_rows), np.arange(self.system.n_unknowns))]
        self.decided = False

    @staticmethod
    def applies(solver: Solver) -> bool:
        """Whether the system's structure allows waves (see the module docstring; the rank is
        checked at the first pose by the caller)."""
        o, s = solver.options, solver.system
        return (o.solver == "lm" and not o.accelerations and not s.customs and not solver.normal.sparse
                and solver.normal.unique_entries)

    # ---- batched evaluation ---------------------------------------------------------------

    def _layout(self, B: int) -> "_Layout":
        """What an evaluation of B poses needs that does not change between calls (cached)."""
        if B not in self._layouts:
            s = self.system
            lanes = np.arange(B)
            spread = lambda idx: (idx[:, None] * B + lanes).ravel()  # noqa: E731
            blocks = [dataclasses.replace(blk, a=spread(blk.a), b=spread(blk.b),
                                          vectors=tuple(slice(v.start * B, v.stop * B) for v in blk.vectors))
                      for blk in s.blocks]
            P = np.zeros((s.n_members + 1, B, 3))
            Q = np.zeros((s.n_members + 1, B, 4))
            Q[-1, :, 0] = 1.0  # the world
            self._layouts[B] = _Layout(blocks, spread(s.vector_member), np.repeat(s.vectors[:, None], B, axis=1),
                                       np.repeat(s.rel_inverse[:, None], B, axis=1), P, Q)
        return self._layouts[B]

    def evaluate(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray,
                 jacobian: bool) -> tuple[np.ndarray, list[np.ndarray]]:
        """Residuals (B, R) at positions P (B, M, 3) and quaternions Q (B, M, 4) at the table's
        ``steps`` (B,), and with ``jacobian`` the Jacobian per group (B, n, k, 2, 6)."""
        s, tab = self.system, self.table
        B, M = P.shape[0], s.n_members
        lay = self._layout(B)
        # member-major layouts (M + 1, B, ·), the world last
        lay.position[:M] = np.swapaxes(P, 0, 1)
        lay.orientation[:M] = np.swapaxes(Q, 0, 1)
        Pm, Qm = lay.position.reshape(-1, 3), lay.orientation.reshape(-1, 4)
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
        jacs: list[np.ndarray] = []
        for blk, wide in zip(s.blocks, lay.blocks):
            n, k = blk.rows.shape
            out = np.empty((n * B, k))
            J = EVALUATE[blk.kind](wide, X, W, Qm, par, out, jacobian)
            r[:, blk.start:blk.stop] = np.swapaxes(out.reshape(n, B, k), 0, 1).reshape(B, -1)
            if J is not None:
                jacs.append(np.swapaxes(J.reshape((n, B) + J.shape[1:]), 0, 1))
        return r, jacs

    def time_derivative(self, Q: np.ndarray, steps: np.ndarray, jacs: list[np.ndarray]) -> np.ndarray:
        """∂r/∂t (B, R) at quaternions Q (B, M, 4) (as :meth:`System.time_derivative`, batched)."""
        s = self.system
        B = Q.shape[0]
        out = np.zeros((B, s.n_rows))
        for blk, jac, rate in zip(s.blocks, jacs, self.table.rates):
            if rate is None:
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

    def jacobian(self, jacs: list[np.ndarray]) -> Jacobians:
        """The scaled Jacobians, dense block by block of :attr:`parts`, from the groups'
        (B, n, k, 2, 6) as :meth:`evaluate` returns them (views of the kernels'
        constraint-major arrays, put in place as they lie; the blocks are found from the first
        call with at least :data:`SPLIT_FROM` poses)."""
        B = jacs[0].shape[0]
        if self._places is None:
            self._places, self._ends = self._place()
        # the blocks, then a slot for each entry off them, then a dump for the world's entries
        flat = np.zeros((B, self._ends[-1] + 1))
        for J, (at, scale) in zip(jacs, self._places):
            flat[:, at] = J.reshape((B,) + at.shape) * scale
        ends = self._ends
        blocks = [flat[:, e - len(p.rows) * len(p.cols):e].reshape(B, len(p.rows), len(p.cols))
                  for p, e in zip(self.parts, ends)]
        leaves = np.asarray(flat[:, ends[-2]:ends[-1]].any(axis=1))
        if not self.decided and B >= SPLIT_FROM:  # many poses: no accidental zeros
            self.decided = True
            if self._decouple(blocks[0]):
                self._places = None
                return self.jacobian(jacs)
        return Jacobians(blocks, leaves)

    def _place(self) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[int]]:
        """Per group: where a pose's Jacobian entries (n, k·12) go in its flat Jacobian — the
        blocks of :attr:`parts` one after the other, then a slot for each entry off them, then
        a dump for the world's — and their scales (n, k·12); and where the blocks and the
        off-block slots end."""
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
        places, off = [], ends[-1]
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
        ends.append(off)  # the dump follows
        return [(np.where(at < 0, off, at).reshape(len(at), -1), np.broadcast_to(sc, at.shape).reshape(len(at), -1))
                for at, sc in zip(places, ne.group_scale)], ends

    def _decouple(self, J: np.ndarray) -> bool:
        """Split :attr:`parts` (one block) by Jacobians J (B, R, N): the unknowns that no
        residual row ties together solve apart; whether it split."""
        pattern = (J != 0.0).any(axis=0)
        R, N = pattern.shape
        root = np.arange(N)

        def find(i: int) -> int:
            while root[i] != i:
                root[i] = root[root[i]]
                i = int(root[i])
            return i

        for row in pattern:
            cols = np.flatnonzero(row)
            for c in cols[1:]:
                root[find(int(c))] = find(int(cols[0]))
        label = np.array([find(i) for i in range(N)])
        groups = [np.flatnonzero(label == g) for g in np.unique(label)]
        if len(groups) == 1:
            return False
        row_label = np.array([label[np.flatnonzero(row)[0]] if row.any() else label[0] for row in pattern])
        self.parts = [Part(np.flatnonzero(row_label == label[g[0]]), g) for g in groups]
        return True

    # ---- a block of steps -----------------------------------------------------------------

    def block(self, k: int, stop: int, pos: np.ndarray, ori: np.ndarray, vel: np.ndarray, first: int) -> Solved:
        """Solve the steps k … stop − 1 given the accepted ones before k (positions (T, M, 3),
        quaternions (T, M, 4), real velocities (T, M, 6) of the run, converged from step
        ``first`` on, k − first ≥ :data:`START`): steps about :data:`STRIDE` apart (and the
        last) first, roughly (:meth:`correct`), in waves from the osculating polynomial through
        the poses before them; then all of them at once, the steps between from the polynomial
        through the poses around them; then the continuation's acceptance test."""
        col, M = self.solver.col, self.system.n_members
        t = self.table.t
        coarse: list[np.ndarray] = []
        rough: list[tuple[np.ndarray, np.ndarray]] = []
        prior = np.unique(np.clip(k - 1 - STRIDE * np.arange(NODES), first, None))
        node_t = list(t[prior])
        z, dz = flat(pos[prior], ori[prior], vel[prior])
        node_z, node_dz = list(z), list(dz)
        here, stride, width = k - 1, STRIDE, 1 if len(prior) < NODES else 4
        while here < stop - 1:
            ahead = np.unique(np.minimum(here + stride * np.arange(1, width + 1), stop - 1))
            P, Q = self.extrapolated(np.array(node_t[-NODES:]), np.array(node_z[-NODES:]),
                                     np.array(node_dz[-NODES:]), t[ahead])
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
            # the spacing keeps the first prediction's error between LOW and HIGH (of the size)
            if error > HIGH:
                stride = max(1, stride // 2)
            elif error < LOW:
                stride = min(2 * stride, WIDEST_STRIDE)
            # as many steps as the extrapolation reaches within REACH of the size (its error
            # grows about as the fifth power of the distance)
            reach = (REACH / max(error, 1e-16)) ** 0.2 * (1 if error > HIGH else 0.5 if error < LOW else 1)
            width = int(np.clip(reach, 1, WIDEST))
        if not coarse:
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
            around = np.clip(right - NODES // 2, 0, max(len(nt) - NODES, 0))
            P[fine], Q[fine] = self.osculating(nt, nz, ndz, around, t[k + fine])
        R, V, work, ok = self.solve(P, Q, steps)
        work[at] += CORRECTIONS  # the rough corrections: a linear solve and a factorization each
        before = (pos[k - 1], ori[k - 1], vel[k - 1].ravel() / col)
        n = self.accepted(P, Q, V, ok, steps, before, float(t[k - 1]))
        return Solved(P, Q, R, V, work, n)

    def correct(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """Rough poses at the table's ``steps`` (B,) from predictions P (B, M, 3), Q (B, M, 4)
        (moved in place), good enough to predict from: :data:`CORRECTIONS` Gauss–Newton steps
        (the error after each about the square of the one before). Returns the scaled
        velocities (B, N) at the last linearization (exact to about the size of the last
        correction), the first pose's first correction (its prediction's error), and which
        poses are good (B,): a sound factorization (:meth:`_factor`) and a last correction of at
        most :data:`ROUGH`."""
        row, parts = self.solver.row, self.parts
        B, N = len(steps), self.system.n_unknowns
        error = np.inf
        for i in range(CORRECTIONS):
            r, jacs = self.evaluate(P, Q, steps, True)
            J = self.jacobian(jacs)
            parts = self.parts
            factors, sound = self._factor(J)
            step = np.empty((B, N))
            for p, x in zip(parts, self._solve(factors, self._gradient(J, r * row, parts))):
                step[:, p.cols] = -x
            size = np.abs(step).max(axis=1)
            error = float(size[0]) if i == 0 else error
            if i == CORRECTIONS - 1:
                rt = self.time_derivative(Q, steps, jacs)
            P[:], Q[:] = self.moved(P, Q, step)
        velocity = np.empty((B, N))
        for p, x in zip(parts, self._solve(factors, self._gradient(J, -rt * row, parts))):
            velocity[:, p.cols] = x
        return velocity, error, sound & (size <= ROUGH)

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
        return np.concatenate([P - P0, phi], axis=2).reshape(B, -1) / self.solver.col

    @staticmethod
    def _factor(J: Jacobians) -> tuple[list[np.ndarray], np.ndarray]:
        """Cholesky factors (B, Np, Np) of the scaled JᵀJ + μI, block by block (μ as the
        continuation's: 1e-13 of the largest diagonal entry, at least 1e-13), and whether each
        pose's is sound (B,): positive definite with every pivot above :data:`FREE_PIVOT` of
        that entry (no free or singular direction), and J zero off its blocks."""
        normal = [np.swapaxes(Jp, 1, 2) @ Jp for Jp in J.blocks]
        B = len(J.leaves)
        top = np.ones(len(J.leaves))
        for H in normal:
            np.maximum(top, np.diagonal(H, axis1=1, axis2=2).max(axis=1), out=top)
        factors = []
        sound = ~J.leaves
        for H in normal:
            n = H.shape[1]
            H.reshape(B, n * n)[:, ::n + 1] += (1e-13 * top)[:, None]
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
            sound &= (np.diagonal(L, axis1=1, axis2=2) ** 2 >= FREE_PIVOT * top[:, None]).all(axis=1)
        return factors, sound

    @staticmethod
    def _solve(factors: list[np.ndarray], b: list[np.ndarray]) -> list[np.ndarray]:
        """x of L Lᵀ x = b block by block: factors (B, Np, Np) and right-hand sides (B, Np)."""
        return [cholesky_solve(L, bp) if bp.any() else np.zeros_like(bp)  # a planar linkage's out-of-plane
                for L, bp in zip(factors, b)]                                 # part rarely is

    @staticmethod
    def _gradient(J: Jacobians, r: np.ndarray, parts: list[Part]) -> list[np.ndarray]:
        """Jᵀ r block by block (B, Np) for residual rows r (B, R)."""
        return [(r[:, p.rows][:, None, :] @ Jp)[:, 0] for p, Jp in zip(parts, J.blocks)]

    def solve(self, P: np.ndarray, Q: np.ndarray, steps: np.ndarray,
              budget: int = ITERATIONS) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Gauss–Newton at the table's ``steps`` (B,) from poses P (B, M, 3), Q (B, M, 4)
        (moved in place). A pose's JᵀJ + μI is factorized at its first iterate and again only
        where a step reusing it (chord) contracted the residual less than tenfold; every step
        contracts it twofold at least. The exact velocity at the solved pose (J v = −∂r/∂t,
        J evaluated there) is solved with the kept factorization and refined twice against
        that J (the factorization is at most :data:`REFINE` away, so the refinement contracts
        the error by that much each time), or with a fresh one. Returns the residuals (B, R),
        the scaled velocities (B, N), the linear solves and factorizations (B, 2) and whether
        each step converged with a sound factorization (:meth:`_factor`) (B,), after at most
        ``budget`` steps."""
        solver, tol = self.solver, self.solver.options.tol
        row = solver.row
        B, N = len(steps), self.system.n_unknowns
        r = np.empty((B, self.system.n_rows))
        velocity = np.zeros((B, N))
        work = np.zeros((B, 2), dtype=np.int32)  # linear solves, factorizations
        done = np.zeros(B, dtype=bool)
        sound = np.zeros(B, dtype=bool)
        factors: list[np.ndarray] | None = None  # per block (B, Np, Np), once the blocks are known
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
            parts = self.parts
            if factors is None:
                factors = [np.zeros((B, len(p.cols), len(p.cols))) for p in parts]
            converged = np.abs(rs).max(axis=1) <= tol
            slow = norm > 0.1 * last[live]
            # a Newton step must contract twofold; a chord step that did not is retried afresh
            going = ~converged & np.isfinite(norm) & ((norm < 0.5 * last[live]) | ~newton[live])
            fresh = going & (~have[live] | slow) | converged & (~have[live] | (since[live] > REFINE))
            if fresh.any():
                f = np.flatnonzero(fresh)
                new, sound[live[f]] = self._factor(J.take(f))
                for L, Lf in zip(factors, new):
                    L[live[f]] = Lf
                have[live[f]], since[live[f]] = True, 0.0
                work[live[f], 1] += 1
            newton[live] = fresh
            if converged.any():
                c = np.flatnonzero(converged)
                lc = live[c]
                Jc, Lc = J.take(c), [_take(L, lc) for L in factors]
                rt = self.time_derivative(_take(Q, lc), steps[lc], [_take(j, c) for j in jacs])
                b = self._gradient(Jc, -rt * row, parts)
                v = self._solve(Lc, b)
                # iterative refinement against this J: once where the factorization is of a
                # pose at most FRESH away, twice up to REFINE
                for _ in range(1 if (since[lc] <= FRESH).all() else 2):
                    fix = self._solve(Lc, [bp - ((Jp @ vp[..., None])[..., 0][:, None, :] @ Jp)[:, 0]
                                           for bp, Jp, vp in zip(b, Jc.blocks, v)])
                    v = [vp + dp for vp, dp in zip(v, fix)]
                for p, vp in zip(parts, v):
                    velocity[lc[:, None], p.cols] = vp
                done[lc] = sound[lc]
                work[lc, 0] += 1
            g = np.flatnonzero(going)
            if not g.size:
                break
            lg = live[g]
            step = np.empty((len(g), N))
            for p, x in zip(parts, self._solve([_take(L, lg) for L in factors], self._gradient(J.take(g), _take(rs, g), parts))):
                step[:, p.cols] = -x
            last[lg] = norm[g]
            since[lg] += np.abs(step).max(axis=1)
            work[lg, 0] += 1
            P[lg], Q[lg] = self.moved(_take(P, lg), _take(Q, lg), step)
            live = lg
        return r, velocity, work, done

    def accepted(self, P: np.ndarray, Q: np.ndarray, velocity: np.ndarray, done: np.ndarray, steps: np.ndarray,
                 before: tuple[np.ndarray, np.ndarray, np.ndarray], t_before: float) -> int:
        """How many of the consecutive ``steps`` (B,), solved (P, Q, scaled velocities,
        ``done``), pass the continuation's acceptance test, each from the step before it; the
        first from ``before`` (position (M, 3), quaternions (M, 4), scaled velocity (N,)) at
        ``t_before``."""
        opt = self.solver.options
        P0 = np.concatenate([before[0][None], P[:-1]])
        Q0 = np.concatenate([before[1][None], Q[:-1]])
        v0 = np.concatenate([before[2][None], velocity[:-1]])
        h = np.diff(np.concatenate([[t_before], self.table.t[steps]]))
        moved = self.displacement(P, Q, P0, Q0)
        ok = done & (np.abs(moved - h[:, None] * v0).max(axis=1) <= opt.predictor_tol) \
            & (np.abs(v0).max(axis=1) * np.abs(h) <= opt.max_motion)
        return int(np.argmin(ok)) if not ok.all() else len(steps)

    # ---- predictions ----------------------------------------------------------------------

    def osculating(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray, around: np.ndarray,
                   t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (B, M, 3) and quaternions (B, M, 4) at times ``t`` (B,), each from the
        osculating polynomial (degree 2k − 1) through k consecutive ones of n solved poses
        (the first of them ``around`` (B,)) and their time derivatives: times (n,), flat poses
        and derivatives (n, 7M) (:func:`flat`; quaternions component-wise, then normalized)."""
        k = min(NODES, len(t_nodes))
        first, which = np.unique(around, return_inverse=True)
        window = first[:, None] + np.arange(k)  # (W, k): the node sets in use
        tw = t_nodes[window]
        t0, span = tw[:, -1], np.maximum(np.ptp(tw, axis=1), np.finfo(float).tiny)
        # the interpolant's weights on the node values and rates: w A = (1, τ, τ², …) at τ
        inverse = np.linalg.inv(_hermite((tw - t0[:, None]) / span[:, None]))[which]  # (B, 2k, 2k)
        w = (((t - t0[which]) / span[which])[:, None] ** np.arange(2 * k))[:, None, :] @ inverse
        idx = window[which]
        Z = w[:, :, :k] @ nodes[idx] + (w[:, :, k:] * span[which][:, None, None]) @ rates[idx]
        return self._split(Z[:, 0])

    def extrapolated(self, t_nodes: np.ndarray, nodes: np.ndarray, rates: np.ndarray,
                     t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`osculating`, every time from the same k poses: times (k,), flat poses and
        their time derivatives (k, 7M), normalized by the farthest time."""
        t0, k = t_nodes[-1], len(t_nodes)
        span = max(float(np.ptp(t_nodes)), float(np.abs(t - t0).max()))
        A = _hermite((t_nodes - t0) / span)
        w = np.linalg.solve(A.T, ((t - t0) / span) ** np.arange(2 * k)[:, None])  # (2k, B)
        return self._split(w[:k].T @ nodes + (span * w[k:].T) @ rates)

    def _split(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        M = self.system.n_members
        return Z[:, :3 * M].reshape(-1, M, 3), quat.normalize(Z[:, 3 * M:].reshape(-1, M, 4))


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
