"""The gcs package's imports (issue 22): every module imports on its own in a fresh
interpreter, no import cycle runs through a gcs module (function-level imports included: none
may hide one), and gcs never reaches up into the result files, the commands or the CLI.

Before: ``gcs/result`` imported ``io.hdf5`` inside its functions while ``io/gcs_svg``
imported ``gcs.result`` (gcs ⇄ io)."""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import linkedit
import linkedit.gcs

ROOT = Path(linkedit.__file__).parent
GCS = sorted(f"linkedit.gcs.{m.name}" for m in pkgutil.iter_modules(linkedit.gcs.__path__))
#: packages above gcs: it must not import them
ABOVE = ("linkedit.io", "linkedit.commands", "linkedit.cli", "linkedit.notebook", "linkedit.synthesis")


def _module_names() -> dict[str, Path]:
    out = {}
    for path in ROOT.rglob("*.py"):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(path: Path, name: str, known: dict[str, Path]) -> set[str]:
    """The linkedit modules a module imports anywhere in it (functions included), but for
    ``if TYPE_CHECKING:`` blocks (never run)."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in known)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1] + ([base] if base else []))
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.add(sub if sub in known else base)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return {m for m in out if m in known and m != name}


@pytest.mark.slow  # 8 s of fresh imports; test_no_import_cycle_runs_through_gcs_and_gcs_does_not_reach_up runs by default
def test_each_gcs_module_imports_alone_in_a_fresh_interpreter():
    """One interpreter, gcs and io dropped from it before each module (the specs and planar
    kinematics below them stay loaded: they never import gcs)."""
    script = ("import importlib, sys\n"
              f"for name in {GCS!r}:\n"
              "    for m in [m for m in sys.modules if m.startswith(('linkedit.gcs', 'linkedit.io'))]:\n"
              "        del sys.modules[m]\n"
              "    importlib.import_module(name)\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT.parent)
    assert done.returncode == 0, done.stderr[-2000:]


def test_no_import_cycle_runs_through_gcs_and_gcs_does_not_reach_up():
    known = _module_names()
    graph: dict[str, set[str]] = {}
    todo = list(GCS)
    while todo:  # the modules gcs reaches
        name = todo.pop()
        if name not in graph:
            graph[name] = _imports(known[name], name, known)
            todo += graph[name]
    for name in GCS:
        up = sorted(m for m in graph[name] if m.startswith(ABOVE))
        assert not up, f"{name} imports {up}"
        # every module reachable from it, and whether it reaches back
        seen, todo = set(), [name]
        while todo:
            for m in graph[todo.pop()]:
                if m not in seen:
                    seen.add(m)
                    todo.append(m)
        assert name not in seen, f"{name} is on an import cycle"
