"""Families built on a catalog linkage: Jansen's and Klann's legs, Watt and Stephenson six-bars.

A family's parameters are the rest-pose coordinates of all joints (x₀, y₀, x₁, y₁, … in the
catalog spec's joint order), in a family frame: the catalog linkage moved so its motor pivot (a
linear input's: its first ground joint) is at the origin and scaled to a largest extent of 1. The
distribution keeps that joint and moves every other joint by N(0, s²) per coordinate, s
log-uniform in [0.005, 0.08] per linkage.

One cycle of the input: a crank's full turn; an oscillating crank's swing ``oscillate_deg`` [a, b]
a → b → a as ``simulate`` has it, a + (b − a)·(1 − cos 2πt)/2; a linear input's stroke [s0, s1]
out and back by the same law (its tracked point retraces its path: an open curve's, as
``synthesize`` queries an open target).

Evaluation is the planar engine's own (:func:`linkedit.planar.kinematics.evaluate` with a
:class:`~linkedit.planar.plan.Geometry` of K linkages): every batch of the compiled plan is one
array operation over linkages and samples; each linkage keeps the catalog design's triangle
orientations (its branch). A linkage works
by the one planar predicate (:mod:`linkedit.planar.feasibility`): it assembles at every one of
its ``CHECK_SAMPLES`` crank samples, and the lower bound of d_s between them stays at or above
the margin (sin² 20° in an atlas).

The built-in four-bar and slider-crank families evaluate the same way: their parameters (lengths,
side, coupler point) give the constants of their plan directly (:meth:`CatalogFamily.geometry`,
:func:`constant_geometry`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cached_property
from typing import Any

import numpy as np

from linkedit.planar import catalog, compile_plan
from linkedit.planar.feasibility import CHECK_SAMPLES, assembles, lowest, margin_of, works
from linkedit.planar.kinematics import State, _evaluate, evaluate
from linkedit.planar.plan import Geometry, Plan
from linkedit.planar.rules import Slider, Triangles
from linkedit.spec.linkage import JointTrack, LinkageSpec

MU_MIN_DEG = 20.0
#: With a margin, every SCREEN-th of the CHECK_SAMPLES is evaluated first: a linkage already below the
#: margin there fails it (those samples are among the dense ones), and only the others are evaluated densely.
SCREEN = 32
#: Linkages evaluated together at the dense samples (their working arrays stay in the CPU cache).
BLOCK = 64


class CatalogFamily:
    """A family around one catalog linkage, tracking one of its joints."""

    def __init__(self, name: str, family_id: int, build: Callable[[], LinkageSpec], track: str) -> None:
        self.NAME, self.ID, self.track = name, family_id, track
        spec = build()
        # the family's curve is this track's alone: a point on a link would add a plan point no parameter gives
        spec = spec.model_copy(update={"tracks": {track: spec.tracks[track]}})
        self.spec = spec
        self.plan = compile_plan(spec)
        names = self.plan.joint_names
        rest = np.array([spec.joints[n] for n in names], dtype=float)
        motor, tracked = spec.motor, spec.tracks[track]
        if motor.range_deg is not None or not isinstance(tracked, JointTrack):
            raise ValueError(f"family {name!r}: needs a cyclic input (no range_deg) and a tracked joint")
        #: the joint kept at the family frame's origin: the motor pivot, or a linear input's first ground joint
        self.pivot = names.index(motor.pivot if motor.pivot is not None else spec.ground[0])
        self.track_joint = names.index(tracked.joint)
        self.ground = [names.index(g) for g in spec.ground]
        self.direction = 1.0 if spec.motor.direction == "ccw" else -1.0
        self.size = float(np.ptp(rest, axis=0).max())
        #: a swing's input range from the rest pose: oscillate_deg (radians) or the stroke (family
        #: frame); None for a full-turn crank
        self.swing: tuple[float, float] | None = None
        if motor.oscillate_deg is not None:
            self.swing = (float(np.radians(motor.oscillate_deg[0])), float(np.radians(motor.oscillate_deg[1])))
        elif motor.stroke is not None:
            self.swing = (motor.stroke[0] / self.size, motor.stroke[1] / self.size)
        self.base = ((rest - rest[self.pivot]) / self.size).ravel()
        self.PARAMETERS = tuple(f"{n}_{axis}" for n in names for axis in "xy")
        #: the d_s rows the margin holds: every watched rule's (dyads, sliders, slotted links)
        self.watched = np.array([r for rule, rows in zip(self.plan.rules, self.plan.ds_rows) if rule.watched
                                 for r in range(rows.start, rows.stop)], dtype=int)

    def margin(self, margin_deg: float = MU_MIN_DEG) -> float:
        """The singularity margin its linkages keep in the transmission band [μ, 180° − μ] (μ = ``margin_deg``;
        an atlas linkage's: MU_MIN_DEG): sin² μ; with a numeric group (whose d_s is the Hadamard ratio of its
        Jacobian, not a transmission angle's sin²), at most its design's own lowest d_s: linkages as far from
        singular as it, in the atlas and through synthesis alike."""
        band = margin_of(margin_deg)
        return min(band, self.design_margin) if self.plan.has_groups and self.design_margin > 0.0 else band

    @cached_property
    def design_margin(self) -> float:
        """The design's lowest d_s over its cycle (:meth:`min_singularity`; −1: it does not assemble)."""
        return float(self.min_singularity(self.base[None])[0])

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """Rest poses around the catalog design: every coordinate but the motor pivot's moved by
        N(0, s²), s log-uniform in [0.005, 0.08] (family frame, largest extent 1)."""
        spread = np.exp(rng.uniform(np.log(0.005), np.log(0.08), (count, 1)))
        rows = self.base[None, :] + spread * rng.normal(size=(count, len(self.base)))
        rows[:, 2 * self.pivot:2 * self.pivot + 2] = 0.0
        return rows

    def geometry(self, params: np.ndarray) -> Geometry:
        """The plan's constants for K parameter rows (K, P): here the rows are rest poses."""
        return Geometry.of(self.plan, params.reshape(len(params), -1, 2))

    def _state(self, params: np.ndarray, samples: int, phase: np.ndarray | float, distances: bool = True) -> State:
        """The planar engine's one evaluation with a linkage axis: rows (P, K, T) at motor phases
        ``phase`` + t/T, t = 0..T−1 (``phase`` a number or (K,); a swinging input: :meth:`turn`). Linkages that share their rest
        angle and phase turn through common angles (T,) (cheaper: :func:`~linkedit.planar.kinematics.turn_arm`).
        Without ``distances``: positions alone (the state's ``ds`` has no rows)."""
        geom = self.geometry(params)
        turn = self.turn(np.asarray(phase, dtype=float).reshape(-1, 1) + np.arange(samples)[None, :] / samples)
        rest = np.asarray(geom.rest_angle)
        if self.plan.linear:
            angle = turn
        elif turn.shape[0] == 1 and (rest == rest.flat[0]).all():
            angle = rest.flat[0] + self.direction * turn[0]
        else:
            angle = geom.rest_angle + self.direction * turn
        if self.plan.has_groups:  # a complex loop: each linkage continued from its rest pose (evaluate's grid)
            return evaluate(self.plan, geom, angle, order=0)
        return _evaluate(self.plan, geom, angle, order=0, distances=distances)

    def _evaluate(self, params: np.ndarray, samples: int, phase: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions (K, J, T) complex and d_s (K, D, T) of the D watched rule rows (NaN or < 0
        where a joint cannot be placed)."""
        state = self._state(params, samples, phase)
        z = state.z[self.plan.row_of[: self.plan.n_joints]]  # (J, K, T)
        return z.transpose(1, 0, 2), state.ds[self.watched].transpose(1, 0, 2)

    def pose(self, row: np.ndarray, phase: float) -> list[complex]:
        """The joints of parameter ``row`` at motor phase ``phase``, family frame (plan joint order)."""
        return [complex(z) for z in self._evaluate(row[None], 1, phase)[0][0, :, 0]]

    def turn(self, t: np.ndarray) -> np.ndarray:
        """The input's change from the rest pose at phases ``t``: the crank's rotation (radians,
        ccw-positive before the motor's direction), or a linear input's stroke (family frame)."""
        if self.swing is None:
            return 2.0 * np.pi * t
        a, b = self.swing
        return a + (b - a) * 0.5 * (1.0 - np.cos(2.0 * np.pi * t))

    def min_singularity(self, params: np.ndarray, margin: float | None = None) -> np.ndarray:
        """The lowest d_s over the cycle (K,): :func:`linkedit.planar.feasibility.lowest` of the dyads
        at ``CHECK_SAMPLES`` crank samples, −1 where a joint cannot be placed. With ``margin``, a
        linkage already below it at one of every ``SCREEN``-th sample gets the smallest of those
        (an upper bound, below the margin all the same: the verdict of
        :func:`~linkedit.planar.feasibility.works` is that of the dense check)."""
        out = np.empty(len(params))
        dense = np.ones(len(params), dtype=bool)
        if margin is not None:
            coarse = self._evaluate(params, CHECK_SAMPLES // SCREEN, 0.0)[1]
            with np.errstate(invalid="ignore"):
                sampled = np.where(assembles(coarse).all(axis=(1, 2)), coarse.min(axis=(1, 2), initial=np.inf), -1.0)
            dense = works(sampled, margin)
            out[~dense] = sampled[~dense]
        rows = np.flatnonzero(dense)
        for start in range(0, rows.size, BLOCK):
            block = rows[start:start + BLOCK]
            out[block] = lowest(self._evaluate(params[block], CHECK_SAMPLES, 0.0)[1]).min(axis=1, initial=np.inf)
        return out

    def curves(self, params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
        """The tracked joint's curves (K, T) complex, family frame (K may be 0)."""
        if not len(params):
            return np.empty((0, samples), dtype=complex)
        return self._state(params, samples, phase, distances=False).z[self.plan.row_of[self.track_joint]].copy()

    def to_spec(self, row: np.ndarray, *, phase: float, scale: float, turn: complex, shift: complex, mirrored: bool,
                name: str, units: str, description: str, reversed: bool = False) -> LinkageSpec:
        """The linkage of ``row`` at crank phase ``phase``, placed like :func:`linkedit.synthesis.fourbar.to_spec`."""
        pose = np.array(self.pose(row, phase))
        placed = shift + scale * turn * (np.conj(pose) if mirrored else pose)
        flip = {"ccw": "cw", "cw": "ccw"}
        motor = self.spec.motor
        if not self.plan.linear:  # a linear input has no sense of rotation
            motor = motor.model_copy(update={"direction": (motor.direction if mirrored == reversed else
                                                           flip[motor.direction])})
        if self.swing is not None:  # the swing from the new rest pose (at ``phase``): its t = 0 stays phase 0
            at = float(self.turn(np.array(phase)))
            a, b = (v - at for v in self.swing)
            motor = motor.model_copy(update={"stroke": (scale * a, scale * b)} if self.plan.linear else
                                     {"oscillate_deg": (float(np.degrees(a)), float(np.degrees(b)))})
        data = self.spec.model_dump(mode="python")
        data.update(name=name, units=units, description=description,
                    joints={n: [float(p.real), float(p.imag)] for n, p in zip(self.plan.joint_names, placed)},
                    motor=motor.model_dump(mode="python"),
                    tracks={"target": {"joint": self.plan.joint_names[self.track_joint]}},
                    sliders=self._sliders(row.reshape(-1, 2), pose, turn, mirrored))
        return LinkageSpec.model_validate(data)

    def _sliders(self, rest: np.ndarray, pose: np.ndarray, turn: complex, mirrored: bool) -> dict:
        """The spec's sliders at ``pose`` (J,) complex, placed: a slot's direction turns with its
        guide from the rest pose ``rest`` (J, 2) (family frame), then with the placement."""
        g = self.plan.graph
        start = rest[:, 0] + 1j * rest[:, 1]
        out = {}
        for s, (name, slider) in zip(g.sliders, self.spec.sliders.items()):
            direction = np.exp(1j * s.angle)
            if not g.fixed(s.guide):
                a, b = g.frame_pair(s.guide)
                direction *= (pose[b] - pose[a]) / (start[b] - start[a])
            direction = turn * (np.conj(direction) if mirrored else direction)
            out[name] = slider.model_copy(update={"angle_deg": float(np.degrees(np.angle(direction)))}).model_dump(
                mode="python")
        return out


def constant_geometry(plan: Plan, *, pivot: complex, arm: np.ndarray, ground: tuple[complex, ...],
                      constants: tuple[tuple[Any, ...], ...]) -> Geometry:
    """The :class:`~linkedit.planar.plan.Geometry` of K linkages of ``plan`` given by their
    constants rather than a rest pose: the motor ``pivot`` (one for all), ``arm`` (K, 1) the crank
    pin − pivot at rest, the ground joints' positions (in ``plan.graph.ground`` order) and each
    rule's constants (:meth:`~linkedit.planar.rules.base.Rule.constants`' shapes, K linkages).
    Its ``rest`` is NaN: an evaluation of K linkages reads only the constants (a plan without a
    numeric group, the one rule that starts from rest points)."""
    count = len(arm)
    arm = np.asarray(arm, dtype=complex)
    return Geometry(rest=np.full((plan.n_points, count), np.nan, dtype=complex),
                    pivot=np.full((count, 1), pivot, dtype=complex), arm=arm, rest_angle=np.angle(arm),
                    ground=np.array(ground, dtype=complex)[:, None, None] * np.ones((1, count, 1)), constants=constants)


def expect_rules(plan: Plan, *rules: tuple[str, tuple[str, ...]]) -> None:
    """Check that ``plan`` is the sequence ``rules`` (kind, joints read then the joint written) a
    family's :meth:`CatalogFamily.geometry` gives the constants of; ValueError otherwise."""
    joints = plan.joint_names
    names = [joints[p] if p < len(joints) else f"point {p}" for p in range(plan.n_points)]
    have: list[tuple[str, tuple[str, ...]]] = []
    for rule in plan.rules:
        if isinstance(rule, Triangles):
            have += [(rule.kind, tuple(names[p] for p in (i, j, k)))
                     for i, j, k in zip(rule.i_point, rule.j_point, rule.k_point)]
        elif isinstance(rule, Slider):
            have.append((rule.kind, (names[rule.i], names[rule.joints[0]])))
        else:
            have.append((rule.kind, ()))
    if have != list(rules):
        raise ValueError(f"family {plan.spec.name!r}: its plan is {have}, not {list(rules)}")


JANSEN = CatalogFamily("jansen", 2, catalog.jansen_leg, "foot")
KLANN = CatalogFamily("klann", 3, catalog.klann_leg, "foot")
WATT = CatalogFamily("watt", 4, catalog.watt_six_bar, "output_tip")
STEPHENSON = CatalogFamily("stephenson", 5, catalog.stephenson_six_bar, "coupler_point")
