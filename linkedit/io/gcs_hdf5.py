"""The HDF5 file of a solved 3D mechanism (kind="gcs", ``specs/gcs-hdf5.md``): written from a
:class:`~linkedit.gcs.result.GcsResult` and read back into one."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.gcs.diagnostics import Diagnostics
from linkedit.gcs.result import KIND, GcsResult, Track3D, check_finite
from linkedit.gcs.tolerances import STATUS_NAMES
from linkedit.io.h5read import open_result
from linkedit.io.hdf5 import Entry, result_file, scale, write_entries

FORMAT_VERSION = "2"
#: the time axis t is dimensionless (one run is t ∈ [0, 1]): d/dt of a length in ``units`` is in ``units``
PER_T = "per unit t: t is the dimensionless run parameter in [0, 1], so the unit is the quantity's own"


def write_result(path: str | Path, res: GcsResult) -> None:
    """Write atomically (see ``specs/gcs-hdf5.md``); refuses NaN and inf (:func:`check_finite`)."""
    check_finite(res)
    with result_file(path, kind=KIND, units=res.units, spec_text=res.spec_text, options=res.options,
                     format_version=FORMAT_VERSION) as f:
        f.attrs["name"] = res.name
        for group in ("members/shapes", "constraints", "tracks", "diagnostics"):
            f.require_group(group)
        scale(f, "t", res.t, "time: the dimensionless run parameter, linspace(0, 1, steps)", units="1")
        scale(f, "member", res.member_names, "member names, spec order")
        scale(f, "constraint", res.constraint_names, "named constraints, then inputs")
        scale(f, "xyz", ["x", "y", "z"], "world (or member-space) coordinate")
        scale(f, "wxyz", ["w", "x", "y", "z"], "quaternion component")
        for name in res.member_names:
            scale(f, f"members/shapes/{name}/point", list(res.points.get(name, {})), f"point names of member {name}")
        write_entries(f, datasets(res))
        f["members"].attrs["periodic"] = res.periodic
        for name in res.member_names:
            f[f"members/shapes/{name}"].attrs["lines"] = json.dumps(res.lines.get(name, []))
        for name, track in res.tracks.items():
            f[f"tracks/{name}"].attrs.update(member=track.member, point=track.point, cyclic=track.cyclic,
                                             velocity_rule=res.velocity_rule)
        f["diagnostics"].attrs["redundant_constraints"] = json.dumps(res.diagnostics.redundant_names)


def datasets(res: GcsResult) -> list[Entry]:
    """The layout of a gcs result file, one entry per dataset (add a dataset: add an entry)."""
    u, d = res.units, res.diagnostics
    tm3, tm4, tc = ("t", "member", "xyz"), ("t", "member", "wxyz"), ("t", "constraint")
    out = [
        Entry("members/position", res.position, tm3, "member origin in the world", u),
        Entry("members/orientation", res.orientation, tm4, "member orientation", "1",
              {"convention": "unit quaternion [w, x, y, z], member to world"}),
        Entry("members/velocity", res.velocity[..., :3], tm3, f"d position / d t of the member origin; {PER_T}", u),
        Entry("members/angular_velocity", res.velocity[..., 3:], tm3, f"world-frame angular velocity; {PER_T}", "rad"),
    ]
    if res.acceleration is not None:
        out += [Entry("members/acceleration", res.acceleration[..., :3], tm3,
                      f"d2 position / d t2 of the member origin (solve3d --accelerations); {PER_T}", u),
                Entry("members/angular_acceleration", res.acceleration[..., 3:], tm3,
                      f"world-frame angular acceleration (solve3d --accelerations); {PER_T}", "rad")]
    out += [
        Entry("constraints/is_input", res.constraint_inputs.astype(bool), ("constraint",),
              "the constraint is an input (its target moves with t)"),
        Entry("constraints/cost", d.costs, tc,
              "per constraint: |p1-p2|^2 (length units squared), theta^2 (orientation, axis: rad^2), d^2 (on-plane)"),
        Entry("diagnostics/status", d.status.astype(np.int8), ("t",), "0 converged, 1 inconsistent, 2 did not converge",
              None, {"codes": json.dumps(dict(enumerate(STATUS_NAMES)))}),
        Entry("diagnostics/residual", d.residual, ("t",), "residual norm, sqrt of the summed costs"),
        Entry("diagnostics/dof", d.dof, ("t",), "degrees of freedom left: 6M - rank(J)"),
        Entry("diagnostics/redundant", d.redundant, ("t",),
              "redundant equations: independent equations - rank(J)"),
        Entry("diagnostics/dof_evaluated", d.dof_evaluated.astype(bool), ("t",),
              "rank of J evaluated at this step (else dof and redundant are the last evaluated step's)"),
        Entry("diagnostics/iterations", res.iterations, ("t",), "linear solves at the step"),
        Entry("diagnostics/unsatisfied", [", ".join(n) for n in d.unsatisfied], ("t",),
              "constraints off by more than the tolerance, worst first (comma-separated)"),
    ]
    for name in res.member_names:
        pts = res.points.get(name, {})
        out.append(Entry(f"members/shapes/{name}/points", np.array(list(pts.values()), dtype=float).reshape(-1, 3),
                         (f"members/shapes/{name}/point", "xyz"), f"shape points of member {name}, member space", u,
                         {"names": json.dumps(list(pts))}))
    for name, track in res.tracks.items():
        out += [Entry(f"tracks/{name}/position", track.position, ("t", "xyz"), f"position of track {name}", u),
                Entry(f"tracks/{name}/velocity", track.velocity, ("t", "xyz"),
                      f"d position / d t ({res.velocity_rule}); {PER_T}", u)]
    return out


def read_result(path: str | Path) -> GcsResult:
    """Read a kind="gcs" result file, guarded (:mod:`linkedit.io.h5read`)."""
    with open_result(path, kind=KIND) as f:
        names = f.strings("member") if f.has("member") else f.strings("members/names")  # format 2, 1
        try:
            points, lines = {}, {}
            for name in names:
                where = f"members/shapes/{name}"
                pts = f.array(f"{where}/points", shape=(None, 3))
                points[name] = dict(zip(json.loads(f.attr("names", f"{where}/points")), pts))
                lines[name] = json.loads(f.attr("lines", where))
            d = "diagnostics"
            diag = Diagnostics(status=f.array(f"{d}/status", kinds="iu"),
                               residual=f.array(f"{d}/residual"), dof=f.array(f"{d}/dof", kinds="iu"),
                               redundant=f.array(f"{d}/redundant", kinds="iu"),
                               costs=f.array("constraints/cost"),
                               unsatisfied=[[x for x in s.split(", ") if x] for s in f.strings(f"{d}/unsatisfied")],
                               dof_evaluated=f.array(f"{d}/dof_evaluated", kinds="biu").astype(bool),
                               redundant_names=json.loads(f.attr("redundant_constraints", d, default="[]")))
            tracks = {}
            for name in f.names("tracks"):
                g = f"tracks/{name}"
                tracks[name] = Track3D(member=f.attr("member", g),
                                       point=np.asarray(f.group(g).attrs["point"], dtype=float),
                                       position=f.array(f"{g}/position"), velocity=f.array(f"{g}/velocity"),
                                       cyclic=f.attr("cyclic", g, kind=bool))
            options = json.loads(f.attr("options"))
            rule = options.get("velocity", "exact") if isinstance(options, dict) else "exact"
            accel = f.has("members/acceleration")
            res = GcsResult(
                name=f.attr("name"), units=f.attr("units"), t=f.array("t", shape=(None,)), member_names=names,
                position=f.array("members/position"), orientation=f.array("members/orientation"),
                velocity=np.concatenate([f.array("members/velocity"), f.array("members/angular_velocity")], axis=-1),
                acceleration=np.concatenate([f.array("members/acceleration"), f.array("members/angular_acceleration")],
                                            axis=-1) if accel else None,
                velocity_rule=str(rule),
                periodic=f.attr("periodic", "members", kind=bool),
                constraint_names=f.strings("constraint") if f.has("constraint") else f.strings("constraints/names"),
                constraint_inputs=f.array("constraints/is_input", kinds="biu"),
                diagnostics=diag, iterations=f.array(f"{d}/iterations", kinds="iu"), points=points,
                lines=lines, tracks=tracks, spec_text=f.attr("spec"), options=options)
        except KeyError as exc:
            raise InputError(f"not a complete gcs result: missing {exc}", file=str(path)) from None
        except (ValueError, TypeError, AttributeError) as exc:  # e.g. options or lines that are not JSON
            raise InputError(f"not a readable gcs result: {exc}", file=str(path)) from None
    _check_read(res, str(path))
    return res


def _check_read(res: GcsResult, file: str) -> None:
    """InputError unless the arrays of a result read back agree in shape and the drawing lines name points."""
    steps, members = len(res.t), len(res.member_names)
    shapes: dict[str, tuple[np.ndarray, tuple[int, ...]]] = {
              "members/position": (res.position, (steps, members, 3)),
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
