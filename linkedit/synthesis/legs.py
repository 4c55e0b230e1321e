"""Families built on a catalog linkage: Jansen's and Klann's legs, Watt and Stephenson six-bars.

A family's parameters are the rest-pose coordinates of all joints (x₀, y₀, x₁, y₁, … in the
catalog spec's joint order), in a family frame: the catalog linkage moved so its motor pivot is
at the origin and scaled to a largest extent of 1. The distribution keeps the motor pivot and
moves every other joint by N(0, s²) per coordinate, s log-uniform in [0.005, 0.08] per linkage.

Evaluation follows the linkage's compiled plan (:mod:`linkedit.planar.plan`: the same rules in
the same order), with each linkage's lengths, rigid coefficients and triangle orientations as
(K, 1) arrays: every rule is one array operation over linkages and samples. A linkage is kept
when it assembles at every one of ``CHECK_SAMPLES`` crank samples with min d_s ≥ sin² 20°.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from linkedit.planar import catalog, compile_plan
from linkedit.planar.law_of_cosines import dyad
from linkedit.spec.linkage import JointTrack, LinkageSpec

#: Crank samples at which a linkage must assemble with the margin.
CHECK_SAMPLES = 64
MU_MIN_DEG = 20.0


class CatalogFamily:
    """A family around one catalog linkage, tracking one of its joints."""

    def __init__(self, name: str, family_id: int, build: Callable[[], LinkageSpec], track: str) -> None:
        self.NAME, self.ID, self.track = name, family_id, track
        spec = build()
        self.spec = spec
        self.plan = compile_plan(spec)
        names = self.plan.joint_names
        rest = np.array([spec.joints[n] for n in names], dtype=float)
        motor, tracked = spec.motor, spec.tracks[track]
        if motor.joint is None or motor.pivot is None or not isinstance(tracked, JointTrack):
            raise ValueError(f"family {name!r}: needs a crank and a tracked joint")
        self.pivot = names.index(motor.pivot)
        self.motor = names.index(motor.joint)
        self.track_joint = names.index(tracked.joint)
        self.ground = [names.index(g) for g in spec.ground]
        self.direction = 1.0 if spec.motor.direction == "ccw" else -1.0
        self.size = float(np.ptp(rest, axis=0).max())
        self.base = ((rest - rest[self.pivot]) / self.size).ravel()
        self.PARAMETERS = tuple(f"{n}_{axis}" for n in names for axis in "xy")

    def margin(self) -> float:
        return float(np.sin(np.radians(MU_MIN_DEG)) ** 2)

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """Rest poses around the catalog design: every coordinate but the motor pivot's moved by
        N(0, s²), s log-uniform in [0.005, 0.08] (family frame, largest extent 1)."""
        spread = np.exp(rng.uniform(np.log(0.005), np.log(0.08), (count, 1)))
        rows = self.base[None, :] + spread * rng.normal(size=(count, len(self.base)))
        rows[:, 2 * self.pivot:2 * self.pivot + 2] = 0.0
        return rows

    def _evaluate(self, params: np.ndarray, samples: int, phase: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions (K, J, T) complex and min d_s (K,) (−1 where a joint cannot be placed)."""
        count = len(params)
        rest = params.reshape(count, -1, 2)
        rest = rest[..., 0] + 1j * rest[..., 1]  # (K, J)
        z = np.empty((count, rest.shape[1], samples), dtype=complex)
        for g in self.ground:
            z[:, g, :] = rest[:, g, None]
        angle = 2.0 * np.pi * (np.asarray(phase, dtype=float).reshape(-1, 1) + np.arange(samples)[None, :] / samples)
        pivot = rest[:, self.pivot, None]
        z[:, self.motor, :] = pivot + (rest[:, self.motor, None] - pivot) * np.exp(1j * self.direction * angle)
        worst = np.full(count, np.inf)
        with np.errstate(invalid="ignore", divide="ignore"):
            for (i, j, k), rigid in zip(self.plan.rules, self.plan.rigid):
                ri, rj, rk = rest[:, i, None], rest[:, j, None], rest[:, k, None]
                if rigid:
                    z[:, k, :] = z[:, i, :] + (rk - ri) / (rj - ri) * (z[:, j, :] - z[:, i, :])
                    continue
                lik2, ljk2 = np.abs(rk - ri) ** 2, np.abs(rk - rj) ** 2
                sign = np.sign(((rj - ri).conjugate() * (rk - ri)).imag)
                z[:, k, :], terms = dyad(z[:, i, :], z[:, j, :], 0.5 * (lik2 - ljk2), lik2, sign)
                d2 = 1.0 / terms.u
                cos_k = (lik2 + ljk2 - d2) / (2.0 * np.sqrt(lik2 * ljk2))
                ds = np.where(terms.bsq >= 0.0, 1.0 - cos_k * cos_k, -1.0)
                worst = np.minimum(worst, np.nan_to_num(ds, nan=-1.0).min(axis=1))
        return z, worst

    def min_singularity(self, params: np.ndarray) -> np.ndarray:
        """min d_s over ``CHECK_SAMPLES`` crank samples (K,); −1 where the linkage does not assemble."""
        return self._evaluate(params, CHECK_SAMPLES, 0.0)[1]

    def curves(self, params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
        """The tracked joint's curves (K, T) complex, family frame."""
        return self._evaluate(params, samples, phase)[0][:, self.track_joint, :]

    def to_spec(self, row: np.ndarray, *, phase: float, scale: float, turn: complex, shift: complex, mirrored: bool,
                name: str, units: str, description: str, reversed: bool = False) -> LinkageSpec:
        """The linkage of ``row`` at crank phase ``phase``, placed like :func:`linkedit.synthesis.fourbar.to_spec`."""
        pose = self._evaluate(row[None], 1, phase)[0][0, :, 0]
        placed = shift + scale * turn * (np.conj(pose) if mirrored else pose)
        flip = {"ccw": "cw", "cw": "ccw"}
        motor = self.spec.motor.model_copy(update={"direction": (self.spec.motor.direction if mirrored == reversed else
                                                                 flip[self.spec.motor.direction])})
        data = self.spec.model_dump(mode="python")
        data.update(name=name, units=units, description=description,
                    joints={n: [float(p.real), float(p.imag)] for n, p in zip(self.plan.joint_names, placed)},
                    motor=motor.model_dump(mode="python"),
                    tracks={"target": {"joint": self.plan.joint_names[self.track_joint]}})
        return LinkageSpec.model_validate(data)


JANSEN = CatalogFamily("jansen", 2, catalog.jansen_leg, "foot")
KLANN = CatalogFamily("klann", 3, catalog.klann_leg, "foot")
WATT = CatalogFamily("watt", 4, catalog.watt_six_bar, "output_tip")
STEPHENSON = CatalogFamily("stephenson", 5, catalog.stephenson_six_bar, "coupler_point")
