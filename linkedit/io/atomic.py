"""Atomic file writes: write to a temporary file beside the target, then rename.

An interrupted or failed run never leaves a half-written result in place, and never a stray
temporary file after an error, Ctrl-C or SIGTERM (see :func:`interruptible`). Inside
:func:`together`, the renames wait until the whole block succeeds, so the outputs of one run
appear together or not at all. Only regular files (or new paths) are ever replaced: a device
node, a FIFO or a folder at the target is an error, not something to rename over.

Temporary files are named ``.<name>.<pid>.<random>.part`` (a name longer than 200 bytes is cut to
its first 120 bytes and a hash of the whole, ``<start>~<hash>``, so that any name the file system
takes, up to 255 bytes, can be written); one whose process is gone (SIGKILL, power loss) is removed
by the next write to the same target. A file read and replaced (an atlas appended to, a result
updated in place) is locked meanwhile (:func:`locked`, :func:`hold`). A write that fails (a full disk: ENOSPC,
EFBIG past the file size limit) raises an OSError naming the target, not its temporary file.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import errno
import hashlib
import os
import re
import signal
import stat
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

#: errno of a write that failed for want of room → what the one-line error says ("… writing FILE")
DISK_FULL = {errno.ENOSPC: "no space left", errno.EFBIG: "file size limit reached", errno.EDQUOT: "disk quota exceeded"}

#: (temporary, target) renames waiting for the innermost :func:`together` block to succeed.
_PENDING: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar("pending", default=None)
#: folders the writes of the enclosing :func:`together` block created (removed again, if empty, when it fails)
_MADE: contextvars.ContextVar[list[Path] | None] = contextvars.ContextVar("made", default=None)


@dataclasses.dataclass
class _Held:
    """A lock taken inside :func:`together`: its release, and whether its update is written (its :func:`locked`
    block ended; :func:`hold`'s lock stays until the block ends)."""

    release: Callable[[], None]
    written: bool = False


@dataclasses.dataclass
class _Locks:
    """The locks taken inside the outermost :func:`together` block, whose renames wait in ``pending``."""

    pending: list[tuple[Path, Path]]
    held: list[_Held] = dataclasses.field(default_factory=list)

    def release(self, written_only: bool) -> None:
        """Release the locks (last taken first), or only those of written updates (their renames are done)."""
        for lock in reversed(self.held):
            if lock.written or not written_only:
                lock.release()
        self.held = [lock for lock in self.held if written_only and not lock.written]


#: the locks of the outermost :func:`together` block, released after the renames of the writes they guard.
_HELD: contextvars.ContextVar[_Locks | None] = contextvars.ContextVar("held", default=None)
#: Seconds a writer waits for another process's lock on the same target before it gives up.
LOCK_WAIT = 2.0


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
    made: list[Path] = []
    made_token = _MADE.set(made)
    held = _HELD.set(_Locks(pending)) if outer is None else None
    try:
        try:
            yield
        except BaseException:
            _discard(pending)
            locks = _HELD.get() if held is not None else None
            if locks is not None:  # nothing is renamed: the locks go first, so that the folders they made are empty
                locks.release(written_only=False)
            _unmake(made)
            raise
        finally:
            _PENDING.reset(token)
            _MADE.reset(made_token)
        if outer is not None:
            (_MADE.get() or []).extend(made)
            outer.extend(pending)
            return
        _commit(pending)
    finally:
        if held is not None:  # the locks of the block's in-place updates, after their renames
            locks = _HELD.get()
            if locks is not None:
                locks.release(written_only=False)
            _HELD.reset(held)


def commit() -> None:
    """Rename the writes of the enclosing :func:`together` blocks now (for a run that fails after
    writing results it wants kept, e.g. an edit that stops at its last working linkage). In the
    outermost block every write made so far is then in place: the locks of the updates written
    (their :func:`locked` blocks ended) are released, so the run may update those files again."""
    pending = _PENDING.get()
    if pending:
        _commit(pending)
    locks = _HELD.get()
    if locks is not None and locks.pending is pending:
        locks.release(written_only=True)


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
    made = _MADE.get()
    own = made is None
    made = [] if made is None else made
    try:
        missing = [p for p in (target.parent, *target.parent.parents) if not p.exists()]
        target.parent.mkdir(parents=True, exist_ok=True)
        made.extend(missing)
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
            if own and not target.exists():  # a lone write that failed: the folders it made go too
                _unmake(made)


@contextlib.contextmanager
def durable_path(target: str | Path) -> Iterator[Path]:
    """:func:`atomic_path` renamed as soon as the block succeeds, even inside :func:`together`: one
    piece of a long run that outlives the run's failure or interruption (an atlas shard, its manifest)."""
    pending, made = _PENDING.set(None), _MADE.set(None)
    try:
        with atomic_path(target) as tmp:
            yield tmp
    finally:
        _MADE.reset(made)
        _PENDING.reset(pending)


@contextlib.contextmanager
def locked(target: str | Path, wait: float | None = None) -> Iterator[None]:
    """Hold ``target`` for a read-modify-write (an atlas appended to, a result updated in place): an
    exclusive ``flock`` on ``.<name>.lock`` beside it, which records the holder's process ID. Another
    process holding it is waited for ``wait`` seconds (:data:`LOCK_WAIT`), then InputError (exit 2) naming it. Inside
    :func:`together` the lock is kept until the renames of the block's writes are done (by the block's end, or
    :func:`commit`): an update is read and replaced under one lock. It is not re-entrant: the same run updating
    the file again before that would read it without the first update, and is refused like another process.
    The lock file is removed when released.
    """
    locks = _HELD.get()
    if locks is not None:
        lock = _Held(_lock(Path(target), LOCK_WAIT if wait is None else wait))
        locks.held.append(lock)
        yield
        lock.written = True
        return
    release = _lock(Path(target), LOCK_WAIT if wait is None else wait)
    try:
        yield
    finally:
        release()


def hold(target: str | Path, wait: float | None = None) -> None:
    """Take ``target``'s lock (see :func:`locked`) until the enclosing :func:`together` block has
    renamed its writes: for a command that reads a file and replaces it (``solve3d --from R.h5``)."""
    locks = _HELD.get()
    if locks is None:
        raise RuntimeError("hold() needs an enclosing together() block")
    locks.held.append(_Held(_lock(Path(target), LOCK_WAIT if wait is None else wait)))


def lock_path(target: str | Path) -> Path:
    """The lock file of ``target`` (:func:`locked`): ``.<name>.lock`` beside it."""
    target = Path(target)
    return target.parent / f".{target.name}.lock"


def _lock(target: Path, wait: float) -> Callable[[], None]:
    """Take the lock of :func:`locked`; return its release."""
    import fcntl
    import time

    from linkedit.errors import InputError

    check_target(target)
    try:
        missing = [p for p in (target.parent, *target.parent.parents) if not p.exists()]
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from None
    made = _MADE.get()
    if made is not None:  # removed again, if empty, when the enclosing together() block fails
        made.extend(missing)
    path = lock_path(target)
    deadline = time.monotonic() + wait
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o666)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(target)) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            os.close(fd)
            if time.monotonic() >= deadline:
                raise InputError(f"another linkedit process ({f'pid {holder}' if holder.isdigit() else 'unknown'}) "
                                 "is updating it; try again when it has finished", file=str(target)) from None
            time.sleep(0.05)
            continue
        if _same_file(fd, path):  # else its holder removed it while we waited: lock the new one
            break
        os.close(fd)
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)

    def release() -> None:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)

    return release


def _same_file(fd: int, path: Path) -> bool:
    try:
        here, there = os.fstat(fd), os.stat(path, follow_symlinks=False)
    except OSError:
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def write_text(target: str | Path, text: str | Iterable[str]) -> None:
    """Write a text file atomically: one string, or its pieces in order (a long table, never held whole)."""
    with atomic_path(target) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        fh.writelines([text] if isinstance(text, str) else text)


class Interrupted(KeyboardInterrupt):
    """The run was interrupted by ``signum`` (SIGINT: Ctrl-C, or SIGTERM); exit code 128 + signum; ``detail``:
    what the user should know beyond "interrupted" (empty: nothing)."""

    def __init__(self, signum: int, detail: str = "") -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum, self.detail = signum, detail


class _Signals:
    """SIGINT/SIGTERM received inside :func:`interruptible`, and how deep :func:`deferred_interrupts` holds them."""

    received: list[int] = []
    held = 0


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Inside the block SIGINT and SIGTERM raise :class:`Interrupted` (a KeyboardInterrupt), so temporary
    files are cleaned up, and are remembered: one whose exception a finalizer swallowed ("Exception
    ignored", e.g. while h5py frees an object or in a garbage collector callback) is raised again by
    :func:`check_interrupt`, without Python's "Exception ignored" traceback on stderr. A signal
    ignored when the block starts stays ignored; the previous handlers are restored after the block. An
    error the block ends with after a signal arrived is that signal's :class:`Interrupted` (Python wraps an
    exception raised in some hooks, e.g. a dataclass field's ``__set_name__``, in a RuntimeError)."""

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
    unraisable = sys.unraisablehook

    def quiet(info: Any) -> None:  # "Exception ignored in …" with its traceback: the signal is recorded
        if not isinstance(info.exc_value, Interrupted):
            unraisable(info)

    sys.unraisablehook = quiet
    try:
        yield
    except Exception as exc:  # the interrupt as Python passed it on: e.g. RuntimeError from a class's
        if _Signals.received:  # creation ("Error calling __set_name__"), which wraps what its hooks raise
            raise Interrupted(_Signals.received[0]) from exc
        raise
    finally:
        sys.unraisablehook = unraisable
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


def _unmake(made: list[Path]) -> None:
    """Remove the folders ``made`` (deepest first) that a failed run created and left empty."""
    for folder in sorted(set(made), key=lambda p: len(p.parts), reverse=True):  # deepest first
        with contextlib.suppress(OSError):
            folder.rmdir()
    made.clear()


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
    """Remove temporary files of ``target`` left by linkedit processes that no longer run."""
    tag = _tag(target.name)
    for part in target.parent.glob(f".{_glob_escape(tag)}.*.part"):
        m = re.fullmatch(r"(\d+)\.[^.]+\.part", part.name[len(tag) + 2:])  # not another target's (``name.1``)
        try:
            changed = part.stat().st_mtime
        except OSError:
            continue
        if m and not _running_since(int(m[1]), changed):
            with contextlib.suppress(OSError):
                part.unlink()


def _glob_escape(name: str) -> str:
    """``name`` with glob metacharacters made literal."""
    return "".join(f"[{c}]" if c in "*?[" else c for c in name)


def _running_since(pid: int, when: float) -> bool:
    """Whether process ``pid`` runs and already ran at ``when`` (a time its temporary file changed): a
    killed process not yet reaped (a zombie) does not run, and a later process given the same number
    started after its file last changed."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        with open("/proc/stat") as fh:
            boot = next(float(line.split()[1]) for line in fh if line.startswith("btime "))
    except (OSError, IndexError, StopIteration, ValueError):  # no /proc (not Linux): trust kill(pid, 0)
        return True
    started = boot + int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22 of stat: start time, clock ticks after boot
    return fields[0] not in ("Z", "X") and started <= when + 1.0  # btime has whole seconds
