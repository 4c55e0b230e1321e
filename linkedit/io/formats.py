"""Which writer an output path asks for: the file suffix decides; ``-`` is standard output.

``.h5``/``.hdf5`` → HDF5, ``.csv`` → CSV, ``.dxf`` → DXF, ``.svg`` → SVG, ``.json`` → JSON,
``.yaml``/``.yml`` → YAML, ``.gif`` → GIF. A command lists the formats it can write; any other suffix is an
input error (exit 2) naming the option and the formats it accepts.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path

from linkedit.errors import InputError
from linkedit.io.atomic import write_text

SUFFIXES = {".h5": "hdf5", ".hdf5": "hdf5", ".csv": "csv", ".dxf": "dxf", ".svg": "svg", ".json": "json",
            ".yaml": "yaml", ".yml": "yaml", ".gif": "gif"}
#: formats that can go to standard output (``-o -``)
TEXT = ("csv", "svg", "json", "yaml")
STDOUT = Path("-")


def is_stdout(path: str | Path | None) -> bool:
    """Whether ``path`` is ``-`` (standard output)."""
    return path is not None and str(path) == "-"


def output_format(path: str | Path, accepted: tuple[str, ...], *, option: str = "--output",
                  stdout: str | None = None) -> str:
    """The format ``path`` asks for, one of ``accepted``; ``-`` gives ``stdout`` (a text format).

    InputError (exit 2) for a suffix that is not accepted, or ``-`` where no text format is.
    """
    if is_stdout(path):
        if stdout is None:
            raise InputError("cannot write this output to standard output: give a file name", field=option)
        return stdout
    kind = SUFFIXES.get(Path(path).suffix.lower())
    if kind not in accepted:
        wanted = ", ".join(s for s, k in SUFFIXES.items() if k in accepted)
        raise InputError(f"{path}: unknown output format {Path(path).suffix or '(no suffix)'!r}; "
                         f"give a file ending in {wanted}", field=option)
    return kind


#: formats written by an optional package: format → (module, package name, extra)
OPTIONAL = {"dxf": ("ezdxf", "ezdxf", "dxf"), "gif": ("PIL", "Pillow", "gif")}


def require(kind: str, path: str | Path) -> None:
    """InputError (exit 2) if the optional package that writes ``kind`` is not installed."""
    if kind not in OPTIONAL:
        return
    module, package, extra = OPTIONAL[kind]
    try:
        __import__(module)
    except ImportError:
        raise InputError(f"writing {kind.upper()} needs the optional package {package}: "
                         f"pip install 'linkedit[{extra}]'", file=str(path)) from None


def write_out(path: str | Path, text: str | Iterable[str]) -> None:
    """Write text (one string, or its pieces in order) to ``path`` atomically, or to standard output for
    ``-`` (UTF-8).

    Every byte must reach standard output: a failed write (a full disk behind ``> file``) is an
    OSError naming ``standard output`` (Python's buffered stdout dropped a short write's rest silently).
    """
    if not is_stdout(path):
        write_text(path, text)
        return
    pieces = [text] if isinstance(text, str) else text
    sys.stdout.flush()
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, ValueError, OSError):  # not a file (a test's captured stdout)
        sys.stdout.writelines(pieces)
        sys.stdout.flush()
        return
    for piece in pieces:
        data = memoryview(piece.encode("utf-8"))
        try:
            while data:
                data = data[os.write(fd, data):]
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, "standard output") from None
