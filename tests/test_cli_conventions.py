"""CLI conventions: -h, -V, python -m linkedit, completion, help text that keeps its defaults,
flags shown as flags, choices listed."""

from __future__ import annotations

import re
from enum import Enum
import subprocess
import sys

import pytest

from linkedit import __version__
from linkedit.cli import app
from tests.conftest import EXAMPLES


def _commands() -> list[str]:
    import typer.main

    return sorted(typer.main.get_command(app).commands)  # type: ignore[attr-defined]


def test_version_and_short_help(run_cli):
    for flag in ("-V", "--version"):
        r = run_cli(flag)
        assert r.exit_code == 0 and r.output.strip() == f"linkedit {__version__}"
    r = run_cli("-h")
    assert r.exit_code == 0 and "simulate" in r.output and "--install-completion" in r.output


def test_python_dash_m():
    r = subprocess.run([sys.executable, "-m", "linkedit", "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == f"linkedit {__version__}"


@pytest.mark.parametrize("command", _commands())
def test_help_keeps_defaults_shows_flags_and_choices(command):
    import typer.main
    from typer.testing import CliRunner

    r = CliRunner().invoke(app, [command, "-h"], terminal_width=400)
    assert r.exit_code == 0, r.output
    text = " ".join(r.output.split())
    assert "<bool>" not in text  # flags take no value
    params = typer.main.get_command(app).commands[command].params  # type: ignore[attr-defined]
    for p in params:
        help_text = " ".join((getattr(p, "help", None) or "").split())
        for default in re.findall(r"\[default: [^\]]*\]", help_text):
            assert default in text, (p.name, default)
        kind = getattr(p, "bare_type", None)
        if isinstance(kind, type) and issubclass(kind, Enum):
            assert "<" + "|".join(c.value for c in kind) + ">" in text, p.name


def _keys(o, path=""):
    if isinstance(o, dict):
        for k, v in o.items():
            yield f"{path}/{k}"
            yield from _keys(v, f"{path}/{k}")
    elif isinstance(o, list):
        for v in o[:3]:
            yield from _keys(v, path + "[]")


def test_json_keys_have_no_spaces(run_cli, tmp_path):
    import json

    from tests.conftest import EXAMPLES

    runs = [("simulate", EXAMPLES / "crank-rocker.yaml", "-o", tmp_path / "c.h5", "-n", "12"),
            ("validate", EXAMPLES / "crank-rocker.yaml", "-n", "12"),
            ("solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "-o", tmp_path / "s.h5", "--steps", "8"),
            ("compare-curves", EXAMPLES / "curves" / "foot-paths.yaml")]
    for args in runs:
        r = run_cli(*args, "--json")
        assert r.exit_code == 0, r.output
        assert [k for k in _keys(json.loads(r.stdout)) if " " in k.rsplit("/", 1)[1]] == [], args[0]


def test_quiet_prints_the_errors_and_nothing_else(run_cli, tmp_path):
    """-q: nothing on stdout, and each failure still one ``linkedit: error:`` line on stderr that names it."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\njoints: [\n")
    locking = EXAMPLES / "invalid" / "locking-slider-crank.yaml"
    failures = [
        (("validate", locking), 1, "locking-slider-crank.yaml: locks up: the linkage cannot be assembled for motor "
                                   "angles 220.5°…319.5°: slider piston cannot place joint B"),  # 180° ± asin(13/20) from 0°, 360°
        (("validate", EXAMPLES / "crank-rocker.yaml", bad), 2, "bad.yaml:3: malformed YAML"),
        (("simulate", locking, "-o", tmp_path / "l.h5"), 1, "slider piston cannot place joint B"),
        (("simulate", EXAMPLES / "crank-rocker.yaml", "--samples", "0"), 2, "--samples: must be ≥ 1"),
        (("features", EXAMPLES / "curves" / "foot-paths.yaml", bad), 2, "bad.yaml:3: malformed YAML"),
        (("atlas", "build", "--family", "nosuch", "-n", "10", "-o", tmp_path / "a.h5"), 2, "unknown family 'nosuch'"),
    ]
    for args, code, message in failures:
        r = run_cli(*args, "-q")
        assert (r.exit_code, r.stdout) == (code, ""), (args, r.output)
        lines = r.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith("linkedit: error: ") and message in lines[0], (args, lines)
    for args in [("validate", EXAMPLES / "crank-rocker.yaml", "-n", "12"),
                 ("simulate", EXAMPLES / "crank-rocker.yaml", "-n", "12", "-o", tmp_path / "c.h5")]:
        r = run_cli(*args, "-q")
        assert (r.exit_code, r.output) == (0, ""), args


def test_the_readme_option_error_is_what_the_cli_says(run_cli, monkeypatch):
    """The errors table's example of a bad option is the CLI's own line (it went stale once: ``≥ 8``)."""
    import shlex

    from tests.conftest import ROOT

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    command, message = re.search(r"an option: `linkedit ([^`]+)` says `([^`]+)`", readme).groups()
    monkeypatch.chdir(ROOT)
    r = run_cli(*shlex.split(command))
    assert (r.exit_code, r.stderr) == (2, f"linkedit: error: {message}\n")
