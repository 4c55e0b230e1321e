"""What a run may take from the machine: memory and disk, read before the work starts, so that a run
that cannot fit is refused in one line (exit 2) naming the bytes it needs instead of ending in a
MemoryError (or a full disk) half-way.

Memory available is the smallest of the system's available memory (``MemAvailable``), the
process's cgroup limit (containers, v1 and v2) less its usage, and the address-space limit
(``ulimit -v``) less what the process already maps; disk available for a file is the free space of
the target's file system, at most the file size limit (``ulimit -f``). A write that still runs out of
room is exit 1: see :data:`linkedit.io.atomic.DISK_FULL`.
"""

from __future__ import annotations

import os
import resource
import shutil
from pathlib import Path
from typing import Any

from linkedit.errors import InputError

#: a limit at or above this is "unlimited" (cgroup v1 writes 2⁶³ − page size for none)
_UNLIMITED = 1 << 60


def size_text(count: float) -> str:
    """Bytes for a person: ``512 MiB``, ``6.1 GiB``, ``3.1e+09 GiB``."""
    gib = count / 2**30
    if gib < 1:
        return f"{count / 2**20:,.0f} MiB"
    return f"{gib:,.1f} GiB" if gib < 1e6 else f"{gib:.1e} GiB"


def available_memory() -> int:
    """Bytes of memory this process can still allocate (see the module docstring)."""
    limits = [_meminfo(), *_cgroup_room()]
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        limits.append(soft - _status_kib("VmSize") * 1024)
    return max(0, min(limits))


def available_disk(path: str | Path) -> int:
    """Bytes a new file at ``path`` can take: the free space of the file system of its nearest existing
    folder, at most the file size limit (:func:`file_size_limit`)."""
    folder = Path(path).absolute().parent
    while not folder.is_dir() and folder != folder.parent:
        folder = folder.parent
    free = shutil.disk_usage(folder).free
    limit = file_size_limit()
    return free if limit is None else min(free, limit)


def file_size_limit() -> int | None:
    """The largest file this process may write in bytes (``ulimit -f``, RLIMIT_FSIZE's soft limit), None if unlimited."""
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    return None if soft == resource.RLIM_INFINITY else soft


def require_memory(need: float, what: str, **where: Any) -> None:
    """InputError (exit 2, placed by ``where``: ``field=``, ``file=``) if ``need`` bytes do not fit in memory."""
    have = available_memory()
    if need > have:
        raise InputError(f"{what} would need about {size_text(need)} of memory; {size_text(have)} are available",
                         **where)


def require_disk(need: float, path: str | Path, what: str, **where: Any) -> None:
    """InputError (exit 2) if a file of ``need`` bytes cannot be written at ``path`` (the disk's free space
    or the file size limit)."""
    have = available_disk(path)
    if need > have:
        room = (f"the file size limit (ulimit -f) is {size_text(have)}" if have == file_size_limit()
                else f"{size_text(have)} are free")
        raise InputError(f"{what} would need about {size_text(need)} of disk at {path}; {room}", **where)


def _meminfo() -> int:
    """MemAvailable (Linux), else the physical memory."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _status_kib(key: str) -> int:
    """A ``kB`` line of /proc/self/status (0 where there is none)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def _cgroup_room() -> list[int]:
    """Limit less usage of the memory cgroups this process is in (none where unlimited or unreadable)."""
    out: list[int] = []
    try:
        with open("/proc/self/cgroup") as fh:
            entries = [line.rstrip("\n").split(":", 2) for line in fh]
    except OSError:
        return out
    for _, controllers, path in entries:
        if controllers == "":  # v2
            pairs = [("/sys/fs/cgroup" + path.rstrip("/"), "memory.max", "memory.current"),
                     ("/sys/fs/cgroup", "memory.max", "memory.current")]
        elif "memory" in controllers.split(","):  # v1
            pairs = [("/sys/fs/cgroup/memory" + path.rstrip("/"), "memory.limit_in_bytes", "memory.usage_in_bytes"),
                     ("/sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes")]
        else:
            continue
        for folder, limit_file, usage_file in pairs:
            try:
                limit = Path(folder, limit_file).read_text().strip()
                usage = int(Path(folder, usage_file).read_text())
            except (OSError, ValueError):
                continue
            if limit != "max" and int(limit) < _UNLIMITED:
                out.append(int(limit) - usage)
            break
    return out
