"""``linkedit examples DIR``: copy the example mechanisms out of the installation."""

from __future__ import annotations

from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, guard, report, say


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def examples(
        directory: Path = typer.Argument(..., help="Folder to copy the examples into (created if missing)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Copy the example linkages, edit scripts, 3D mechanisms and curve sets into DIRECTORY."""
        from linkedit.examples import copy_examples

        written = copy_examples(directory)
        report({"output": str(directory), "files": [str(p) for p in written]})
        say(f"{len(written)} example files → {directory}")
