"""Exit codes by command, one case of each (specs/cli-json.md): 2 = the input is malformed, refers to
something absent or is inconsistent in itself, or an option is out of range; 1 = the input is well formed
but the mechanism cannot do it, the computation fails or the disk is full. Always one line on stderr."""

from __future__ import annotations

import resource
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.conftest import EXAMPLES
from tests.planar_specs import LOCKING

CRANK_ROCKER = EXAMPLES / "crank-rocker.yaml"
ROCKER_3D = EXAMPLES / "3d" / "crank-rocker.yaml"
GERONO = f"{EXAMPLES / 'curves' / 'gerono.yaml'}:figure-eight"


def _file(name: str, text: str) -> Callable[[Path], Path]:
    def make(tmp: Path) -> Path:
        (tmp / name).write_text(text)
        return tmp / name
    return make


def _atlas(tmp: Path) -> Path:
    from typer.testing import CliRunner

    from linkedit.cli import app

    r = CliRunner().invoke(app, ["atlas", "build", "--family", "four-bar", "-n", "200", "-o", str(tmp / "a.h5")])
    assert r.exit_code == 0, r.output
    return tmp / "a.h5"


def _result(tmp: Path) -> Path:
    from typer.testing import CliRunner

    from linkedit.cli import app

    assert CliRunner().invoke(app, ["simulate", str(CRANK_ROCKER), "-n", "36", "-o", str(tmp / "r.h5")]).exit_code == 0
    return tmp / "r.h5"


UNKNOWN_JOINT = _file("bad.yaml", CRANK_ROCKER.read_text().replace("rocker: [D, B]", "rocker: [D, Q]"))
LOCKS = _file("lock.yaml", LOCKING)
#: the rocker's pivot so far off that no pose satisfies the pins: the solver cannot assemble it
APART = _file("apart.yaml", ROCKER_3D.read_text().replace("world: [2, -3, 0]}", "world: [40, -3, 0]}"))
KNEE = "operations:\n  - displace: {joint: B, to: [12, 6]}\n"  # within 10 sizes of the 3 mm LOCKING: a target, not other units

#: command → (exit 2 case, exit 1 case); a case: argument builder (tmp folder → args), "disk" (the
#: exit 1 case is a full disk: a 100-byte file size limit) or None (the command has no such case)
CASES: dict[str, tuple[Callable[[Path], list], Callable[[Path], list] | None, bool]] = {
    "simulate": (lambda t: [UNKNOWN_JOINT(t), "-o", t / "o.h5"], lambda t: [LOCKS(t), "-o", t / "o.h5"], False),
    "validate": (lambda t: [UNKNOWN_JOINT(t)], lambda t: [LOCKS(t)], False),
    "assemble": (lambda t: [t / "absent.yaml"], lambda t: [EXAMPLES / "lengths" / "jansen.yaml", "-o", t / "o.yaml"], True),
    "import": (lambda t: ["M[", "-o", t / "o.yaml"], lambda t: [EXAMPLES / "import" / "fourbar.pyslvs", "-o", t / "o.yaml"], True),
    "plot": (lambda t: [t / "absent.h5", "-o", t / "o.svg"], lambda t: [_result(t), "-o", t / "o.svg"], True),
    "examples": (lambda t: [_file("taken", "x")(t)], lambda t: [t / "ex"], True),
    "edit": (lambda t: [CRANK_ROCKER, _file("s.yaml", KNEE.replace("joint: B", "joint: Q"))(t), "-o", t / "o"],
             lambda t: [LOCKS(t), _file("s.yaml", KNEE)(t), "-o", t / "o"], False),
    "solve3d": (lambda t: [ROCKER_3D, "--steps", "1", "-o", t / "o.h5"], lambda t: [APART(t), "-o", t / "o.h5"], False),
    "features": (lambda t: [f"{t / 'absent.yaml'}:x"], lambda t: [GERONO, "-o", t / "o.csv"], True),
    "compare-curves": (lambda t: [EXAMPLES / "curves" / "foot-paths.yaml", "--weight", "points=-1"],
                       lambda t: [EXAMPLES / "curves" / "foot-paths.yaml", "-o", t / "o.csv"], True),
    "synthesize": (lambda t: [GERONO, "--atlas", t / "absent.h5", "-o", t / "o"],
                   lambda t: [GERONO, "--atlas", _atlas(t), "-o", t / "o"], True),
    "atlas build": (lambda t: ["--family", "no-such", "-n", "3", "-o", t / "a.h5"],
                    lambda t: ["--family", "four-bar", "-n", "50", "-o", t / "a.h5"], True),
    "schemas": (lambda t: [_file("taken", "x")(t)], lambda t: [t / "s"], True),
    "bench": (lambda t: ["-s", "no-such"], None, False),  # bench reads and writes nothing of the user's
}
#: the file size limit of a "disk" case where 100 bytes is not it: the atlas's is checked before the build
#: (50 linkages: ~22 kB), so the limit lies above that and below the 2 MB file HDF5 writes
DISK_LIMIT = {"atlas build": 100_000}


def _one_line(r, code: int) -> str:
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]  # stdout: what validate found, say
    assert r.exit_code == code and len(lines) == 1 and lines[0].startswith("linkedit: error: "), r.output
    assert "Traceback" not in r.output
    return lines[0]


@pytest.mark.parametrize("command", sorted(CASES))
def test_malformed_or_absent_input_is_exit_2(run_cli, tmp_path, command):
    args = CASES[command][0](tmp_path)
    _one_line(run_cli(*command.split(), *args), 2)


@pytest.mark.parametrize("command", sorted(c for c in CASES if CASES[c][1] is not None))
def test_what_cannot_be_done_is_exit_1(run_cli, tmp_path, command, monkeypatch):
    make, disk = CASES[command][1], CASES[command][2]
    assert make is not None
    args = make(tmp_path)
    if not disk:
        _one_line(run_cli(*command.split(), *args), 1)
        return
    monkeypatch.setattr(sys, "dont_write_bytecode", True)  # a module first imported here: its .pyc would be cut short
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (DISK_LIMIT.get(command, 100), hard))  # Python ignores SIGXFSZ: writes fail with EFBIG
    try:
        r = run_cli(*command.split(), *args)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert "file size limit reached writing" in _one_line(r, 1)
