"""The edit result file (kind="edit"), layout documented in ``specs/edit-hdf5.md``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.edit.runner import EditResult
from linkedit.io.hdf5 import put, result_file
from linkedit.planar.simulate import Motion


def _motion(group: Any, motion: Motion, units: str) -> None:
    put(group, "rest", motion.plan.graph.rest, units=units, description="rest pose of the joints")
    per = units if motion.plan.linear else "rad"
    if motion.plan.linear:
        put(group, "stroke", motion.motor_angle, units=units,
            description="the driven joint's displacement along its slot from rest at each phase")
    else:
        put(group, "motor_angle", motion.motor_angle, units="rad", description="absolute motor angle at each phase")
    put(group, "joints/position", motion.positions, units=units)
    put(group, "joints/velocity", motion.velocity, units=f"{units}/{per}")
    for name, track in motion.tracks.items():
        put(group, f"tracks/{name}/position", track.position, units=units)
        put(group, f"tracks/{name}/velocity", track.velocity, units=f"{units}/{per}")
    put(group, "diagnostics/singularity", motion.singularity)


def write_edit(path: str | Path, result: EditResult, *, script_text: str, linkage_text: str,
               edited_text: str, options: dict[str, Any]) -> None:
    """Write before/after trajectories and per-operation reports atomically."""
    units = result.original.units
    with result_file(path, kind="edit", units=units, spec_text=script_text, options=options) as f:
        f.attrs["linkage"] = linkage_text
        f.attrs["edited_linkage"] = edited_text
        put(f, "t", result.before.t, description="motor phase; 0 is the rest pose of each linkage")
        put(f, "joints/names", result.before.plan.joint_names)
        _motion(f.create_group("before"), result.before, units)
        _motion(f.create_group("after"), result.after, units)
        ops = f.create_group("operations")
        for n, op in enumerate(result.operations):
            g = ops.create_group(f"{n:03d}")
            g.attrs["name"] = op.name
            g.attrs["iterations"] = op.iterations
            g.attrs["evaluations"] = op.evaluations
            g.attrs["rejected_steps"] = op.rejected_steps
            g.attrs["seconds"] = op.seconds
            g.attrs["converged"] = op.converged
            g.attrs["discarded"] = op.discarded
            g.attrs["unmet"] = json.dumps(op.unmet)
            g.attrs["before"] = json.dumps(op.before)
            g.attrs["after"] = json.dumps(op.after)
            put(g, "energy", np.array(op.energy), description="total energy after each accepted iteration")
            for label, curve in op.targets.items():
                put(g, f"targets/{label}", curve, units=units)
