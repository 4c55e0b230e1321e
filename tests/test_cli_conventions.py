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
