"""The lock of a file read and replaced (io/atomic.py `locked`): released once its update is renamed, so the same
run can update the file again; another process is refused while it is held."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from linkedit.errors import InputError
from linkedit.io import atomic
from linkedit.synthesis import atlas

#: Takes the lock of argv[1] (no wait), prints "taken" or the refusal, and holds it until stdin closes.
HOLDER = """
import sys
from linkedit.errors import InputError
from linkedit.io import atomic
try:
    with atomic.locked(sys.argv[1], wait=0.0):
        print("taken", flush=True)
        sys.stdin.read()
except InputError as exc:
    print(exc, flush=True)
"""


def other_process(path: Path) -> subprocess.Popen:
    """A process trying to take ``path``'s lock (and holding it, if it got it, until its stdin closes)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen([sys.executable, "-c", HOLDER, str(path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=env)


def other_takes(path: Path) -> str:
    """What another process trying to take ``path``'s lock now says ("taken", or its refusal)."""
    proc = other_process(path)
    out, _ = proc.communicate("", timeout=60)
    return out.strip()


def linkages(path: Path) -> int:
    with h5py.File(path) as f:
        return int(f["families/four-bar/params"].shape[0])


def test_a_run_updates_a_file_again_after_its_first_update_is_renamed(tmp_path):
    """`linkedit bench -s synthesis` built the same atlas twice in one run (renaming it in between) and was refused
    by its own lock ("another linkedit process (pid <its own>)"): the lock now goes with the rename."""
    path = tmp_path / "a.h5"
    with atomic.together():  # as every command runs
        atlas.build(path, ["four-bar"], 10, seed=1)
        assert other_takes(path).endswith(f"(pid {os.getpid()}) is updating it; try again when it has finished")
        atomic.commit()
        assert linkages(path) == 10 and other_takes(path) == "taken"
        atlas.build(path, ["four-bar"], 10, seed=1)  # appended to, under the lock again
        assert other_takes(path).startswith(f"{path}: another linkedit process (pid {os.getpid()})")
    assert linkages(path) == 20 and sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]


def test_an_update_not_yet_renamed_keeps_its_lock_against_the_same_run(tmp_path, monkeypatch):
    """Without the rename a second read-modify-write would read the old file and its rename would drop the first
    update: it stays refused (the lock is not re-entrant), and the first update is kept."""
    path = tmp_path / "a.h5"
    monkeypatch.setattr(atomic, "LOCK_WAIT", 0.1)
    with atomic.together():
        atlas.build(path, ["four-bar"], 10, seed=1)
        with pytest.raises(InputError, match="is updating it"):
            atlas.build(path, ["four-bar"], 10, seed=1)
    assert linkages(path) == 10


def test_a_build_is_refused_while_another_process_holds_the_lock(tmp_path, monkeypatch):
    path = tmp_path / "a.h5"
    atlas.build(path, ["four-bar"], 10, seed=1)
    before = path.read_bytes()
    holder = other_process(path)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "taken"
        monkeypatch.setattr(atomic, "LOCK_WAIT", 0.2)
        with pytest.raises(InputError) as refused, atomic.together():
            atlas.build(path, ["four-bar"], 10, seed=1)
        assert str(refused.value) == (f"{path}: another linkedit process (pid {holder.pid}) is updating it; "
                                      "try again when it has finished")
        assert path.read_bytes() == before
    finally:
        holder.communicate("", timeout=60)
    with atomic.together():
        atlas.build(path, ["four-bar"], 10, seed=1)
    assert linkages(path) == 20 and sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]


@pytest.mark.slow
def test_the_bench_compares_build_rates_on_dask():
    """The full bench's Dask comparison (here one chunk, one repeat, 2 workers) builds bench-0.h5 several times in
    one run; its header names the workers and the cores."""
    pytest.importorskip("dask.distributed")
    from linkedit.synthesis import bench_cluster

    lines: list[str] = []
    with atomic.together():
        bench_cluster.dask_comparison(lines.append, 1, 1, 2)
    assert "local Dask cluster, 2 single-threaded workers" in lines[-1]
    assert re.search(r"with 2 workers \(--workers; \d+ cores usable of the machine's \d+, load average [\d.]+ before\)",
                     "\n".join(lines)), lines
