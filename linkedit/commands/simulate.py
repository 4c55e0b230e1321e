"""``linkedit simulate`` and ``linkedit validate``: planar linkages from YAML specs."""

from __future__ import annotations

import sys
from enum import Enum
from pathlib import Path
from typing import Any

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, error_entry, error_json, guard, refuse_json_with_stdout, report, say
from linkedit.errors import InputError, LinkeditError, MechanismError
from linkedit.io.atomic import together
from linkedit.io.formats import is_stdout, output_format, require, write_out
from linkedit.planar.diagnostics import degrees_text


class Engine(str, Enum):
    """How positions are computed."""

    symbolic = "symbolic"
    numeric = "numeric"


def _outputs(specs: list[Path], out: Path | None, svg: Path | None, animate: bool) -> list[tuple[Path, Path | None]]:
    """Result and picture path per spec: a path with a suffix is a file (one spec only), else a folder."""
    batch = len(specs) > 1
    for option, value, suffix in (("--output", out, ".h5"), ("--svg", svg, ".svg")):
        if value is not None and batch and _is_file(value):
            raise InputError(f"{value}: with several specs, give a folder (one file per spec is written)", field=option)
    from linkedit.io.planar_out import result_format  # the planar engine: loaded when needed (start-up)

    pairs = []
    for spec in specs:
        h5 = out if out is not None and _is_file(out) else (out or Path("out")) / f"{spec.stem}.h5"
        require(result_format(h5), h5)  # a missing optional writer is found before any work
        pic = None
        if svg is not None:
            pic = svg if _is_file(svg) else svg / f"{spec.stem}.svg"
            kind = output_format(pic, ("svg", "gif"), option="--svg", stdout="svg")
            if kind == "gif" and not animate:
                raise InputError(f"{pic}: a GIF is an animation: add --animate (or write .svg)", field="--svg")
            require(kind, pic)
        elif animate:
            if is_stdout(h5):
                raise InputError("the result goes to standard output: give the animation a file with --svg",
                                 field="--animate")
            pic = h5.with_suffix(".svg")
        pairs.append((h5, pic))
    if sum(is_stdout(p) for pair in pairs for p in pair) > 1:
        raise InputError("only one output can go to standard output ('-')", field="--svg")
    return pairs


def _is_file(path: Path) -> bool:
    """A path with a suffix, or ``-``, names one file; anything else is a folder."""
    return bool(path.suffix) or is_stdout(path)


def _simulate_one(spec_path: Path, h5: Path, svg: Path | None, *, samples: int | None, animate: bool,
                  partial: bool, engine: str) -> dict[str, Any]:
    from linkedit.io.planar_out import write_result
    from linkedit.planar import simulate
    from linkedit.planar.plan import compile_plan
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model, read_text

    text = read_text(spec_path)
    spec = load_model(LinkageSpec, spec_path, text)
    check_memory(samples, spec, spec_path)
    try:
        plan = compile_plan(spec)
        if engine == "numeric":
            from linkedit.gcs.planar_bridge import UNSUPPORTED, numeric_motion, supported

            if not supported(spec):
                raise InputError(f"--engine numeric does not support {UNSUPPORTED} yet "
                                 "(use the default symbolic engine)", file=str(spec_path), field="--engine")
            motion = numeric_motion(plan, samples)
        else:
            motion = simulate(plan, samples, partial=partial)
    except MechanismError as exc:
        raise MechanismError(f"{spec_path}: {exc}") from None
    options = {"samples": int(motion.t.size), "engine": engine, "partial": partial}
    write_result(h5, motion, spec_text=text, options=options)
    result = {"spec": str(spec_path), "output": str(h5)} | motion.summary()
    if svg is not None:
        from linkedit.io.planar_svg import draw_gif, draw_motion

        if svg.suffix.lower() == ".gif":
            draw_gif(svg, motion)
        else:
            write_out(svg, draw_motion(None, motion, animate=animate))
        result["svg"] = str(svg)
    return result


def _at(m: dict[str, Any], units: str) -> str:
    """Where a minimum occurs: the motor angle, or a linear input's stroke (in ``units``)."""
    return degrees_text(m['motor_angle_deg']) if "motor_angle_deg" in m else f"stroke {m['stroke']:.6g} {units}"


def _line(r: dict[str, Any]) -> str:
    samples = f"{r['samples']} sample" + ("s" if r["samples"] != 1 else "")
    parts = [f"{r['spec']}: {samples}, {r['rules']} rules in {r['levels']} levels"]
    if "min_singularity" in r:
        m = r["min_singularity"]
        parts.append(f"min d_s {m['value']:.4f} (joint {m['joint']} at {_at(m, r['units'])})")
    if r.get("lockups"):
        parts.append("PARTIAL: " + "; ".join(r["lockups"]))
    out = ", ".join(parts) + f"\n  → {r['output']}"
    if r.get("svg"):
        out += f", {r['svg']}"
    return out


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def simulate(
        specs: list[Path] = typer.Argument(..., help="Linkage spec YAML files."),
        output: Path = typer.Option(None, "--output", "-o", help="Result file (one spec): .h5/.hdf5, .csv or .dxf by its suffix, - for CSV on stdout; or a folder of .h5 files [default: out/]."),
        svg: Path = typer.Option(None, "--svg", help="Motion plot .svg (one spec; - for stdout), .gif with --animate, or a folder."),
        animate: bool = typer.Option(False, "--animate", help="Make the picture an animation of the cycle (SVG with SMIL, or GIF)."),
        samples: int = typer.Option(None, "--samples", "-n", min=1, help="Time samples per cycle [default: spec's, else 360]."),
        engine: Engine = typer.Option(Engine.symbolic, "--engine", help="symbolic (closed form) or numeric (3D constraint solver)."),
        partial: bool = typer.Option(False, "--partial", help="Write a cycle that locks up somewhere (positions NaN there, flagged in /diagnostics/assembled) instead of failing."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Simulate planar linkages; write HDF5 trajectories (and SVG motion plots)."""
        if engine == Engine.numeric and partial:
            raise InputError("--partial works with the symbolic engine only", field="--partial")
        targets = _outputs(specs, output, svg, animate)
        refuse_json_with_stdout(*(p for pair in targets for p in pair))
        check_outputs([(option, path) for pair in targets for option, path in zip(("--output", "--svg"), pair)], specs)
        to_stderr = any(is_stdout(p) for pair in targets for p in pair)  # stdout carries the data
        results: list[dict[str, Any]] = []
        errors: list[dict[str, Any]] = []
        worst = 0
        progress = _progress(0 if quiet else len(specs))
        for spec_path, (h5, pic) in zip(specs, targets):
            try:
                with together():
                    r = _simulate_one(spec_path, h5, pic, samples=samples, animate=animate, partial=partial,
                                      engine=engine.value)
            except LinkeditError as exc:  # (the failed spec's outputs are discarded by together())
                if len(specs) == 1:
                    raise
                typer.echo(f"linkedit: error: {exc}", err=True)
                errors.append(error_json(exc, spec_path))
                worst = max(worst, exc.exit_code)
                progress()
                continue
            results.append(r)
            say(_line(r), err=to_stderr)
            progress()
        report(results, exit_code=worst, errors=errors)
        if len(specs) > 1:
            failed = len(errors)
            say(f"{len(specs) - failed} of {len(specs)} specs simulated" + (f", {failed} failed" if failed else ""))
        if worst:
            raise typer.Exit(worst)

    @app.command()
    @guard
    def validate(
        specs: list[Path] = typer.Argument(..., help="Linkage spec YAML files."),
        samples: int = typer.Option(None, "--samples", "-n", min=1, help="Samples for the diagnostics [default: spec's, else 360]."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Check specs: print the joint ordering (rules per level), mobility and diagnostics. Writes nothing."""
        from linkedit.planar import compile_plan, simulate as run
        from linkedit.spec.linkage import LinkageSpec
        from linkedit.spec.yamlload import load_model

        reports: list[dict[str, Any]] = []
        errors: list[dict[str, Any]] = []
        worst = 0
        for path in specs:
            try:
                spec = load_model(LinkageSpec, path)
                check_memory(samples, spec, path)
                plan = compile_plan(spec)
                motion = run(plan, samples, partial=True)
            except LinkeditError as exc:  # name the bad file (as simulate does), go on with the others
                err = MechanismError(f"{path}: {exc}") if isinstance(exc, MechanismError) else exc
                typer.echo(f"linkedit: error: {err}", err=True)
                errors.append(error_json(err, path))
                worst = max(worst, err.exit_code)
                continue
            levels = plan.describe()
            reports.append({"spec": str(path)} | motion.summary() | {"grubler": plan.mobility.grubler,
                            "redundant": plan.mobility.redundant, "levels": levels,
                            "warnings": transmission_warnings(motion)})
        for r in reports:  # a linkage that locks up is a mechanism failure (exit 1): an error line, --quiet too
            for lk in r.get("lockups", []):
                typer.echo(f"linkedit: error: {r['spec']}: locks up: {lk}", err=True)
                errors.append(error_entry(f"locks up: {lk}", 1, file=r["spec"], source=r["spec"]))
                worst = max(worst, 1)
        report(reports, exit_code=worst, errors=errors)
        if not (as_json or quiet):
            for r in reports:
                typer.echo(f"{r['spec']}: {r['name']}, {r['joints']} joints, mobility {r['mobility']} "
                           f"(Grübler count {r['grubler']}, {r['redundant']} redundant)")
                typer.echo("  level 0: ground and motor")
                for lv, items in r["levels"].items():
                    typer.echo(f"  level {lv}: " + "; ".join(items))
                if "min_singularity" in r:
                    m = r["min_singularity"]
                    alpha = r.get("worst_transmission_angle_deg")
                    typer.echo(f"  min d_s {m['value']:.4f} (joint {m['joint']} at {_at(m, r['units'])})"
                               + (f", worst transmission angle {alpha:.1f}°" if alpha is not None else ""))
                for lk in r.get("lockups", []):
                    typer.echo(f"  LOCK-UP: {lk}")
                for w in r["warnings"]:
                    typer.echo(f"  warning: {w}")
        if worst:
            raise typer.Exit(worst)


def transmission_warnings(motion: Any, before: Any = None) -> list[str]:
    """One line per dyad whose transmission angle leaves 40°–140° (its worst angle and where).
    With ``before`` (the same linkage before an edit): only the dyads the edit took out of the
    band or further out, with their worst angle before."""
    from linkedit.io.kinematics_plot import GOOD_TRANSMISSION

    lo, hi = GOOD_TRANSMISSION
    was = dict(_worst_transmission(before)) if before is not None else {}
    out = []
    for joint, (angle, where) in _worst_transmission(motion):
        if (angle < lo or angle > hi) and not (joint in was and abs(angle - 90) <= abs(was[joint][0] - 90) + 0.05):
            note = f" ({was[joint][0]:.1f}° before the edit)" if joint in was else ""
            out.append(f"transmission angle at joint {joint} leaves {lo:g}°–{hi:g}°: "
                       f"{angle:.1f}° at {where}{note}")
    return out


def _worst_transmission(motion: Any) -> list[tuple[str, tuple[float, str]]]:
    """(rebuilt joint, (its transmission angle furthest from 90° in degrees, the input there in
    words)) per dyad."""
    import numpy as np

    plan = motion.plan
    out = []
    for r in np.flatnonzero(~plan.table.rigid):
        a = np.where(motion.assembled, np.degrees(motion.transmission[:, r]), 90.0)
        t = int(np.argmax(np.abs(a - 90.0)))
        out.append((plan.joint_names[plan.table.joints[r, 2]], (float(a[t]), motion.describe_input(motion.input_at(t)))))
    return out


def check_memory(samples: int | None, spec: Any, path: Path) -> None:
    """InputError (exit 2) if ``samples`` samples of ``spec`` would not fit in the memory available
    (:func:`linkedit.planar.simulate.require_sample_memory`)."""
    from linkedit.planar.simulate import DEFAULT_SAMPLES, require_sample_memory

    count = samples or spec.samples or DEFAULT_SAMPLES
    where: dict[str, Any] = {"field": "--samples"} if samples else {"file": str(path), "field": "samples"}
    require_sample_memory(count, len(spec.joints), **where)


def _progress(total: int):
    """A progress bar on a terminal for batches; returns the 'one done' callback."""
    if total < 4 or not sys.stderr.isatty():
        return lambda: None
    from rich.progress import Progress

    bar = Progress(transient=True)
    task = bar.add_task("simulating", total=total)
    bar.start()
    done = [0]

    def step() -> None:
        done[0] += 1
        bar.advance(task)
        if done[0] == total:
            bar.stop()

    return step
