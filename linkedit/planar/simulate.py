"""Simulate a planar linkage over a motor cycle: the library's main entry point.

``simulate(spec_or_plan, samples)`` returns a :class:`Motion` with positions, velocities and
accelerations of every joint and track (derivatives with respect to the motor angle), and the
per-sample diagnostics. It raises :class:`MechanismError` when the linkage locks up anywhere,
unless ``partial=True``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar.diagnostics import LockUp, degrees_text, lockups, transmission_angle, triangle_orientation
from linkedit.planar.feasibility import CHECK_SAMPLES, TOGGLE, assembles, lowest
from linkedit.planar.kinematics import State, evaluate
from linkedit.planar.plan import Geometry, Plan, compile_plan
from linkedit.planar.rules import Failure
from linkedit.spec.common import require_count
from linkedit.spec.linkage import LinkageSpec, Motor

DEFAULT_SAMPLES = 360


@dataclass(frozen=True)
class Track:
    """Motion of one tracked point: (T, 2) arrays; derivatives per radian of motor angle."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


@dataclass(repr=False)
class Motion:
    """A simulated cycle. T samples, J joints, R triangle rules (``plan.table``), X steps (``plan.steps``)."""

    plan: Plan
    t: np.ndarray  #: (T,) motor phase: fraction of a revolution, or of the sweep for ``range_deg``
    motor_angle: np.ndarray  #: (T,) absolute motor (crank) angle, radians; a linear input's stroke (spec units)
    positions: np.ndarray  #: (T, J, 2)
    velocity: np.ndarray  #: (T, J, 2) d position / d motor angle
    acceleration: np.ndarray  #: (T, J, 2)
    tracks: dict[str, Track]
    singularity: np.ndarray  #: (T, R) d_s = sin²α per rule; 1 for rigid rules
    orientation: np.ndarray  #: (T, R) int8 orientation sign of each rule's triangle
    transmission: np.ndarray  #: (T, R) angle at the rebuilt joint, radians
    assembled: np.ndarray  #: (T,) bool
    lockups: list[LockUp] = field(default_factory=list)
    #: (T, X) singularity distance of each of ``plan.steps`` (slider: sin² of the rod's angle to
    #: the slot normal; numeric group: (det J / ∏ ‖row‖)² of its Jacobian; 1 otherwise)
    step_singularity: np.ndarray | None = None

    @property
    def cyclic(self) -> bool:
        return self.plan.spec.motor.cyclic

    def rule_ds(self) -> tuple[np.ndarray, np.ndarray]:
        """d_s (T, N) per row of the plan's rules (``Plan.ds_rows``; 1 where not measured) and
        (N,) whether each row was measured (a step's by the symbolic engine only)."""
        plan = self.plan
        ds = np.ones((self.t.size, plan.n_ds))
        known = np.zeros(plan.n_ds, dtype=bool)
        ds[:, plan.table.row] = self.singularity
        known[plan.table.row] = True
        if self.step_singularity is not None:
            ds[:, plan.step_rows] = self.step_singularity
            known[plan.step_rows] = True
        return ds, known

    def _watched(self) -> tuple[np.ndarray, list[str]] | None:
        """d_s (T, W) of the watched rules' rows (dyad, slider and group; NaN where not
        assembled), in evaluation order, and the joint each one places; None without any."""
        plan = self.plan
        ds, known = self.rule_ds()
        names = plan.joint_names
        rows: list[int] = []
        joints: list[str] = []
        for rule, own in zip(plan.rules, plan.ds_rows):
            if rule.watched and known[own].all():
                rows += range(own.start, own.stop)
                joints += [names[k] for k in rule.placed()]
        if not rows:
            return None
        return ds[:, np.array(rows, dtype=int)], joints

    def input_at(self, t: int) -> float:
        """The input at sample ``t``: motor angle in degrees, or a linear input's stroke."""
        return float(self.motor_angle[t] if self.plan.linear else np.degrees(self.motor_angle[t]))

    def describe_input(self, value: float) -> str:
        """An input ``value`` as :meth:`input_at` gives it, in words: ``motor angle 12.0°`` or ``stroke 5 mm``."""
        return f"stroke {value:.6g} {self.plan.spec.units}" if self.plan.linear else f"motor angle {degrees_text(value)}"

    def min_singularity(self) -> tuple[float, str, float] | None:
        """(min d_s over dyad, slider and group rules and assembled samples, its joint, the input
        there: motor angle in degrees, or a linear input's stroke)."""
        found = self._watched()
        if found is None or not self.assembled.any():
            return None
        ds = np.where(self.assembled[:, None], found[0], np.inf)
        t, r = np.unravel_index(np.argmin(ds), ds.shape)
        return float(ds[t, r]), found[1][r], self.input_at(int(t))

    def lowest_singularity(self) -> tuple[float, str, float] | None:
        """(the lower bound of d_s over the cycle, between samples too, its joint, the input at the
        sample it comes from), as :func:`linkedit.planar.feasibility.lowest` takes it from these
        samples (−1 where the linkage does not assemble); None without dyad, slider or group rules.
        Evenly spaced samples: ``simulate(plan, CHECK_SAMPLES)`` gives the density every command checks."""
        found = self._watched()
        if found is None:
            return None
        ds = found[0].T  # (W, T)
        low = lowest(ds, self.cyclic)
        r = int(np.argmin(low))
        t = int(np.argmin(np.nan_to_num(ds[r], nan=-np.inf)))
        return float(low[r]), found[1][r], self.input_at(t)

    def __repr__(self) -> str:
        s = self.summary()
        worst = s.get("min_singularity")
        ds = f", min d_s {worst['value']:.3g} at {worst['joint']}" if worst else ""
        locks = f", {len(self.lockups)} lock-up(s)" if self.lockups else ""
        return (f"<{type(self).__name__} {s['name']!r}: {s['samples']} samples, {s['joints']} joints, "
                f"{s['rules']} rules{ds}{locks}>")

    def summary(self) -> dict:
        """Key figures for printing or JSON."""
        out: dict = {
            "name": self.plan.spec.name, "units": self.plan.spec.units, "samples": int(self.t.size),
            "joints": self.plan.n_joints,
            "rules": int(len(self.plan.table.joints) + len(self.plan.steps)),
            "levels": int(self.plan.levels),
            "mobility": self.plan.mobility.rank, "assembled": bool(self.assembled.all()),
        }
        worst = self.min_singularity()
        if worst:
            where = "stroke" if self.plan.linear else "motor_angle_deg"
            out["min_singularity"] = {"value": worst[0], "joint": worst[1], where: worst[2]}
            dyads = ~self.plan.table.rigid
            if dyads.any():
                dev = np.abs(np.where(self.assembled[:, None], self.transmission, np.pi / 2)[:, dyads] - np.pi / 2)
                out["worst_transmission_angle_deg"] = float(90.0 - np.degrees(dev.max()))
        if self.lockups:
            out["lockups"] = [lk.describe() for lk in self.lockups]
            out["lockup_intervals"] = [lk.record() for lk in self.lockups]
        return out


def motor_phases(spec: LinkageSpec, samples: int) -> np.ndarray:
    """Phases t (T,): a full revolution or an ``oscillate_deg`` swing samples t = n/T (the end
    is the start); a ``range_deg`` sweep and a linear input's stroke include both ends."""
    if spec.motor.cyclic:
        return np.arange(samples) / samples
    return np.linspace(0.0, 1.0, samples) if samples > 1 else np.zeros(1)


def motor_turn(motor: Motor, t: np.ndarray) -> np.ndarray:
    """Motor rotation from the rest pose at phases ``t`` (T,), radians (signed by direction).

    The one time axis of linkedit: phase 0 of a full revolution is the rest pose. An
    ``oscillate_deg`` swing [a, b] goes a → b → a as a + (b − a)·(1 − cos 2πt)/2.
    """
    sign = 1.0 if motor.direction == "ccw" else -1.0
    if motor.oscillate_deg is not None:
        a, b = np.radians(motor.oscillate_deg)
        return sign * (a + (b - a) * 0.5 * (1.0 - np.cos(2.0 * np.pi * t)))
    if motor.range_deg is None:
        return sign * 2.0 * np.pi * t
    a, b = np.radians(motor.range_deg)
    return sign * (a + (b - a) * t)


def motor_input(motor: Motor, t: np.ndarray) -> np.ndarray:
    """The input's change from the rest pose at phases ``t`` (T,): the motor's rotation
    (:func:`motor_turn`, radians) or a linear input's stroke s0 + (s1 − s0)·t, the driven joint's
    displacement along its slot in the spec's units."""
    if motor.stroke is not None:  # a linear input
        s0, s1 = motor.stroke
        return s0 + (s1 - s0) * np.asarray(t, dtype=float)
    return motor_turn(motor, t)


def motor_angles(spec: LinkageSpec, samples: int, phases: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Phases t (T,) and input values (T,) for ``samples`` samples (or at the given ``phases``).

    Rotary: absolute motor angles, radians. Linear: the stroke, the driven joint's
    displacement from rest along its slot in the spec's units, from s0 to s1.
    """
    m = spec.motor
    t = motor_phases(spec, samples) if phases is None else np.asarray(phases, dtype=float)
    if m.joint is None or m.pivot is None:  # a linear input
        return t, motor_input(m, t)
    rest = np.arctan2(*(np.subtract(spec.joints[m.joint], spec.joints[m.pivot])[::-1]))
    return t, rest + motor_turn(m, t)


def _joint_order(plan: Plan, z: np.ndarray) -> np.ndarray:
    """Internal complex rows (P, T) → joint positions (T, J, 2)."""
    zj = z[plan.row_of[: plan.n_joints]].T
    return np.stack([zj.real, zj.imag], axis=-1)


def _check_constraints(plan: Plan, p: np.ndarray, ok: np.ndarray, value: np.ndarray, unit: str) -> None:
    """Every rigid-link and slider constraint must hold (relative to the linkage's size) at every
    assembled sample; only redundant (over-constrained) ones can fail here, and then the
    linkage cannot move as specified. ``p`` (T, J, 2) in the normalized frame."""
    from linkedit.planar.constraints import linkage_rows

    if not ok.any():
        return
    rows = linkage_rows(plan_graph_normalized(plan))
    z = (p[ok, :, 0] + 1j * p[ok, :, 1]).T
    s = value[ok] / plan.scale if plan.linear else 0.0
    d, e = rows.terms(z)
    size = np.maximum(np.abs(d) * np.abs(e), np.abs(e))  # distance rows are squares of lengths
    err = np.abs(rows.residual(z, s)) / np.maximum(size, 1.0)
    if err.size and err.max() > 1e-7:
        r, t = np.unravel_index(np.argmax(err), err.shape)
        where = value[ok][t]
        at = f"motor angle {degrees_text(np.degrees(where))}" if unit == "°" else f"input position {where:.6g} {unit}"
        raise MechanismError(
            f"{rows.labels[r]} cannot be kept at {at} (off by {err[r, t]:.3g} relative to its size): "
            f"the linkage is over-constrained ({plan.mobility.describe()})")


def plan_graph_normalized(plan: Plan):
    """The plan's linkage graph in the normalized frame."""
    o = np.array([plan.origin.real, plan.origin.imag])
    return plan.graph.with_rest((plan.graph.rest - o) / plan.scale)


def _unit(plan: Plan) -> str:
    return plan.spec.units if plan.linear else "°"


#: Bytes held per sample and joint while simulating (positions, velocities, accelerations and
#: their working copies, float64), for :func:`require_sample_memory`.
BYTES_PER_SAMPLE_JOINT = 2 * 3 * 8 * 8
#: Below this many bytes :func:`simulate` skips the memory check (reading the limits costs ~0.4 ms a call).
CHECK_MEMORY_FROM = 1 << 28


def require_sample_memory(samples: int, joints: int, **where: Any) -> None:
    """InputError (exit 2, placed by ``where``) if ``samples`` samples of ``joints`` joints would not fit in the
    memory available (:func:`linkedit.resources.require_memory`: cgroup and ``ulimit -v`` limits included)."""
    from linkedit.resources import require_memory

    require_memory(samples * joints * BYTES_PER_SAMPLE_JOINT, f"{samples:,} samples of {joints} joints", **where)


def simulate(linkage: LinkageSpec | Plan, samples: int | None = None, *, partial: bool = False,
             geometry: Geometry | None = None, phases: np.ndarray | None = None) -> Motion:
    """Simulate one motor cycle with ``samples`` samples (a whole number ≥ 1, else InputError;
    default: the spec's, else 360), or at the
    motor phases ``phases`` (T,), increasing from 0 within the cycle.

    With ``partial=True`` a linkage that locks up somewhere is still returned; its positions
    are NaN where ``assembled`` is False and ``lockups`` says where and why. The evaluation
    runs in the normalized frame (origin at the first ground joint, unit the characteristic
    length; scale-free) and is scaled back; a ``geometry`` given by the caller is used as is.
    """
    plan = linkage if isinstance(linkage, Plan) else compile_plan(linkage)
    spec = plan.spec
    if phases is not None:
        samples = len(phases)
    else:
        samples = spec.samples or DEFAULT_SAMPLES if samples is None else require_count(samples, "samples", 1)
    if samples * len(spec.joints) * BYTES_PER_SAMPLE_JOINT > CHECK_MEMORY_FROM:
        require_sample_memory(samples, len(spec.joints), field="samples")
    t, value = motor_angles(spec, samples, phases)
    if geometry is None:
        geom, origin, scale = Geometry.of(plan, plan.normalized_points()), plan.origin, plan.scale
    else:
        geom, origin, scale = geometry, 0j, 1.0
    inp = value / scale if plan.linear else value
    close = plan.has_groups and spec.motor.cyclic and samples > 1
    if close:  # continue once round the cycle and back to the first sample
        turn = plan.direction * 2.0 * np.pi if spec.motor.oscillate_deg is None else 0.0
        inp = np.append(inp, inp[0] + turn)
    state = evaluate(plan, geom, inp, order=2)
    if close:
        _check_closure(plan, state)
        dz, ddz = state.derivatives()
        state = State(z=state.z[:, :-1], dz=dz[:, :-1], ddz=ddz[:, :-1], ds=state.ds[:, :-1],
                      between_ok=state.between_ok)
    unit = _unit(plan)
    shown = value if plan.linear else np.degrees(value)

    pn = _joint_order(plan, state.z)  # normalized frame
    ds = state.ds.T.copy()
    ok = _assembled(pn, ds)
    found: list[LockUp] = []
    if not ok.all():
        found = _find_lockups(plan, pn, ds, unit, _edges(plan, geom, scale, t))
        if not partial or not ok.any():
            raise MechanismError(f"{spec.name}: " + "; ".join(lk.describe() for lk in found))
    else:
        if samples >= CHECK_SAMPLES:
            found = _toggles_passed(plan, pn, ds, shown, unit)
        elif samples < 2 or not plan.has_groups or not state.between_ok or \
                any(r.watched and not r.numeric for r in plan.rules):
            # (a group's own continuation checked it between two samples or more, not round the cycle from one)
            found = _lockups_between(plan, geom, scale)
        if found and not partial:
            raise MechanismError(f"{spec.name}: " + "; ".join(lk.describe() for lk in found))
    _check_constraints(plan, pn, ok, value, unit)

    o = np.array([origin.real, origin.imag])
    p = pn * scale + o
    p[:, list(plan.graph.ground)] = plan.graph.rest[list(plan.graph.ground)]  # exactly where they are
    dscale, ddscale = (1.0, 1.0 / scale) if plan.linear else (scale, scale)

    def rows(a: np.ndarray) -> np.ndarray:
        return _joint_order(plan, a)

    dz, ddz = state.derivatives()
    v, acc = rows(dz) * dscale, rows(ddz) * ddscale
    bad = ~ok
    for arr in (p, v, acc):
        arr[bad] = np.nan
    tracks = {}
    for name, point in zip(plan.track_names, plan.track_points):
        r = plan.row_of[point]

        def xy(a: np.ndarray, factor: float, shift: np.ndarray | float) -> np.ndarray:
            out = np.stack([a[r].real, a[r].imag], axis=-1) * factor + shift
            out[bad] = np.nan
            return out

        tracks[name] = Track(position=xy(state.z, scale, o), velocity=xy(dz, dscale, 0.0),
                             acceleration=xy(ddz, ddscale, 0.0))
    with np.errstate(invalid="ignore"):
        transmission = transmission_angle(pn, plan.table.joints, plan.table.rigid)
        orientation = triangle_orientation(pn, plan.table.joints)
    ds = np.where(ok[:, None], ds, np.nan)
    return Motion(plan=plan, t=t, motor_angle=value, positions=p, velocity=v, acceleration=acc,
                  tracks=tracks, singularity=ds[:, plan.table.row], orientation=orientation,
                  transmission=transmission, assembled=ok, lockups=found, step_singularity=ds[:, plan.step_rows])


def _assembled(pn: np.ndarray, ds: np.ndarray) -> np.ndarray:
    """(T,) whether every joint is placed at each sample: positions (T, J, 2), d_s of every rule
    row (T, N) (:func:`linkedit.planar.feasibility.assembles`)."""
    return np.isfinite(pn).all(axis=(1, 2)) & assembles(ds).all(axis=1)


def _lockups_between(plan: Plan, geom: Geometry, scale: float) -> list[LockUp]:
    """Lock-ups the requested samples step over: the cycle is checked again at CHECK_SAMPLES
    (positions only, batched); what fails there is reported as found between the samples."""
    spec = plan.spec
    t, value = motor_angles(spec, CHECK_SAMPLES)
    state = evaluate(plan, geom, value / scale if plan.linear else value, order=0)
    pn = _joint_order(plan, state.z)
    ds = state.ds.T
    shown = value if plan.linear else np.degrees(value)
    if _assembled(pn, ds).all():
        return _toggles_passed(plan, pn, ds, shown, _unit(plan))
    found = _find_lockups(plan, pn, ds, _unit(plan), _edges(plan, geom, scale, t))
    return [replace(lk, run=None, what=(lk.what or lk.because()) + " (found between the requested samples: "
                    "simulate with more samples to see it)") for lk in found]


def _toggles_passed(plan: Plan, pn: np.ndarray, ds: np.ndarray, shown: np.ndarray, unit: str) -> list[LockUp]:
    """Toggles that evenly spaced samples (CHECK_SAMPLES a cycle or more) step over while every
    sample assembles: a change point, where a closed-form rule's d_s touches 0 and rises again (a
    dyad stretched or folded, a rod perpendicular to its slot), and the side the rule keeps takes
    the linkage onto another branch there. A sampled local minimum of such a d_s row (``ds`` (T, N))
    whose parabola through its neighbours reaches 0 within the third difference (the parabola's own
    error) is reported as a toggle at the parabola's vertex; ``shown`` (T,) the inputs. (A numeric
    group's continuation watches its own determinant.)"""
    cols = np.array([c for rule, own in zip(plan.rules, plan.ds_rows) if rule.watched and not rule.numeric
                     for c in range(own.start, own.stop)], dtype=int)
    count = ds.shape[0]
    if cols.size == 0 or count < 5:
        return []
    d = ds[:, cols]
    before, after = np.roll(d, 1, axis=0), np.roll(d, -1, axis=0)
    second = before + after - 2.0 * d
    third = np.maximum(np.abs(np.roll(d, -2, axis=0) - 3.0 * after + 3.0 * d - before),
                       np.abs(after - 3.0 * d + 3.0 * before - np.roll(d, 2, axis=0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = d - (after - before) ** 2 / (8.0 * second)
    touch = (d <= before) & (d < after) & (second > 0.0) & (vertex <= third + TOGGLE)
    if not plan.spec.motor.cyclic:  # the ends have no neighbours on both sides
        touch[:2] = touch[-2:] = False
    owner, within = plan.ds_rule()
    rest = plan_graph_normalized(plan).rest
    out = []
    for t, c in np.argwhere(touch):
        r, shift = cols[c], (before - after)[t, c] / (2.0 * second[t, c])  # the vertex, in samples from t
        step = shown[t + 1] - shown[t] if t + 1 < count else shown[t] - shown[t - 1]
        rule = plan.rules[owner[r]]
        joint, inputs, stretched, what = rule.explain(plan.joint_names, int(within[r]),
                                                      Failure(pn, ds[:, plan.ds_rows[owner[r]]], rest, np.inf), int(t))
        where = float(shown[t] + shift * step)
        out.append(LockUp(start_deg=where, end_deg=where, joint=joint, inputs=inputs, stretched=stretched,
                          what=what + " (between two samples: a change point, where it could leave its branch)",
                          unit=unit))
    return out


#: a lock-up's edge is bracketed between its last assembled and first failing sample, and each
#: bracket is cut in SPLIT pieces REFINES times (to 2^-54 of it: the rounding of the phase)
SPLIT, REFINES = 64, 9


def _edges(plan: Plan, geom: Geometry, scale: float, t: np.ndarray) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, bool]]:
    """The ``edges`` of :func:`linkedit.planar.diagnostics.lockups` for samples at phases ``t`` (T,).

    Each run's start lies between its first failing sample and the assembled one before it, its
    end between its last and the one after (a full cycle wraps; a sweep's end bounds its run):
    the phase where it stops assembling (every d_s above TOGGLE, :func:`_assembled`) is found by
    cutting the bracket (:data:`SPLIT`) on the same evaluator, all boundaries in one batch per cut. A plan with numeric
    groups is continued from the rest pose and cannot be restarted between two samples: its
    edges are the assembled samples either side (not exact). A swing (``oscillate_deg``) turns
    back inside a run that holds phase 0 or ½."""
    spec, count = plan.spec, t.size
    cyclic = spec.motor.cyclic

    def shown(phase: np.ndarray) -> np.ndarray:
        value = motor_angles(spec, count, np.where((phase < 0.0) | (phase > 1.0), phase % 1.0, phase))[1]
        return value if plan.linear else np.degrees(value)

    def edges(run: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        bad = t[run]  # (R, 2) phases of the first and last failing samples
        prev, after = run[:, 0] - 1, run[:, 1] + 1
        good = np.stack([t[prev % count] - (prev < 0), t[after % count] + (after >= count)], axis=1)
        inside = cyclic | np.stack([prev >= 0, after < count], axis=1)  # else the sweep's end bounds the run
        phase = np.where(inside, good, bad)
        if not plan.has_groups and inside.any():
            lo, hi = good[inside], bad[inside]
            cut = np.arange(1, SPLIT) / SPLIT
            for _ in range(REFINES):  # each bracket cut in SPLIT: the first failing piece is kept
                at = lo[:, None] + (hi - lo)[:, None] * cut  # (B, SPLIT − 1)
                value = motor_angles(spec, count, at.ravel())[1]
                state = evaluate(plan, geom, value / scale if plan.linear else value, order=0)
                ok = np.c_[_assembled(_joint_order(plan, state.z), state.ds.T).reshape(at.shape), np.zeros(len(lo), bool)]
                k = ok.argmin(axis=1)  # the first failing point (SPLIT − 1: hi itself)
                lo, hi = np.where(k > 0, at[np.arange(len(lo)), k - 1], lo), np.c_[at, hi][np.arange(len(lo)), k]
            phase[inside] = 0.5 * (lo + hi)
        turns = np.full(len(run), np.nan)
        if spec.motor.oscillate_deg is not None:
            start = phase[:, 0] % 1.0
            end = start + (phase[:, 1] - phase[:, 0]) % 1.0  # the run's phases, start ≤ end
            back = np.ceil(2.0 * start) / 2.0  # the first turning phase (a multiple of ½) from its start
            turns = np.where(back <= end, shown(back), np.nan)
        return shown(phase), turns, not plan.has_groups

    return edges


def _find_lockups(plan: Plan, pn: np.ndarray, ds: np.ndarray, unit: str,
                  edges: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, bool]]) -> list[LockUp]:
    """Lock-up intervals of the rules' d_s rows (T, N), in evaluation order (see :func:`lockups`);
    each rule explains its own rows."""
    finite = np.isfinite(pn).all(axis=2)  # (T, J)
    bad = ~assembles(ds)
    placed = np.hstack([rule.inputs_placed(finite) for rule in plan.rules]) if plan.rules \
        else np.zeros((pn.shape[0], 0), dtype=bool)
    own = (ds <= TOGGLE) | (bad & placed)
    owner, within = plan.ds_rule()
    rest = plan_graph_normalized(plan).rest
    names = plan.joint_names

    def explain(r: int, t: int) -> tuple[str, tuple[str, str], bool, str]:
        rule = plan.rules[owner[r]]
        return rule.explain(names, int(within[r]), Failure(pn, ds[:, plan.ds_rows[owner[r]]], rest, TOGGLE), t)

    return lockups(bad, own, plan.spec.motor.cyclic, explain, edges, unit)


def _check_closure(plan: Plan, state: State) -> None:
    """After one full cycle every step must be back where it started (same branch, :meth:`Step.closure`)."""
    for step in plan.steps:
        z = state.z[plan.row_of[step.joints]]
        why = step.closure(z[:, 0], z[:, -1], plan.scale, plan.spec.units)
        if why is not None:
            raise MechanismError(f"{plan.spec.name}: {why}: it changed assembly branch")
