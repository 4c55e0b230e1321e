"""The objectives of one edit operation as residuals (LinkEdit Eqs. 3–5, 7, 9) and their Jacobian.

E(v) = ½‖r(v)‖². Lengths are divided by the mechanism's size L, so weights and tolerances do
not depend on the units (the same edit in mm or m gives the same linkage, scaled):

* tracking: √(w/S)·(p(t) − p̂(t))/L over the S selected samples (preserve: p̂ = the curve at the
  start of the operation; retarget: that curve transformed about its centroid; drag: displaced
  with a Gaussian falloff in phase); without timing, the distance to the curve p̂ instead;
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

Edit terms carry μ_e, the operation's ``terms`` weight and the item's own ``weight``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.linalg import null_space

from linkedit.edit.kinematics import Evaluation, RestPoseKinematics
from linkedit.edit.variables import Variables, colour, column_map, seeds
from linkedit.planar.plan import Plan
from linkedit.planar.simulate import motor_input
from linkedit.spec.edit_script import EditScript, Operation

Block = tuple[np.ndarray, np.ndarray | None, np.ndarray]  # r (m,), ∂r (m, C) per colour, columns (m, C)


def _split(values: np.ndarray) -> np.ndarray:
    """Complex (…) → real (2·…): real parts, then imaginary parts, along the first axis."""
    return np.concatenate([values.real, values.imag])


@dataclass
class Track:
    """Follow a target curve (T,) complex with point row ``row`` over samples ``select``."""

    label: str
    row: int
    target: np.ndarray
    weight: float
    select: np.ndarray
    timing: bool = True
    cyclic: bool = True
    size: float = 0.0  # size of the track's curve at the start of the operation (for reports)
    shape: np.ndarray | None = None  # the polyline for ``timing: false`` when not ``target`` itself

    def deviation(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(signed deviation (S,) complex or real, unit direction) of the selected samples."""
        p = z[self.row, self.select]
        if self.timing:
            return p - self.target[self.select], np.ones(p.size, dtype=complex)
        line = self.target if self.shape is None else self.shape
        a = line if self.cyclic else line[:-1]
        b = np.roll(line, -1) if self.cyclic else line[1:]
        seg = b - a
        rel = p[:, None] - a[None, :]
        s = np.clip((rel * seg.conj()).real / np.maximum(np.abs(seg) ** 2, 1e-300), 0.0, 1.0)
        k = np.argmin(np.abs(rel - s * seg), axis=1)
        rows = np.arange(p.size)
        d = rel[rows, k] - s[rows, k] * seg[k]  # from the nearest point of the curve to p
        normal = 1j * seg[k] / np.maximum(np.abs(seg[k]), 1e-300)
        side = np.where((d * normal.conj()).real < 0.0, -1.0, 1.0)
        dist = np.abs(d)
        # the distance to the curve, signed by the side: continuous; its direction, the normal on the curve
        direction = np.where(dist > 0.0, side * d / np.where(dist > 0.0, dist, 1.0), normal)
        return side * dist, direction

    def rms(self, ev: Evaluation) -> float:
        d, _ = self.deviation(ev.z)
        return float(np.sqrt(np.mean(np.abs(d) ** 2)))

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float) -> Block:
        d, normal = self.deviation(ev.z)
        s = np.sqrt(self.weight / self.select.size) * scale
        dz = None if ev.dz is None else ev.dz[self.row][:, self.select].T  # (S, C)
        if self.timing:
            r, D = s * _split(d), None if dz is None else s * _split(dz)
        else:
            r, D = s * d, None if dz is None else s * (normal.conj()[:, None] * dz).real
        return r, D, np.broadcast_to(cols[self.row], (r.size, cols.shape[1]))


@dataclass
class Displacement:
    """Point row ``row`` at sample column ``column`` (the rest column for the rest pose) to ``target``."""

    label: str
    row: int
    column: int
    target: complex
    weight: float

    def error(self, ev: Evaluation) -> float:
        return float(abs(ev.z[self.row, self.column] - self.target))

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float) -> Block:
        s = np.sqrt(self.weight) * scale
        r = s * _split(np.atleast_1d(ev.z[self.row, self.column] - self.target))
        D = None if ev.dz is None else s * _split(ev.dz[self.row][None, :, self.column])
        return r, D, np.broadcast_to(cols[self.row], (2, cols.shape[1]))


@dataclass
class Envelope:
    """Keep point rows ``rows`` inside the box lo–hi (complex corners, ±inf where open)."""

    rows: np.ndarray
    lo: complex
    hi: complex
    weight: float

    def outside(self, z: np.ndarray, T: int) -> np.ndarray:
        p = z[self.rows, :T]
        return (np.minimum(p.real - self.lo.real, 0.0) + np.maximum(p.real - self.hi.real, 0.0)
                + 1j * (np.minimum(p.imag - self.lo.imag, 0.0) + np.maximum(p.imag - self.hi.imag, 0.0)))

    def block(self, ev: Evaluation, cols: np.ndarray, scale: float, T: int) -> Block:
        over = self.outside(ev.z, T)
        s = np.sqrt(self.weight / T) * scale
        rs, Ds, cs = [], [], []
        for part in ("real", "imag"):
            n, t = np.nonzero(getattr(over, part))
            rs.append(s * getattr(over, part)[n, t])
            cs.append(cols[self.rows[n]])
            if ev.dz is not None:
                Ds.append(s * getattr(ev.dz[self.rows[n], :, t], part))
        return np.concatenate(rs), (np.concatenate(Ds) if ev.dz is not None else None), np.concatenate(cs)


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
            out.append((s * _split(c + u2 * np.conj(rest[g] - c) - rest[h]),
                        s * _split(dc + u2 * np.conj(drest[g] - dc) - drest[h]) if tangents else None,
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


def _phase_distance(t: np.ndarray, at: float, cyclic: bool) -> np.ndarray:
    """Distance in phase; around the cycle for a full turn, along the sweep otherwise."""
    d = np.abs(t - at) % 1.0
    return np.minimum(d, 1.0 - d) if cyclic else np.abs(t - at)


def _select(t: np.ndarray, phases: tuple[float, float] | None) -> np.ndarray:
    if phases is None:
        return np.arange(t.size)
    a, b = phases
    inside = (t >= a) & (t <= b) if a <= b else (t >= a) | (t <= b)
    return np.flatnonzero(inside)


def regularized_pairs(plan: Plan) -> np.ndarray:
    """Joint pairs on links and every pair of ground joints (the frame is a link too), (Q, 2)."""
    ground = list(plan.graph.ground)
    frame = [(a, b) for n, a in enumerate(ground) for b in ground[n + 1:]]
    pairs = {tuple(sorted(p)) for p in plan.pairs.tolist()} | {tuple(sorted(p)) for p in frame}
    return np.array(sorted(pairs), dtype=int).reshape(-1, 2)


def mirrored_pairs(pairs: np.ndarray, mirror: dict[str, str], index: dict[str, int]) -> np.ndarray:
    """(M, 2) indices into ``pairs`` of each pair and its distinct mirror image (once each)."""
    names = {i: n for n, i in index.items()}
    where = {tuple(p): q for q, p in enumerate(pairs.tolist())}
    out = []
    for q, (a, b) in enumerate(pairs.tolist()):
        image = tuple(sorted((index[mirror.get(names[a], names[a])], index[mirror.get(names[b], names[b])])))
        other = where.get(image)
        if other is not None and other > q:
            out.append((q, other))
    return np.array(out, dtype=int).reshape(-1, 2)


def mirror_frame(plan: Plan, x: np.ndarray, mirror: dict[str, str], index: dict[str, int],
                 size: float) -> tuple[np.ndarray, complex, tuple[int | None, complex]]:
    """Mirrored ground joints (K, 2), û² of the mirror axis, and the axis' point: the motor pivot
    (a joint index) when it lies on the axis at ``x`` (J, 2), else the fixed midpoint."""
    names = plan.joint_names
    ground = [g for g in plan.graph.ground if names[g] in mirror and index[mirror[names[g]]] > g
              and index[mirror[names[g]]] in plan.graph.ground]
    pairs = np.array([(g, index[mirror[names[g]]]) for g in ground], dtype=int).reshape(-1, 2)
    if not pairs.size:
        return pairs, 1.0 + 0j, (None, 0j)
    z = x[:, 0] + 1j * x[:, 1]
    a, b = z[pairs[0, 0]], z[pairs[0, 1]]
    u = 1j * (b - a) / abs(b - a)
    mid = 0.5 * (a + b)
    pivot = plan.graph.pivot
    on_axis = pivot >= 0 and abs(((z[pivot] - mid) * np.conj(1j * u)).real) <= 1e-9 * size
    return pairs, complex(u * u), ((pivot, 0j) if on_axis else (None, complex(mid)))


def dependencies(plan: Plan, uses: np.ndarray) -> np.ndarray:
    """(P, n) bool: the variables each point row depends on (``uses`` (J, n): per joint)."""
    dep = np.zeros((plan.n_points, uses.shape[1]), dtype=bool)
    g = plan.graph
    dep[plan.ground_rows] = uses[list(g.ground)]
    if g.pivot >= 0:  # a linear input's driven joint is written by its step
        dep[plan.motor_row] = uses[g.motor] | uses[g.pivot]
    for rule in plan.rules:
        rule.depend(plan.row_of, dep, uses)
    return dep


def build_problem(plan: Plan, script: EditScript, op: Operation, var: Variables, turn: np.ndarray,
                  t: np.ndarray, size: float, probes: dict[int, int]) -> Problem:
    """The energy of operation ``op`` from the rest pose ``var.x0``.

    ``turn`` (T,) the input from the rest pose at the phases ``t`` (T,) of one cycle, as
    ``simulate`` samples them (:func:`~linkedit.planar.simulate.motor_input`: motor rotations,
    radians, signed; a linear input's stroke, spec units); ``probes`` maps displacement index → point id of
    the link point it moves.
    """
    T = t.size
    names = plan.joint_names
    index = {n: i for i, n in enumerate(names)}
    displaces = op.listed("displace")
    cyclic = plan.spec.motor.cyclic
    extra = [_turn_at(plan, d.when) for d in displaces if d.when is not None]
    inputs = np.concatenate([turn, [0.0], extra])

    uses = var.uses()
    dep = dependencies(plan, uses)
    pairs = regularized_pairs(plan)
    pair_dep = uses[pairs[:, 0]] | uses[pairs[:, 1]]
    mirror = script.mirror(names)
    mirrored = mirrored_pairs(pairs, mirror, index)
    mirror_dep = pair_dep[mirrored[:, 0]] | pair_dep[mirrored[:, 1]]
    ground_pairs, axis, centre = mirror_frame(plan, var.x0, mirror, index, size)
    centre_uses = uses[centre[0]] if centre[0] is not None else np.zeros(var.n, dtype=bool)
    ground_dep = (uses[ground_pairs[:, 0]] | uses[ground_pairs[:, 1]] | centre_uses).reshape(-1, var.n)
    colours = colour(np.vstack([dep, pair_dep, mirror_dep, ground_dep])) if var.n else np.zeros(0, dtype=int)
    C = int(colours.max(initial=-1)) + 1
    g = plan.graph
    arm = None if script.motor.free_angle or plan.linear else complex(*(var.x0[g.motor] - var.x0[g.pivot]))
    kin = RestPoseKinematics(plan, inputs, seeds(var, colours, C), arm)
    start = kin.evaluate(var.x0)
    me, ms, mr = script.weights.edit, script.weights.singularity, script.weights.regularization
    w = op.terms

    # the barrier guards each triangle from coming closer to its toggle than it is now
    eps = np.zeros(kin.guarded.size)
    dyads = kin.guarded
    eps[dyads] = np.minimum(script.singularity_epsilon, 0.5 * start.ds[dyads, :T].min(axis=1))

    ref = np.abs(start.rest[pairs[:, 1]] - start.rest[pairs[:, 0]])
    if op.transform is not None and op.transform.scale != 1.0:
        moved = set(range(len(names))) if op.transform.joints == "all" else {index[n] for n in op.transform.joints}
        scaled = np.array([a in moved and b in moved for a, b in pairs])
        ref = np.where(scaled, ref * op.transform.scale, ref)

    problem = Problem(plan=plan, kin=kin, var=var, samples=T, size=size, weights=(me, ms, mr), eps=eps,
                      pairs=pairs, ref_lengths=ref, point_cols=column_map(dep, colours, C),
                      pair_cols=column_map(pair_dep, colours, C), mirrored=mirrored,
                      mirror_cols=column_map(mirror_dep, colours, C), mirror_ground=ground_pairs,
                      mirror_ground_cols=column_map(ground_dep, colours, C), mirror_axis=axis, mirror_centre=centre)
    track_row = {n: int(plan.row_of[p]) for n, p in zip(plan.track_names, plan.track_points)}
    everywhere = np.arange(T)

    def curve(name: str) -> np.ndarray:
        return start.z[track_row[name], :T].copy()

    rocking = plan.spec.motor.oscillate_deg is not None
    for p in op.preserved:
        c = curve(p.track)
        # a rocking input traces its curve out and back: its shape is the outward half, open
        shape = c[: (T + 1) // 2 + 1] if rocking else None
        problem.tracking.append(Track(f"preserve {p.track}", track_row[p.track], c, me * w.preserve * p.weight,
                                      _select(t, p.phases), p.timing, cyclic and not rocking, shape=shape))
    for r in op.listed("retarget"):
        c = curve(r.track)
        mid = c.mean()
        q = (c - mid).real * r.scale[0] + 1j * (c - mid).imag * r.scale[1]
        target = mid + complex(*r.translate) + np.exp(1j * np.radians(r.rotate_deg)) * q
        problem.tracking.append(Track(f"retarget {r.track}", track_row[r.track], target,
                                      me * w.retarget * r.weight, everywhere))
    for f in op.listed("follow"):
        pts = np.array([complex(*p) for p in f.curve])
        if f.timing:  # the curve's points evenly over the cycle, interpolated at the samples
            u = np.arange(pts.size + f.closed) / (pts.size - (not f.closed))
            ring = np.append(pts, pts[0]) if f.closed else pts
            target = np.interp(t, u, ring.real) + 1j * np.interp(t, u, ring.imag)
        else:
            target = pts
        problem.tracking.append(Track(f"follow {f.track}", track_row[f.track], target, me * w.follow * f.weight,
                                      everywhere, f.timing, f.closed))
    for d in op.listed("drag"):
        falloff = np.exp(-0.5 * (_phase_distance(t, d.at, cyclic) / d.radius) ** 2)
        problem.tracking.append(Track(f"drag {d.track}", track_row[d.track], curve(d.track) + complex(*d.by) * falloff,
                                      me * w.drag * d.weight, everywhere))
    column = T + 1
    for n, d in enumerate(displaces):
        point = index[d.joint] if d.joint is not None else probes[n]
        col = problem.rest_column if d.when is None else column
        column += d.when is not None
        problem.displacements.append(Displacement(d.label, int(plan.row_of[point]), col, complex(*d.to),
                                                  me * w.displace * d.weight))
    if op.transform is not None:
        tf = op.transform
        members = list(range(len(names))) if tf.joints == "all" else [index[n] for n in tf.joints]
        rest = start.rest
        about = complex(*tf.about) if tf.about is not None else rest[members].mean()
        turn_by = tf.scale * np.exp(1j * np.radians(tf.rotate_deg))
        for m in members:
            target = about + complex(*tf.translate) + turn_by * (rest[m] - about)
            problem.displacements.append(Displacement(f"transform {names[m]}", int(plan.row_of[m]),
                                                      problem.rest_column, target, me * w.transform))
    if op.envelope is not None:
        env = op.envelope
        boxed = list(range(len(names))) if not env.joints else [index[n] for n in env.joints]
        inf = np.inf
        problem.envelope = Envelope(
            rows=plan.row_of[np.array(boxed)],
            lo=complex(-inf if env.xmin is None else env.xmin, -inf if env.ymin is None else env.ymin),
            hi=complex(inf if env.xmax is None else env.xmax, inf if env.ymax is None else env.ymax),
            weight=me * w.envelope)
    for tr in problem.tracking:
        c = start.z[tr.row, :T]
        tr.size = float(max(np.ptp(c.real), np.ptp(c.imag)))
    return problem


def _turn_at(plan: Plan, phase: float) -> float:
    """The input from the rest pose at ``phase`` (as ``simulate`` samples it)."""
    return float(motor_input(plan.spec.motor, np.array([phase]))[0])
