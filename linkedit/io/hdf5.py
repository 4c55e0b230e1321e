"""HDF5 conventions shared by every result kind: root attributes, atomic writing, named dimensions.

Reading is :mod:`linkedit.io.h5read` (guarded: no links followed, sizes checked first)."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from linkedit import __version__
from linkedit.io.atomic import atomic_path

FORMAT_VERSION = "1"


@contextlib.contextmanager
def result_file(path: str | Path, *, kind: str, units: str, spec_text: str,
                options: dict[str, Any], format_version: str = FORMAT_VERSION) -> Iterator[h5py.File]:
    """Open a new result file for writing; it appears at ``path`` only if the block succeeds.

    Root attributes: ``format_version``, ``generator``, ``kind``, ``units``, ``spec`` (the
    input text) and ``options`` (JSON of the options used).
    """
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["format_version"] = format_version
            f.attrs["generator"] = f"linkedit {__version__}"
            f.attrs["kind"] = kind
            f.attrs["units"] = units
            f.attrs["spec"] = spec_text
            f.attrs["options"] = json.dumps(options, sort_keys=True)
            yield f


def put(group: h5py.Group, name: str, data: Any, *, dims: tuple[str | None, ...] = (), **attrs: Any) -> h5py.Dataset:
    """Create a dataset (strings as UTF-8 variable-length) with attributes (e.g. units).

    ``dims`` names the dimension scale of each axis (a dataset of that name at the file's
    root, made by :func:`scale`; None leaves an axis without one), so xarray and netCDF
    readers see named dimensions.
    """
    arr = np.asarray(data)
    if arr.dtype.kind in "UO":
        ds = group.create_dataset(name, data=np.asarray(arr, dtype=object), dtype=h5py.string_dtype())
    else:
        ds = group.create_dataset(name, data=arr)
    for key, value in attrs.items():
        ds.attrs[key] = value
    for axis, dim in enumerate(dims):
        if dim is not None:
            ds.dims[axis].attach_scale(group.file[dim])
    return ds


def scale(f: h5py.File, name: str, data: Any, description: str, **attrs: Any) -> h5py.Dataset:
    """A dimension scale at path ``name`` (a coordinate axis: sample times, joint names, x/y), named
    by its last path part (a scale in a group is that group's own dimension, e.g. a member's points)."""
    ds = put(f, name, data, description=description, **attrs)
    ds.make_scale(name.rpartition("/")[2])
    return ds


@dataclass(frozen=True)
class Entry:
    """One dataset of a result layout: where, what, its named dimensions, what it means and its unit.

    ``dims``: a dimension scale path per axis (see :func:`put`); ``units``: a string pint parses, or
    None for a number without a unit (counts, indices, flags); ``attrs``: further attributes.
    """

    path: str
    data: Any
    dims: tuple[str | None, ...]
    description: str
    units: str | None = None
    attrs: dict[str, Any] = field(default_factory=dict)


def write_entries(f: h5py.File, entries: Iterable[Entry]) -> None:
    """Write a layout: each entry one dataset (parent groups created as needed)."""
    for e in entries:
        extra = dict(e.attrs) | ({"units": e.units} if e.units is not None else {})
        put(f, e.path, e.data, dims=e.dims, description=e.description, **extra)
