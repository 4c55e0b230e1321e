"""Faults: a long simulate or solve3d killed at a random moment (SIGTERM, SIGINT, SIGKILL) leaves the
older result at its path intact (or the complete new one), and after SIGTERM/SIGINT no stray file."""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES, ROOT

RUNS = {
    "simulate": (["simulate", EXAMPLES / "strandbeest-10.yaml", "--samples"], 100, 8000),
    "solve3d": (["solve3d", EXAMPLES / "3d" / "six-bar.yaml", "--steps"], 5, 300),
}


def _linkedit(*args) -> list[str]:
    # -B: under a file size limit CPython writes a .pyc cut short (and every later import fails)
    return [sys.executable, "-B", "-c", "from linkedit.cli import main; main()", *map(str, args)]


def _samples(path) -> int:
    """Samples of a complete result (every dataset readable, every number finite)."""
    with h5py.File(path, "r") as f:
        assert "format_version" in f.attrs

        def finite(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f":
                assert np.isfinite(obj[()]).all(), name

        f.visititems(finite)
        return len(f["t"])


@pytest.fixture(scope="module")
def older(tmp_path_factory):
    """A small result per command, made once: the 'older result' each killed run would replace."""
    made = {}
    for command, (args, old, _) in RUNS.items():
        made[command] = tmp_path_factory.mktemp(command) / "old.h5"
        subprocess.run(_linkedit(*args, old, "-o", made[command]), check=True, capture_output=True, timeout=300)
    return made


@pytest.mark.parametrize("command", sorted(RUNS))
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=lambda s: s.name)
def test_a_killed_run_leaves_the_older_result_and_no_stray_file(tmp_path, older, command, sig):
    args, old, new = RUNS[command]
    out = tmp_path / "r.h5"
    shutil.copy(older[command], out)
    seed = random.randrange(2**32)
    delay = random.Random(seed).uniform(0.2, 2.5)
    proc = subprocess.Popen(_linkedit(*args, new, "-o", out), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    time.sleep(delay)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=300)
    assert _samples(out) in (old, new), f"seed {seed}"
    if sig != signal.SIGKILL:  # 128 + the signal (killed by it: during start-up, before linkedit's handlers),
        finished = proc.returncode == 0 and _samples(out) == new  # unless the run had finished
        assert proc.returncode in (128 + sig, -sig) or finished, (seed, delay, proc.returncode, err)
    leftovers = sorted(p.name for p in tmp_path.iterdir() if p.name != "r.h5")
    if sig != signal.SIGKILL:
        assert leftovers == [], f"seed {seed}, delay {delay:.2f}s: {leftovers}; {err}"
        return
    # the temporary file a killed run left is removed by the next run writing there
    subprocess.run(_linkedit(*args, old, "-o", out), check=True, capture_output=True, timeout=300)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.h5"]


FINALIZER = """
import os, signal, sys
import linkedit.io.hdf5 as hdf5
from linkedit.cli import main

class Finalizer:  # like an h5py object freed while the signal arrives: its exception is "ignored"
    def __del__(self):
        os.kill(os.getpid(), signal.{sig})
        for _ in range(100000):
            pass

put, fired = hdf5.put, []

def put_once_interrupted(*args, **kwargs):
    if not fired:
        fired.append(True)
        Finalizer()  # made and freed at once: the handler runs inside __del__
    return put(*args, **kwargs)

hdf5.put = put_once_interrupted
sys.argv = ["linkedit", *sys.argv[1:]]
main()
"""


@pytest.mark.parametrize("command", [("simulate", EXAMPLES / "crank-rocker.yaml", "-n", "36"),
                                     ("solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "--steps", "12")],
                         ids=lambda c: c[0])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
def test_a_signal_landing_in_a_finalizer_still_interrupts_the_run(tmp_path, sig, command):
    """A SIGINT/SIGTERM whose KeyboardInterrupt a finalizer swallows ("Exception ignored") while the result
    is written still ends the run with 128 + the signal, and the result is not written (it exited 0 with
    the file written; solve3d: a KeyboardInterrupt traceback, issue 26 §7)."""
    out = tmp_path / "r.h5"
    out.write_bytes(b"the older result")
    # --quiet: a run slowed by a loaded machine prints progress lines on stderr, which this test does not pin
    r = subprocess.run([sys.executable, "-c", FINALIZER.format(sig=sig.name), *map(str, command), "-o", str(out),
                        "--quiet"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 128 + sig, r.stderr
    assert r.stderr == "linkedit: error: interrupted\n"  # without Python's "Exception ignored" traceback
    assert out.read_bytes() == b"the older result"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.h5"]


def _limited(max_bytes: int):
    """A ``preexec_fn``: the child may write files up to ``max_bytes`` (RLIMIT_FSIZE, as a full quota)."""
    import resource

    return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (max_bytes, max_bytes))


#: (command, output file, file size limit): each writes well past the limit
FULL = {
    "simulate-h5": (["simulate", EXAMPLES / "jansen.yaml", "-n", "2000", "-o"], "r.h5", 200_000),
    "simulate-csv": (["simulate", EXAMPLES / "jansen.yaml", "-n", "2000", "-o"], "r.csv", 200_000),
    "solve3d": (["solve3d", EXAMPLES / "3d" / "six-bar.yaml", "-o"], "r.h5", 100_000),
    "features": (["features", EXAMPLES / "curves" / "foot-paths.yaml", "-o"], "r.h5", 16_000),
    "compare-curves": (["compare-curves", EXAMPLES / "curves" / "foot-paths.yaml", "-o"], "r.h5", 4_000),
    "atlas": (["atlas", "build", "--family", "four-bar", "-n", "10000", "-o"], "r.h5", 1_000_000),
}
SLOW = {"atlas"}  # 5 s: one chunk of 10,000 linkages


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if c in SLOW else c for c in sorted(FULL)])
def test_a_full_disk_is_one_line_exit_1_and_leaves_the_older_file(tmp_path, case):
    """A write that hits the file size limit (EFBIG, as a full disk's ENOSPC): exit 1, one line naming the
    output, no traceback, no temporary file, the older file untouched (they were RuntimeError tracebacks,
    and the atlas a segfault leaving its .part behind)."""
    args, name, limit = FULL[case]
    out = tmp_path / name
    if case != "atlas":  # an existing atlas is grown, not replaced
        out.write_bytes(b"the older result")
    r = subprocess.run(_linkedit(*args, out), capture_output=True, text=True, timeout=300, preexec_fn=_limited(limit))
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().splitlines() == [f"linkedit: error: file size limit reached writing {out}"], r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ([name] if case != "atlas" else [])
    if case != "atlas":
        assert out.read_bytes() == b"the older result"


def test_a_file_size_limit_below_the_atlas_is_refused_before_the_work(tmp_path):
    """`(ulimit -f 2000; atlas build -n 100000 -o a.h5)`: the 41 MiB atlas cannot be written under a 2 MiB
    file size limit; the disk check counted only the free space, so the build ran a chunk and failed
    at its first write (exit 1). Refused up front naming the output and the limit, exit 2, nothing left."""
    out = tmp_path / "a.h5"
    r = subprocess.run(_linkedit(*ATLAS, out, "-n", 100_000), capture_output=True, text=True, timeout=120,
                       preexec_fn=_limited(2000 * 1024))
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [f"linkedit: error: --count: 100,000 linkages would need about 41 MiB of "
                                             f"disk at {out}; the file size limit (ulimit -f) is 2 MiB"]
    assert list(tmp_path.iterdir()) == []


def test_a_file_size_limit_leaves_python_s_byte_code_cache_whole(tmp_path):
    """Run under `ulimit -f 4` with no byte-code cache yet (a fresh install, an upgrade): CPython wrote
    each module's .pyc cut at 4096 bytes and kept it, so every later run failed (EOFError: marshal data
    too short). linkedit's entry point writes no cache under a file size limit."""
    import marshal

    shutil.copytree(ROOT / "linkedit", tmp_path / "linkedit", ignore=shutil.ignore_patterns("__pycache__"))
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(tmp_path)}
    r = subprocess.run([sys.executable, "-m", "linkedit", "simulate", EXAMPLES / "jansen.yaml", "-o", tmp_path / "j.csv"],
                       capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path, preexec_fn=_limited(4096))
    assert r.returncode == 1 and "file size limit reached writing" in r.stderr, r.stderr
    for pyc in (tmp_path / "linkedit").rglob("*.pyc"):  # the package's own start, cached before the entry point runs
        marshal.loads(pyc.read_bytes()[16:])  # EOFError for one cut short


@pytest.mark.parametrize("device", ["limit", "/dev/full"])
def test_a_full_standard_output_is_exit_1(tmp_path, device):
    """`simulate -o - > file` on a full disk: exit 1 naming standard output (it exited 0, the CSV cut mid-row)."""
    target = tmp_path / "j.csv" if device == "limit" else device
    with open(target, "wb") as stdout:
        r = subprocess.run(_linkedit("simulate", EXAMPLES / "jansen.yaml", "-n", "2000", "-o", "-"), stdout=stdout,
                           stderr=subprocess.PIPE, text=True, timeout=300,
                           preexec_fn=_limited(200_000) if device == "limit" else None)
    what = "file size limit reached" if device == "limit" else "no space left"
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().splitlines()[-1] == f"linkedit: error: {what} writing standard output", r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.slow
def test_synthesize_on_a_full_disk_is_one_line_exit_1(tmp_path):
    """`synthesize` whose result.h5 hits the file size limit (it segfaulted, exit 139)."""
    atlas, out = tmp_path / "a.h5", tmp_path / "out"
    subprocess.run(_linkedit("atlas", "build", "--family", "four-bar", "-n", "10000", "-o", atlas), check=True,
                   capture_output=True, timeout=300)
    target = EXAMPLES / "curves" / "foot-paths.yaml"
    r = subprocess.run(_linkedit("synthesize", f"{target}:ellipse", "--atlas", atlas, "-o", out, "--top", "1"),
                       capture_output=True, text=True, timeout=300, preexec_fn=_limited(60_000))
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().splitlines() == [f"linkedit: error: file size limit reached writing {out / 'result.h5'}"]
    assert not [p for p in tmp_path.rglob("*") if p.is_file() and p != atlas]
    assert not out.exists()  # nor the output folder it made (it was left empty)


@pytest.mark.parametrize("name", ["r.h5", "r.csv"])
def test_a_write_that_fails_removes_the_folders_it_made(tmp_path, name):
    """`-o new/deep/r.h5` on a full disk: exit 1, and the folders the run created are gone again (they were
    left behind, empty); a folder that was there before stays."""
    out = tmp_path / "new" / "deep" / name
    r = subprocess.run(_linkedit("simulate", EXAMPLES / "jansen.yaml", "-n", "2000", "-o", out), capture_output=True,
                       text=True, timeout=300, preexec_fn=_limited(20_000))
    assert r.returncode == 1, r.stderr
    assert list(tmp_path.iterdir()) == []


# --- atlas builds: killed, interrupted, concurrent ------------------------------------------------

ATLAS = ["atlas", "build", "--family", "four-bar", "-o"]


def _wait_for(condition, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_a_killed_build_s_temporary_file_is_removed_by_the_next_build(tmp_path):
    """A build killed with SIGKILL and not yet reaped by its parent (a zombie: kill(pid, 0) still
    succeeds) left its large .part behind for good: the next build to the same atlas removes it."""
    out = tmp_path / "a.h5"
    proc = subprocess.Popen(_linkedit(*ATLAS, out, "-n", 10**6), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait_for(lambda: any(p.name.endswith(".part") for p in tmp_path.iterdir()))
        proc.send_signal(signal.SIGKILL)
        _wait_for(lambda: open(f"/proc/{proc.pid}/stat").read().rsplit(")", 1)[1].split()[0] == "Z")
        subprocess.run(_linkedit(*ATLAS, out, "-n", 10), check=True, capture_output=True, timeout=120)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]
    finally:
        proc.kill()
        proc.wait()


def _processes() -> dict[tuple[int, int], int]:
    """Every running process now, from /proc: (pid, start time) → parent pid (the start time tells a
    process from a later one given the same pid)."""
    out = {}
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if entry.isdigit() and fields[0] not in ("Z", "X"):
            out[(int(entry), int(fields[19]))] = int(fields[1])
    return out


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _descendants(pid: int) -> set[tuple[int, int]]:
    """Every running process below ``pid``, as (pid, start time)."""
    table = _processes()
    found: set[tuple[int, int]] = set()
    todo = [pid]
    while todo:
        below = todo.pop()
        kids = {key for key, parent in table.items() if parent == below}
        found |= kids
        todo += [kid for kid, _ in kids]
    return found


@pytest.mark.slow  # two local clusters: 20 s, 90 s on a loaded 2-core machine
def test_dask_workers_end_with_the_command_and_keep_quiet(tmp_path):
    """`--workers 2`, finished and interrupted by SIGTERM (both at once: a cluster takes ~10 s to start):
    no worker outlives the command (multiprocessing's resource tracker ends when it sees its pipe close),
    and stderr holds no Dask text around the one-line message (it held `Task exception was never
    retrieved … AllExit` and worker warnings)."""
    pytest.importorskip("dask.distributed")
    done, stopped = tmp_path / "done.h5", tmp_path / "stopped.h5"
    runs = {out: subprocess.Popen(_linkedit(*ATLAS, out, "-n", n, "--workers", 2), stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True)
            for out, n in ((done, 20), (stopped, 10**7))}
    seen: dict[Path, set[tuple[int, int]]] = {out: set() for out in runs}

    def started() -> bool:
        for out, proc in runs.items():
            seen[out] |= _descendants(proc.pid)
        return any(p.name.startswith(".stopped.h5.") and p.name.endswith(".part") for p in tmp_path.iterdir())

    _wait_for(started, timeout=180)
    time.sleep(1.0)
    seen[stopped] |= _descendants(runs[stopped].pid)
    runs[stopped].send_signal(signal.SIGTERM)
    for out, proc in runs.items():
        _, err = proc.communicate(timeout=120)
        assert len(seen[out]) >= 2, seen  # the two workers (and the resource tracker) were children
        left = {key: _cmdline(key[0]) for key in seen[out] & set(_processes())}
        assert not [c for c in left.values() if "resource_tracker" not in c], f"{out.name}: workers outlived it: {left}"
        _wait_for(lambda: not seen[out] & set(_processes()), timeout=10)  # the tracker: at the end of its pipe
        if out == done:
            assert proc.returncode == 0 and err == "", err
        else:
            assert proc.returncode == 128 + signal.SIGTERM and err == "linkedit: error: interrupted\n", err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done.h5"]


@pytest.mark.slow  # ≈ 8 s of racing appends; the single-writer crash-safety tests run by default
def test_two_concurrent_appends_never_lose_an_update(tmp_path):
    """Two `atlas build -o same.h5` at once: each either appends (one after the other, under the lock)
    or is refused with exit 2 naming the other; the atlas holds exactly the appends that succeeded."""
    out = tmp_path / "a.h5"
    subprocess.run(_linkedit(*ATLAS, out, "-n", 100), check=True, capture_output=True, timeout=120)
    runs = [subprocess.Popen(_linkedit(*ATLAS, out, "-n", 30_000), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True) for _ in range(2)]
    results = [(proc.wait(timeout=300), proc.stderr.read()) for proc in runs]
    for code, err in results:
        assert code == 0 or (code == 2 and "another linkedit process (pid " in err and len(err.splitlines()) == 1), err
    with h5py.File(out) as f:
        assert f["families/four-bar/params"].shape[0] == 100 + 30_000 * sum(code == 0 for code, _ in results)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]


# --- an interrupt while the command line loads ----------------------------------------------------

LONG_RUN = ["simulate", EXAMPLES / "strandbeest-10.yaml", "--samples", "8000", "-o"]

INTERRUPT_AT_IMPORT = """
import os, signal, sys, runpy

class Interrupt:  # the signal lands while {module!r} is being imported
    def find_spec(self, name, path=None, target=None):
        if name == {module!r}:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.{sig})
        return None

sys.meta_path.insert(0, Interrupt())
sys.argv = ["linkedit", *sys.argv[1:]]
runpy.run_module("linkedit", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("module, sig", [(m, signal.SIGINT) for m in ("linkedit.cli", "typer", "numpy", "pydantic",
                                                                       "linkedit.commands.simulate")]
                         + [("typer", signal.SIGTERM)], ids=lambda p: getattr(p, "name", p))
def test_an_interrupt_while_the_command_line_loads_is_one_line(tmp_path, module, sig):
    """SIGINT/SIGTERM while `python -m linkedit` imports typer, pydantic, the commands (and numpy, loaded
    inside the run): one line, 128 + the signal, nothing written (a KeyboardInterrupt traceback, issue 26)."""
    code = INTERRUPT_AT_IMPORT.format(module=module, sig=sig.name)
    r = subprocess.run([sys.executable, "-c", code, "simulate", EXAMPLES / "jansen.yaml", "-o", tmp_path / "r.h5"], capture_output=True,
                       text=True, timeout=120)
    assert (r.returncode, r.stderr) == (128 + sig, "linkedit: error: interrupted\n")
    assert list(tmp_path.iterdir()) == []


def _console_script(folder: Path) -> Path:
    """The ``linkedit`` script pip writes for pyproject.toml's entry point."""
    import tomllib

    module, function = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["linkedit"].split(":")
    script = folder / "linkedit"
    script.write_text(f"import sys\nfrom {module} import {function}\nif __name__ == '__main__':\n    sys.exit({function}())\n")
    return script


def _interrupt_after(command: list, delay: float, folder: Path) -> tuple[int, list[str]]:
    """Run ``command`` (a Python command line) and send SIGINT ``delay`` s after the interpreter has
    imported the package ``linkedit`` (the first line of linkedit that runs: before it, the
    interpreter's own start-up, site's .pth files included, answers Ctrl-C); return the exit code and
    stderr's lines other than ``-X importtime``'s."""
    err = folder / "stderr"
    with open(err, "w") as fh:
        proc = subprocess.Popen([sys.executable, "-X", "importtime", *map(str, command)], stdout=subprocess.DEVNULL,
                                stderr=fh)
    try:
        _wait_for(lambda: any(line.rsplit("|", 1)[-1].strip() == "linkedit" for line in err.read_text().splitlines()),
                  timeout=60)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=120)
    finally:
        proc.kill()
        proc.wait()
    lines = [line for line in err.read_text().splitlines() if not line.startswith("import time:")]
    err.unlink()
    return code, lines


@pytest.mark.parametrize("entry, delays", [("-m", (0.02, 0.2, 0.5, 1.0)), ("script", (0.05, 0.1, 0.35, 0.75))])
def test_ctrl_c_at_any_moment_is_one_line_and_exit_130(tmp_path, entry, delays):
    """Ctrl-C from 0.02 s to 1 s into `python -m linkedit simulate …` and the console script (numpy, h5py,
    typer loading; options parsed; the run under way): exit 130, the one line, no file left (in the
    first half second it was a KeyboardInterrupt traceback from whichever import it hit)."""
    out = tmp_path / "out"
    out.mkdir()
    command = ["-m", "linkedit"] if entry == "-m" else [_console_script(tmp_path)]
    for delay in delays:
        code, lines = _interrupt_after([*command, *LONG_RUN, out / "r.h5"], delay, tmp_path)
        assert (code, lines) == (130, ["linkedit: error: interrupted"]), delay
        assert list(out.iterdir()) == [], delay


def test_an_interrupt_that_python_turns_into_another_error_is_still_an_interrupt():
    """A signal landing inside a class's creation (a dataclass field's ``__set_name__``, as a command's
    first import of a module runs it) reaches the command as ``RuntimeError: Error calling __set_name__``
    (Python 3.11) wrapping the interrupt: it was printed as a traceback with exit 1, not 143."""
    from linkedit.io.atomic import Interrupted, interruptible

    class Kill:
        def __set_name__(self, owner: type, name: str) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)  # the handler runs here

    with pytest.raises(Interrupted) as info, interruptible():
        type("Made", (), {"field": Kill()})
    assert info.value.signum == signal.SIGTERM
