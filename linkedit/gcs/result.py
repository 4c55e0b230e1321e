"""A solved 3D mechanism over time, and its HDF5 file (kind="gcs", ``specs/gcs-hdf5.md``).

The member states are stored, so new tracked points are evaluated from them without solving
again (:meth:`GcsResult.add_track`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.errors import InputError, MechanismError
from linkedit.gcs.diagnostics import Diagnostics
from linkedit.gcs.outputs import ends_meet, track_positions, track_velocities, velocity
from linkedit.gcs.solver import STATUS_NAMES

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


@dataclass
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


def write_result(path: str | Path, res: GcsResult) -> None:
    """Write atomically (see ``specs/gcs-hdf5.md``); refuses NaN and inf (:func:`check_finite`)."""
    from linkedit.io.hdf5 import put, result_file

    check_finite(res)

    u = res.units
    with result_file(path, kind=KIND, units=u, spec_text=res.spec_text, options=res.options) as f:
        f.attrs["name"] = res.name
        put(f, "t", res.t, description="time in [0, 1]")
        m = f.create_group("members")
        put(m, "names", res.member_names)
        put(m, "position", res.position, units=u, description="member origin in the world")
        put(m, "orientation", res.orientation, convention="unit quaternion [w, x, y, z], member to world")
        put(m, "velocity", res.velocity[..., :3], units=f"{u}/t", description="d position / d t, t in [0, 1]")
        put(m, "angular_velocity", res.velocity[..., 3:], units="rad/t", description="world frame, t in [0, 1]")
        if res.acceleration is not None:
            put(m, "acceleration", res.acceleration[..., :3], units=f"{u}/t^2",
                description="d2 position / d t2, t in [0, 1]")
            put(m, "angular_acceleration", res.acceleration[..., 3:], units="rad/t^2",
                description="d angular_velocity / d t, world frame, t in [0, 1]")
        m.attrs["periodic"] = res.periodic
        shapes = m.create_group("shapes")
        for name in res.member_names:
            pts = res.points.get(name, {})
            g = shapes.create_group(name)
            put(g, "points", np.array(list(pts.values()), dtype=float).reshape(-1, 3), units=u,
                names=json.dumps(list(pts)))
            g.attrs["lines"] = json.dumps(res.lines.get(name, []))
        c = f.create_group("constraints")
        put(c, "names", res.constraint_names)
        put(c, "is_input", res.constraint_inputs.astype(bool))
        put(c, "cost", res.diagnostics.costs, description="per constraint: |p1-p2|^2, theta^2 (orientation, axis), d^2")
        tr = f.create_group("tracks")
        for name, track in res.tracks.items():
            g = tr.create_group(name)
            put(g, "position", track.position, units=u)
            put(g, "velocity", track.velocity, units=f"{u}/t", description="d position / d t, t in [0, 1]")
            g.attrs["member"] = track.member
            g.attrs["point"] = track.point
            g.attrs["cyclic"] = track.cyclic
            g.attrs["velocity_rule"] = res.velocity_rule
        d = f.create_group("diagnostics")
        dg = res.diagnostics
        put(d, "status", dg.status.astype(np.int8), codes=json.dumps(dict(enumerate(STATUS_NAMES))))
        put(d, "residual", dg.residual, description="residual norm, sqrt of the summed costs")
        put(d, "dof", dg.dof, description="degrees of freedom left: 6M - rank(J)")
        put(d, "redundant", dg.redundant, description="redundant equations: independent equations - rank(J)")
        put(d, "dof_evaluated", dg.dof_evaluated.astype(bool),
            description="rank of J evaluated at this step (else dof and redundant are the last evaluated step's)")
        put(d, "iterations", res.iterations)
        put(d, "unsatisfied", [", ".join(n) for n in dg.unsatisfied])
        d.attrs["redundant_constraints"] = json.dumps(dg.redundant_names)


def read_result(path: str | Path) -> GcsResult:
    """Read a kind="gcs" result file."""
    from linkedit.io.hdf5 import open_result, strings

    with open_result(path, kind=KIND) as f:
        try:
            names = strings(f["members/names"])
            points, lines = {}, {}
            for name in names:
                g = f[f"members/shapes/{name}"]
                pts = g["points"][()]
                points[name] = dict(zip(json.loads(g["points"].attrs["names"]), pts))
                lines[name] = json.loads(g.attrs["lines"])
            d = f["diagnostics"]
            diag = Diagnostics(status=d["status"][()], residual=d["residual"][()], dof=d["dof"][()],
                               redundant=d["redundant"][()], costs=f["constraints/cost"][()],
                               unsatisfied=[[x for x in s.split(", ") if x] for s in strings(d["unsatisfied"])],
                               dof_evaluated=d["dof_evaluated"][()].astype(bool),
                               redundant_names=json.loads(d.attrs.get("redundant_constraints", "[]")))
            tracks = {}
            for name, g in f["tracks"].items():
                tracks[name] = Track3D(member=str(g.attrs["member"]), point=np.asarray(g.attrs["point"]),
                                       position=g["position"][()], velocity=g["velocity"][()],
                                       cyclic=bool(g.attrs["cyclic"]))
            options = json.loads(f.attrs["options"])
            rule = options.get("velocity", "exact") if isinstance(options, dict) else "exact"
            res = GcsResult(
                name=str(f.attrs["name"]), units=str(f.attrs["units"]), t=f["t"][()], member_names=names,
                position=f["members/position"][()], orientation=f["members/orientation"][()],
                velocity=np.concatenate([f["members/velocity"][()], f["members/angular_velocity"][()]], axis=-1),
                acceleration=np.concatenate([f["members/acceleration"][()], f["members/angular_acceleration"][()]],
                                            axis=-1) if "acceleration" in f["members"] else None,
                velocity_rule=str(rule),
                periodic=bool(f["members"].attrs["periodic"]),
                constraint_names=strings(f["constraints/names"]), constraint_inputs=f["constraints/is_input"][()],
                diagnostics=diag, iterations=d["iterations"][()], points=points, lines=lines, tracks=tracks,
                spec_text=str(f.attrs["spec"]), options=options)
        except KeyError as exc:
            raise InputError(f"not a complete gcs result: missing {exc}", file=str(path)) from None
        except (ValueError, TypeError, AttributeError) as exc:  # e.g. options or lines that are not JSON
            raise InputError(f"not a readable gcs result: {exc}", file=str(path)) from None
    _check_read(res, str(path))
    return res


def _check_read(res: GcsResult, file: str) -> None:
    """InputError unless the arrays of a result read back agree in shape and the drawing lines name points."""
    steps, members = len(res.t), len(res.member_names)
    shapes = {"members/position": (res.position, (steps, members, 3)),
              "members/orientation": (res.orientation, (steps, members, 4)),
              "members/velocity, members/angular_velocity": (res.velocity, (steps, members, 6))}
    if res.acceleration is not None:
        shapes["members/acceleration, members/angular_acceleration"] = (res.acceleration, (steps, members, 6))
    shapes |= {f"tracks/{n}/position": (tr.position, (steps, 3)) for n, tr in res.tracks.items()}
    shapes |= {f"tracks/{n}/velocity": (tr.velocity, (steps, 3)) for n, tr in res.tracks.items()}
    for where, (array, shape) in shapes.items():
        if np.shape(array) != shape or np.asarray(array).dtype.kind != "f":
            raise InputError(f"{where}: expected a {shape} array of numbers, found {np.shape(array)}", file=file)
    for name, lines in res.lines.items():
        if not isinstance(lines, list) or not all(isinstance(ln, list) and all(p in res.points[name] for p in ln)
                                                  for ln in lines):
            raise InputError(f"members/shapes/{name}: 'lines' must be lists of the member's point names", file=file)
    if not isinstance(res.options, dict):
        raise InputError("the 'options' attribute is not a JSON object", file=file)
