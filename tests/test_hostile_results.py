"""Result files someone else wrote: every command that reads HDF5 reads it guarded.

No link is followed (soft, external, a loop, to a FIFO), no data outside the file is read (a
virtual dataset, external storage), no dataset is read before its size is checked against the
file (a sparse dataset declaring 10¹⁰ rows), and a missing or malformed member is one line
``file: /path: what``, exit 2 — never a traceback, a hang or a huge allocation.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.conftest import EXAMPLES

JANSEN = EXAMPLES / "jansen.yaml"


@pytest.fixture(scope="module")
def planar(tmp_path_factory) -> Path:
    """A real planar result of the Jansen leg (60 samples)."""
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = tmp_path_factory.mktemp("planar") / "jansen.h5"
    r = CliRunner().invoke(app, ["simulate", str(JANSEN), "-o", str(out), "-n", "60", "-q"])
    assert r.exit_code == 0, r.output
    return out


@pytest.fixture(scope="module")
def gcs(tmp_path_factory) -> Path:
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = tmp_path_factory.mktemp("gcs") / "crank.h5"
    r = CliRunner().invoke(app, ["solve3d", str(EXAMPLES / "3d" / "crank-rocker.yaml"), "-o", str(out), "--steps", "19", "-q"])
    assert r.exit_code == 0, r.output
    return out


def mutated(src: Path, tmp_path: Path, change) -> Path:
    dst = tmp_path / "m.h5"
    shutil.copy(src, dst)
    with h5py.File(dst, "a") as f:
        change(f, tmp_path)
    return dst


def fifo(tmp_path: Path) -> str:
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return str(path)


def run(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    """The CLI in a subprocess, so a hang fails the test instead of stopping the suite."""
    return subprocess.run([sys.executable, "-m", "linkedit", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


def one_line(r: subprocess.CompletedProcess, file: Path, *words: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(file) in lines[0], r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


def external_fifo(f: h5py.File, tmp: Path) -> None:
    del f["tracks/foot/position"]
    f["tracks/foot/position"] = h5py.ExternalLink(fifo(tmp), "/x")


def external_self(f: h5py.File, tmp: Path) -> None:
    del f["tracks/foot/position"]
    f["tracks/foot/position"] = h5py.ExternalLink(f.filename, "/tracks/foot/position")


def external_passwd(f: h5py.File, tmp: Path) -> None:
    del f["tracks"]
    f["tracks"] = h5py.ExternalLink("/etc/passwd", "/")


def soft_loop(f: h5py.File, tmp: Path) -> None:
    del f["tracks/foot/position"]
    f["tracks/foot/position"] = h5py.SoftLink("/tracks/foot/position")


def virtual_fifo(f: h5py.File, tmp: Path) -> None:
    shape = f["tracks/foot/position"].shape
    del f["tracks/foot/position"]
    layout = h5py.VirtualLayout(shape=shape, dtype="f8")
    layout[:] = h5py.VirtualSource(fifo(tmp), "data", shape=shape)
    f["tracks/foot"].create_virtual_dataset("position", layout, fillvalue=0.0)


def sparse(f: h5py.File, tmp: Path) -> None:
    del f["tracks/foot/position"]
    f["tracks/foot"].create_dataset("position", shape=(10**10, 2), dtype="f8", chunks=(1024, 2))


ATTACKS = {"external link to a FIFO": (external_fifo, "external link"),
           "external link to itself": (external_self, "external link"),
           "external link to /etc/passwd": (external_passwd, "external link"),
           "soft-link loop": (soft_loop, "soft link"),
           "virtual dataset from a FIFO": (virtual_fifo, "virtual dataset"),
           "sparse 10^10 rows": (sparse, "/tracks/foot/position")}


def reading(command: str, bad: Path, tmp_path: Path) -> list:
    return {"plot": ["plot", bad, "-o", tmp_path / "p.svg"],
            "features": ["features", f"{bad}:foot", "-o", tmp_path / "f.csv"],
            "compare-curves": ["compare-curves", "--query", f"{bad}:foot", "--library",
                               EXAMPLES / "curves" / "foot-paths.yaml", "-o", tmp_path / "r.csv"],
            "synthesize": ["synthesize", f"{bad}:foot", "--atlas", tmp_path / "none.h5", "-o", tmp_path / "syn"]}[command]


COMMANDS = ["plot", "features", "compare-curves", "synthesize"]


@pytest.mark.parametrize("attack", ["external link to a FIFO", "virtual dataset from a FIFO"])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_track_behind_a_fifo_is_refused_without_waiting_for_it(planar, tmp_path, attack, command):
    change, words = ATTACKS[attack]
    bad = mutated(planar, tmp_path, change)
    one_line(run(*reading(command, bad, tmp_path)), bad, words)
    assert not (tmp_path / "p.svg").exists() and not (tmp_path / "f.csv").exists()


@pytest.mark.parametrize("attack", [a for a in ATTACKS if "FIFO" not in a])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_linked_or_sparse_track_is_refused_in_one_line(run_cli, planar, tmp_path, attack, command):
    change, words = ATTACKS[attack]
    bad = mutated(planar, tmp_path, change)
    r = run_cli(*reading(command, bad, tmp_path))
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    line = [ln for ln in r.output.splitlines() if str(bad) in ln]
    assert len(line) == 1 and words in line[0], r.output
    assert not (tmp_path / "p.svg").exists() and not (tmp_path / "f.csv").exists()


@pytest.mark.parametrize("attack", ["soft-link loop", "external link to a FIFO", "sparse 10^10 rows"])
def test_solve3d_from_a_linked_or_sparse_result_is_refused(gcs, tmp_path, attack):
    def change(f: h5py.File, tmp: Path) -> None:
        where = "members/position"
        shape = f[where].shape
        del f[where]
        if attack == "soft-link loop":
            f[where] = h5py.SoftLink("/" + where)
        elif attack == "sparse 10^10 rows":
            f["members"].create_dataset("position", shape=(10**10,) + shape[1:], dtype="f8", chunks=(64,) + shape[1:])
        else:
            f[where] = h5py.ExternalLink(fifo(tmp), "/x")

    bad = mutated(gcs, tmp_path, change)
    before = bad.read_bytes()
    r = run("solve3d", "--from", bad, "-o", tmp_path / "again.h5")
    one_line(r, bad, "members/position")
    assert bad.read_bytes() == before and not (tmp_path / "again.h5").exists()


def drop(where: str):
    def change(f: h5py.File, tmp: Path) -> None:
        del f[where]
    return change


def replace(where: str, data):
    def change(f: h5py.File, tmp: Path) -> None:
        del f[where]
        f[where] = data
    return change


def drop_attr(name: str):
    def change(f: h5py.File, tmp: Path) -> None:
        del f.attrs[name]
    return change


def undecodable(f: h5py.File, tmp: Path) -> None:
    del f["joint"]
    f.create_dataset("joint", data=np.array([b"\xff\xfe"] * 12, dtype=h5py.string_dtype("utf-8", None).type),
                     dtype=h5py.string_dtype("ascii"))


BROKEN = {"no /rules": (drop("rules"), "/rules"),
          "no /tracks": (drop("tracks"), None),
          "no transmission angle": (drop("diagnostics/transmission_angle"), "/diagnostics/transmission_angle"),
          "no motor angle": (drop("motor_angle"), "/motor_angle"),
          "no units": (drop_attr("units"), "units"),
          "empty /t": (replace("t", np.zeros(0)), "/t"),
          "string angles": (replace("motor_angle", np.array(["a"] * 60, dtype=object).astype(h5py.string_dtype())), "/motor_angle"),
          "joint index out of range": (replace("rules/joints", np.full((9, 3), 99)), "/rules/joints"),
          "wrong shape": (replace("diagnostics/singularity", np.zeros((3, 3))), "/diagnostics/singularity")}


@pytest.mark.parametrize("broken", BROKEN, ids=list(BROKEN))
def test_plot_of_an_incomplete_result_names_what_is_missing(run_cli, planar, tmp_path, broken):
    change, words = BROKEN[broken]
    bad = mutated(planar, tmp_path, change)
    args = ["plot", bad, "-o", tmp_path / "p.svg"] + (["--joint", "C"] if broken == "no /tracks" else [])
    r = run_cli(*args)
    if broken == "no /tracks":  # a joint needs no track: the plot is still drawn
        assert r.exit_code == 0, r.output
        return
    assert r.exit_code == 2, r.output
    assert str(bad) in r.output and (words is None or words in r.output), r.output
    assert not (tmp_path / "p.svg").exists()


def test_le_load_refuses_a_linked_result(planar, tmp_path):
    import linkedit as le
    from linkedit.errors import InputError

    bad = mutated(planar, tmp_path, soft_loop)
    with pytest.raises(InputError, match="soft link"):
        le.load(bad)


def test_plot_of_a_linear_input_result_is_drawn_against_the_stroke(run_cli, tmp_path):
    """A cylinder-driven linkage's result has a stroke, not a motor angle: its plot is drawn
    against the stroke (its own units), and per-second derivatives (--rpm) are refused."""
    h5 = tmp_path / "lift.h5"
    assert run_cli("simulate", EXAMPLES / "lifting-arm.yaml", "-o", h5, "-n", "40", "-q").exit_code == 0
    r = run_cli("plot", h5, "-o", tmp_path / "p.svg")
    assert r.exit_code == 0, r.output
    svg = (tmp_path / "p.svg").read_text()
    with h5py.File(h5) as f:
        units = f.attrs["units"]
    assert f"stroke from rest ({units})" in svg and "crank angle" not in svg
    r = run_cli("plot", h5, "-o", tmp_path / "q.svg", "--per-second", "--rpm", "60")
    assert r.exit_code == 2 and "--rpm" in r.output


@pytest.mark.parametrize("rpm", ["inf", "nan", "0"])
def test_plot_refuses_a_speed_that_is_not_finite_and_positive(run_cli, planar, tmp_path, rpm):
    r = run_cli("plot", planar, "-o", tmp_path / "p.svg", "--per-second", "--rpm", rpm)
    assert r.exit_code == 2 and "--rpm" in r.output, r.output
    assert not (tmp_path / "p.svg").exists()


@pytest.fixture(scope="module")
def small_atlas(tmp_path_factory) -> Path:
    from typer.testing import CliRunner

    from linkedit.cli import app

    out = tmp_path_factory.mktemp("atlas") / "a.h5"
    r = CliRunner().invoke(app, ["atlas", "build", "--family", "four-bar", "-n", "3000", "-o", str(out), "--seed", "1", "-q"])
    assert r.exit_code == 0, r.output
    return out


def drop_root_attr(name: str):
    def change(f: h5py.File, tmp: Path) -> None:
        del f.attrs[name]
    return change


def drop_group_attr(where: str, name: str):
    def change(f: h5py.File, tmp: Path) -> None:
        del f[where].attrs[name]
    return change


def narrow_index(f: h5py.File, tmp: Path) -> None:
    data = f["families/four-bar/index"][:, :-1]
    del f["families/four-bar/index"]
    f["families/four-bar/index"] = data


def huge_chunks(f: h5py.File, tmp: Path) -> None:
    f["families/four-bar"].attrs["chunks"] = 1e300  # an integer, as a float beyond 64 bits


def half_precision_params(f: h5py.File, tmp: Path) -> None:
    data = f["families/four-bar/params"][()]
    del f["families/four-bar/params"]
    f.create_dataset("families/four-bar/params", data=data.astype("f2"), maxshape=(None, data.shape[1]),
                     chunks=(100, data.shape[1]))


def linked_curves(f: h5py.File, tmp: Path) -> None:
    del f["families/four-bar/curves"]
    f["families/four-bar/curves"] = h5py.SoftLink("/families/four-bar/curves")


ATLAS_DAMAGE = {"no seed": (drop_root_attr("seed"), "seed"), "no chunk": (drop_root_attr("chunk"), "chunk"),
                "no harmonics": (drop_root_attr("harmonics"), "harmonics"),
                "no chunks": (drop_group_attr("families/four-bar", "chunks"), "chunks"),
                "no params": (drop("families/four-bar/params"), "params"),
                "no index": (drop("families/four-bar/index"), "index"),
                "index of the wrong width": (narrow_index, "/families/four-bar/index"),
                "curves behind a soft link": (linked_curves, "soft link"),
                "sparse curves": (replace("families/four-bar/curves", h5py.Empty("f")), "curves"),
                "chunks beyond 64 bits": (huge_chunks, "chunks"),  # the append: a TypeError traceback
                "params in half precision": (half_precision_params, "/families/four-bar/params")}  # appended to, rounded


@pytest.mark.parametrize("damage", ATLAS_DAMAGE, ids=list(ATLAS_DAMAGE))
def test_a_damaged_atlas_is_one_line_for_synthesize_and_for_an_append(run_cli, small_atlas, tmp_path, damage):
    change, words = ATLAS_DAMAGE[damage]
    bad = mutated(small_atlas, tmp_path, change)
    before = bad.read_bytes()
    target = tmp_path / "t.csv"
    target.write_text("x,y\n" + "\n".join(f"{np.cos(a):.6f},{0.5 * np.sin(a):.6f}" for a in np.linspace(0, 6.2, 40)))
    for args in (["synthesize", target, "--atlas", bad, "-o", tmp_path / "syn"],
                 ["atlas", "build", "--family", "four-bar", "-n", "100", "-o", bad, "--seed", "1"]):
        r = run_cli(*args)
        assert r.exit_code == 2 and "Traceback" not in r.output, (args[0], r.output)
        line = [ln for ln in r.output.splitlines() if str(bad) in ln]
        assert len(line) == 1 and words in line[0], (args[0], r.output)
    assert bad.read_bytes() == before and not (tmp_path / "syn").exists()


def test_an_atlas_stored_at_a_fixed_size_is_refused_for_an_append(run_cli, small_atlas, tmp_path):
    """An atlas whose arrays another tool rewrote without chunks (as `h5repack -l CONTI` does) can be read
    but not grown: the append is one line naming the array, the atlas untouched (a TypeError traceback
    from h5py's resize, found by tests/test_fuzz_atlas.py)."""
    def contiguous(f: h5py.File, tmp: Path) -> None:
        data = f["families/four-bar/params"][()]
        del f["families/four-bar/params"]
        f["families/four-bar/params"] = data

    bad = mutated(small_atlas, tmp_path, contiguous)
    before = bad.read_bytes()
    r = run_cli("atlas", "build", "--family", "four-bar", "-n", "100", "-o", bad, "--seed", "1")
    assert r.exit_code == 2, r.output
    assert r.stderr == f"linkedit: error: {bad}: /families/four-bar/params: is stored at a fixed size (rewritten by " \
                       "another tool?) and cannot grow; append to a new atlas\n"
    assert bad.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["m.h5"]
