"""A planar result as CSV: one row per sample, for spreadsheets and pandas.

Columns: ``t``, the input (``motor_angle_deg`` in degrees, or a linear input's ``stroke_<units>`` in
the spec's units, as the HDF5's ``/motor_angle`` or ``/stroke``), then ``<joint>_x, <joint>_y`` for
every joint (spec order) and ``<track>_x, <track>_y`` for every track (a track named like a joint:
``<track>_track``, with ``_track`` added until the name is free), then the velocities ``<name>_vx,
<name>_vy`` (per radian of motor angle, or per unit of stroke) in the same order. A first comment
line (``#``) states the units. Cells follow :mod:`linkedit.io.csv_table` (quoted where needed, formula
prefixes neutralized, 17 significant digits); samples where the linkage does not assemble
(``--partial``) have empty cells, never NaN. ``pandas.read_csv(path, comment="#")`` reads it.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from linkedit import __version__
from linkedit.io.csv_table import csv_chunks
from linkedit.planar.simulate import Motion


def input_column(motion: Motion) -> tuple[str, np.ndarray]:
    """The input's column: (``motor_angle_deg``, degrees) or (``stroke_<units>``, spec units)."""
    if motion.plan.linear:
        return f"stroke_{motion.plan.spec.units}", motion.motor_angle
    return "motor_angle_deg", np.degrees(motion.motor_angle)


def point_names(motion: Motion) -> list[str]:
    """The joints, then the tracks, each a name no other point has (see the module docstring)."""
    names = list(motion.plan.joint_names)
    for track in motion.tracks:
        while track in names:
            track = f"{track}_track"
        names.append(track)
    return names


def columns(motion: Motion) -> tuple[list[str], np.ndarray]:
    """Column names and the (T, C) table of ``motion``."""
    points = point_names(motion)
    pos = np.concatenate([motion.positions] + [tr.position[:, None] for tr in motion.tracks.values()], axis=1)
    vel = np.concatenate([motion.velocity] + [tr.velocity[:, None] for tr in motion.tracks.values()], axis=1)
    name, value = input_column(motion)
    names = ["t", name]
    names += [f"{p}_{c}" for p in points for c in ("x", "y")]
    names += [f"{p}_{c}" for p in points for c in ("vx", "vy")]
    T = motion.t.size
    table = np.column_stack([motion.t, value, pos.reshape(T, -1), vel.reshape(T, -1)])
    return names, table


def motion_csv(motion: Motion) -> Iterator[str]:
    """The CSV text of ``motion`` (see module docstring), in pieces of rows (:func:`csv_chunks`)."""
    units = motion.plan.spec.units
    names, table = columns(motion)
    if motion.plan.linear:
        what = f"t the fraction of the stroke (0..1), {names[1]} in {units}"
    else:
        what = "t the motor phase (0..1: a revolution, the sweep, or the swing there and back), motor_angle_deg in degrees"
    per = units if motion.plan.linear else "rad"
    what += f", positions in {units}, velocities in {units}/{per}"
    return csv_chunks(names, table, comment=f"linkedit {__version__} planar result {motion.plan.spec.name}: {what}")
