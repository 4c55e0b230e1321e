"""Per-step diagnostics in SolveSpace's vocabulary: status, residual, unsatisfied constraints,
degrees of freedom left and redundant equations.

The rank of the Jacobian is taken from its singular values after scaling lengths by the
system's length scale (rows and translation columns), so that lengths and angles weigh alike:
dof = 6M − rank, redundant = (independent equations of the active constraints) − rank.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from linkedit.gcs.solver import Run
from linkedit.gcs.system import State, StepTable, System

#: singular values below this fraction of the largest count as zero
RANK_TOL = 1e-9
#: a named constraint is reported unsatisfied when a residual row exceeds this (scaled) value
UNSATISFIED_TOL = 1e-9
#: name redundant constraints (one rank per constraint) only up to this many constraints
MAX_NAMED_CHECKS = 200


@dataclass
class Diagnostics:
    """(T,) arrays over the run, plus the unsatisfied constraint names per step."""

    status: np.ndarray
    residual: np.ndarray  #: residual norm √(Σ costs)
    dof: np.ndarray
    redundant: np.ndarray
    costs: np.ndarray  #: (T, C) per named constraint
    unsatisfied: list[list[str]]
    #: named constraints that restrict nothing the others do not (at the first step)
    redundant_names: list[str] = field(default_factory=list)


def scaled_jacobian(system: System, state: State, table: StepTable, step: int) -> np.ndarray:
    """The Jacobian (R, 6M) with lengths divided by the length scale."""
    J = system.dense_jacobian(system.evaluate(state, table, step, jacobian=True))
    J = J * system.row_scale[:, None]
    cols = np.tile(np.r_[np.full(3, system.length_scale), np.ones(3)], system.n_members)
    return J * cols


def _rank(J: np.ndarray) -> np.ndarray:
    """Numerical rank of each of a stack of matrices (T, R, N)."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:
        return np.zeros(J.shape[0], dtype=int)
    s = np.linalg.svd(J, compute_uv=False)
    return np.sum(s > RANK_TOL * np.maximum(s[..., :1], 1e-300), axis=-1)


def active_equations(system: System, table: StepTable) -> np.ndarray:
    """Independent equations of the constraints active at each step, (T,)."""
    from linkedit.gcs.constraints import EQUATIONS

    total = np.full(table.t.size, int(system.owner_equations.sum()))
    for blk, act in zip(system.blocks, table.active):
        if act is not None:
            total -= (~act).sum(axis=1) * EQUATIONS[blk.kind]
    return total


def run_diagnostics(system: System, run: Run, table: StepTable, rank: bool = True) -> Diagnostics:
    """Diagnostics of every step of a run (the rank needs one Jacobian per step)."""
    T = run.t.size
    costs = system.costs(run.residual)
    bad = np.abs(run.residual) * system.row_scale > UNSATISFIED_TOL
    owners = np.zeros((T, len(system.constraint_names)), dtype=bool)
    for k in np.flatnonzero(bad.any(axis=1)):
        owners[k, np.unique(system.row_owner[bad[k]])] = True
    unsatisfied = [[system.constraint_names[c] for c in np.flatnonzero(row)] for row in owners]
    if rank:
        ranks = np.empty(T, dtype=int)
        chunk = max(1, int(2e7 // max(system.n_rows * system.n_unknowns * 8, 1)))
        for s in range(0, T, chunk):
            J = np.stack([scaled_jacobian(system, run.state(k), table, k) for k in range(s, min(T, s + chunk))])
            ranks[s:s + len(J)] = _rank(J)
        dof = system.n_unknowns - ranks
        redundant = active_equations(system, table) - ranks
    else:
        dof = np.full(T, -1)
        redundant = np.full(T, -1)
    names = []
    if rank and len(system.constraint_names) <= MAX_NAMED_CHECKS and redundant[0] > 0:
        names = redundant_constraints(system, run.state(0), table, 0)
    return Diagnostics(status=run.status.copy(), residual=np.sqrt(costs.sum(axis=1)), dof=dof,
                       redundant=redundant, costs=costs, unsatisfied=unsatisfied, redundant_names=names)


def redundant_constraints(system: System, state: State, table: StepTable, step: int) -> list[str]:
    """Named constraints whose removal leaves the rank unchanged (they restrict nothing more)."""
    J = scaled_jacobian(system, state, table, step)
    full = int(_rank(J[None])[0])
    out = []
    for c, name in enumerate(system.constraint_names):
        keep = system.row_owner != c
        if keep.all():
            continue
        if int(_rank(J[keep][None])[0]) == full:
            out.append(name)
    return out
