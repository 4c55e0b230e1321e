"""Where the example mechanisms are: the source checkout's ``examples/``, or the copy installed
with the package (``<prefix>/share/linkedit/examples``)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from linkedit.errors import InputError


def examples_dir() -> Path:
    """The folder of example files (specs, edit scripts, 3D mechanisms, curve sets)."""
    here = Path(__file__).resolve().parents[1] / "examples"
    for candidate in (here, Path(sys.prefix) / "share" / "linkedit" / "examples"):
        if (candidate / "jansen.yaml").is_file():
            return candidate
    raise InputError("the example files are not installed (reinstall linkedit)")


def copy_examples(target: str | Path) -> list[Path]:
    """Copy every example file into ``target`` (created); refuses to overwrite a file that differs."""
    source = examples_dir()
    target = Path(target)
    files = sorted(p for p in source.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    for p in files:
        dest = target / p.relative_to(source)
        if dest.exists() and dest.read_bytes() != p.read_bytes():
            raise InputError(f"{dest} exists and differs: not overwritten (choose an empty folder)")
    out = []
    for p in files:
        dest = target / p.relative_to(source)
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(p, dest)
        out.append(dest)
    return out
