"""Faults: a long simulate or solve3d killed at a random moment (SIGTERM, SIGINT, SIGKILL) leaves the
older result at its path intact (or the complete new one), and after SIGTERM/SIGINT no stray file."""

from __future__ import annotations

import random
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES

RUNS = {
    "simulate": (["simulate", EXAMPLES / "strandbeest-10.yaml", "--samples"], 100, 8000),
    "solve3d": (["solve3d", EXAMPLES / "3d" / "six-bar.yaml", "--steps"], 5, 300),
}


def _linkedit(*args) -> list[str]:
    return [sys.executable, "-c", "from linkedit.cli import main; main()", *map(str, args)]


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
    r = subprocess.run([sys.executable, "-c", FINALIZER.format(sig=sig.name), *map(str, command), "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 128 + sig, r.stderr
    assert r.stderr.strip().splitlines()[-1] == "linkedit: error: interrupted"
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
