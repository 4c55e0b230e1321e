"""The problem of one edit operation, built from the script: its goals (tracks, displacements,
transform, envelope), the regularized and mirrored lengths, and the variables' colouring."""

from __future__ import annotations

import numpy as np

from linkedit.edit.goals import Aim, Displacement, Envelope, Track
from linkedit.edit.kinematics import RestPoseKinematics
from linkedit.edit.objectives import Problem
from linkedit.edit.variables import Variables, colour, column_map, seeds
from linkedit.planar.plan import Plan
from linkedit.planar.simulate import motor_input
from linkedit.spec.edit_script import Drag, EditScript, Follow, Operation, Retarget


def _phase_distance(t: np.ndarray, at: float, cyclic: bool) -> np.ndarray:
    """Distance in phase; around the cycle for a full turn, along the sweep otherwise."""
    d = np.abs(t - at) % 1.0
    return np.minimum(d, 1.0 - d) if cyclic else np.abs(t - at)


def select(t: np.ndarray, phases: tuple[float, float] | None) -> np.ndarray:
    """Indices of the phases ``t`` (T,) inside the window ``[a, b]`` (a > b wraps round), or all."""
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

    def curve(name: str) -> np.ndarray:
        return start.z[track_row[name], :T].copy()

    rocking = plan.spec.motor.oscillate_deg is not None
    goals: list[tuple[str, str, Aim, float, tuple[float, float] | None, bool, bool]] = []  # label, track, …
    for p in op.preserved:
        goals.append(("preserve", p.track, _kept, w.preserve * p.weight, p.phases, p.timing, cyclic and not rocking))
    for r in op.listed("retarget"):
        goals.append(("retarget", r.track, _retargeted(r, curve(r.track).mean()), w.retarget * r.weight, None,
                      True, True))
    for f in op.listed("follow"):
        goals.append(("follow", f.track, _followed(f), w.follow * f.weight, None, f.timing, f.closed))
    for d in op.listed("drag"):
        goals.append(("drag", d.track, _dragged(d, cyclic), w.drag * d.weight, None, True, True))
    for kind, name, aim, weight, phases, timing, closed in goals:
        c = curve(name)
        # a rocking input traces its curve out and back: its shape is the outward half, open
        shape = c[: (T + 1) // 2 + 1] if kind == "preserve" and rocking else None
        problem.tracking.append(Track(f"{kind} {name}", track_row[name], aim(c, t), me * weight, select(t, phases),
                                      timing, closed, shape=shape, track=name, aim=aim, phases=phases))
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


def _kept(c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """A preserved curve's target: the curve itself."""
    return c


def _retargeted(r: Retarget, mid: complex) -> Aim:
    """The curve scaled (per axis), rotated and translated about ``mid`` (its centroid at the
    script's samples, so that every sampling aims at the same curve)."""
    def aim(c: np.ndarray, t: np.ndarray) -> np.ndarray:
        q = (c - mid).real * r.scale[0] + 1j * (c - mid).imag * r.scale[1]
        return mid + complex(*r.translate) + np.exp(1j * np.radians(r.rotate_deg)) * q
    return aim


def _followed(f: Follow) -> Aim:
    """The given curve: its points spread evenly over the cycle, interpolated at ``t`` (``timing``),
    or the polyline itself."""
    pts = np.array([complex(*p) for p in f.curve])

    def aim(c: np.ndarray, t: np.ndarray) -> np.ndarray:
        if not f.timing:
            return pts
        u = np.arange(pts.size + f.closed) / (pts.size - (not f.closed))
        ring = np.append(pts, pts[0]) if f.closed else pts
        return np.interp(t, u, ring.real) + 1j * np.interp(t, u, ring.imag)
    return aim


def _dragged(d: Drag, cyclic: bool) -> Aim:
    """The curve displaced by ``by``·exp(−Δt²/2r²), Δt the phase distance to ``at``."""
    def aim(c: np.ndarray, t: np.ndarray) -> np.ndarray:
        return c + complex(*d.by) * np.exp(-0.5 * (_phase_distance(t, d.at, cyclic) / d.radius) ** 2)
    return aim


def _turn_at(plan: Plan, phase: float) -> float:
    """The input from the rest pose at ``phase`` (as ``simulate`` samples it)."""
    return float(motor_input(plan.spec.motor, np.array([phase]))[0])
