"""A planar result as CSV: one row per sample, for spreadsheets and pandas.

Columns: ``t``, ``motor_angle_deg``, then ``<joint>_x, <joint>_y`` for every joint (spec
order) and ``<track>_x, <track>_y`` for every track, then the velocities ``<name>_vx,
<name>_vy`` (per radian of motor angle) in the same order. A first comment line (``#``) states
the units; numbers are written with 17 significant digits (they read back as the same doubles).
Samples where the linkage does not assemble (``--partial``) have empty cells, never NaN.
``pandas.read_csv(path, comment="#")`` reads it.
"""

from __future__ import annotations

import io

import numpy as np

from linkedit import __version__
from linkedit.planar.simulate import Motion


def columns(motion: Motion) -> tuple[list[str], np.ndarray]:
    """Column names and the (T, C) table of ``motion``."""
    plan = motion.plan
    joints = plan.joint_names
    points = list(joints) + [n if n not in joints else f"{n}_track" for n in motion.tracks]
    pos = np.concatenate([motion.positions] + [tr.position[:, None] for tr in motion.tracks.values()], axis=1)
    vel = np.concatenate([motion.velocity] + [tr.velocity[:, None] for tr in motion.tracks.values()], axis=1)
    names = ["t", "motor_angle_deg"]
    names += [f"{p}_{c}" for p in points for c in ("x", "y")]
    names += [f"{p}_{c}" for p in points for c in ("vx", "vy")]
    T = motion.t.size
    table = np.column_stack([motion.t, np.degrees(motion.motor_angle), pos.reshape(T, -1), vel.reshape(T, -1)])
    return names, table


def motion_csv(motion: Motion) -> str:
    """The CSV text of ``motion`` (see module docstring)."""
    units = motion.plan.spec.units
    names, table = columns(motion)
    out = io.StringIO()
    out.write(f"# linkedit {__version__} planar result {motion.plan.spec.name}: t in revolutions (0..1), "
              f"motor_angle_deg in degrees, positions in {units}, velocities in {units}/rad\n")
    out.write(",".join(names) + "\n")
    for row in table:
        out.write(",".join(repr(float(v)) if np.isfinite(v) else "" for v in row) + "\n")
    return out.getvalue()
