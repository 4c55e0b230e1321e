"""Atomic file writes: write to a temporary file beside the target, then rename.

An interrupted or failed run never leaves a half-written result in place, and never a stray
temporary file after an error, Ctrl-C or SIGTERM (see :func:`interruptible`). Inside
:func:`together`, the renames wait until the whole block succeeds, so the outputs of one run
appear together or not at all. Only regular files (or new paths) are ever replaced: a device
node, a FIFO or a folder at the target is an error, not something to rename over.

Temporary files are named ``.<name>.<pid>.<random>.part`` (a name longer than 200 bytes is cut to
its first 120 bytes and a hash of the whole, ``<start>~<hash>``, so that any name the file system
takes, up to 255 bytes, can be written); one whose process is gone (SIGKILL, power loss) is removed
by the next write to the same target. A write that fails (a full disk: ENOSPC,
EFBIG past the file size limit) raises an OSError naming the target, not its temporary file.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import hashlib
import os
import re
import signal
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

#: errno of a write that failed for want of room → what the one-line error says ("… writing FILE")
DISK_FULL = {errno.ENOSPC: "no space left", errno.EFBIG: "file size limit reached", errno.EDQUOT: "disk quota exceeded"}

#: (temporary, target) renames waiting for the innermost :func:`together` block to succeed.
_PENDING: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar("pending", default=None)


def check_target(target: str | Path) -> None:
    """OSError naming ``target`` unless it can be written as a regular file: the path is new or a
    regular file, and its nearest existing folder is a folder we may write into."""
    target = Path(target)
    try:
        info = target.stat()
    except FileNotFoundError:
        info = None
    except NotADirectoryError:
        info = None
    if info is not None and not stat.S_ISREG(info.st_mode):
        what = "is a folder" if stat.S_ISDIR(info.st_mode) else "is not a regular file (only regular files are replaced)"
        raise OSError(f"{target}: {what}")
    parent = target.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise OSError(f"{target}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OSError(f"{target}: cannot write into {parent} (permission denied)")


@contextlib.contextmanager
def together() -> Iterator[None]:
    """Commit every atomic write made inside the block when it succeeds, and none when it fails.

    Blocks nest: an inner block's writes join the outer block's on success.
    """
    pending: list[tuple[Path, Path]] = []
    outer = _PENDING.get()
    token = _PENDING.set(pending)
    try:
        yield
    except BaseException:
        _discard(pending)
        raise
    finally:
        _PENDING.reset(token)
    if outer is not None:
        outer.extend(pending)
        return
    _commit(pending)


def commit() -> None:
    """Rename the writes of the enclosing :func:`together` blocks now (for a run that fails after
    writing results it wants kept, e.g. an edit that stops at its last working linkage)."""
    pending = _PENDING.get()
    if pending:
        _commit(pending)


def _commit(pending: list[tuple[Path, Path]]) -> None:
    """Rename every pending write, none if the run was interrupted first; a signal during the renames
    is raised after them (the outputs still appear together)."""
    try:
        check_interrupt()
        with deferred_interrupts():
            for tmp, target in pending:
                _replace(tmp, target)
    finally:
        _discard(pending)
        pending.clear()


@contextlib.contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``target`` on success
    (at the end of the enclosing :func:`together` block, if any). Errors name ``target``."""
    target = Path(target)
    check_target(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(target)
        fd, name = tempfile.mkstemp(prefix=f".{_tag(target.name)}.{os.getpid()}.", suffix=".part", dir=target.parent)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from None
    tmp = Path(name)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are ordinary files
    pending = _PENDING.get()
    try:
        yield tmp
        if pending is not None:
            pending.append((tmp, target))
            return
        _replace(tmp, target)
    except OSError as exc:
        if exc.errno is not None and (exc.errno in DISK_FULL or exc.filename is None or str(exc.filename) == str(tmp)):
            raise OSError(exc.errno, exc.strerror, str(target)) from None
        raise
    finally:
        if pending is None or (tmp, target) not in pending:
            _discard([(tmp, target)])


def write_text(target: str | Path, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


class Interrupted(KeyboardInterrupt):
    """The run was interrupted by ``signum`` (SIGINT: Ctrl-C, or SIGTERM); exit code 128 + signum."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _Signals:
    """SIGINT/SIGTERM received inside :func:`interruptible`, and how deep :func:`deferred_interrupts` holds them."""

    received: list[int] = []
    held = 0


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Inside the block SIGINT and SIGTERM raise :class:`Interrupted` (a KeyboardInterrupt), so temporary
    files are cleaned up, and are remembered: one whose exception a finalizer swallowed ("Exception
    ignored", e.g. while h5py frees an object) is raised again by :func:`check_interrupt`. A signal
    ignored when the block starts stays ignored; the previous handlers are restored after the block."""

    def handler(signum: int, frame: object) -> None:
        _Signals.received.append(signum)
        if not _Signals.held:
            raise Interrupted(signum)

    try:  # a signal ignored by whoever started us (`nohup`, a shell's background job) stays ignored
        previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)
                    if signal.getsignal(sig) != signal.SIG_IGN}
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    _Signals.received.clear()
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        _Signals.received.clear()  # handled by now (the Interrupted exception carries the signal)


def check_interrupt() -> None:
    """Raise :class:`Interrupted` if a signal arrived inside :func:`interruptible` (even one whose
    exception was swallowed); a run calls it before it reports success."""
    if _Signals.received:
        raise Interrupted(_Signals.received[0])


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Signals arriving inside the block are only recorded, and raised when it ends: for code that must not
    be cut short (HDF5 writing and closing a file, the renames of :func:`together`)."""
    _Signals.held += 1
    try:
        yield
    finally:
        _Signals.held -= 1
    if not _Signals.held:
        check_interrupt()


def _replace(tmp: Path, target: Path) -> None:
    check_target(target)
    try:
        os.replace(tmp, target)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from None


def _discard(pending: list[tuple[Path, Path]]) -> None:
    for tmp, _ in pending:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


#: longest file name (bytes) whose temporary file keeps it whole: ``.`` + 200 + ``.<pid>.<random>.part`` < 255
_WHOLE = 200


def _tag(name: str) -> str:
    """What a temporary file of ``name`` is named after: ``name`` itself, or for a name longer than
    :data:`_WHOLE` bytes its first 120 bytes and a hash of the whole (``start~0123abcd…``)."""
    raw = name.encode("utf-8", "surrogateescape")
    if len(raw) <= _WHOLE:
        return name
    start = raw[:120].decode("utf-8", "ignore")
    return f"{start}~{hashlib.sha256(raw).hexdigest()[:16]}"


def _remove_stale(target: Path) -> None:
    """Remove temporary files of ``target`` left by linkedit processes that no longer exist."""
    tag = _tag(target.name)
    for part in target.parent.glob(f".{_glob_escape(tag)}.*.part"):
        m = re.fullmatch(r"(\d+)\.[^.]+\.part", part.name[len(tag) + 2:])  # not another target's (``name.1``)
        if m and not _alive(int(m[1])):
            with contextlib.suppress(OSError):
                part.unlink()


def _glob_escape(name: str) -> str:
    """``name`` with glob metacharacters made literal."""
    return "".join(f"[{c}]" if c in "*?[" else c for c in name)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
