"""Packaging: LICENSE, examples shipped and copied out, the catalog never writes where it should not,
scipy stays out of a planar simulate."""

from __future__ import annotations

import subprocess
import sys
import tomllib

from tests.conftest import EXAMPLES, ROOT


def test_license_and_metadata():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["license"] == "MIT" and (ROOT / "LICENSE").read_text().startswith("MIT License")
    data = meta["tool"]["setuptools"]["data-files"]
    shipped = {p for patterns in data.values() for p in patterns}
    for folder in {p.parent for p in EXAMPLES.rglob("*.yaml")}:
        assert f"{folder.relative_to(ROOT)}/*.yaml" in shipped, folder
    assert (ROOT / "linkedit" / "py.typed").exists()


def test_examples_command_copies_every_file(run_cli, tmp_path):
    r = run_cli("examples", tmp_path / "ex")
    assert r.exit_code == 0, r.output
    copied = sorted(p.relative_to(tmp_path / "ex") for p in (tmp_path / "ex").rglob("*.yaml"))
    assert copied == sorted(p.relative_to(EXAMPLES) for p in EXAMPLES.rglob("*.yaml"))
    assert run_cli("examples", tmp_path / "ex").exit_code == 0  # the same files again: fine
    (tmp_path / "ex" / "jansen.yaml").write_text("mine\n")
    r = run_cli("examples", tmp_path / "ex")
    assert r.exit_code == 2 and "differs: not overwritten" in r.output
    assert (tmp_path / "ex" / "jansen.yaml").read_text() == "mine\n"


def test_catalog_help_writes_nothing(tmp_path):
    r = subprocess.run([sys.executable, "-m", "linkedit.planar.catalog", "--help"], cwd=tmp_path,
                       capture_output=True, text=True)
    assert r.returncode == 0 and "usage:" in r.stdout
    assert list(tmp_path.iterdir()) == []


def test_planar_simulate_does_not_import_scipy(tmp_path):
    code = ("import sys; from typer.testing import CliRunner; from linkedit.cli import app; "
            f"r = CliRunner().invoke(app, ['simulate', {str(EXAMPLES / 'jansen.yaml')!r}, '-o', {str(tmp_path / 'j.h5')!r},"
            f" '--svg', {str(tmp_path / 'j.svg')!r}]); print(r.exit_code, 'scipy' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.split() == ["0", "False"]


def test_no_private_typer_module_is_imported():
    """typer's private modules come and go (``typer._click`` appeared in 0.26): importing one ties
    linkedit to a narrower typer than pyproject.toml declares (with typer 0.15 ``linkedit --version``
    raised ModuleNotFoundError)."""
    import ast

    private = []
    for path in sorted((ROOT / "linkedit").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [f"{node.module}.{a.name}" for a in node.names]  # from typer import _click
                     if isinstance(node, ast.ImportFrom) and node.module and not node.level else [])
            private += [f"{path.relative_to(ROOT)}:{node.lineno}: {n}" for n in names
                        if n.split(".")[0] == "typer" and any(p.startswith("_") for p in n.split(".")[1:])]
    assert private == []
