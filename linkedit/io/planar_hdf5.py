"""The planar result file (kind="planar"), layout documented in ``specs/planar-hdf5.md``.

Every axis is a named dimension (HDF5 dimension scales ``/t``, ``/joint``, ``/xy``, ``/rule``,
``/link``, ``/ground_joint``, ``/pair``, ``/end``, ``/ijk``, ``/step``, ``/slider`` at the root; a
link's joints have the scale ``/links/<link>.joint``, a step's lists are their own scales), so ``xarray.open_dataset(path,
group="joints", engine="h5netcdf")`` shows ``t``, ``joint``, ``xy``; units are strings pint
parses (``mm``, ``mm/rad``, ``mm/rad**2``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io.hdf5 import put, result_file, scale
from linkedit.planar.simulate import Motion

FORMAT_VERSION = "3"
TXY = ("t", "xy")


def write_motion(path: str | Path, motion: Motion, *, spec_text: str, options: dict[str, Any]) -> None:
    """Write a simulated cycle atomically (see ``specs/planar-hdf5.md``)."""
    plan = motion.plan
    spec = plan.spec
    u = spec.units
    names = plan.joint_names
    with result_file(path, kind="planar", units=u, spec_text=spec_text, options=options,
                     format_version=FORMAT_VERSION) as f:
        f.attrs["name"] = spec.name
        f.attrs["engine"] = options.get("engine", "symbolic")
        f.attrs["input"] = "linear" if plan.linear else "rotary"
        per = u if plan.linear else "rad"
        what = "stroke" if plan.linear else "motor angle"
        scale(f, "t", motion.t, "motor phase: fraction of a revolution (or of the range_deg sweep, "
              "the oscillate_deg swing there and back, the stroke)", units="1")
        scale(f, "joint", names, "joint names, spec order")
        scale(f, "xy", ["x", "y"], "plane coordinate")
        scale(f, "link", list(plan.graph.link_names), "link names, spec order")
        scale(f, "rule", [names[k] for k in plan.table.joints[:, 2]], "the joint each rule rebuilds, evaluation order")
        scale(f, "ground_joint", [names[g] for g in plan.graph.ground], "ground joint names")
        scale(f, "pair", np.arange(len(plan.pairs)), "index of a joint pair held at constant distance")
        scale(f, "end", [0, 1], "first or second joint of a pair")
        scale(f, "ijk", ["i", "j", "k"], "joints of a rule: k rebuilt from i and j")
        if plan.steps:
            scale(f, "step", [st.name for st in plan.steps], "the slider, or the group's joints, of each step, evaluation order")
        if plan.spec.sliders:
            scale(f, "slider", list(plan.spec.sliders), "slider names, spec order")
        if plan.linear:
            put(f, "stroke", motion.motor_angle, dims=("t",), units=u,
                description="linear input: the driven joint's displacement along its slot from rest")
        else:
            put(f, "motor_angle", motion.motor_angle, dims=("t",), units="rad", description="absolute motor (crank) angle")
        j = f.create_group("joints")
        txy = ("t", "joint", "xy")
        put(j, "position", motion.positions, dims=txy, units=u, description="joint positions")
        put(j, "velocity", motion.velocity, dims=txy, units=f"{u}/{per}", description=f"d position / d {what}")
        put(j, "acceleration", motion.acceleration, dims=txy, units=f"{u}/{per}**2",
            description=f"d² position / d {what}²")
        put(j, "ground", np.array(plan.graph.ground, dtype=int), dims=("ground_joint",), description="indices of the ground joints")
        j.attrs["motor"] = plan.graph.motor
        j.attrs["pivot"] = plan.graph.pivot
        links = f.create_group("links")
        put(links, "pairs", plan.pairs, dims=("pair", "end"), description="joint index pairs held at constant distance")
        for name, members in zip(plan.graph.link_names, plan.graph.links):
            # its axis: the scale /links/<link>.joint (the joints' names), never a root scale's name
            scale(f, f"links/{name}.joint", [names[k] for k in members], f"names of the joints on link {name}")
            put(links, f"joints/{name}", np.array(members, dtype=int), dims=(f"links/{name}.joint",),
                description=f"joint indices on link {name}")
        tracks = f.create_group("tracks")
        for name, track in motion.tracks.items():
            g = tracks.create_group(name)
            put(g, "position", track.position, dims=TXY, units=u, description=f"position of track {name}")
            put(g, "velocity", track.velocity, dims=TXY, units=f"{u}/{per}", description=f"d position / d {what}")
            put(g, "acceleration", track.acceleration, dims=TXY, units=f"{u}/{per}**2",
                description=f"d² position / d {what}²")
        rules = f.create_group("rules")
        table = plan.table
        put(rules, "joints", table.joints, dims=("rule", "ijk"),
            description="(i, j, k): joint k rebuilt from i and j, evaluation order")
        put(rules, "level", table.level, dims=("rule",), description="level of each rule (evaluated together)")
        put(rules, "rigid", table.rigid, dims=("rule",), description="i, j, k on one link (else a dyad)")
        put(rules, "orientation", table.orientation.astype(np.int8), dims=("rule",),
            description="orientation of triangle (i, j, k) at rest: +1 ccw, -1 cw, 0 collinear")
        if plan.steps:
            steps = f.create_group("steps")
            put(steps, "kind", [st.kind for st in plan.steps], dims=("step",),
                description="slider, drive, lines, rotate, yoke or group")
            put(steps, "name", [st.name for st in plan.steps], dims=("step",), description="the slider, or the group's joints")
            put(steps, "level", np.array([st.level for st in plan.steps], dtype=int), dims=("step",),
                description="level of each step")
            for n, st in enumerate(plan.steps):
                scale(f, f"steps/joints/{n}", np.asarray(st.joints, dtype=int), "joints the step writes")
                scale(f, f"steps/inputs/{n}", np.asarray(st.inputs, dtype=int), "joints the step reads")
        if plan.spec.sliders:
            sl = f.create_group("sliders")
            put(sl, "names", list(plan.spec.sliders), dims=("slider",), description="slider names, spec order")
            put(sl, "joint", np.array([s.joint for s in plan.graph.sliders], dtype=int), dims=("slider",), description="joint in the slot, -1: a translating link")
            put(sl, "link", np.array([s.link for s in plan.graph.sliders], dtype=int), dims=("slider",), description="translating link, -1: a joint slider")
            put(sl, "guide", np.array([s.guide for s in plan.graph.sliders], dtype=int), dims=("slider",), description="guide link, -1: the frame")
            put(sl, "angle", np.array([s.angle for s in plan.graph.sliders]), dims=("slider",), units="rad", description="slot direction at rest")
        d = f.create_group("diagnostics")
        put(d, "assembled", motion.assembled, dims=("t",), description="the linkage closes at this sample")
        put(d, "singularity", motion.singularity, dims=("t", "rule"), units="1",
            description="d_s = sin^2(angle at the rebuilt joint); 1 for rigid rules")
        put(d, "transmission_angle", motion.transmission, dims=("t", "rule"), units="rad",
            description="angle at the rebuilt joint (a four-bar's coupler-rocker dyad: the "
                        "transmission angle); pi/2 for rigid rules")
        put(d, "orientation", motion.orientation, dims=("t", "rule"),
            description="orientation sign of each rule's triangle at each sample")
        if plan.steps and motion.step_singularity is not None:
            put(d, "step_singularity", motion.step_singularity, dims=("t", "step"), units="1",
                description="per step: slider sin^2 of the rod's angle to the slot normal; group (smin/smax)^2; else 1")
        worst = motion.min_singularity()
        if worst is not None:
            d.attrs["min_singularity"] = worst[0]
            d.attrs["min_singularity_joint"] = worst[1]
            d.attrs["min_singularity_motor_angle_deg" if not plan.linear else "min_singularity_stroke"] = worst[2]
        d.attrs["lockups"] = "; ".join(lk.describe() for lk in motion.lockups)
        d.attrs["lockup_intervals"] = json.dumps([lk.record() for lk in motion.lockups])
