"""The one guarded reader of HDF5 files someone else may have written.

Every command that reads HDF5 (``plot``, ``features``, ``compare-curves``, ``solve3d --from``,
``synthesize``, ``atlas build`` appending, ``le.load``) opens it with :func:`open_result` and
reads through a :class:`ResultReader`, which

* follows **hard links only**: a soft link (a loop, a dangling name), an external link (to the
  file itself, to ``/etc/passwd``, to a FIFO) is refused, never traversed;
* reads **only data stored in the file**: a virtual dataset (whose source may be a FIFO) or a
  dataset with external raw storage is refused;
* checks a dataset's **size before reading it**: a dataset declaring more bytes than the file
  stores for it (a sparse, unallocated dataset of 10¹⁰ rows in a 2 KB file) or more than
  :data:`MAX_READ_BYTES` is refused, and so is one whose shape or number type is not what the
  file's kind says;
* names what is wrong as ``file: /path: what``, exit 2 (an :class:`~linkedit.errors.InputError`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from linkedit.errors import InputError
from linkedit.spec.yamlload import require_regular_file

#: the most bytes one read may bring into memory (a million-curve atlas's curves are 0.5 GB)
MAX_READ_BYTES = 4 << 30
#: compressed data may expand this much over what the file stores for it
MAX_EXPANSION = 1000

Shape = Sequence[int | None]


class ResultReader:
    """A linkedit HDF5 file opened for reading, guarded (see the module docstring).

    Paths are absolute within the file (``tracks/foot/position``); a shape is a tuple with None
    where any length goes (``(None, 2)``).
    """

    def __init__(self, path: str | Path, file: h5py.File) -> None:
        self.path = str(path)
        self.file = file
        self.stored = os.path.getsize(path)

    def __enter__(self) -> "ResultReader":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.file.close()

    def error(self, where: str, what: str) -> InputError:
        """The one-line error about the object at ``where``."""
        return InputError(f"/{where.strip('/')}: {what}" if where.strip("/") else what, file=self.path)

    # --- nodes -----------------------------------------------------------------------------
    def _node(self, where: str) -> Any:
        """The object at ``where`` reached through hard links only, or None if it is absent."""
        node: Any = self.file
        parts = [p for p in where.split("/") if p]
        for n, part in enumerate(parts):
            if not isinstance(node, h5py.Group):
                return None
            try:
                link = node.get(part, getlink=True)
            except (KeyError, ValueError, RuntimeError, OSError) as exc:
                raise self.error("/".join(parts[: n + 1]), f"cannot be read ({exc})") from None
            if link is None:
                return None
            if not isinstance(link, h5py.HardLink):
                kind = "an external link" if isinstance(link, h5py.ExternalLink) else "a soft link"
                raise self.error("/".join(parts[: n + 1]), f"is {kind}; linkedit reads no links (copy the data into "
                                 "the file)")
            try:
                node = node[part]
            except (KeyError, ValueError, RuntimeError, OSError) as exc:
                raise self.error("/".join(parts[: n + 1]), f"cannot be read ({exc})") from None
        return node

    def has(self, where: str) -> bool:
        """Whether an object exists at ``where`` (through hard links)."""
        return self._node(where) is not None

    def group(self, where: str) -> h5py.Group:
        """The group at ``where`` (required)."""
        node = self._node(where)
        if not isinstance(node, h5py.Group):
            raise self.error(where, "missing (expected a group)" if node is None else "is not a group")
        return node

    def names(self, where: str) -> list[str]:
        """The member names of the group at ``where``, in the file's order."""
        try:
            return [str(n) for n in self.group(where)]
        except (UnicodeDecodeError, RuntimeError, OSError) as exc:
            raise self.error(where, f"member names cannot be read ({exc})") from None

    def dataset(self, where: str) -> h5py.Dataset:
        """The dataset at ``where`` (required), checked to hold only data stored in this file."""
        node = self._node(where)
        if not isinstance(node, h5py.Dataset):
            raise self.error(where, "missing (expected a dataset)" if node is None else "is not a dataset")
        if node.is_virtual:
            raise self.error(where, "is a virtual dataset; linkedit reads only data stored in the file")
        if node.external:
            raise self.error(where, "keeps its data in an external file; linkedit reads only data stored in the file")
        return node

    # --- data ------------------------------------------------------------------------------
    def array(self, where: str, *, shape: Shape | None = None, kinds: str = "fiu",
              rows: slice | None = None) -> np.ndarray:
        """The numbers of the dataset at ``where``, its number type (dtype kinds: "f" float, "i"/"u"
        integers, "b" bool) and shape checked; ``rows`` reads part of its first axis only."""
        ds = self.dataset(where)
        if ds.dtype.kind not in kinds:
            want = {"b": "booleans", "iu": "integers", "biu": "flags"}.get(kinds, "numbers")
            raise self.error(where, f"expected {want}, found {ds.dtype}")
        if shape is not None and not _fits(ds.shape, shape):
            raise self.error(where, f"expected shape {_show(shape)}, found {ds.shape}")
        if rows is not None and len(ds.shape) == 0:
            raise self.error(where, "expected an array, found a scalar")
        count = int(np.prod(ds.shape, dtype=np.int64))
        if rows is not None and ds.shape:
            count = count // max(ds.shape[0], 1) * len(range(*rows.indices(ds.shape[0])))
        self._check_size(ds, count)
        try:
            return np.asarray(ds[()] if rows is None else ds[rows])
        except (OSError, RuntimeError, ValueError, TypeError) as exc:
            raise self.error(where, f"cannot be read ({exc})") from None

    def strings(self, where: str, count: int | None = None) -> list[str]:
        """A dataset of strings as a list of str (``count``: its required length)."""
        ds = self.dataset(where)
        if ds.ndim != 1 or ds.dtype.kind not in "OSU":
            raise self.error(where, f"expected a list of strings, found {ds.dtype} of shape {ds.shape}")
        if count is not None and ds.shape[0] != count:
            raise self.error(where, f"expected {count} names, found {ds.shape[0]}")
        self._check_size(ds, ds.shape[0])
        try:
            return [s.decode() if isinstance(s, bytes) else str(s) for s in ds[()]]
        except (UnicodeDecodeError, OSError, RuntimeError) as exc:
            raise self.error(where, f"names cannot be read as UTF-8 text ({exc})") from None

    def attr(self, name: str, where: str = "/", *, kind: type = str, default: Any = ...) -> Any:
        """Attribute ``name`` of the object at ``where`` as ``kind`` (str, int, float, bool);
        required unless a ``default`` is given."""
        node = self.file if where.strip("/") == "" else self._node(where)
        if node is None:
            raise self.error(where, "missing")
        try:
            value = node.attrs.get(name)
        except (OSError, RuntimeError, UnicodeDecodeError, TypeError) as exc:
            raise self.error(where, f"attribute {name!r} cannot be read ({exc})") from None
        if value is None:
            if default is not ...:
                return default
            raise self.error(where, f"attribute {name!r} is missing")
        if isinstance(value, bytes):
            try:
                value = value.decode()
            except UnicodeDecodeError:
                raise self.error(where, f"attribute {name!r} is not UTF-8 text") from None
        if isinstance(value, np.ndarray):
            if value.size != 1:
                raise self.error(where, f"attribute {name!r}: expected one value, found {value.shape}")
            value = value.reshape(-1)[0]
        if kind is str:
            if not isinstance(value, str):
                raise self.error(where, f"attribute {name!r}: expected text, found {value!r}")
            return value
        if isinstance(value, str) or (kind is not bool and isinstance(value, (bool, np.bool_))):
            raise self.error(where, f"attribute {name!r}: expected a number, found {value!r}")
        try:
            out = kind(value)
        except (TypeError, ValueError, OverflowError):
            raise self.error(where, f"attribute {name!r}: expected {kind.__name__}, found {value!r}") from None
        if kind is int and out != value:
            raise self.error(where, f"attribute {name!r}: expected an integer, found {value!r}")
        if kind is int and not -(2**63) <= out < 2**63:  # as HDF5 stores it: a 64-bit integer
            raise self.error(where, f"attribute {name!r}: {value!r} is out of the range of a 64-bit integer")
        if kind is float and not np.isfinite(out):
            raise self.error(where, f"attribute {name!r}: expected a finite number, found {value!r}")
        return out

    def _check_size(self, ds: h5py.Dataset, count: int) -> None:
        """Refuse to read ``count`` elements of ``ds`` when that is more than the file stores for
        it (a sparse dataset), than compression could expand to, or than MAX_READ_BYTES."""
        where = ds.name
        want = count * ds.dtype.itemsize
        if want > MAX_READ_BYTES:
            raise self.error(where, f"declares {want / 2**30:.3g} GiB: more than linkedit reads at once "
                             f"({MAX_READ_BYTES / 2**30:.0f} GiB)")
        total = int(np.prod(ds.shape, dtype=np.int64)) * ds.dtype.itemsize
        if total == 0:
            return
        stored = ds.id.get_storage_size()
        limit = stored * (MAX_EXPANSION if _filtered(ds) else 1)
        if total > limit:
            raise self.error(where, f"declares {total} bytes of data but the file stores {stored} for it "
                             f"(the whole file is {self.stored} bytes): a dataset larger than its file")


def open_result(path: str | Path, kind: str | None = None, *, ours: bool = True) -> ResultReader:
    """Open a linkedit result for reading, guarded; InputError if it is not one (or not of ``kind``).
    ``ours=False`` opens any HDF5 file (a curve source: tracks written by another program)."""
    require_regular_file(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"cannot open as HDF5: {exc}", file=str(path)) from None
    reader = ResultReader(path, f)
    try:
        if ours and reader.attr("format_version", default=None) is None:
            raise InputError("not a linkedit result file (no format_version attribute)", file=str(path))
        found = reader.attr("kind", default=None)
        if kind is not None and found != kind:
            raise InputError(f"expected a {kind!r} result, found {found!r}", file=str(path))
    except BaseException:
        f.close()
        raise
    return reader


def _filtered(ds: h5py.Dataset) -> bool:
    """Whether the dataset's chunks pass through filters (compression) when stored."""
    try:
        return bool(ds.id.get_create_plist().get_nfilters())
    except (AttributeError, RuntimeError, OSError):
        return False


def _fits(shape: tuple[int, ...], want: Shape) -> bool:
    return len(shape) == len(want) and all(w is None or s == w for s, w in zip(shape, want))


def _show(shape: Shape) -> str:
    return "(" + ", ".join("any" if s is None else str(s) for s in shape) + (",)" if len(shape) == 1 else ")")
