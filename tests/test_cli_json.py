"""Every command has `--json` (one documented report shape, specs/cli-json.md) and `--quiet`.

The report is one JSON object on stdout: command, linkedit, ok, exit_code, result, errors,
warnings; keys without spaces; a user error is in the report too (exit 2), a mechanism failure
likewise (exit 1); `--quiet` prints nothing on success."""

from __future__ import annotations

import json

import pytest

from tests.conftest import EXAMPLES

ENVELOPE = ["command", "linkedit", "ok", "exit_code", "result", "errors", "warnings"]
ERROR_KEYS = {"message", "text", "exit_code", "file", "line", "field", "input"}


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Inputs the commands read: a planar result, an atlas."""
    from typer.testing import CliRunner

    from linkedit.cli import app

    folder = tmp_path_factory.mktemp("cli-json")
    for args in (["simulate", str(EXAMPLES / "crank-rocker.yaml"), "-o", str(folder / "c.h5"), "-n", "72", "-q"],
                 ["atlas", "build", "--family", "four-bar", "-n", "100", "-o", str(folder / "a.h5"), "-q"]):
        r = CliRunner().invoke(app, args)
        assert r.exit_code == 0 and r.stdout == "", r.output
    return folder


def _runs(made, out):
    """command → (arguments of a successful run, arguments of a run with a missing input file or a bad option)."""
    missing = out / "missing.yaml"
    curves = EXAMPLES / "curves" / "foot-paths.yaml"
    return {
        "simulate": (["simulate", EXAMPLES / "crank-rocker.yaml", "-o", out / "s.h5", "-n", "12"], ["simulate", missing]),
        "validate": (["validate", EXAMPLES / "crank-rocker.yaml", "-n", "12"], ["validate", missing]),
        "assemble": (["assemble", EXAMPLES / "lengths" / "jansen.yaml", "-o", out / "posed.yaml"],
                     ["assemble", missing, "-o", out / "p.yaml"]),
        "import": (["import", EXAMPLES / "import" / "fourbar.pyslvs", "-o", out / "i.yaml"],
                   ["import", "M[J[R, P[0, 0], L[ground, L1]]", "--from", "pyslvs", "-o", out / "i2.yaml"]),
        "plot": (["plot", made / "c.h5", "-o", out / "k.svg"], ["plot", out / "missing.h5", "-o", out / "k2.svg"]),
        "examples": (["examples", out / "ex"], ["examples", EXAMPLES / "crank-rocker.yaml"]),
        "edit": (["edit", EXAMPLES / "edits" / "jansen-move-knee.yaml", "-o", out / "e"], ["edit", missing]),
        "solve3d": (["solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "-o", out / "g.h5", "--steps", "8"],
                    ["solve3d", missing]),
        "features": (["features", curves], ["features", out / "missing.csv"]),
        "compare-curves": (["compare-curves", curves], ["compare-curves", out / "missing.csv", curves]),
        "synthesize": (["synthesize", f"{made / 'c.h5'}:coupler_point", "--atlas", made / "a.h5", "-o", out / "syn",
                        "--top", "1"], ["synthesize", out / "missing.csv", "--atlas", made / "a.h5", "-o", out / "s2"]),
        "atlas build": (["atlas", "build", "--family", "four-bar", "-n", "20", "-o", out / "a2.h5"],
                        ["atlas", "build", "--family", "no-such-family", "-n", "20", "-o", out / "a3.h5"]),
        "schemas": (["schemas", out / "schemas"], ["schemas", EXAMPLES / "crank-rocker.yaml"]),
        "bench": (["bench", "--quick", "-s", "planar"], ["bench", "-s", "no-such-section"]),
    }


def _keys(o, path=""):
    if isinstance(o, dict):
        for k, v in o.items():
            yield k, f"{path}/{k}"
            yield from _keys(v, f"{path}/{k}")
    elif isinstance(o, list):
        for v in o[:3]:
            yield from _keys(v, path + "[]")


COMMANDS = ["simulate", "validate", "assemble", "import", "plot", "examples", "edit", "solve3d", "features",
            "compare-curves", "synthesize", "atlas build", "schemas", "bench"]


def test_every_command_has_json_and_quiet():
    import typer

    from linkedit.cli import app

    group = typer.main.get_command(app)
    found = []
    for name, cmd in group.commands.items():  # type: ignore[attr-defined]
        for sub, leaf in getattr(cmd, "commands", {name: cmd}).items():
            opts = {o for p in leaf.params for o in p.opts}
            found.append(name if sub == name else f"{name} {sub}")
            assert {"--json", "--quiet", "-q"} <= opts, found[-1]
    assert sorted(found) == sorted(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_json_report_quiet_and_errors(run_cli, made, tmp_path, command):
    good, bad = _runs(made, tmp_path)[command]
    r = run_cli(*good, "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert list(data) == ENVELOPE and data["command"] == command
    assert data["ok"] is True and data["exit_code"] == 0 and data["errors"] == [] and data["result"] is not None
    assert [p for k, p in _keys(data) if " " in k] == []
    # --quiet: nothing at all on success (the run is redone into a fresh folder where it writes one)
    quiet = [a if a != tmp_path / "ex" else tmp_path / "ex2" for a in good]
    quiet = [tmp_path / "q" / a.name if hasattr(a, "name") and str(a).startswith(str(tmp_path)) else a for a in quiet]
    (tmp_path / "q").mkdir()
    r = run_cli(*quiet, "--quiet")
    assert r.exit_code == 0 and r.stdout == "" and r.stderr == "", r.output
    # a user error: one line on stderr, and with --json the same error as the report, exit 2
    r = run_cli(*bad, "--json")
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output, r.output
    data = json.loads(r.stdout)
    assert list(data) == ENVELOPE and data["ok"] is False and data["exit_code"] == 2
    assert len(data["errors"]) == 1 and set(data["errors"][0]) == ERROR_KEYS
    assert data["errors"][0]["text"] in r.stderr


def test_a_mechanism_failure_is_exit_1_in_the_report(run_cli, tmp_path):
    spec = tmp_path / "locks.yaml"  # a crank longer than the rest allows: locks up part of the turn
    spec.write_text((EXAMPLES / "crank-rocker.yaml").read_text())
    import yaml

    data = yaml.safe_load(spec.read_text())
    pivot, driven = data["motor"]["pivot"], data["motor"]["joint"]
    px, py = data["joints"][pivot]
    x, y = data["joints"][driven]
    data["joints"][driven] = [px + 2 * (x - px), py + 2 * (y - py)]
    spec.write_text(yaml.safe_dump(data))
    r = run_cli("simulate", spec, "-o", tmp_path / "l.h5", "--json")
    assert r.exit_code == 1, r.output
    report = json.loads(r.stdout)
    assert report["ok"] is False and report["exit_code"] == 1 and report["errors"][0]["exit_code"] == 1
    assert report["errors"][0]["text"] in r.stderr
    locking = EXAMPLES / "invalid" / "locking-slider-crank.yaml"  # validate reports the lock-up as an error
    r = run_cli("validate", locking, "--json")
    report = json.loads(r.stdout)
    assert r.exit_code == 1 and report["exit_code"] == 1 and report["result"][0]["lockups"]
    assert [(e["exit_code"], e["input"]) for e in report["errors"]] == [(1, str(locking))]
    assert report["errors"][0]["message"].startswith("locks up: ") and "slider piston" in report["errors"][0]["message"]


def test_json_and_stdout_output_do_not_share_stdout(run_cli):
    r = run_cli("assemble", EXAMPLES / "lengths" / "jansen.yaml", "--json")  # -o - is its default
    assert r.exit_code == 2 and json.loads(r.stdout)["errors"][0]["field"] == "--json"


def test_usage_error_with_json_is_a_report(run_cli):
    r = run_cli("simulate", EXAMPLES / "crank-rocker.yaml", "--samples", "0", "--json")
    data = json.loads(r.stdout)
    assert r.exit_code == 2 and data["command"] == "simulate" and data["exit_code"] == 2
    assert "--samples" in data["errors"][0]["message"]


def test_simulate_json_gives_lock_ups_as_numbers(run_cli, tmp_path):
    """A program reading ``simulate --partial --json`` gets each lock-up's interval as numbers with
    units and the joint to blame: the locking slider-crank (crank 20, rod 25, offset 12) cannot
    close where 20 sin θ < −13, θ in (180° + asin(13/20), 360° − asin(13/20)), at its piston B."""
    import math

    spec = EXAMPLES / "invalid" / "locking-slider-crank.yaml"
    r = run_cli("simulate", spec, "-o", tmp_path / "l.h5", "-n", "72", "--partial", "--json")
    assert r.exit_code == 0, r.output
    result = json.loads(r.stdout)["result"][0]
    (lk,) = result["lockup_intervals"]
    edge = math.degrees(math.asin(13 / 20))
    assert lk["units"] == "deg" and lk["joint"] == "B" and lk["exact"] is True and lk["turn"] is None
    assert abs(lk["start"] - (180 + edge)) < 1e-6 and abs(lk["end"] - (360 - edge)) < 1e-6
    assert lk["reason"].startswith("slider piston") and lk["samples"] == [45, 63]
    assert result["lockups"] == [f"the linkage cannot be assembled for motor angles 220.5°…319.5°: {lk['reason']}"]
