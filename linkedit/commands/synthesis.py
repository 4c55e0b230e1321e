"""``linkedit atlas build`` and ``linkedit synthesize``: which linkage draws this curve?"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, guard, report, say
from linkedit.errors import InputError


def _families(text: str) -> list[str]:
    from linkedit.synthesis.families import family, spec_family

    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise InputError("name at least one family", field="--family")
    out = []
    for n in names:  # a built-in family's name, or a linkage spec file (its name is the family's)
        if n.lower().endswith((".yaml", ".yml")):
            out.append(spec_family(Path(n)))
        else:
            family(n)
            out.append(n)
    return list(dict.fromkeys(out))


class _Progress:
    """A rich progress bar on stderr while an atlas builds (a terminal only): linkages done, rate, time
    left (80 columns hold it); the callback of :func:`linkedit.synthesis.atlas.build`, stopped with the block."""

    def __init__(self, live: bool = True) -> None:
        self.live = live and sys.stderr.isatty()
        self.bar: Any = None

    def __enter__(self) -> _Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.stop()

    def __call__(self, done: int, total: int, seconds: float) -> None:
        if not self.live:
            return
        if self.bar is None:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

            self.bar = Progress(TextColumn("atlas build"), BarColumn(), MofNCompleteColumn(), TextColumn("linkages"),
                                TextColumn("{task.fields[rate]}"), TimeRemainingColumn(), TextColumn("left"),
                                console=Console(stderr=True))
            self.task = self.bar.add_task("build", total=total, rate="")
            self.bar.start()
        self.bar.update(self.task, completed=done, rate=f"{done / max(seconds, 1e-9):,.0f}/s")


def register(app: typer.Typer) -> None:
    atlas_app = typer.Typer(help="Atlases of linkage curves for `linkedit synthesize`.", no_args_is_help=True)
    app.add_typer(atlas_app, name="atlas")

    @atlas_app.command("build")
    @guard
    def build(
        family: str = typer.Option(..., "--family", help="Families, comma-separated: four-bar, slider-crank, jansen, klann, watt, stephenson, spherical-four-bar, rssr (spatial), or a linkage spec file (e.g. examples/klann.yaml)."),
        count: int = typer.Option(None, "-n", "--count", min=1, help="Linkages to add per family."),
        output: Path = typer.Option(..., "-o", "--output", help="Atlas file (.h5), or a folder of shards (a name "
                                                                "without suffix; workers write their shards there); "
                                                                "an existing one is appended to."),
        seed: int = typer.Option(1, "--seed", min=0, max=2**63 - 1, help="Seed of the chunks (an atlas keeps its seed)."),
        scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler address (tcp://host:8786): build there."),
        workers: int = typer.Option(None, "--workers", min=1, help="Build on a local Dask cluster of N worker processes."),
        connect_timeout: float = typer.Option(10.0, "--connect-timeout", metavar="SECONDS", min=0.1, max=3600.0,
                                              help="Seconds the --scheduler has to answer (and its first worker to join)."),
        resume: bool = typer.Option(False, "--resume", help="A folder of shards: finish the build that was "
                                                            "interrupted there (the same --family and -n)."),
        verbose: bool = typer.Option(False, "--verbose", help="Show Dask's own log lines (--scheduler, --workers)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Sample a family's linkages, keep the working ones, store their curves and descriptors."""
        import time

        from linkedit.synthesis import atlas as atlas_file
        from linkedit.synthesis import shards

        names = _families(family)
        sharded = output.is_dir() or output.suffix == ""
        if not sharded and output.suffix.lower() not in (".h5", ".hdf5"):
            raise InputError(f"{output}: an atlas is an HDF5 file (.h5) or a folder of shards (a name without suffix)",
                             field="--output")
        if not sharded and (resume or count is None):
            raise InputError("--resume continues a folder of shards (an atlas file is written whole or not at all)"
                             if resume else "give the number of linkages to add", field="--resume" if resume else "--count")
        before = (shards.counts(shards.read_manifest(output)) if resume and (output / shards.MANIFEST).is_file()
                  else {})  # a resumed build adds only what the interrupted one left
        start = time.perf_counter()
        options: dict[str, Any] = {"seed": seed, "scheduler": scheduler, "workers": workers,
                                   "connect_timeout": connect_timeout, "verbose": verbose}
        with _Progress(live=not quiet) as progress:
            counts = (shards.build(output, names, count, resume=resume, progress=progress, **options) if sharded else
                      atlas_file.build(output, names, count, progress=progress, **options))
        seconds = time.perf_counter() - start
        added = sum(counts.values()) - sum(before.values()) if resume else count * len(names)
        report({"output": str(output), "families": dict(counts), "linkages": added, "seconds": seconds})
        say(f"{added:,} linkages in {seconds:.2f} s ({added / seconds:,.0f} linkages/s) → {output}: "
            + ", ".join(f"{n} {c:,}" for n, c in counts.items()))

    @app.command()
    @guard
    def synthesize(
        target: str = typer.Argument(None, help="The curve: .csv (x, y[, t]; x, y, z: a spatial target), set.yaml:name "
                                                "or result.h5:track."),
        atlas: Path = typer.Option(None, "--atlas", help="Atlas file, folder of shards, or folder of atlas files "
                                                           "(`linkedit atlas build`)."),
        output: Path = typer.Option(..., "-o", "--output", help="Output folder: result.yaml, result.h5, overlay.svg, "
                                                                "history.svg, report.json."),
        pairs: Path = typer.Option(None, "--function", metavar="PAIRS.csv",
                                   help="Function generation instead: a four-bar (or --family six-bar) whose output "
                                        "link turns as the CSV's input_deg, output_deg pairs prescribe (no target, "
                                        "no --atlas)."),
        poses: Path = typer.Option(None, "--motion", metavar="POSES.csv",
                                   help="Motion generation instead: a four-bar (or --family slider-crank, or six-bar "
                                        "meeting the motor phases t too) whose coupler passes through the CSV's poses "
                                        "x, y, angle_deg[, t] in order (no target, no --atlas)."),
        relative: bool = typer.Option(False, "--relative", help="With --function: the angles are changes from "
                                                                "rest angles the synthesis chooses (and the output "
                                                                "may turn either way) [default: absolute, from the "
                                                                "ground line]."),
        family: str = typer.Option(None, "--family", metavar="FAMILY",
                                   help="With --function: four-bar, or six-bar (a Watt II: two four-bars in series, "
                                        "more freedom; with --relative); with --motion: four-bar, slider-crank, "
                                        "or six-bar (a Watt II meeting the poses at the motor phases of their t "
                                        "column too) "
                                        "[default: four-bar]."),
        sense: str = typer.Option(None, "--sense", metavar="WAY",
                                  help="With --function --relative: the output turns the crank's way (same) or "
                                       "the other way (opposite) [default: whichever fits better]."),
        tolerance: float = typer.Option(0.5, "--tolerance", metavar="DEG", min=0.0,
                                        help="With --function or --motion: a larger max output (coupler) angle "
                                             "error gets a note."),
        top: int = typer.Option(5, "--top", min=1, max=50, help="Candidates refined."),
        closed: bool = typer.Option(None, "--closed/--open", help="The target is a closed cycle / an open (partial) "
                                                                  "curve [default: detected from its ends]."),
        smooth: float = typer.Option(0.0, "--smooth", min=0.0, max=0.5,
                                     help="Smooth a sketched target first: Gaussian σ as a fraction of its points."),
        timing: bool = typer.Option(False, "--timing", help="Match the target's sample times too (a closed target "
                                                              "with a CSV t column or a result.h5 track): positions "
                                                              "and velocities at those times."),
        margin: float = typer.Option(20.0, "--margin", metavar="DEG", min=1.0, max=60.0,
                                     help="Transmission band [DEG, 180° − DEG] every candidate and the result keep "
                                          "(d_s ≥ sin² DEG); below the atlas's 20° trades transmission for accuracy."),
        points: bool = typer.Option(None, "--points/--curve", help="The target is precision points (each point's "
                                                                   "distance to the curve at any crank phase) / a "
                                                                   "sampled curve [default: points for a closed "
                                                                   "target of ≤ 25 unevenly spaced points]."),
        seed: int = typer.Option(1, "--seed", min=0, max=2**63 - 1, help="Recorded with the result (the search is deterministic)."),
        scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler address (tcp://host:8786): search the "
                                                                "--atlas folder of shards on its workers (the folder "
                                                                "at the same path on every worker)."),
        connect_timeout: float = typer.Option(10.0, "--connect-timeout", metavar="SECONDS", min=0.1, max=3600.0,
                                              help="Seconds the --scheduler has to answer (and its first worker to join)."),
        units: str = typer.Option(None, "--units", help="The target's length units, written into the result "
                                                        "[default: the target's own (a CSV header's `x (m)`, a "
                                                        "result's or curve set's units), else mm]."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Find the linkage whose tracked point draws the target curve: atlas search, placement, refinement;
        or, with --function or --motion, a four-bar function or motion generator."""
        curve_only = {"--top": top != 5, "--closed/--open": closed is not None, "--smooth": smooth != 0.0,
                      "--timing": timing, "--seed": seed != 1, "--units": units is not None,
                      "--points/--curve": points is not None, "--scheduler": scheduler is not None}
        for option, given in (("--relative", relative), ("--sense", sense is not None)):
            if pairs is None and given:
                raise InputError(f"{option} applies to --function", field=option)
        if family is not None and pairs is None and poses is None:
            raise InputError("--family applies to --function and --motion", field="--family")
        if pairs is not None or poses is not None:
            mode = "--function" if pairs is not None else "--motion"
            if target is not None or atlas is not None or (pairs is not None and poses is not None):
                raise InputError(f"{mode} takes no target curve, no --atlas and not both --function and --motion",
                                 field=mode)
            for option, given in curve_only.items():
                if given:
                    raise InputError(f"{option} applies to a target curve, not to {mode}", field=option)
            if pairs is not None:
                _function(pairs, output, relative=relative, margin=margin, tolerance=tolerance, family=family,
                          sense=sense)
            else:
                _motion(poses, output, margin=margin, tolerance=tolerance, family=family or "four-bar")
            return
        if target is None or atlas is None:
            raise InputError("give a target curve and --atlas (or --function PAIRS.csv, or --motion POSES.csv)",
                             field="--atlas" if target is not None else "target")
        if tolerance != 0.5:
            raise InputError("--tolerance applies to --function and --motion", field="--tolerance")
        from linkedit.curves.sources import UNIT_NAME, input_files, load_inputs
        from linkedit.synthesis.outputs import FILES, write_all
        from linkedit.synthesis.shards import open_atlas
        from linkedit.synthesis.synthesize import synthesize as run

        if units is not None and not UNIT_NAME.fullmatch(units):
            raise InputError(f"{units!r} is not a length unit's name (no '/', no leading '.')", field="--units")
        check_outputs([("--output", output / name) for name in FILES], [*input_files([target]), atlas])
        curves = load_inputs([target], closed=closed)
        if len(curves) != 1:
            raise InputError(f"the target holds {len(curves)} curves; name one (set.yaml:name, result.h5:track)",
                             file=target)
        curve = curves[0]
        if units is not None and curve.units is not None and units != curve.units:
            raise InputError(f"--units {units} contradicts the target's own units, {curve.units}", file=curve.origin)
        if curve.points.shape[1] == 3:
            _spatial(curve, target, atlas, output, top=top, margin=margin, seed=seed, units=units,
                     scheduler=scheduler, connect_timeout=connect_timeout,
                     planar_only={"--smooth": smooth != 0.0, "--timing": timing, "--points/--curve": points is not None})
            return
        from linkedit.synthesis.shard_search import remote_atlas
        from linkedit.synthesis.spatial import restrict

        settings: dict[str, Any] = {"top": top, "smooth": smooth, "timing": timing, "margin_deg": margin, "seed": seed,
                                    "units": units or curve.units or "mm", "points": points}
        if scheduler is not None:  # the shards searched on the cluster's workers, the hits ranked here
            with remote_atlas(atlas, scheduler, dim=2, connect_timeout=connect_timeout) as (found, index):
                result = run(curve, found, index, **settings)
        else:
            found = restrict(open_atlas(atlas), 2)
            result = run(curve, found, **settings)
        options = {"target": target, "atlas": str(atlas), "top": top, "smooth": smooth, "timing": timing,
                   "margin_deg": margin, "seed": seed, "closed": curve.closed, "atlas_size": found.size,
                   "units": units, "points": points} | ({"scheduler": scheduler} if scheduler is not None else {})
        done = write_all(output, result, options)
        report({k: v for k, v in done.items() if k != "result"} | {"output": str(output)})
        before, after = done["error"]["before"], done["error"]["after"]
        say(f"{done['family']}: normalized RMS error {100 * before['rms']:.3g} % → {100 * after['rms']:.3g} % "
            f"(max {100 * after['max']:.3g} %) in {done['seconds']['total']:.2f} s → {output}/")
        if "timed" in done["error"]:
            timed = done["error"]["timed"]
            say(f"at the target's times: {100 * timed['before']['rms']:.3g} % → {100 * timed['after']['rms']:.3g} % "
                f"(max {100 * timed['after']['max']:.3g} %)")
        if done["note"]:
            say(f"note: {done['note']}")


def _spatial(curve, target: str, atlas: Path, output: Path, *, top: int, margin: float, seed: int, units: str | None,
             scheduler: str | None, connect_timeout: float, planar_only: dict[str, bool]) -> None:
    """``synthesize`` of a 3D (x, y, z) target: search the atlas's spatial families (on the cluster at
    ``scheduler``, as for a planar target), refine, write a 3D spec."""
    from linkedit.synthesis.shard_search import remote_atlas
    from linkedit.synthesis.shards import open_atlas
    from linkedit.synthesis.spatial import restrict, synthesize3d, write_all

    for option, given in planar_only.items():
        if given:
            raise InputError(f"{option} applies to a planar target, not to a 3D (x, y, z) one", field=option)
    settings: dict[str, Any] = {"top": top, "margin_deg": margin, "units": units or curve.units or "mm"}
    if scheduler is not None:  # the shards searched on the cluster's workers, the hits ranked here
        with remote_atlas(atlas, scheduler, dim=3, connect_timeout=connect_timeout) as (found, index):
            result = synthesize3d(curve, found, index, **settings)  # type: ignore[arg-type]
    else:
        found = restrict(open_atlas(atlas), 3)
        result = synthesize3d(curve, found, **settings)
    options = {"target": target, "atlas": str(atlas), "top": top, "margin_deg": margin, "seed": seed,
               "closed": curve.closed, "atlas_size": found.size, "units": units} | (
        {"scheduler": scheduler} if scheduler is not None else {})
    done = write_all(output, result, options)
    report({k: v for k, v in done.items() if k != "result"} | {"output": str(output)})
    before, after = done["error"]["before"], done["error"]["after"]
    say(f"{done['family']}: normalized RMS error {100 * before['rms']:.3g} % → {100 * after['rms']:.3g} % "
        f"(max {100 * after['max']:.3g} %; result.yaml solved by solve3d) in {done['seconds']['total']:.2f} s "
        f"→ {output}/")
    if done["note"]:
        say(f"note: {done['note']}")


def _function(pairs: Path, output: Path, *, relative: bool, margin: float, tolerance: float, family: str | None,
              sense: str | None) -> None:
    """``synthesize --function``: fit, write the output folder, say the errors."""
    from linkedit.synthesis.generate import FILES, run_function

    if family not in (None, "four-bar", "six-bar"):
        raise InputError(f"unknown family {family!r} (four-bar or six-bar)", field="--family")
    if sense not in (None, "same", "opposite"):
        raise InputError(f"unknown sense {sense!r} (same or opposite)", field="--sense")
    for option, given in (("--family six-bar", family == "six-bar"), ("--sense", sense is not None)):
        if given and not relative:
            raise InputError(f"{option} needs --relative (angles as changes from fitted rest angles)", field=option)
    check_outputs([("--output", output / name) for name in FILES], [pairs])
    options = {"function": str(pairs), "relative": relative, "margin_deg": margin, "tolerance_deg": tolerance,
               "family": family or "four-bar", "sense": sense}
    done = run_function(pairs, output, relative=relative, margin_deg=margin, tolerance_deg=tolerance, options=options,
                        family=family or "four-bar", sense=None if sense is None else 1.0 if sense == "same" else -1.0)
    report(done | {"output": str(output)})
    link = done["linkage"]
    lengths = ", ".join(f"{name} {value:.4g}" for name, value in link.items() if name != "units")
    say(f"{done['family']} function generator: output error max {done['error']['max_deg']:.3g}°, RMS "
        f"{done['error']['rms_deg']:.3g}° over {done['pairs']['count']} pairs; {lengths} {link['units']}; "
        f"transmission {done['transmission_deg']['min']:.1f}°…{done['transmission_deg']['max']:.1f}° → {output}/")
    if done["angles"]["output_sense"] == "opposite":
        say("the output link turns clockwise as the output angle grows"
            + (" (the other way fits better)" if sense is None else ""))
    if done["note"]:
        say(f"note: {done['note']}")


def _motion(poses: Path, output: Path, *, margin: float, tolerance: float, family: str) -> None:
    """``synthesize --motion``: fit the ``family``'s motion generator, write the output folder, say the errors."""
    from functools import partial

    from linkedit.synthesis.generate import FILES, MOTION_FAMILIES, run_motion
    from linkedit.synthesis.generate_six import run_motion_six

    runners = {name: partial(run_motion, family=name) for name in MOTION_FAMILIES} | {"six-bar": run_motion_six}
    if family not in runners:
        raise InputError(f"unknown family {family!r} for --motion ({', '.join(runners)})", field="--family")
    check_outputs([("--output", output / name) for name in FILES], [poses])
    options = {"motion": str(poses), "margin_deg": margin, "tolerance_deg": tolerance, "family": family}
    done = runners[family](poses, output, margin_deg=margin, tolerance_deg=tolerance, options=options)
    report(done | {"output": str(output)})
    link, error = done["linkage"], done["error"]
    lengths = ", ".join(f"{name} {value:.4g}" for name, value in link.items()
                        if name not in ("units", "guide_angle_deg"))
    guide = f" (guide at {link['guide_angle_deg']:.4g}°)" if "guide_angle_deg" in link else ""
    timing = f", motor timing within {error['timing_deg']['max']:.3g}°" if "timing_deg" in error else ""
    say(f"{family} motion generator: {done['poses']['count']} poses met within {100 * error['position']['max']:.3g} "
        f"% of their size and {error['angle_deg']['max']:.3g}°{timing} (max); {lengths} {link['units']}{guide}; motor "
        f"sweep {done['crank_sweep_deg']:.1f}°, transmission {done['transmission_deg']['min']:.1f}°…"
        f"{done['transmission_deg']['max']:.1f}° → {output}/")
    if done["note"]:
        say(f"note: {done['note']}")
