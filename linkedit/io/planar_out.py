"""Write a simulated planar cycle in the format its output path asks for (HDF5, CSV or DXF)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from linkedit.io.formats import output_format, write_out
from linkedit.planar.simulate import Motion

#: what ``simulate -o`` can write; ``-o -`` writes CSV to standard output
RESULT_FORMATS = ("hdf5", "csv", "dxf")


def result_format(path: str | Path, option: str = "--output") -> str:
    """The format of a planar result path (InputError for an unknown suffix)."""
    return output_format(path, RESULT_FORMATS, option=option, stdout="csv")


def write_result(path: str | Path, motion: Motion, *, spec_text: str, options: dict[str, Any]) -> None:
    """Write ``motion`` to ``path`` as HDF5, CSV or DXF by its suffix (``-``: CSV on stdout)."""
    kind = result_format(path)
    if kind == "hdf5":
        from linkedit.io.planar_hdf5 import write_motion

        write_motion(path, motion, spec_text=spec_text, options=options)
    elif kind == "csv":
        from linkedit.io.planar_csv import motion_csv

        write_out(path, motion_csv(motion))
    else:
        from linkedit.io.dxf import write_motion_dxf

        write_motion_dxf(path, motion)
