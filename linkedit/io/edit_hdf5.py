"""The edit result file (kind="edit"), layout documented in ``specs/edit-hdf5.md``.

Like the planar file (format 2): every axis a named dimension (scales ``/t``, ``/joint``, ``/xy``
at the root; ``rule`` in each stage, ``iteration`` and ``sample`` in each operation), a
``description`` on every dataset, units pint parses.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.edit.runner import EditResult
from linkedit.io.hdf5 import Entry, result_file, scale, write_entries
from linkedit.planar.simulate import Motion

FORMAT_VERSION = "2"


def _motion(stage: str, motion: Motion, units: str) -> list[Entry]:
    """The datasets of one stage (``before`` or ``after``): the linkage as ``simulate`` gives it."""
    per, what = (units, "stroke") if motion.plan.linear else ("rad", "motor angle")
    txy, g = ("t", "joint", "xy"), stage
    out = [
        Entry(f"{g}/rest", motion.plan.graph.rest, ("joint", "xy"), "rest pose of the joints", units),
        Entry(f"{g}/stroke", motion.motor_angle, ("t",),
              "the driven joint's displacement along its slot from rest at each phase", units)
        if motion.plan.linear else
        Entry(f"{g}/motor_angle", motion.motor_angle, ("t",), "absolute motor angle at each phase", "rad"),
        Entry(f"{g}/joints/position", motion.positions, txy, "joint positions", units),
        Entry(f"{g}/joints/velocity", motion.velocity, txy, f"d position / d {what}", f"{units}/{per}"),
        Entry(f"{g}/diagnostics/singularity", motion.singularity, ("t", f"{g}/rule"),
              "d_s = sin^2(angle at the rebuilt joint); 1 for rigid rules", "1"),
    ]
    for name, track in motion.tracks.items():
        out += [Entry(f"{g}/tracks/{name}/position", track.position, ("t", "xy"), f"position of track {name}", units),
                Entry(f"{g}/tracks/{name}/velocity", track.velocity, ("t", "xy"), f"d position / d {what}",
                      f"{units}/{per}")]
    return out


def write_edit(path: str | Path, result: EditResult, *, script_text: str, linkage_text: str,
               edited_text: str, options: dict[str, Any]) -> None:
    """Write before/after trajectories and per-operation reports atomically."""
    units = result.original.units
    names = result.before.plan.joint_names
    with result_file(path, kind="edit", units=units, spec_text=script_text, options=options,
                     format_version=FORMAT_VERSION) as f:
        f.attrs["linkage"] = linkage_text
        f.attrs["edited_linkage"] = edited_text
        scale(f, "t", result.before.t, "motor phase; 0 is the rest pose of each linkage", units="1")
        scale(f, "joint", names, "joint names, spec order")
        scale(f, "xy", ["x", "y"], "plane coordinate")
        entries: list[Entry] = []
        for stage, motion in (("before", result.before), ("after", result.after)):
            scale(f, f"{stage}/rule", [motion.plan.joint_names[k] for k in motion.plan.table.joints[:, 2]],
                  "the joint each rule rebuilds, evaluation order")
            entries += _motion(stage, motion, units)
        ops = f.create_group("operations")
        for n, op in enumerate(result.operations):
            g = f"operations/{n:03d}"
            scale(f, f"{g}/iteration", np.arange(len(op.energy)), "accepted iterations (0: the start)")
            entries.append(Entry(f"{g}/energy", np.array(op.energy), (f"{g}/iteration",),
                                 "total energy after each accepted iteration"))
            sampled = [label for label in op.targets if label not in op.polylines]
            if sampled:
                samples = len(op.targets[sampled[0]])
                scale(f, f"{g}/sample", np.arange(samples), "sample of the target curves (the final check's)")
            entries += [Entry(f"{g}/targets/{label}", op.targets[label], (f"{g}/sample", "xy"),
                              f"target curve {label} at the final check's samples", units) for label in sampled]
            for k, label in enumerate(sorted(op.polylines)):
                curve = op.targets[label]
                scale(f, f"{g}/point_{k}", np.arange(len(curve)), f"point of the curve given to {label}")
                entries.append(Entry(f"{g}/targets/{label}", curve, (f"{g}/point_{k}", "xy"),
                                     f"the curve given to {label} (timing: false): its points", units))
            ops.require_group(f"{n:03d}").attrs.update(
                name=op.name, iterations=op.iterations, evaluations=op.evaluations, rejected_steps=op.rejected_steps,
                seconds=op.seconds, converged=op.converged, discarded=op.discarded, unmet=json.dumps(op.unmet),
                before=json.dumps(op.before), after=json.dumps(op.after))
        write_entries(f, entries)
