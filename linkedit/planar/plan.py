"""Compile a linkage once into a reconstruction plan; evaluate it many times.

The plan holds everything that depends only on topology and the rest-pose branch: one sequence
of rules (:mod:`linkedit.planar.rules`) in evaluation order — per level its rigid batch, its
dyad batch (each one array operation), then its sliders, slots and numeric groups — and the
table of triangle rules (i, j) → k with their levels and rest orientations that result files
list. Points are joints (0..J-1, spec order) followed by tracked points attached to links
(J..). Internally, rows are ordered ground, motor, then rule by rule, so every rule writes one
contiguous block; every rule owns a contiguous block of the singularity-distance rows too.

The numeric constants that come from a rest pose (link lengths, rigid coefficients, motor arm)
are a separate :class:`Geometry`, so an optimizer can change the rest pose without recompiling.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.diagnostics import degrees_text
from linkedit.planar.graph import LinkageGraph, Mobility, mobility
from linkedit.planar.ordering import order_joints
from linkedit.planar.rules import Dyad, Rigid, Rule, Step, compile_steps
from linkedit.spec.linkage import JointTrack, LinkageSpec, LinkTrack


@dataclass(frozen=True)
class TriangleTable:
    """The dyad and rigid rules (i, j) → k, as result files list them (``/rules``, the ``rule``
    axis): the ordering's order (by level). R entries."""

    joints: np.ndarray  # (R, 3) joint indices (i, j, k)
    level: np.ndarray  # (R,)
    rigid: np.ndarray  # (R,) bool
    orientation: np.ndarray  # (R,) rest orientation of (i, j, k): +1 ccw, −1 cw, 0 collinear
    row: np.ndarray  # (R,) each entry's row of the singularity distance (Plan.ds_rows)


@dataclass(frozen=True)
class Plan:
    """A compiled linkage (see module docstring)."""

    spec: LinkageSpec
    graph: LinkageGraph
    mobility: Mobility
    #: every rule, in evaluation order
    rules: tuple[Rule, ...]
    #: each rule's rows of the singularity distance d_s (N rows in all), aligned with ``rules``
    ds_rows: tuple[slice, ...]
    table: TriangleTable
    row_of: np.ndarray  # (P,) internal row of each point
    ground_rows: np.ndarray  # (G,) == row_of[ground]
    motor_row: int
    pivot_row: int
    track_names: tuple[str, ...]
    track_points: np.ndarray  # (K,) point id of each track
    rest_points: np.ndarray  # (P, 2) rest positions of all points (joints, then track points)
    origin: complex = 0j  #: the first ground joint at rest: the normalized frame's origin
    scale: float = 1.0  #: the linkage's characteristic length: the normalized frame's unit

    @property
    def linear(self) -> bool:
        """True when the input is a driven slider (derivatives are per unit of stroke)."""
        return self.graph.pivot < 0

    @cached_property
    def has_groups(self) -> bool:
        return any(rule.numeric for rule in self.rules)

    @cached_property
    def steps(self) -> tuple[Step, ...]:
        """The rules of the non-revolute kinds (sliders, the linear input, numeric groups), in
        order, with joint-space rows in the normalized frame (see ``origin``, ``scale``); result
        files list them under ``/rules/steps``."""
        return tuple(r for r in self.rules if isinstance(r, Step))

    @cached_property
    def step_rows(self) -> np.ndarray:
        """(X,) each of :attr:`steps`' row of the singularity distance."""
        return np.array([rows.start for r, rows in zip(self.rules, self.ds_rows) if isinstance(r, Step)], dtype=int)

    @cached_property
    def steps_rest(self) -> np.ndarray:
        """(J,) complex: the rest joints in the normalized frame, where :attr:`steps` were compiled."""
        p = self.normalized_points()[: self.n_joints]
        return p[:, 0] + 1j * p[:, 1]

    @cached_property
    def n_ds(self) -> int:
        """N: how many rows of singularity distance an evaluation has."""
        return self.ds_rows[-1].stop if self.ds_rows else 0

    @property
    def levels(self) -> int:
        """The deepest level of a rule that places a joint (0: ground and motor only; tracked
        points on links do not count)."""
        return max((r.level for r in self.rules if r.ds_count()), default=0)

    def ds_rule(self) -> tuple[np.ndarray, np.ndarray]:
        """(N,) the index into ``rules`` of each d_s row, and its index within that rule."""
        owner = np.repeat(np.arange(len(self.rules)), [rows.stop - rows.start for rows in self.ds_rows])
        within = np.arange(owner.size) - np.array([self.ds_rows[o].start for o in owner], dtype=int)
        return owner, within

    def describe(self) -> dict[int, list[str]]:
        """What every rule does, level by level (``validate``): the triangle table's entries in
        its order, then the other kinds in evaluation order."""
        names = self.joint_names
        lines = sorted((line for r in self.rules for line in r.lines(names)), key=lambda e: e[0])
        out: dict[int, list[str]] = {}
        for (level, _, _), text in lines:
            out.setdefault(level, []).append(text)
        return out

    def normalized_points(self, points: np.ndarray | None = None) -> np.ndarray:
        """Rest points (P, 2) moved to the normalized frame: (p − origin)/scale."""
        p = self.rest_points if points is None else points
        return (p - np.array([self.origin.real, self.origin.imag])) / self.scale

    @property
    def joint_names(self) -> list[str]:
        return list(self.graph.joint_names)

    @property
    def n_joints(self) -> int:
        return self.graph.n_joints

    @property
    def n_points(self) -> int:
        return len(self.row_of)

    @property
    def pairs(self) -> np.ndarray:
        """(P, 2) joint index pairs held at constant distance."""
        return self.graph.pairs

    @property
    def direction(self) -> float:
        """+1 for a counter-clockwise motor, −1 for clockwise."""
        return 1.0 if self.spec.motor.direction == "ccw" else -1.0

    def geometry(self, rest: np.ndarray | None = None) -> "Geometry":
        """Numeric constants for a rest pose of the joints, (J, 2); default: the spec's."""
        return Geometry.of(self, self.rest_points if rest is None else self.points_for(rest))

    def rebased(self, spec: LinkageSpec) -> "Plan":
        """This plan for ``spec``: the same topology and tracks at another rest pose, without
        compiling again, in the new rest pose's normalized frame (as :func:`compile_plan` takes it,
        so both simulate alike, bit for bit). Every dyad triangle must keep its orientation
        (ValueError otherwise)."""
        graph = dataclasses.replace(self.graph, rest=np.array([spec.joints[n] for n in self.joint_names], dtype=float))
        extra = [_link_point(spec.tracks[n]) for n, p in zip(self.track_names, self.track_points) if p >= self.n_joints]
        points = np.vstack([graph.rest, np.array(extra, dtype=float).reshape(-1, 2)])
        t = self.table
        orientation = np.array([_orientation(graph.rest, i, j, k) for i, j, k in t.joints], dtype=int)
        if not np.array_equal(orientation[~t.rigid], t.orientation[~t.rigid]):
            raise ValueError("a dyad triangle changed orientation: compile the spec instead")
        origin, scale = characteristic_frame(graph.rest, graph.ground)
        return dataclasses.replace(self, spec=spec, graph=graph, table=dataclasses.replace(t, orientation=orientation),
                                   rest_points=points, origin=origin, scale=scale)

    def points_for(self, rest: np.ndarray) -> np.ndarray:
        """Rest positions of all points (P, 2) for new joint positions (J, 2).

        Tracked points attached to links move with their link's frame (defined by the two
        joints that rebuild them), so they stay in place relative to the link.
        """
        rest = np.asarray(rest, dtype=float)
        if rest.shape == self.rest_points.shape:
            return rest
        out = np.empty_like(self.rest_points)
        out[: self.n_joints] = rest
        old = self.rest_points[:, 0] + 1j * self.rest_points[:, 1]
        new = out[:, 0] + 1j * out[:, 1]
        for rule in self.rules:
            rule.move_tracks(old, new)
        out[self.n_joints:] = np.column_stack([new.real, new.imag])[self.n_joints:]
        return out


@dataclass(frozen=True)
class Geometry:
    """Constants of a plan at one rest pose — or at K rest poses of one topology (a leading
    linkage axis: the atlas, a synthesis family). Per rule (``Rule.constants``): (R, 1) arrays
    for one linkage, (R, K, 1) for K."""

    rest: np.ndarray  # (P,) complex rest positions of all points; (P, K) for K linkages
    pivot: complex | np.ndarray  # (K, 1) for K linkages
    arm: complex | np.ndarray  # motor joint − pivot at rest; (K, 1) for K linkages
    rest_angle: float | np.ndarray  # motor angle at rest, radians; (K, 1) for K linkages
    ground: np.ndarray  # (G, 1) complex; (G, K, 1) for K linkages
    constants: tuple[tuple[Any, ...], ...]  # per rule of the plan, aligned with ``Plan.rules``

    @property
    def linkages(self) -> tuple[int, ...]:
        """() for one linkage, (K,) for K: the axes between a row and the samples."""
        return self.ground.shape[1:-1]

    @classmethod
    def of(cls, plan: Plan, points: np.ndarray) -> "Geometry":
        """The constants of ``plan`` at rest points (P, 2) — or (K, P, 2) for K linkages."""
        many = points.ndim == 3
        pts = points if many else points[None]
        z = (pts[..., 0] + 1j * pts[..., 1]).T  # (P, K)
        g = plan.graph
        constants = tuple(rule.constants(z, many) for rule in plan.rules)
        if g.pivot >= 0:
            pivot, arm = z[g.pivot, :, None], z[g.motor, :, None] - z[g.pivot, :, None]
        else:
            pivot, arm = np.zeros((z.shape[1], 1), dtype=complex), np.ones((z.shape[1], 1), dtype=complex)
        if not many:
            return cls(rest=z[:, 0], pivot=complex(pivot[0, 0]), arm=complex(arm[0, 0]),
                       rest_angle=float(np.angle(arm[0, 0])), ground=z[list(g.ground), 0, None], constants=constants)
        return cls(rest=z, pivot=pivot, arm=arm, rest_angle=np.angle(arm), ground=z[list(g.ground), :, None],
                   constants=constants)


def _link_point(track: JointTrack | LinkTrack) -> tuple[float, float]:
    """The rest position of a point tracked on a link."""
    assert isinstance(track, LinkTrack)  # only link tracks add points beyond the joints
    return track.at


def _orientation(p: np.ndarray, i: int, j: int, k: int) -> int:
    u, v = p[j] - p[i], p[k] - p[i]
    cross = u[0] * v[1] - u[1] * v[0]
    scale = np.hypot(*u) * np.hypot(*v)
    return 0 if abs(cross) <= 1e-12 * scale else int(np.sign(cross))


def _fail_ordering(graph: LinkageGraph, mob: Mobility, undetermined: tuple[int, ...]) -> MechanismError:
    names = ", ".join(graph.joint_names[k] for k in undetermined)
    if mob.rank > 1:
        why = f"the linkage is under-constrained ({mob.describe()}; one motor drives 1)"
    else:
        why = ("neither a closed-form rule nor a numeric group places them: their link and slider "
               f"constraints do not fix them at the rest pose ({mob.describe()})")
    return MechanismError(f"joints {names} cannot be determined from the ground and the motor: {why}")


def characteristic_frame(rest: np.ndarray, ground: tuple[int, ...]) -> tuple[complex, float]:
    """(origin, scale): the first ground joint and the largest distance of a joint from it.

    Computed without overflow for any finite coordinates (each term is scaled first)."""
    o = rest[ground[0]]
    big = float(np.abs(rest).max())
    if big == 0.0:
        return complex(*o), 1.0
    d = (rest / big) - (o / big)
    scale = float(np.hypot(d[:, 0], d[:, 1]).max()) * big
    return complex(*o), (scale if np.isfinite(scale) and scale > 0.0 else 1.0)


def compile_plan(spec: LinkageSpec) -> Plan:
    """Order the joints (Algorithm 1) and build the batched plan.

    Raises :class:`MechanismError` for over- or under-constrained linkages, linkages that no
    rule (not even a numeric group) can order, and dyads that are collinear at the rest pose
    (whose branch is undefined). Every decision is taken in the normalized frame (origin at the
    first ground joint, unit = the characteristic length), so it does not depend on units.
    """
    original = LinkageGraph.from_spec(spec)
    origin, scale = characteristic_frame(original.rest, original.ground)
    o = np.array([origin.real, origin.imag])
    graph = original.with_rest((original.rest - o) / scale)
    mob = mobility(graph)
    ordering = order_joints(graph)
    if ordering.undetermined:
        raise _fail_ordering(graph, mob, ordering.undetermined)
    rest = graph.rest
    J = graph.n_joints
    rules = ordering.rules
    orientation = np.array([_orientation(rest, r.i, r.j, r.k) for r in rules], dtype=int)
    for r, sense in zip(rules, orientation):
        if not r.rigid and sense == 0:
            n = graph.joint_names
            raise MechanismError(
                f"joint {n[r.k]} is collinear with {n[r.i]} and {n[r.j]} at the rest pose (motor angle "
                f"{degrees_text(_rest_input(graph))}): the branch of its triangle is undefined; move it off the line")
    if mob.rank < 1:
        held = graph.joint_names[graph.motor]
        raise MechanismError(f"the linkage cannot move: it is over-constrained ({mob.describe()}): its links hold "
                             f"the motor's joint {held} still")
    if mob.rank > 1:
        raise MechanismError(f"the linkage is under-constrained ({mob.describe()}; one motor drives 1)")
    initial = set(graph.ground) | ({graph.motor} if graph.pivot >= 0 else set())
    steps = compile_steps(graph, ordering.steps, initial, {r.k: r.level for r in rules})

    # tracked points attached to links: rigid rules from the two farthest joints of the link
    level_of = {g: 0 for g in initial}
    level_of.update({r.k: r.level for r in rules})
    level_of.update({k: st.level for st in steps for k in st.joints})
    track_names: list[str] = []
    track_points: list[int] = []
    extra_rest: list[tuple[float, float]] = []
    extra_rules: list[tuple[int, int, int, int]] = []
    for name, track in spec.tracks.items():
        track_names.append(name)
        if isinstance(track, JointTrack):
            track_points.append(graph.joint_names.index(track.joint))
            continue
        li = graph.link_names.index(track.link)
        link = graph.links[li]
        i, j = max(((a, b) for a in link for b in link if a < b),
                    key=lambda p: np.hypot(*(rest[p[0]] - rest[p[1]])))
        point = J + len(extra_rest)
        extra_rest.append(track.at)
        earliest = max(level_of[i], level_of[j]) + 1  # join a rigid batch at or after it, if any
        extra_rules.append((i, j, point, min((r.level for r in rules if r.rigid and r.level >= earliest),
                                             default=earliest)))
        track_points.append(point)
    points = np.vstack([original.rest, np.array(extra_rest, dtype=float).reshape(-1, 2)])

    # rows: ground, motor, then per level: rigid batch, dyad batch, steps
    order = list(graph.ground) + ([graph.motor] if graph.pivot >= 0 else [])
    entries: list[tuple[int, bool, int, int, int, int]] = [
        (r.level, not r.rigid, idx, r.i, r.j, r.k) for idx, r in enumerate(rules)]
    entries += [(lv, False, -1, i, j, k) for i, j, k, lv in extra_rules]
    entries.sort(key=lambda e: (e[0], e[1]))
    row_of = np.empty(len(points), dtype=int)
    for row, p in enumerate(order):
        row_of[p] = row
    sequence: list[Rule] = []
    row = len(order)
    groups: dict[tuple[int, bool], list[tuple[int, bool, int, int, int, int]]] = {}
    for e in entries:
        groups.setdefault((e[0], e[1]), []).append(e)
    for level in sorted({lv for lv, _ in groups} | {st.level for st in steps}):
        for (lv, is_dyad), members in groups.items():
            if lv != level:
                continue
            for offset, e in enumerate(members):
                row_of[e[5]] = row + offset
            ip = np.array([e[3] for e in members])
            jp = np.array([e[4] for e in members])
            kp = np.array([e[5] for e in members])
            rule_idx = np.array([e[2] for e in members])
            sign = np.array([orientation[e[2]] if e[2] >= 0 else 1 for e in members], dtype=float)[:, None]
            kind = Dyad if is_dyad else Rigid
            sequence.append(kind(level=lv, start=row, stop=row + len(members), i=row_of[ip], j=row_of[jp],
                                 k_point=kp, i_point=ip, j_point=jp, rule=rule_idx, sign=sign,
                                 grounded=bool(np.isin(ip, graph.ground).all())))
            row += len(members)
        for st in steps:
            if st.level == level:
                row_of[st.joints] = row + np.arange(st.joints.size)
                row += st.joints.size
                sequence.append(st)
    ds_rows: list[slice] = []
    table_row, first = np.zeros(len(rules), dtype=int), 0
    for rule in sequence:
        ds_rows.append(slice(first, first + rule.ds_count()))
        listed = rule.table_entries()
        table_row[listed] = np.arange(first, first + listed.size)
        first = ds_rows[-1].stop
    table = TriangleTable(joints=np.array([(r.i, r.j, r.k) for r in rules], dtype=int).reshape(-1, 3),
                          level=np.array([r.level for r in rules], dtype=int),
                          rigid=np.array([r.rigid for r in rules], dtype=bool), orientation=orientation, row=table_row)
    return Plan(
        spec=spec, graph=original, mobility=mob, rules=tuple(sequence), ds_rows=tuple(ds_rows), table=table,
        row_of=row_of, ground_rows=row_of[list(graph.ground)], motor_row=int(row_of[graph.motor]),
        pivot_row=int(row_of[graph.pivot]) if graph.pivot >= 0 else -1, track_names=tuple(track_names),
        track_points=np.array(track_points, dtype=int), rest_points=points, origin=origin, scale=scale,
    )


def _rest_input(graph: LinkageGraph) -> float:
    """The motor angle at rest, degrees (0 for a linear input)."""
    if graph.pivot < 0:
        return 0.0
    return float(np.degrees(np.angle(complex(*(graph.rest[graph.motor] - graph.rest[graph.pivot])))))
