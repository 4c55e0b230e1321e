"""``linkedit edit SPEC SCRIPT``: function-preserving linkage editing."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, error_json, guard, report, say
from linkedit.errors import InputError, MechanismError


def _load(spec_path: Path | None, script_path: Path):
    from linkedit.edit.script import read_script
    from linkedit.planar import compile_plan, simulate
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model

    read = read_script(script_path)
    script = read.script
    if spec_path is None:
        if script.linkage is None:
            raise InputError("no linkage: give SPEC on the command line or `linkage:` in the script",
                             file=str(script_path), line=1, field="linkage")
        spec_path = (script_path.parent / script.linkage)
        if not spec_path.is_file():
            raise InputError(f"linkage file not found: {spec_path}", file=str(script_path),
                             line=read.lines.line_of(("linkage",)), field="linkage")
    elif script.linkage is not None:
        say(f"note: {script_path} names linkage {script.linkage}; editing {spec_path} as given", err=True)
    linkage = load_model(LinkageSpec, spec_path)
    read.check(linkage)
    try:  # an edit starts from a working linkage (the barrier keeps it working)
        simulate(compile_plan(linkage), script.samples)
    except MechanismError as exc:
        raise MechanismError(f"{spec_path}: only a linkage that works can be edited: {exc}") from None
    return spec_path, linkage, script


def _report_lines(result: Any, script: Any) -> list[str]:
    out = []
    for op in result.operations:
        status = ((" (stalled: slow progress, along the barrier's edge)" if op.barrier_active
                   else " (stalled: slow progress)") if op.stalled
                  else " (iteration limit)" if not op.converged else "")
        status += " — DISCARDED: its result does not work (see below)" if op.discarded else ""
        out.append(f"{op.name}: {op.iterations} iterations, {op.seconds * 1e3:.0f} ms{status}")
        for key in op.before:
            if key.startswith("energy"):
                continue
            out.append(f"  {key}: {op.before[key]:.4g} → {op.after[key]:.4g}")
        if op.regularization < script.weights.regularization:
            out.append(f"  regularization relaxed from {script.weights.regularization:.3g} to "
                       f"{op.regularization:.3g}: it held a goal back")
    return out


def _report_json(op: Any) -> dict:
    return {"name": op.name, "iterations": op.iterations, "evaluations": op.evaluations,
            "rejected_steps": op.rejected_steps, "seconds": op.seconds, "converged": op.converged,
            "stalled": op.stalled, "barrier_active": op.barrier_active,
            "discarded": op.discarded, "goals_met": op.goals_met, "unmet": op.unmet,
            "goals": [{"goal": g.name, "measure": g.measure, "before": g.before, "error": g.error,
                       "tolerance": g.tolerance, "met": g.met, "held_back_by": g.held_back_by} for g in op.goals],
            "regularization": op.regularization,
            "terms": [{"term": k, "before": v, "after": op.after.get(k)} for k, v in op.before.items()]}


def _unmet_error(result: Any) -> MechanismError | None:
    """The run's error when a goal of an operation kept is not met (exit 1), else None."""
    unmet = [f"{op.name}: {text}" for op in result.operations if not op.discarded for text in op.unmet]
    if not unmet:
        return None
    more = f" (and {len(unmet) - 1} more: see the warnings)" if len(unmet) > 1 else ""
    return MechanismError(f"goal not met: {unmet[0]}{more}; the result is written all the same "
                          "(--best-effort accepts it: exit 0)")


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def edit(
        spec: Path = typer.Argument(..., help="Linkage spec YAML (or the edit script, when it names its linkage)."),
        script: Path = typer.Argument(None, help="Edit script YAML."),
        out_dir: Path = typer.Option(Path("out"), "--output", "-o", help="Folder for the edited spec, HDF5 and SVG."),
        best_effort: bool = typer.Option(False, "--best-effort",
                                         help="Exit 0 even when a goal is not met (each one is still a warning)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Edit a linkage: displace joints, preserve or reshape track curves, fit a box — keeping it working."""
        from linkedit.commands.simulate import transmission_warnings
        from linkedit.edit.runner import EditFailed, run_script
        from linkedit.io.atomic import commit, write_text
        from linkedit.io.edit_hdf5 import write_edit
        from linkedit.io.edit_picture import edit_picture
        from linkedit.io.formats import SUFFIXES, is_stdout
        from linkedit.spec.linkage_yaml import dump_linkage
        from linkedit.spec.yamlload import read_text

        if is_stdout(out_dir) or out_dir.suffix.lower() in SUFFIXES:
            raise InputError(f"{out_dir}: edit writes the edited spec, its HDF5 report and its SVG into a folder: "
                             "give a folder such as out/knee/", field="--output")
        spec_path, script_path = (None, spec) if script is None else (spec, script)
        spec_path, linkage, parsed = _load(spec_path, script_path)
        stem = Path(spec_path).stem
        edited_yaml = out_dir / f"{stem}-edited.yaml"
        h5 = out_dir / f"{stem}-edit.h5"
        svg = out_dir / f"{stem}-edit.svg"
        check_outputs([("--output", edited_yaml), ("--output", h5), ("--output", svg)], [spec_path, script_path])
        failure: MechanismError | None = None
        with _Progress(live=not quiet) as progress:
            try:
                result = run_script(linkage, parsed, progress=progress.update)
            except EditFailed as exc:
                result, failure = exc.result, exc
        if failure is None and not best_effort:
            failure = _unmet_error(result)
        warnings = result.warnings + transmission_warnings(result.after, before=result.before)
        edited_text = dump_linkage(result.edited)
        write_text(edited_yaml, edited_text)
        write_edit(h5, result, script_text=read_text(script_path),
                   linkage_text=read_text(spec_path), edited_text=edited_text,
                   options={"spec": str(spec_path), "script": str(script_path), "best_effort": best_effort})
        edit_picture(svg, result, parsed)
        report({"spec": str(spec_path), "script": str(script_path), "edited": str(edited_yaml),
                "output": str(h5), "svg": str(svg), "operations": [_report_json(o) for o in result.operations]},
               exit_code=0 if failure is None else failure.exit_code,
               errors=[] if failure is None else [error_json(failure)], warnings=warnings)
        for line in _report_lines(result, parsed) + [f"warning: {w}" for w in warnings]:
            say(line)
        say(f"→ {edited_yaml}, {h5}, {svg}")
        if failure is not None:
            commit()  # the last working linkage is a result too: keep it for inspection
            raise failure


class _Progress:
    """A spinner with the current operation, iteration and energy, on a terminal only."""

    def __init__(self, live: bool = True) -> None:
        self.live = live

    def __enter__(self) -> "_Progress":
        self.bar = None
        if self.live and sys.stderr.isatty():
            from rich.progress import Progress, SpinnerColumn, TextColumn

            self.bar = Progress(SpinnerColumn(), TextColumn("{task.description}"), transient=True)
            self.task = self.bar.add_task("editing")
            self.bar.start()
        return self

    def update(self, name: str, iteration: int, energy: float) -> None:
        if self.bar is not None:
            self.bar.update(self.task, description=f"{name}: iteration {iteration}, energy {energy:.6g}")

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.stop()
