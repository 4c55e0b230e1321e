"""Where the example mechanisms are: the source checkout's ``examples/``, or the copy installed
with the package (``<prefix>/share/linkedit/examples``)."""

from __future__ import annotations

import contextlib
import os
import stat
import sys
from pathlib import Path

from linkedit.errors import InputError
from linkedit.io.atomic import atomic_path, together


def examples_dir() -> Path:
    """The folder of example files (specs, edit scripts, 3D mechanisms, curve sets)."""
    here = Path(__file__).resolve().parents[1] / "examples"
    for candidate in (here, Path(sys.prefix) / "share" / "linkedit" / "examples"):
        if (candidate / "jansen.yaml").is_file():
            return candidate
    raise InputError("the example files are not installed (reinstall linkedit)")


def copy_examples(target: str | Path) -> list[Path]:
    """Copy every example file into ``target`` (created): all of them or none.

    InputError (exit 2) before anything is written if ``target`` or a path inside it that a copy would
    go through is a symbolic link (never followed), something other than a folder or a regular file
    (a FIFO, a device), or a file that differs from the example.
    """
    source = examples_dir()
    target = Path(target)
    files = sorted(p.relative_to(source) for p in source.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    for rel in files:
        _check_place(target, rel, source / rel)
    made: list[Path] = []  # folders this copy created, removed again if it fails
    try:
        with together():
            for rel in files:
                for folder in reversed((target / rel).parents):
                    if not os.path.lexists(folder):
                        folder.mkdir()
                        made.append(folder)
                with atomic_path(target / rel) as tmp:
                    tmp.write_bytes((source / rel).read_bytes())
    except BaseException:
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return [target / rel for rel in files]


def _check_place(target: Path, rel: Path, example: Path) -> None:
    """InputError unless ``target / rel`` can take a copy of ``example`` (see :func:`copy_examples`)."""
    path = target
    for depth, part in enumerate(("", *rel.parts)):
        path = path / part if part else path
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            return
        except OSError as exc:
            raise InputError(f"{path}: {exc.strerror}") from None
        if stat.S_ISLNK(info.st_mode):
            raise InputError(f"{path} is a symbolic link: not followed (choose a folder without links)")
        last = depth == len(rel.parts)
        if not last and not stat.S_ISDIR(info.st_mode):
            raise InputError(f"{path} exists and is not a folder")
        if last and not stat.S_ISREG(info.st_mode):
            raise InputError(f"{path} exists and is not a regular file: not overwritten (choose an empty folder)")
    if info.st_size != example.stat().st_size or path.read_bytes() != example.read_bytes():
        raise InputError(f"{path} exists and differs: not overwritten (choose an empty folder)")
