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


#: the commands that write files (their default output folder is out/, shared by all)
WRITERS = {"simulate", "edit", "solve3d", "import", "assemble", "synthesize", "atlas", "examples"}


def test_each_readme_step_names_outputs_of_its_own():
    """A reader who runs the README in order keeps every step's result: each writing step names its
    output (-o), and no two steps name the same output file or folder."""
    seen: dict[str, str] = {}
    for words in _commands():
        line = "linkedit " + " ".join(words)
        if words[0] in WRITERS:
            assert {"-o", "--output"} & set(words), f"{line}: writes to the default out/"
        outputs = {value for option, value in zip(words, words[1:]) if option in ("-o", "--output", "--svg")}
        for value in outputs - {"-"}:  # (one folder may take a step's results and its pictures)
            assert value not in seen, f"{line} overwrites {value} of {seen[value]}"
            seen[value] = line


@pytest.mark.slow
def test_every_readme_command_runs_as_written(run_cli, tmp_path, monkeypatch):
    shutil.copytree(EXAMPLES, tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    written: dict[str, tuple[tuple[int, int], str]] = {}  # file: (inode, mtime), the step that wrote it
    for words in _commands():
        args = [match for w in words for match in (sorted(glob.glob(w)) if "*" in w else [w])]
        r = run_cli(*args)
        line = f"linkedit {' '.join(words)}"
        assert r.exit_code == 0, f"{line}: {r.output}"
        for path in tmp_path.rglob("*"):
            if path.is_file() and not path.is_relative_to(tmp_path / "examples"):
                info = path.stat()
                name, key = str(path.relative_to(tmp_path)), (info.st_ino, info.st_mtime_ns)
                assert written.get(name, (key,))[0] == key, f"{line} rewrote {name} of {written[name][1]}"
                written.setdefault(name, (key, line))
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
