"""Per-step diagnostics in SolveSpace's vocabulary: status, residual, unsatisfied constraints,
degrees of freedom left and redundant equations.

The rank of the Jacobian is taken from its singular values after scaling lengths by the
system's length scale (rows and translation columns), so that lengths and angles weigh alike:
dof = 6M − rank, redundant = (independent equations of the active constraints) − rank.

At a converged step the solver has already read the rank from the factorization it keeps
for the pose (:attr:`~linkedit.gcs.solve.Run.rank`: N where no pivot is small, N minus a clean
null space): that rank is used as it is. Elsewhere a rank costs dense SVDs of the blocks the
Jacobian decouples into (:func:`jacobian_rank`, at most about R·N·min(R, N) operations for R
rows and N unknowns), so it is not taken at every step of a large system: it is taken at the first step, at every step that did not converge or
whose status or number of active equations differs from the step before, and every K steps, K
chosen so that the periodic ranks of a run cost about :data:`RANK_BUDGET` operations (every
step for small systems; over 360 steps, every 5th for the 3-pair Strandbeest and every 120th
for the 10-pair one, R = 1089 and N = 726). Steps in between carry the last value;
:attr:`Diagnostics.dof_evaluated` says which steps were evaluated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from linkedit.blas import single_threaded
from linkedit.gcs.constraints import EQUATIONS, LENGTH_KINDS
from linkedit.gcs.linalg import jacobian_rank, left_null_space
from linkedit.gcs.solve import Run
from linkedit.gcs.system import State, StepTable, System
from linkedit.gcs.tolerances import CONVERGED, NULL_TOL, Options

#: name redundant constraints (a small SVD per constraint) only up to this many constraints
MAX_NAMED_CHECKS = 200
#: operations the periodic rank evaluations of one run may take, counted as R·N·min(R, N)
#: (a dense SVD) plus RANK_OVERHEAD (building the Jacobian) per rank
RANK_BUDGET = 2e9
RANK_OVERHEAD = 1e7


@dataclass
class Diagnostics:
    """(T,) arrays over the run, plus the unsatisfied constraint names per step."""

    status: np.ndarray
    residual: np.ndarray  #: residual norm √(Σ costs)
    dof: np.ndarray
    redundant: np.ndarray
    costs: np.ndarray  #: (T, C) per named constraint
    unsatisfied: list[list[str]]  #: per step, worst first (largest scaled cost: the same in any unit)
    #: per step, how far each unsatisfied constraint is off: (length in the spec's unit, angle
    #: in radians), the norms of its length and angle residual rows (empty when read from a file)
    offsets: list[list[tuple[float, float]]] = field(default_factory=list)
    #: (T,) bool: dof and redundant were evaluated at this step (otherwise carried from the last
    #: evaluated step); all False when the rank was not asked for (dof = redundant = −1)
    dof_evaluated: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: named constraints that restrict nothing the others do not (at the first step)
    redundant_names: list[str] = field(default_factory=list)


def scaled_jacobian(system: System, state: State, table: StepTable, step: int) -> np.ndarray:
    """The Jacobian (R, 6M) with lengths divided by the length scale."""
    J = system.dense_jacobian(system.evaluate(state, table, step, jacobian=True))
    J = J * system.row_scale[:, None]
    cols = np.tile(np.r_[np.full(3, system.length_scale), np.ones(3)], system.n_members)
    return J * cols


def active_equations(system: System, table: StepTable) -> np.ndarray:
    """Independent equations of the constraints active at each step, (T,)."""
    total = np.full(table.t.size, int(system.owner_equations.sum()))
    for blk, act in zip(system.blocks, table.active):
        if act is not None:
            total -= (~act).sum(axis=1) * EQUATIONS[blk.kind]
    return total


def rank_steps(system: System, run: Run, table: StepTable) -> np.ndarray:
    """The steps (T,) bool whose rank is evaluated (module docstring)."""
    T = run.t.size
    R, N = system.n_rows, system.n_unknowns
    every = max(1, math.ceil(T / max(1, int(RANK_BUDGET // (R * N * min(R, N) + RANK_OVERHEAD)))))
    steps = np.zeros(T, dtype=bool)
    steps[::every] = True
    steps |= run.status != CONVERGED
    equations = active_equations(system, table)
    steps[1:] |= (run.status[1:] != run.status[:-1]) | (equations[1:] != equations[:-1])
    return steps


def run_diagnostics(system: System, run: Run, table: StepTable, rank: bool = True,
                    unsatisfied_tol: float = Options.tol) -> Diagnostics:
    """Diagnostics of every step of a run: a residual row above ``unsatisfied_tol`` (scaled:
    the tolerance the steps were solved to, so a step that failed names what it could not
    satisfy) names its constraint unsatisfied; the rank is evaluated at :func:`rank_steps`
    (small SVDs: BLAS on one thread, :mod:`linkedit.blas`)."""
    with single_threaded():
        return _run_diagnostics(system, run, table, rank, unsatisfied_tol)


def _run_diagnostics(system: System, run: Run, table: StepTable, rank: bool, unsatisfied_tol: float) -> Diagnostics:
    T = run.t.size
    costs = system.costs(run.residual)
    scaled = system.costs(run.residual * system.row_scale)  # lengths over the mechanism's size, angles
    bad = np.abs(run.residual) * system.row_scale > unsatisfied_tol
    unsatisfied: list[list[str]] = [[] for _ in range(T)]
    offsets: list[list[tuple[float, float]]] = [[] for _ in range(T)]
    length = length_rows(system)
    for k in np.flatnonzero(bad.any(axis=1)):
        owners = np.unique(system.row_owner[bad[k]])
        worst_first = owners[np.argsort(-scaled[k, owners], kind="stable")]
        unsatisfied[k] = [system.constraint_names[c] for c in worst_first]
        r2 = run.residual[k] ** 2
        offsets[k] = [(math.sqrt(float(r2[mine & length].sum())), math.sqrt(float(r2[mine & ~length].sum())))
                      for mine in (system.row_owner == c for c in worst_first)]
    if rank:
        evaluated = rank_steps(system, run, table)
        steps = np.flatnonzero(evaluated)
        known = run.rank if run.rank.size == T else np.full(T, -1)
        known = np.where(run.status == CONVERGED, known, -1)
        ranks = np.array([known[k] if known[k] >= 0 else
                          jacobian_rank(scaled_jacobian(system, run.state(int(k)), table, int(k))) for k in steps],
                         dtype=np.int64)
        # carry each evaluated rank forward to the next evaluated step (step 0 is always evaluated)
        rank_at = ranks[np.cumsum(evaluated) - 1]
        dof = system.n_unknowns - rank_at
        redundant = active_equations(system, table) - rank_at
    else:
        evaluated = np.zeros(T, dtype=bool)
        dof = np.full(T, -1)
        redundant = np.full(T, -1)
    names = []
    if rank and len(system.constraint_names) <= MAX_NAMED_CHECKS and redundant[0] > 0:
        names = redundant_constraints(system, run.state(0), table, 0)
    return Diagnostics(status=run.status.copy(), residual=np.sqrt(costs.sum(axis=1)), dof=dof,
                       redundant=redundant, costs=costs, unsatisfied=unsatisfied, dof_evaluated=evaluated,
                       redundant_names=names, offsets=offsets)


def length_rows(system: System) -> np.ndarray:
    """Whether each residual row (R,) is a length (in the spec's unit; otherwise an angle in
    radians, or a custom constraint's own value)."""
    out = np.zeros(system.n_rows, dtype=bool)
    for blk in system.blocks:
        out[blk.rows] = blk.kind in LENGTH_KINDS
    return out


def redundant_constraints(system: System, state: State, table: StepTable, step: int) -> list[str]:
    """Named constraints whose removal leaves the rank unchanged (they restrict nothing more).

    With Y (R, R − rank) an orthonormal basis of the left null space of J (Yᵀ J = 0), removing
    the k rows of a constraint lowers the rank by k − rank(Y[rows]): the constraint is redundant
    when Y restricted to its rows has full row rank (smallest singular value above
    :data:`NULL_TOL`). One null space serves every constraint."""
    Y = left_null_space(scaled_jacobian(system, state, table, step))
    out = []
    for c, name in enumerate(system.constraint_names):
        rows = np.flatnonzero(system.row_owner == c)
        if 0 < rows.size <= Y.shape[1] and np.linalg.svd(Y[rows], compute_uv=False)[-1] > NULL_TOL:
            out.append(name)
    return out
