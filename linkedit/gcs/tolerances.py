"""Every tolerance of the 3D solver in one place: the options a caller sets (:class:`Options`),
the fixed rank / null-space thresholds both schedulers (step by step and waves) and the
diagnostics share, and the statuses a step is judged by.

All are dimensionless: residual rows are divided by the mechanism's size (lengths; angles are
radians already) and position unknowns are measured in it (:mod:`linkedit.gcs.continuation`).
"""

from __future__ import annotations

from dataclasses import dataclass

CONVERGED, INCONSISTENT, NOT_CONVERGED = 0, 1, 2
STATUS_NAMES = ("converged", "inconsistent", "did not converge")
SOLVERS = ("lm", "slsqp-fd")
#: largest scaled residual row of a converged ``slsqp-fd`` step (``Options.tol`` is the LM one)
SLSQP_TOL = 1e-6

#: the damping μ of the factorized JᵀJ + μI, as a fraction of its largest diagonal entry (at least 1)
DAMPING = 1e-13
#: a pivot of the factorized JᵀJ + μI below this fraction of its largest diagonal entry is a
#: direction J may not see (a free degree of freedom, a singular pose: both schedulers look
#: closer there). Above it the damped solve errs by about μ / pivot ≲ 1e-8 (relative) along
#: it: a badly conditioned but full-rank pose (a Jansen leg's J: smallest singular value ~5e-3
#: of the largest, pivot ~6e-5) is solved as any other, in waves too
FREE_PIVOT = 1e-5
#: singular values of the scaled J below this fraction of the largest span its null space
NULL_SINGULAR = 1e-8
#: a null-space basis B from inverse iteration is clean when |J B| is below this fraction of
#: √(largest diagonal of JᵀJ) (at most the largest singular value): J's rank is N minus its
#: columns, as the diagnostics' SVD (RANK_TOL) would count it
NULL_CLEAN = 1e-9
#: ... and the other directions of its span are seen by J when above this fraction
NULL_APART = 1e-6
#: the diagnostics' rank: singular values below this fraction of the largest count as zero
RANK_TOL = 1e-9
#: a constraint is redundant when the left null space of J restricted to its rows has full
#: rank: smallest singular value above this (they are O(1) for a repeated constraint)
NULL_TOL = 1e-6
#: scaled Jacobian entries (of order 1) at most this large tie no unknowns, and scaled
#: residual rows stir no still part: the rounding of exact zeros (a planar linkage's poses off
#: their plane by ~1e-30 after steps solved step by step); a block solve that leaves them out
#: errs by as little (:mod:`linkedit.gcs.structure`)
TIED = 1e-15


@dataclass
class Options:
    """Solver settings (scaled quantities: lengths divided by the mechanism's size, radians).

    ``tol``: largest residual row counted as satisfied; ``max_iterations``: linear solves per
    (sub-)step; ``predictor_tol``: largest distance between a sub-step's tangent prediction and
    its solution; ``max_motion``: largest motion of a sub-step; ``min_fraction``: smallest
    sub-step, as a fraction of a time step; ``still_tol``: largest Newton move left along free
    directions (to the canonical pose; where an input is outside its window, the largest
    component of a pose's change along them); ``solver``: one of :data:`SOLVERS` (a
    ``ValueError`` otherwise); ``accelerations``: compute them at every output step (two more
    Jacobian evaluations per step, :mod:`linkedit.gcs.acceleration`, batched over the solved
    steps after the run, :mod:`linkedit.gcs.accelerations`; ``solve3d --accelerations``)."""

    tol: float = 1e-12
    max_iterations: int = 100
    predictor_tol: float = 2e-3
    max_motion: float = 0.05
    min_fraction: float = 1e-9
    still_tol: float = 1e-10
    solver: str = "lm"
    accelerations: bool = False
    #: solve many steps at once where that gives the continuation's poses (:mod:`linkedit.gcs.waves`)
    waves: bool = True
    #: end the run at its first step that fails (the run returned holds the steps up to it)
    stop_at_failure: bool = False

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise ValueError(f"Options.solver: {self.solver!r} is not a solver; use one of "
                             + ", ".join(repr(s) for s in SOLVERS))

    @property
    def satisfied_tol(self) -> float:
        """The largest scaled residual row the chosen solver counts as satisfied."""
        return SLSQP_TOL if self.solver == "slsqp-fd" else self.tol
