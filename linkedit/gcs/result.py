"""A solved 3D mechanism over time (its HDF5 file, kind="gcs": :mod:`linkedit.io.gcs_hdf5`).

The member states are kept, so new tracked points are evaluated from them without solving
again (:meth:`GcsResult.add_track`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from linkedit.errors import InputError, MechanismError
from linkedit.gcs.diagnostics import Diagnostics
from linkedit.gcs.outputs import ends_meet, track_positions, track_velocities, velocity
from linkedit.gcs.tolerances import STATUS_NAMES

KIND = "gcs"


@dataclass
class Track3D:
    """A tracked member point: position and velocity (T, 3), d/dt with t ∈ [0, 1]; ``cyclic``:
    the run is one period of its inputs and the curve's ends meet."""

    member: str
    point: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    cyclic: bool


@dataclass(repr=False)
class GcsResult:
    """Member states, tracks and diagnostics of a solved run (T steps, M members, C constraints)."""

    name: str
    units: str
    t: np.ndarray
    member_names: list[str]
    position: np.ndarray  #: (T, M, 3)
    orientation: np.ndarray  #: (T, M, 4) unit quaternions [w, x, y, z], member → world
    #: (T, M, 6) exact member velocities: d position / dt and world angular velocity (rad / t)
    velocity: np.ndarray
    #: (T, M, 6) exact member accelerations: d² position / dt² and world angular acceleration
    #: (rad / t²); None unless asked for (``solve3d --accelerations``)
    acceleration: np.ndarray | None
    velocity_rule: str  #: "exact" or "parabola": how track velocities are taken
    periodic: bool  #: the run is one period of its inputs (outputs.periodic_inputs)
    constraint_names: list[str]
    constraint_inputs: np.ndarray  #: (C,) bool
    diagnostics: Diagnostics
    iterations: np.ndarray  #: (T,)
    points: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    lines: dict[str, list[list[str]]] = field(default_factory=dict)
    tracks: dict[str, Track3D] = field(default_factory=dict)
    spec_text: str = ""
    options: dict[str, Any] = field(default_factory=dict)

    def member_index(self, member: str) -> int:
        if member not in self.member_names:
            raise InputError(f"unknown member {member!r} (members: {', '.join(self.member_names)})", field="--track")
        return self.member_names.index(member)

    def add_track(self, name: str, member: str, point: np.ndarray) -> Track3D:
        """Evaluate a member point (3,) at every stored step; no solving."""
        m = self.member_index(member)
        p = track_positions(self.position, self.orientation, m, point)
        closed = self.periodic and ends_meet(p)
        if self.velocity_rule == "parabola":
            v = velocity(self.t, p, cyclic=closed)
        else:
            v = track_velocities(self.orientation[:, m], self.velocity[:, m], point)
        track = Track3D(member=member, point=np.asarray(point, dtype=float), position=p, velocity=v, cyclic=closed)
        self.tracks[name] = track
        return track

    def __repr__(self) -> str:
        s = self.summary()
        status = ", ".join(f"{n.replace('_', ' ')} {c}" for n, c in s["status"].items() if c)
        return (f"<{type(self).__name__} {self.name!r}: {s['steps']} steps, {s['members']} members, "
                f"{s['constraints']} constraints; {status}>")

    def summary(self) -> dict[str, Any]:
        """Counts and ranges for ``--json``; a non-finite number is None (JSON has no NaN or inf)."""
        d = self.diagnostics
        counts = {n: int(np.sum(d.status == i)) for i, n in enumerate(STATUS_NAMES)}
        out: dict[str, Any] = {
            "name": self.name, "steps": int(self.t.size), "members": len(self.member_names),
            "constraints": len(self.constraint_names), "status": counts,
            "max_residual": _finite_or_none(d.residual.max(initial=0.0)),
            "dof": sorted({int(x) for x in d.dof}), "redundant": sorted({int(x) for x in d.redundant}),
            "dof_evaluated_steps": int(np.sum(d.dof_evaluated)),
            "redundant_constraints": list(d.redundant_names),
            "iterations_per_step": float(self.iterations.mean()) if self.iterations.size else 0.0,
            "tracks": {n: {"member": tr.member, "point": tr.point.tolist(), "cyclic": tr.cyclic,
                           "min": [_finite_or_none(x) for x in tr.position.min(axis=0)],
                           "max": [_finite_or_none(x) for x in tr.position.max(axis=0)],
                           "max_speed": _finite_or_none(np.linalg.norm(tr.velocity, axis=1).max())}
                       for n, tr in self.tracks.items()},
        }
        return out


def _finite_or_none(x: float) -> float | None:
    """A summary number for JSON (which has no NaN or inf)."""
    x = float(x)
    return x if np.isfinite(x) else None


def check_finite(res: GcsResult) -> None:
    """Raise :class:`MechanismError` naming the first step (and array) holding NaN or inf:
    a result file never holds them."""
    T = res.t.size
    d = res.diagnostics
    arrays = {"member position": res.position, "member orientation": res.orientation,
              "constraint cost": d.costs, "residual": d.residual}
    if res.acceleration is not None:
        arrays["member acceleration"] = res.acceleration
    for name, tr in res.tracks.items():
        arrays[f"track {name!r} position"] = tr.position
        arrays[f"track {name!r} velocity"] = tr.velocity
    for what, a in arrays.items():
        bad = ~np.isfinite(np.asarray(a, dtype=float).reshape(T, -1)).all(axis=1)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise MechanismError(f"{res.name}: {what} is not finite at step {k} (t = {res.t[k]:.4f}); "
                                 "a result never holds NaN or inf, nothing written")
