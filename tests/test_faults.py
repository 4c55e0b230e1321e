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
    leftovers = sorted(p.name for p in tmp_path.iterdir() if p.name != "r.h5")
    if sig != signal.SIGKILL:
        assert leftovers == [], f"seed {seed}, delay {delay:.2f}s: {leftovers}; {err}"
        return
    # the temporary file a killed run left is removed by the next run writing there
    subprocess.run(_linkedit(*args, old, "-o", out), check=True, capture_output=True, timeout=300)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.h5"]
