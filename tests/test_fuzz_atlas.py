"""Fuzz: small valid atlases mutated at random (members and attributes dropped, values of another
type, datasets of another dtype or shape, sparse datasets declaring huge sizes, soft, external and
hard links, families renamed, the file cut short), then read by `synthesize --atlas` and appended to
by `atlas build`. Every run exits 0 or 2 (1 would be a well-formed atlas in which no linkage fits)
with one line on stderr, none on success — never a traceback, a crash or a hang; a run that fails
leaves the atlas as it was and writes nothing, and an atlas appended to is read back.

The cases run in one child process (a hang or a crash there names its case); the default profile
runs ``FUZZ_ATLASES`` (12) mutated atlases, ``LINKEDIT_FUZZ_ATLASES=300 pytest tests/test_fuzz_atlas.py
-m slow`` the long one. ``LINKEDIT_FUZZ_SEED`` replays another sequence.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
import shutil
import subprocess
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.conftest import ROOT

FUZZ_ATLASES = int(os.environ.get("LINKEDIT_FUZZ_ATLASES", "12"))
LONG_ATLASES = int(os.environ.get("LINKEDIT_FUZZ_ATLASES", "300"))
SEED = int(os.environ.get("LINKEDIT_FUZZ_SEED", "26"))

ODD_ATTRIBUTES: list = ["x", "", np.bytes_(b"\xff\xfe"), -1, 0, 2**62, 2**63 - 1, np.uint64(2**64 - 1), 1e300, np.nan,
                        np.inf, -np.inf, 1.5, True, np.array([1, 2]), np.zeros(0), np.int8(-1), "joints: [",
                        "four-bar", np.array(["a", "b"], dtype="S1")]
ODD_DTYPES = ["i4", "u1", "?", "f2", "c16", "S8", np.dtype([("a", "f8"), ("b", "i4")])]
ODD_NAMES = ["no-such", "four-bar ", "FOUR-BAR", "é", "x" * 200, "slider-crank", "four-bar.yaml"]
HUGE = [10**9, 10**12, 2**40 + 1]


def _members(f: h5py.File) -> tuple[list[str], list[str]]:
    """Every group and dataset path (links not followed)."""
    groups: list[str] = []
    datasets: list[str] = []

    def visit(name: str, obj: object) -> None:
        (datasets if isinstance(obj, h5py.Dataset) else groups).append(name)

    f.visititems(visit)
    return groups, datasets


def _small(f: h5py.File) -> list[str]:
    """The datasets that fit in memory (not one a mutation made huge)."""
    return [d for d in _members(f)[1] if f[d].size < 10**7]


def _attributes(f: h5py.File) -> list[tuple[str, str]]:
    groups, datasets = _members(f)
    return [(where, name) for where in ["/", *groups, *datasets] for name in f[where].attrs]


def _replace(f: h5py.File, where: str, data: object = None, **create: object) -> None:
    parent, name = where.rsplit("/", 1) if "/" in where else ("/", where)
    attrs = dict(f[where].attrs) if where in f else {}
    del f[where]
    ds = f[parent].create_dataset(name, data=data, **create)
    for key, value in attrs.items():
        ds.attrs[key] = value


def drop_member(f: h5py.File, rng: random.Random) -> str:
    groups, datasets = _members(f)
    where = rng.choice(groups + datasets)
    del f[where]
    return f"drop {where}"


def drop_attribute(f: h5py.File, rng: random.Random) -> str:
    where, name = rng.choice(_attributes(f))
    del f[where].attrs[name]
    return f"drop attribute {where}@{name}"


def odd_attribute(f: h5py.File, rng: random.Random) -> str:
    where, name = rng.choice(_attributes(f))
    value = rng.choice(ODD_ATTRIBUTES)
    f[where].attrs[name] = value
    return f"attribute {where}@{name} = {value!r}"


def odd_dtype(f: h5py.File, rng: random.Random) -> str:
    where = rng.choice(_small(f))
    dtype = np.dtype(rng.choice(ODD_DTYPES))
    data = np.zeros(f[where].shape, dtype)
    _replace(f, where, data)
    return f"{where} as {dtype}"


def odd_shape(f: h5py.File, rng: random.Random) -> str:
    where = rng.choice(_small(f))
    shape = f[where].shape
    choices = [(), (0,), (shape[0] if shape else 3,), (*shape, 2), shape[::-1], (shape[0] + 5, *shape[1:]) if shape else (5,),
               (max(shape[0] - 1, 0), *shape[1:]) if shape else (0,), (*shape[:-1], shape[-1] + 1) if shape else (1,)]
    new = rng.choice(choices)
    _replace(f, where, np.ones(new, f[where].dtype if f[where].dtype.kind in "fiub" else "f8"))
    return f"{where} of shape {new}"


def huge(f: h5py.File, rng: random.Random) -> str:
    """A sparse dataset (chunked, never written) declaring a huge first axis: a few bytes in the file."""
    where = rng.choice(_members(f)[1])
    shape = f[where].shape or (1,)
    rows = rng.choice(HUGE)
    new = (rows, *shape[1:])
    chunk = (min(1024, rows), *[max(1, s) for s in shape[1:]])
    _replace(f, where, None, shape=new, dtype=f[where].dtype if f[where].dtype.kind == "f" else "f8", chunks=chunk)
    return f"{where}: sparse, shape {new}"


def link(f: h5py.File, rng: random.Random, tmp: Path) -> str:
    groups, datasets = _members(f)
    where = rng.choice(groups + datasets)
    other = rng.choice(datasets) if datasets else "/"
    kinds = {"soft loop": lambda: h5py.SoftLink("/" + where), "soft to a sibling": lambda: h5py.SoftLink("/" + other),
             "dangling": lambda: h5py.SoftLink("/nowhere"),
             "external /etc/passwd": lambda: h5py.ExternalLink("/etc/passwd", "/"),
             "external self": lambda: h5py.ExternalLink(f.filename, "/" + where),
             "external FIFO": lambda: h5py.ExternalLink(_fifo(tmp), "/x"),
             "hard to a sibling": lambda: f[other]}
    kind = rng.choice(sorted(kinds))
    target = kinds[kind]()
    if kind == "hard to a sibling" and (other == where or other.startswith(where + "/")):
        return "nothing (a hard link to itself)"
    del f[where]
    f[where] = target
    return f"{where}: {kind}"


def values(f: h5py.File, rng: random.Random) -> str:
    where = rng.choice(_small(f))
    ds = f[where]
    if ds.dtype.kind != "f" or ds.size == 0:
        return f"nothing ({where} holds no numbers)"
    value = rng.choice([np.nan, np.inf, -np.inf, 1e300, -1e300, 0.0, -1.0])
    data = ds[()]
    with np.errstate(over="ignore"):  # 1e300 in float32: inf
        data.flat[rng.randrange(data.size)] = value
    ds[...] = data
    return f"{where}: a value {value}"


def rename_family(f: h5py.File, rng: random.Random) -> str:
    if "families" not in f or not isinstance(f["families"], h5py.Group) or not len(f["families"]):
        return "nothing (no families)"
    old = rng.choice(sorted(f["families"]))
    new = rng.choice(ODD_NAMES)
    if new in f["families"]:
        del f["families"][new]
    f["families"].move(old, new)
    return f"families/{old} renamed {new!r}"


MUTATIONS: list[Callable] = [drop_member, drop_attribute, odd_attribute, odd_dtype, odd_shape, huge, link, values,
                             rename_family]


def _fifo(tmp: Path) -> str:
    path = tmp / "pipe"
    if not path.exists():
        os.mkfifo(path)
    return str(path)


def mutate(atlas: Path, folder: Path, rng: random.Random) -> list[str]:
    """Copy ``atlas`` to ``folder/a.h5`` and damage it in 1 to 3 ways (or cut it short); say how."""
    folder.mkdir()
    out = folder / "a.h5"
    shutil.copy(atlas, out)
    done: list[str] = []
    with h5py.File(out, "a") as f:
        for _ in range(rng.choice([1, 1, 2, 3])):
            op = rng.choice(MUTATIONS)
            try:
                done.append(op(f, rng, folder) if op is link else op(f, rng))
            except (IndexError, KeyError):  # nothing of that kind left to damage
                continue
    if rng.random() < 0.1:
        size = out.stat().st_size
        cut = rng.randrange(size)
        with open(out, "r+b") as fh:
            fh.truncate(cut)
        done.append(f"cut at {cut} of {size} bytes")
    return done


def drive(cases: str, log: str) -> None:
    """In the child: run both commands on every case's atlas, one JSON line per run in ``log``
    (a "start" line first, so that a hang or a crash names its case)."""
    from typer.testing import CliRunner

    from linkedit.cli import app

    spec = json.loads(Path(cases).read_text())
    with open(log, "a") as out:
        for case in spec["cases"]:
            folder = Path(case["folder"])
            atlas = folder / "a.h5"
            for name, args in (("synthesize", ["synthesize", spec["target"], "--atlas", atlas, "-o", folder / "syn",
                                               "--top", "1", "-q"]),
                               ("append", ["atlas", "build", "--family", "four-bar", "-n", "20", "-o", atlas,
                                           "--seed", "1", "-q"])):
                out.write(json.dumps({"start": case["index"], "command": name}) + "\n")
                out.flush()
                r = CliRunner().invoke(app, [str(a) for a in args])
                crash = None
                if r.exception is not None and not isinstance(r.exception, SystemExit):
                    crash = "".join(traceback.format_exception(r.exception))
                out.write(json.dumps({"index": case["index"], "command": name, "code": r.exit_code,
                                      "stderr": r.stderr, "crash": crash}) + "\n")
                out.flush()


@pytest.fixture(scope="module")
def seed_atlas(tmp_path_factory) -> tuple[Path, Path]:
    """A small valid atlas of two families (40 linkages each) and a target curve (an ellipse)."""
    from typer.testing import CliRunner

    from linkedit.cli import app

    folder = tmp_path_factory.mktemp("seed")
    r = CliRunner().invoke(app, ["atlas", "build", "--family", "four-bar,slider-crank", "-n", "40", "-o",
                                 str(folder / "a.h5"), "--seed", "1", "-q"])
    assert r.exit_code == 0, r.output
    target = folder / "t.csv"
    a = np.linspace(0, 6.2, 40)
    target.write_text("x,y\n" + "\n".join(f"{np.cos(t):.6f},{0.5 * np.sin(t):.6f}" for t in a) + "\n")
    return folder / "a.h5", target


def _fuzz(seed_atlas: tuple[Path, Path], tmp_path: Path, count: int, seed: int) -> None:
    atlas, target = seed_atlas
    rng = random.Random(seed)
    cases, said, before = [], {}, {}
    for index in range(count):
        folder = tmp_path / f"case{index}"
        said[index] = mutate(atlas, folder, rng)
        before[index] = hashlib.sha256((folder / "a.h5").read_bytes()).digest()
        cases.append({"index": index, "folder": str(folder)})
    spec, log = tmp_path / "cases.json", tmp_path / "log.jsonl"
    spec.write_text(json.dumps({"target": str(target), "cases": cases}))
    code = ("import sys; from tests.test_fuzz_atlas import drive; drive(sys.argv[1], sys.argv[2])")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    try:
        child = subprocess.run([sys.executable, "-c", code, str(spec), str(log)], cwd=ROOT, env=env, capture_output=True,
                               text=True, timeout=30 + 10 * count, stdin=subprocess.DEVNULL)
        failed = f"the child ended with {child.returncode}: {child.stderr[-2000:]}" if child.returncode else None
    except subprocess.TimeoutExpired:
        failed = "a hang"
    lines = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    if failed:
        last = lines[-1] if lines else {}
        case = last.get("start", last.get("index"))
        pytest.fail(f"{failed} at case {case} ({said.get(case)}), {last.get('command')}")
    runs = [line for line in lines if "code" in line]
    assert len(runs) == 2 * count
    for run in runs:
        index, name = run["index"], run["command"]
        where = f"case {index} ({'; '.join(said[index])}), {name}: exit {run['code']}, {run['stderr']!r}"
        assert run["crash"] is None, f"{where}\n{run['crash']}"
        assert run["code"] in (0, 1, 2), where
        assert "Traceback" not in run["stderr"] and len(run["stderr"].splitlines()) == (run["code"] != 0), where
        folder = tmp_path / f"case{index}"
        if name == "synthesize" and run["code"]:
            assert not (folder / "syn").exists(), where
        if name == "append" and run["code"]:
            assert hashlib.sha256((folder / "a.h5").read_bytes()).digest() == before[index], where
        if name == "append" and run["code"] == 0:  # the next step: the grown atlas is read back
            from linkedit.synthesis.atlas import load

            assert load(folder / "a.h5").families["four-bar"]["params"].shape[0] >= 20, where


def test_mutated_atlases_fail_in_one_line(seed_atlas, tmp_path):
    _fuzz(seed_atlas, tmp_path, FUZZ_ATLASES, SEED)


@pytest.mark.slow
def test_mutated_atlases_long_profile(seed_atlas, tmp_path):
    _fuzz(seed_atlas, tmp_path, LONG_ATLASES, SEED + 1)
