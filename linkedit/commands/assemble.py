"""``linkedit assemble``: a spec given by link lengths → the same spec with its rest pose written out."""

from __future__ import annotations

from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, guard, refuse_json_with_stdout, report


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def assemble(
        spec: Path = typer.Argument(..., help="Linkage spec YAML whose links are given by length (specs/linkage.md)."),
        output: Path = typer.Option(Path("-"), "--output", "-o",
                                    help="The posed spec .yaml, or - for stdout.", show_default="- (stdout)"),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Assemble the rest pose from link lengths in closed form; write the spec with full-precision positions."""
        from linkedit.io.formats import output_format, write_out
        from linkedit.spec.lengths import link_lengths
        from linkedit.spec.linkage import LinkageSpec
        from linkedit.spec.linkage_yaml import dump_linkage
        from linkedit.spec.yamlload import load_yaml, validate

        output_format(output, ("yaml",), stdout="yaml")
        check_outputs([("--output", output)], [spec])
        refuse_json_with_stdout(output)
        data, lines = load_yaml(spec)
        model = validate(LinkageSpec, data, file=str(spec), lines=lines)
        notes = {}
        if isinstance(data, dict) and isinstance(data.get("links"), dict):
            for name, ll in link_lengths(data).items():
                notes[f"links.{name}"] = ", ".join(f"{a}-{b} = {v:g}" for a, b, v in ll.pair_lengths())
        write_out(output, dump_linkage(model, header=f"assembled from {spec} by linkedit assemble", notes=notes))
        report({"spec": str(spec), "output": str(output), "name": model.name,
                "joints": {n: list(p) for n, p in model.joints.items()}})
