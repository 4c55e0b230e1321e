"""Evaluate a plan over many motor angles at once: positions, velocities, accelerations.

All arrays are complex (x + iy) with rows in the plan's internal order: shape (P, T) for P
points and T samples. One Python iteration per batch (a level's rigid or dyad rules), never
per sample. Derivatives are with respect to the motor angle, propagated analytically through
the same rules.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar import law_of_cosines as loc
from linkedit.planar.plan import Geometry, Plan


@dataclass
class State:
    """Evaluated plan. ``z``, ``dz``, ``ddz``: (P, T) complex in internal rows; ``ds``: (R, T)."""

    z: np.ndarray
    dz: np.ndarray | None
    ddz: np.ndarray | None
    ds: np.ndarray | None  # singularity distance per rule (1 for rigid rules); < 0: cannot close


def positions(plan: Plan, geom: Geometry, angle: np.ndarray) -> np.ndarray:
    """Positions only, (P, T) complex, for absolute motor angles ``angle`` (T,) in radians.

    NaN where the linkage cannot be assembled (see :func:`evaluate` for diagnostics).
    """
    z = np.empty((plan.n_points, angle.shape[0]), dtype=complex)
    z[plan.ground_rows] = geom.ground
    z[plan.motor_row] = geom.pivot + geom.arm * np.exp(1j * (angle - geom.rest_angle))
    for n, b in enumerate(plan.batches):
        zi = z[b.i]
        if b.rigid:
            z[b.start:b.stop] = loc.rigid(zi, z[b.j], geom.coef[n])
        else:
            with np.errstate(invalid="ignore", divide="ignore"):
                z[b.start:b.stop] = loc.dyad(zi, z[b.j], geom.half_diff[n], geom.lik2[n], b.sign)[0]
    return z


def evaluate(plan: Plan, geom: Geometry, angle: np.ndarray, order: int = 2) -> State:
    """Positions and up to ``order`` (0, 1, 2) derivatives, plus singularity distances."""
    T = angle.shape[0]
    P = plan.n_points
    z = np.empty((P, T), dtype=complex)
    dz = np.zeros((P, T), dtype=complex) if order >= 1 else None
    ddz = np.zeros((P, T), dtype=complex) if order >= 2 else None
    ds = np.ones((len(plan.rules), T))
    z[plan.ground_rows] = geom.ground
    arm = geom.arm * np.exp(1j * (angle - geom.rest_angle))
    z[plan.motor_row] = geom.pivot + arm
    if dz is not None:
        dz[plan.motor_row] = 1j * arm
    if ddz is not None:
        ddz[plan.motor_row] = -arm
    with np.errstate(invalid="ignore", divide="ignore"):
        for n, b in enumerate(plan.batches):
            out = slice(b.start, b.stop)
            if b.rigid:
                c = geom.coef[n]
                z[out] = loc.rigid(z[b.i], z[b.j], c)
                if dz is not None:
                    dz[out] = loc.rigid(dz[b.i], dz[b.j], c)
                if ddz is not None:
                    ddz[out] = loc.rigid(ddz[b.i], ddz[b.j], c)
                continue
            half, lik2 = geom.half_diff[n], geom.lik2[n]
            z[out], terms = loc.dyad(z[b.i], z[b.j], half, lik2, b.sign)
            public = b.rule >= 0
            ds[b.rule[public]] = loc.singularity_distance(terms, lik2, geom.ljk2[n])[public]
            if dz is not None:
                dz[out], de, du, dw = loc.dyad_velocity(terms, dz[b.i], dz[b.j], half, lik2)
                if ddz is not None:
                    ddz[out] = loc.dyad_acceleration(terms, de, du, dw, ddz[b.i], ddz[b.j], half, lik2)
    return State(z=z, dz=dz, ddz=ddz, ds=ds)
