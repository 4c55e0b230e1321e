"""HDF5 conventions shared by every result kind: root attributes, atomic writing, named dimensions.

Reading is :mod:`linkedit.io.h5read` (guarded: no links followed, sizes checked first)."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from linkedit import __version__
from linkedit.io.atomic import atomic_path, deferred_interrupts

FORMAT_VERSION = "1"


@contextlib.contextmanager
def result_file(path: str | Path, *, kind: str, units: str, spec_text: str,
                options: dict[str, Any], format_version: str = FORMAT_VERSION) -> Iterator[h5py.File]:
    """Open a new result file for writing; it appears at ``path`` only if the block succeeds.

    Root attributes: ``format_version``, ``generator``, ``kind``, ``units``, ``spec`` (the
    input text) and ``options`` (JSON of the options used).
    """
    with atomic_path(path) as tmp, writing(tmp) as f, deferred_interrupts():
        f.attrs["format_version"] = format_version
        f.attrs["generator"] = f"linkedit {__version__}"
        f.attrs["kind"] = kind
        f.attrs["units"] = units
        f.attrs["spec"] = spec_text
        f.attrs["options"] = json.dumps(options, sort_keys=True)
        yield f


class WritingFile(h5py.File):
    """An HDF5 file being written through a :class:`_Sink` (see :func:`writing`)."""

    def __init__(self, sink: _Sink, mode: str) -> None:
        super().__init__(sink, mode)
        self.sink = sink

    def check(self) -> None:
        """Raise the first failed write's OSError now (a long writer stops early on a full disk)."""
        self.sink.check()


@contextlib.contextmanager
def writing(path: Path, mode: str = "w") -> Iterator[WritingFile]:
    """Open ``path`` (an :func:`~linkedit.io.atomic.atomic_path` temporary) for writing HDF5: ``"w"`` a new
    file, ``"r+"`` to update one. HDF5 writes through a :class:`_Sink`, so a full disk is the OSError
    of the first failed write, raised once the file is closed (HDF5 writing to a full disk itself could
    not close the file: tracebacks from finalizers, a segfault at exit). Opening and closing hold signals
    (:func:`~linkedit.io.atomic.deferred_interrupts`)."""
    sink = _Sink(path, mode)
    try:
        with deferred_interrupts():
            f = WritingFile(sink, mode)
        try:
            yield f
        finally:
            with deferred_interrupts():
                f.close()
    finally:
        sink.close()
    sink.check()


class _Sink:
    """The file-like object HDF5 writes through (h5py's ``fileobj`` driver).

    Until a write fails it reads and writes ``path``; the first failure is kept (:meth:`check` raises it)
    and later writes go to memory, so HDF5 still sees a whole file and closes cleanly. Reads past the end
    are zeros, as HDF5's own POSIX driver gives.
    """

    def __init__(self, path: Path, mode: str) -> None:
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT | (os.O_TRUNC if mode == "w" else 0), 0o666)
        self._pos = 0
        self.error: OSError | None = None
        self._late: list[tuple[int, bytes]] = []  # (offset, data) written after the failure
        self._size = 0  # the file's size as HDF5 sees it, after the failure

    def check(self) -> None:
        """Raise the first failed write's OSError, if any."""
        if self.error is not None:
            raise self.error

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def seek(self, pos: int, whence: int = os.SEEK_SET) -> int:
        self._pos = self._end() + pos if whence == os.SEEK_END else pos
        return self._pos

    def tell(self) -> int:
        return self._pos

    def read(self, size: int = -1) -> bytes:
        if size < 0:
            size = max(self._end() - self._pos, 0)
        data = bytearray(os.pread(self._fd, size, self._pos).ljust(size, b"\0"))
        for at, late in self._late:  # in order: a later write wins
            lo, hi = max(at, self._pos), min(at + len(late), self._pos + size)
            if lo < hi:
                data[lo - self._pos:hi - self._pos] = late[lo - at:hi - at]
        self._pos += size
        return bytes(data)

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        if self.error is None:
            try:
                done = 0
                while done < len(view):
                    done += os.pwrite(self._fd, view[done:], self._pos + done)
            except OSError as exc:
                self._fail(exc)
        if self.error is not None:
            self._late.append((self._pos, view.tobytes()))
            self._size = max(self._size, self._pos + len(view))
        self._pos += len(view)
        return len(view)

    def truncate(self, size: int) -> int:
        if self.error is None:
            try:
                os.ftruncate(self._fd, size)
            except OSError as exc:
                self._fail(exc)
        if self.error is not None:
            self._size = size
        return size

    def flush(self) -> None:
        pass

    def _fail(self, exc: OSError) -> None:
        self.error = exc
        self._size = os.fstat(self._fd).st_size

    def _end(self) -> int:
        return self._size if self.error is not None else os.fstat(self._fd).st_size


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
