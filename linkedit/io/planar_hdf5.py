"""The planar result file (kind="planar"), layout documented in ``specs/planar-hdf5.md``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io.hdf5 import put, result_file
from linkedit.planar.simulate import Motion


def write_motion(path: str | Path, motion: Motion, *, spec_text: str, options: dict[str, Any]) -> None:
    """Write a simulated cycle atomically (see ``specs/planar-hdf5.md``)."""
    plan = motion.plan
    spec = plan.spec
    units = spec.units
    with result_file(path, kind="planar", units=units, spec_text=spec_text, options=options) as f:
        f.attrs["name"] = spec.name
        f.attrs["engine"] = options.get("engine", "symbolic")
        put(f, "t", motion.t, description="motor phase: fraction of a revolution (or of the range_deg sweep)")
        f.attrs["input"] = "linear" if plan.linear else "rotary"
        per = units if plan.linear else "rad"
        if plan.linear:
            put(f, "stroke", motion.motor_angle, units=units, description="linear input: displacement along the slot from rest")
        else:
            put(f, "motor_angle", motion.motor_angle, units="rad", description="absolute motor (crank) angle")
        j = f.create_group("joints")
        put(j, "names", plan.joint_names)
        put(j, "position", motion.positions, units=units)
        put(j, "velocity", motion.velocity, units=f"{units}/{per}", description="d position / d input")
        put(j, "acceleration", motion.acceleration, units=f"{units}/{per}^2")
        put(j, "ground", np.array(plan.graph.ground, dtype=int))
        j.attrs["motor"] = plan.graph.motor
        j.attrs["pivot"] = plan.graph.pivot
        links = f.create_group("links")
        put(links, "names", list(plan.graph.link_names))
        put(links, "pairs", plan.pairs, description="joint index pairs held at constant distance")
        for name, members in zip(plan.graph.link_names, plan.graph.links):
            put(links, f"joints/{name}", np.array(members, dtype=int))
        tracks = f.create_group("tracks")
        for name, track in motion.tracks.items():
            g = tracks.create_group(name)
            put(g, "position", track.position, units=units)
            put(g, "velocity", track.velocity, units=f"{units}/{per}")
            put(g, "acceleration", track.acceleration, units=f"{units}/{per}^2")
        rules = f.create_group("rules")
        put(rules, "joints", plan.rules, description="(i, j, k): joint k rebuilt from i and j, evaluation order")
        put(rules, "level", plan.level)
        put(rules, "rigid", plan.rigid)
        put(rules, "orientation", plan.orientation.astype(np.int8))
        if plan.steps:
            steps = f.create_group("steps")
            put(steps, "kind", [st.kind for st in plan.steps])
            put(steps, "name", [st.name for st in plan.steps])
            put(steps, "level", np.array([st.level for st in plan.steps], dtype=int))
            for n, st in enumerate(plan.steps):
                put(steps, f"joints/{n}", np.asarray(st.joints, dtype=int))
                put(steps, f"inputs/{n}", np.asarray(st.inputs, dtype=int))
        if plan.spec.sliders:
            sl = f.create_group("sliders")
            put(sl, "names", list(plan.spec.sliders))
            put(sl, "joint", np.array([s.joint for s in plan.graph.sliders], dtype=int))
            put(sl, "link", np.array([s.link for s in plan.graph.sliders], dtype=int))
            put(sl, "guide", np.array([s.guide for s in plan.graph.sliders], dtype=int))
            put(sl, "angle", np.array([s.angle for s in plan.graph.sliders]), units="rad")
        d = f.create_group("diagnostics")
        put(d, "assembled", motion.assembled)
        put(d, "singularity", motion.singularity, description="d_s = sin^2(angle at the rebuilt joint); 1 for rigid rules")
        put(d, "transmission_angle", motion.transmission, units="rad")
        put(d, "orientation", motion.orientation)
        if plan.steps and motion.step_singularity is not None:
            put(d, "step_singularity", motion.step_singularity,
                description="per step: slider sin^2 of the rod's angle to the slot normal; group (smin/smax)^2; else 1")
        worst = motion.min_singularity()
        if worst is not None:
            d.attrs["min_singularity"] = worst[0]
            d.attrs["min_singularity_joint"] = worst[1]
            d.attrs["min_singularity_motor_angle_deg" if not plan.linear else "min_singularity_stroke"] = worst[2]
        d.attrs["lockups"] = "; ".join(lk.describe() for lk in motion.lockups)
