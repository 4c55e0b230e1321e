"""Every command of the README runs as written, in order, on a fresh copy of the examples."""

from __future__ import annotations

import glob
import re
import shlex
import shutil
import subprocess
import sys

import pytest

from tests.conftest import EXAMPLES, ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, re.DOTALL)


def _commands() -> list[list[str]]:
    commands = []
    for block in _blocks("sh"):
        for line in block.splitlines():
            words = shlex.split(line, comments=True)
            if words and words[0] == "linkedit":
                commands.append(words[1:])
    return commands


def test_the_readme_has_commands_for_every_tool():
    used = {words[0] for words in _commands() if words}
    assert {"simulate", "validate", "edit", "solve3d", "features", "compare-curves"} <= used


@pytest.mark.slow
def test_every_readme_command_runs_as_written(run_cli, tmp_path, monkeypatch):
    shutil.copytree(EXAMPLES, tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    for words in _commands():
        args = [match for w in words for match in (sorted(glob.glob(w)) if "*" in w else [w])]
        r = run_cli(*args)
        assert r.exit_code == 0, f"linkedit {' '.join(words)}: {r.output}"
    optional = _optional_modules()
    for block in _blocks("python"):  # each in a fresh interpreter, as a new notebook would run it
        r = subprocess.run([sys.executable, "-c", block], capture_output=True, text=True, timeout=600)
        missing = re.search(r"ModuleNotFoundError: No module named '([^'.]+)", r.stderr)
        if r.returncode and missing and missing.group(1) in optional:
            continue  # a block for an optional extra that is not installed here
        assert r.returncode == 0, f"README.md python block:\n{block}\n{r.stderr}"


def _optional_modules() -> set[str]:
    """Module names of the optional extras (pyproject ``[project.optional-dependencies]``)."""
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    return {re.split(r"[^A-Za-z0-9_.-]", req, maxsplit=1)[0].lower() for reqs in extras.values() for req in reqs}
