"""The objectives of one edit operation as residuals (LinkEdit Eqs. 3–5, 7, 9) and their Jacobian.

E(v) = ½‖r(v)‖². Lengths are divided by the mechanism's size L, so weights and tolerances do
not depend on the units (the same edit in mm or m gives the same linkage, scaled):

* tracking: √(w/S)·(p(t) − p̂(t))/L over the S selected samples (preserve: p̂ = the curve at the
  start of the operation; retarget: that curve transformed about its centroid; drag: displaced
  with a Gaussian falloff in phase); without timing, the distance to the curve p̂ instead, and over
  the whole cycle also the distance of p̂'s points (S, evenly by arc length) to the curve p;
* displacement: √w·(x_i(t) − x̂_i)/L at the rest pose or at a phase (transforms give targets to a
  set of joints);
* envelope: √(w/T)·(distance outside the box)/L per joint and sample;
* regularization: √μ_r·(l_ij − l̃_ij)/L over joint pairs on a link and the frame's pivots;
* symmetry (``symmetric``): √(10⁶·μ_e)·(l_ij − l_i'j')/L for every length whose mirror image
  (i', j') is another length, and √(10⁶·μ_e)·(M(x_g) − x_g')/L for mirrored ground joints, M the
  reflection about the mirror axis (its direction from the rest pose; through the motor pivot
  when the pivot lies on it), so mirrored legs stay mirrored in the world frame too;
* singularity barrier: √μ_s·ln(d_s/ε_r) where d_s < ε_r, per dyad triangle and sample (so E
  holds LinkEdit's ½·ln²(d_s/ε)). ε_r = min(ε, half the triangle's own smallest d_s at the start
  of the operation): the barrier is inactive on the design as it is (a null edit changes
  nothing) and only guards a triangle that an edit brings much closer to its toggle.

Edit terms carry μ_e, the operation's ``terms`` weight and the item's own ``weight``. The edit
goals' terms are in :mod:`~linkedit.edit.goals`; :func:`~linkedit.edit.operation.build_problem`
makes the problem of one operation of a script.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.linalg import null_space

from linkedit.edit.goals import Block, Displacement, Envelope, Track, as_real
from linkedit.edit.kinematics import Evaluation, RestPoseKinematics
from linkedit.edit.variables import Variables
from linkedit.planar.plan import Plan


@dataclass
class Problem:
    """One operation's energy over its variables ``var``; ``E(v) = ½‖r(v)‖²``."""

    plan: Plan
    kin: RestPoseKinematics
    var: Variables
    samples: int  # main samples: columns 0..T−1; then the rest column, then displacement phases
    size: float  # L: lengths are measured in units of L
    weights: tuple[float, float, float]  # μ_e, μ_s, μ_r
    eps: np.ndarray  # (R + X,) barrier ε per rule, then per step; 0 where not guarded (never active)
    pairs: np.ndarray  # (Q, 2) joint pairs regularized
    ref_lengths: np.ndarray  # (Q,)
    point_cols: np.ndarray  # (P, C) column map of each point row
    pair_cols: np.ndarray  # (Q, C)
    mirrored: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=int))  # (M, 2) pairs of pairs
    mirror_cols: np.ndarray | None = None  # (M, C)
    mirror_ground: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=int))  # (K, 2) joints
    mirror_ground_cols: np.ndarray | None = None  # (K, C)
    mirror_axis: complex = 1.0  # û² of the axis direction û: M(z) = c + û²·conj(z − c)
    mirror_centre: tuple[int | None, complex] = (None, 0j)  # joint on the axis (moving), or a fixed point
    tracking: list[Track] = field(default_factory=list)
    displacements: list[Displacement] = field(default_factory=list)
    envelope: Envelope | None = None

    @property
    def rest_column(self) -> int:
        return self.samples

    def evaluate(self, v: np.ndarray, tangents: bool = False) -> Evaluation:
        return self.kin.evaluate(self.var.rest(v), tangents)

    def labelled(self, ev: Evaluation) -> list[tuple[str, str, Block]]:
        """(energy term, what it is, residual block) of every block: the terms are ``edit``,
        ``singularity`` and ``regularization``; an edit block is named by its goal's label (a
        transform's joints together as ``transform``) or ``symmetry``."""
        scale = 1.0 / self.size
        cols = self.point_cols
        out = [("edit", t.label, t.block(ev, cols, scale)) for t in self.tracking]
        out += [("edit", "transform" if d.label.startswith("transform") else d.label, d.block(ev, cols, scale))
                for d in self.displacements]
        if self.envelope is not None:
            out.append(("edit", "envelope", self.envelope.block(ev, cols, scale, self.samples)))
        out += [("edit", "symmetry", b) for b in self._symmetric(ev.rest, ev.dz is not None)]
        out.append(("singularity", "singularity barrier", self._barrier(ev)))
        out.append(("regularization", "regularization", self._regularization(ev)))
        return out

    def blocks(self, ev: Evaluation) -> dict[str, list[Block]]:
        """Residual blocks by energy term: ``edit``, ``singularity``, ``regularization``."""
        out: dict[str, list[Block]] = {"edit": [], "singularity": [], "regularization": []}
        for term, _, block in self.labelled(ev):
            out[term].append(block)
        return out

    def gradients(self, v: np.ndarray) -> dict[str, np.ndarray]:
        """∂E/∂v (n,) of each part of the energy at ``v``, by the names of :meth:`labelled`."""
        ev = self.evaluate(v, tangents=True)
        out: dict[str, np.ndarray] = {}
        for _, label, (r, D, cols) in self.labelled(ev):
            assert D is not None  # evaluated with tangents
            keep = cols >= 0
            g = np.bincount(cols[keep], weights=(D * r[:, None])[keep], minlength=self.var.n)
            out[label] = out.get(label, 0.0) + g
        return out

    def _symmetric(self, rest: np.ndarray, tangents: bool) -> list[Block]:
        """The symmetry blocks at rest joints ``rest`` (J,) complex (with ∂ when ``tangents``):
        mirrored lengths equal, mirrored ground joints mirrored; weighted √(10⁶·μ_e)/L."""
        s = np.sqrt(1e6 * self.weights[0]) / self.size
        drest = self.kin.drest
        out: list[Block] = []
        if self.mirrored.size:
            r, D = [], []
            for sign, q in ((1.0, self.mirrored[:, 0]), (-1.0, self.mirrored[:, 1])):
                a, b = self.pairs[q].T
                d = rest[b] - rest[a]
                r.append(sign * np.abs(d))
                if tangents:
                    D.append(sign * ((d / np.abs(d)).conj()[:, None] * (drest[b] - drest[a])).real)
            assert self.mirror_cols is not None  # built with the mirrored pairs
            out.append((s * (r[0] + r[1]), s * (D[0] + D[1]) if tangents else None, self.mirror_cols))
        if self.mirror_ground.size:
            assert self.mirror_ground_cols is not None  # built with the mirrored ground joints
            g, h = self.mirror_ground.T
            joint, fixed = self.mirror_centre
            c = rest[joint] if joint is not None else fixed
            u2 = self.mirror_axis
            dc = drest[joint][None, :] if joint is not None else 0.0
            out.append((s * as_real(c + u2 * np.conj(rest[g] - c) - rest[h]),
                        s * as_real(dc + u2 * np.conj(drest[g] - dc) - drest[h]) if tangents else None,
                        np.concatenate([self.mirror_ground_cols, self.mirror_ground_cols])))
        return out

    def symmetry(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The symmetry constraints at ``v``: (c (m,), ∂c/∂v (m, n) dense), or None without
        ``symmetric``. They depend on the rest pose alone (no kinematics)."""
        if not (self.mirrored.size or self.mirror_ground.size):
            return None
        blocks = self._symmetric(self.rest_joints(v), True)
        c = np.concatenate([b[0] for b in blocks])
        D = np.concatenate([b[1] for b in blocks if b[1] is not None])
        cols = np.concatenate([b[2] for b in blocks])
        keep = cols >= 0
        rows = np.broadcast_to(np.arange(c.size)[:, None], cols.shape)[keep]
        C = np.zeros((c.size, self.var.n))
        np.add.at(C, (rows, cols[keep]), D[keep])
        return c, C

    def symmetric_basis(self, v: np.ndarray) -> np.ndarray | None:
        """(n, k) orthonormal directions that keep the mirrored parts mirrored to first order (the
        null space of the symmetry constraints' Jacobian): mirrored legs share these variables.
        None without ``symmetric``."""
        found = self.symmetry(v)
        return None if found is None else null_space(found[1], rcond=1e-10)

    def keep_symmetric(self, v: np.ndarray, step: np.ndarray) -> np.ndarray:
        """``step`` corrected so that v + step keeps the mirrored parts mirrored exactly (to
        rounding): Newton's least-norm projection onto the symmetry constraints. A step in
        :meth:`symmetric_basis` keeps them to first order only."""
        w = v + step
        for _ in range(4):
            found = self.symmetry(w)
            if found is None or np.abs(found[0]).max(initial=0.0) <= 1e-12:
                break
            w = w - np.linalg.lstsq(found[1], found[0], rcond=None)[0]
        return w - v

    def rest_joints(self, v: np.ndarray) -> np.ndarray:
        """The rest joints (J,) complex of variables ``v``."""
        x = self.var.rest(v)
        return x[:, 0] + 1j * x[:, 1]

    def _barrier(self, ev: Evaluation) -> Block:
        T = self.samples
        ds = ev.ds[:, :T]
        r_idx, t_idx = np.nonzero(ds < self.eps[:, None])
        s = np.sqrt(self.weights[1])
        r = s * np.log(ds[r_idx, t_idx] / self.eps[r_idx])
        D = None if ev.dlnds is None else s * ev.dlnds[r_idx, :, t_idx]
        return r, D, self.point_cols[self.kin.guard_rows[r_idx]]

    def _regularization(self, ev: Evaluation) -> Block:
        a, b = self.pairs.T
        d = ev.rest[b] - ev.rest[a]
        length = np.abs(d)
        s = np.sqrt(self.weights[2]) / self.size
        r = s * (length - self.ref_lengths)
        D = None
        if ev.dz is not None:
            drest = self.kin.drest
            D = s * ((d / length).conj()[:, None] * (drest[b] - drest[a])).real
        return r, D, self.pair_cols

    def residuals(self, v: np.ndarray, jacobian: bool = False) -> tuple[Evaluation, np.ndarray, sparse.csr_matrix | None]:
        """(evaluation, r (m,), ∂r/∂v (m, n) sparse or None)."""
        ev = self.evaluate(v, tangents=jacobian)
        if not ev.works:
            return ev, np.array([np.inf]), None
        blocks = [b for bs in self.blocks(ev).values() for b in bs]
        r = np.concatenate([b[0] for b in blocks])
        if not jacobian:
            return ev, r, None
        D = np.concatenate([b[1] for b in blocks])
        cols = np.concatenate([b[2] for b in blocks])
        keep = cols >= 0
        rows = np.broadcast_to(np.arange(r.size)[:, None], cols.shape)[keep]
        J = sparse.csr_matrix((D[keep], (rows, cols[keep])), shape=(r.size, self.var.n))
        return ev, r, J

    def barrier_step(self, ev: Evaluation, step: np.ndarray, factor: float = 1.1) -> float:
        """Largest fraction (≤ 1) of ``step`` (n,) that, to first order, brings no triangle into
        its barrier band deeper than ``factor`` times closer to its toggle (d_s/factor).

        Samples outside the band are invisible to the Gauss–Newton model; this trust region in
        ln d_s (predicted from the forward-mode tangents) keeps a step from jumping over them.
        """
        T = self.samples
        dyads = np.flatnonzero(self.kin.guarded)
        cols = self.point_cols[self.kin.guard_rows[dyads]]  # (R, C)
        dv = np.where(cols >= 0, step[np.maximum(cols, 0)], 0.0)
        if ev.dlnds is None:
            raise ValueError("barrier_step needs an evaluation with tangents")
        change = np.einsum("rct,rc->rt", ev.dlnds[dyads, :, :T], dv)
        lnds = np.log(ev.ds[dyads, :T])
        entering = (lnds + change < np.log(self.eps[dyads])[:, None]) & (change < -np.log(factor))
        if not entering.any():
            return 1.0
        return float(np.log(factor) / -change[entering].min())

    def energy(self, v: np.ndarray, with_gradient: bool = True) -> tuple[float, np.ndarray | None, Evaluation]:
        """(E, ∂E/∂v, evaluation); E = inf where the linkage does not work."""
        ev, r, J = self.residuals(v, jacobian=with_gradient)
        if not ev.works:
            return np.inf, None, ev
        return 0.5 * float(r @ r), (None if J is None else J.T @ r), ev

    def terms(self, ev: Evaluation) -> dict[str, float]:
        """Energy of each term (weighted), for reports."""
        return {k: 0.5 * float(sum(b[0] @ b[0] for b in bs)) for k, bs in self.blocks(ev).items()}

    def errors(self, v: np.ndarray) -> dict[str, float]:
        """Readable objective errors in the spec's units: tracking RMS per curve, displacement
        distance, envelope excess, min d_s, and the weighted energy terms."""
        ev = self.evaluate(v)
        out: dict[str, float] = {}
        for tr in self.tracking:
            out[f"{tr.label} RMS"] = tr.rms(ev)
        for d in self.displacements:
            out[f"{d.label} error"] = d.error(ev)
        if self.envelope is not None:
            out["envelope max excess"] = float(np.abs(self.envelope.outside(ev.z, self.samples)).max(initial=0.0))
        dyads = self.kin.guarded
        out["min d_s"] = float(ev.ds[dyads, : self.samples].min()) if dyads.any() else 1.0
        out |= {f"energy {k}": v_ for k, v_ in self.terms(ev).items()}
        return out
