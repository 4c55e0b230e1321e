"""Batched Gauss–Newton: B poses of a system solved at once to convergence (step 3 of
:mod:`linkedit.gcs.waves`), a factorization kept while it contracts the residual (chord), and
each solved pose's exact velocity — for the waves."""

from __future__ import annotations

import numpy as np

from linkedit.gcs.factors import BatchedFactors, Factors
from linkedit.gcs.structure import SPLIT_FROM, _take

#: Gauss–Newton iterations of a block's steps
ITERATIONS = 8
#: largest scaled move of a pose since its factorization for the factorization to serve its
#: velocity (by two refinements: error ~REFINE³ relative); at most FRESH, one refinement; none
#: where the factorization is of the pose itself
REFINE = 1e-5
FRESH = 1e-9


class BatchedGaussNewton(BatchedFactors):
    """Least-norm Gauss–Newton of B poses at once, block by block of :attr:`parts`."""

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
