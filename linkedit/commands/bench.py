"""``linkedit bench``: print the benchmark figures each capability promises.

Each section is ``linkedit.<package>.bench.run(echo, quick)``; figures are ratios against a
baseline measured in the same run where possible. ``--quick`` runs tiny sizes (for tests).
"""

from __future__ import annotations

import importlib
from pathlib import Path

import typer

from linkedit.commands.common import JSON, QUIET, guard, report, say

SECTIONS = {
    "planar": "linkedit.planar.bench",
    "edit": "linkedit.edit.bench",
    "gcs": "linkedit.gcs.bench",
    "curves": "linkedit.curves.bench",
    "synthesis": "linkedit.synthesis.bench",
}


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def bench(
        section: list[str] = typer.Option(None, "--section", "-s", help=f"Only these sections: {', '.join(SECTIONS)}."),
        quick: bool = typer.Option(False, "--quick", help="Tiny sizes and few repeats: checks the benchmark runs."),
        large: int = typer.Option(None, "--large", metavar="N", min=1, max=10**9,
                                  help="synthesis: also build a sharded atlas of N four-bars and time the query over "
                                       "it, with the extrapolation to 100M (opt-in: 10M take minutes)."),
        large_atlas: Path = typer.Option(None, "--large-atlas", metavar="FOLDER",
                                         help="synthesis: time the query at scale over this sharded four-bar atlas "
                                              "(built before by `atlas build`) instead of building --large N."),
        workers: int = typer.Option(None, "--workers", metavar="N", min=1, max=1024,
                                    help="synthesis: worker processes of the local Dask clusters (and in-process "
                                         "builds side by side) [default: the cores this process may use]; with "
                                         "--quick only --large's."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Print benchmark figures (µs per step, ratios against baselines measured in the same run)."""
        from linkedit.errors import InputError

        chosen = section or list(SECTIONS)
        figures: dict[str, list[str]] = {}
        for name in chosen:
            if name not in SECTIONS:
                raise InputError(f"unknown section {name!r} (choose from {', '.join(SECTIONS)})", field="--section")
        if large is not None and large_atlas is not None:
            raise InputError("give --large N (build one) or --large-atlas FOLDER (one built before), not both",
                             field="--large-atlas")
        for field, value in (("--large", large), ("--large-atlas", large_atlas), ("--workers", workers)):
            if value is not None and "synthesis" not in chosen:
                raise InputError("applies to the synthesis section (-s synthesis)", field=field)
        if workers is not None and quick and large is None:
            raise InputError("--quick starts no local cluster (with --large N it sizes the query at scale's)",
                             field="--workers")
        for name in chosen:
            try:
                module = importlib.import_module(SECTIONS[name])
            except ModuleNotFoundError as exc:
                if exc.name != SECTIONS[name]:
                    raise
                continue
            say(f"== {name}")
            lines = figures.setdefault(name, [])

            def line(text: str = "", lines: list[str] = lines) -> None:
                lines.append(text)
                say(text)

            options = {"large": large, "large_atlas": large_atlas, "workers": workers} if name == "synthesis" else {}
            module.run(line, quick=quick, **options)
        report({"sections": figures})
