"""``linkedit schemas DIR``: write the JSON Schema of every input format (kept in sync by a test)."""

from __future__ import annotations

from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, guard, report, say


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def schemas(out_dir: Path = typer.Argument(Path("specs"), help="Folder for the *.schema.json files."),
                as_json: bool = JSON, quiet: bool = QUIET) -> None:
        """Write the JSON Schemas of the input formats (linkage, edit script, 3D mechanism, curve set)."""
        from linkedit.spec.schema import write_schemas

        written = [str(p) for p in write_schemas(out_dir)]
        report({"output": str(out_dir), "files": written})
        for path in written:
            say(path)
