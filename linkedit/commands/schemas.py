"""``linkedit schemas DIR``: write the JSON Schema of every input format (kept in sync by a test)."""

from __future__ import annotations

from pathlib import Path

import typer

from linkedit.commands.common import guard


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def schemas(out_dir: Path = typer.Argument(Path("specs"), help="Folder for the *.schema.json files.")) -> None:
        """Write the JSON Schemas of the input formats (linkage, edit script, 3D mechanism, curve set)."""
        from linkedit.spec.schema import write_schemas

        for path in write_schemas(out_dir):
            typer.echo(str(path))
