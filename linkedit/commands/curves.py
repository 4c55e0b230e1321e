"""``linkedit features`` and ``linkedit compare-curves``: motion-curve descriptors and distances."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from linkedit.commands.common import JSON, QUIET, check_outputs, error_json, guard, refuse_json_with_stdout, report, say
from linkedit.errors import InputError

#: what tables (features, distance matrices, rankings) can be written as, by suffix
TABLE_FORMATS = ("csv", "hdf5", "json")
SAMPLES_HELP = "Points per resampled curve [default: 64, or the weights file's]."
SMOOTH_HELP = "Smooth sketched or noisy curves first: Gaussian σ as a fraction of the points (e.g. 0.01) [default: 0]."
MIRROR_HELP = "Count a curve and its mirror image as the same."
CLOSED_HELP = "Treat every curve as closed (cyclic) or open [default: detected from the ends, or declared]."


def _anchor(text: str | None) -> Any:
    if text is None:
        return None
    import numpy as np

    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise InputError(f"expected X,Y or X,Y,Z, got {text!r}", field="--anchor") from None
    if len(values) not in (2, 3) or not np.isfinite(values).all():
        raise InputError(f"expected 2 or 3 finite numbers, got {text!r}", field="--anchor")
    return values


def _skipped(failures: list[InputError]):
    """A ``skip`` callback: report a bad input on stderr, remember it, go on."""

    def skip(exc: InputError) -> None:
        typer.echo(f"linkedit: error: {exc} (skipped)", err=True)
        failures.append(exc)

    return skip


def _load(inputs: list[str], closed: bool | None, samples: int | None, harmonics: int | None, anchor: str | None,
          curves: list | None = None, skip=None, smooth: float = 0.0):
    """Load (unless ``curves`` are given) and describe curves; ``skip`` as for ``load_inputs``."""
    from linkedit.curves.compare import describe_curves
    from linkedit.curves.descriptors import DEFAULT_HARMONICS, DEFAULT_SAMPLES
    from linkedit.curves.sources import load_inputs

    if curves is None:
        curves = load_inputs(inputs, closed=closed, skip=skip)
        if not curves:
            raise InputError("no curve could be read", field="INPUT")
    _check_memory(len(curves), samples or DEFAULT_SAMPLES)
    desc = describe_curves(curves, samples=samples or DEFAULT_SAMPLES, harmonics=harmonics or DEFAULT_HARMONICS,
                           anchor=_anchor(anchor), smooth=smooth)
    return curves, desc


#: Bytes per curve and pair of resampled points while crossings are counted (a float64 product and
#: four boolean arrays, :func:`linkedit.curves.features.self_intersections`).
CROSSING_BYTES = 8 + 5


def _check_memory(count: int, samples: int) -> None:
    """InputError (exit 2) if describing ``count`` curves of ``samples`` points would not fit in memory:
    crossings are counted for up to ``CROSSING_BLOCK`` curves at once, each over all pairs of points."""
    from linkedit.curves.features import CROSSING_BLOCK
    from linkedit.resources import require_memory

    require_memory(min(count, CROSSING_BLOCK) * samples * (samples + 1) * CROSSING_BYTES,
                   f"{count:,} curves of {samples:,} points", field="--samples")


def _feature_rows(curves: list, desc: Any) -> list[dict[str, Any]]:
    rows = []
    for i, c in enumerate(curves):
        values = {n: float(v) for n, v in zip(desc.names, desc.features[i])}
        values["self_intersections"] = int(values["self_intersections"])
        rows.append({"name": c.name, "origin": c.origin, "closed": bool(c.closed), "points": len(c.points)} | values)
    return rows


def _write_features(out: Path, curves: list, desc: Any, options: dict[str, Any]) -> None:
    from linkedit.io.formats import output_format, write_out

    rows = _feature_rows(curves, desc)
    fmt = output_format(out, TABLE_FORMATS, stdout="csv")
    if fmt == "json":
        write_out(out, json.dumps(rows, indent=2, allow_nan=False) + "\n")
    elif fmt == "csv":
        from linkedit.io.csv_table import csv_text

        write_out(out, csv_text(list(rows[0]), [list(r.values()) for r in rows]))
    else:
        _write_features_h5(out, curves, desc, options)


def _write_features_h5(out: Path, curves: list, desc: Any, options: dict[str, Any]) -> None:
    import numpy as np

    from linkedit.io.hdf5 import put, result_file

    units = {c.units for c in curves}
    norm = desc.normalized
    with result_file(out, kind="curve-features", units=units.pop() if len(units) == 1 and None not in units else "",
                     spec_text="", options=options) as f:
        put(f, "names", [c.name for c in curves])
        put(f, "origin", [c.origin for c in curves])
        put(f, "closed", np.array([c.closed for c in curves]))
        put(f, "features", desc.features, columns=json.dumps(list(desc.names)),
            description="per-curve features; lengths in units of the major extent, angles in rad")
        put(f, "normalized", norm.points, units="major extent",
            description="resampled curves: centred, principal frame, scaled by the major extent")
        put(f, "turning", desc.turning, units="rad", description="turning angle at every resampled point")
        put(f, "efd", desc.efd, columns=json.dumps(["a", "b", "c", "d"]),
            description="normalized elliptic Fourier descriptors, harmonics 1..H")
        put(f, "centroid", norm.centroid, description="wire centroid, input units")
        put(f, "frame", norm.frame, description="principal axes as columns (proper rotation)")
        put(f, "scale", norm.scale, description="major extent, input units")


def _print_table(rows: list[dict[str, Any]]) -> None:
    cols = [k for k in rows[0] if k != "origin"]

    def cell(v: Any) -> str:
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    cells = [[cell(r[c]) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[k]) for row in cells)) + 2 for k, c in enumerate(cols)]
    say("".join(c.ljust(w) for c, w in zip(cols, widths)).rstrip())
    for row in cells:
        say("".join(v.ljust(w) for v, w in zip(row, widths)).rstrip())


#: (the weights file's weights, or None for all 1; the --weight overrides)
_Weights = tuple[dict[str, float] | None, dict[str, float]]


def _load_weights(path: Path | None, overrides: list[str]) -> tuple[_Weights, int | None, int | None]:
    """Weights from a file (default: all 1) and --weight term=value overrides, and the samples/harmonics
    the file asks for."""
    from linkedit.spec.common import MAX_WEIGHT  # pydantic: loaded when needed (start-up)

    weights, samples, harmonics, changed = None, None, None, {}
    if path is not None:
        from linkedit.spec.curveset import CurveWeights
        from linkedit.spec.yamlload import load_model

        spec = load_model(CurveWeights, path)
        weights, samples, harmonics = dict(spec.weights), spec.samples, spec.harmonics
    for item in overrides:
        name, sep, value = item.partition("=")
        try:
            w = float(value)
        except ValueError:
            w = -1.0
        if not sep or not name.strip() or not 0 <= w <= MAX_WEIGHT:
            raise InputError(f"expected TERM=WEIGHT with 0 ≤ WEIGHT ≤ {MAX_WEIGHT:g}, got {item!r}", field="--weight")
        changed[name.strip()] = w
    return (weights, changed), samples, harmonics


def _resolve(desc: Any, weights: _Weights) -> dict[str, float]:
    """Every term's weight: the file's (or 1), then the --weight overrides."""
    from linkedit.curves.compare import resolve_weights

    base, changed = weights
    out = resolve_weights(desc, base)
    for name in changed:
        if name not in out:
            raise InputError(f"term {name!r} does not apply to these curves (their terms: {', '.join(out)})",
                             field="--weight")
    out |= changed
    if not any(out.values()):
        raise InputError("every weight is 0", field="--weight")
    return out


def _input_paths(texts: list[Any]) -> list[Path]:
    """Every file and folder curve inputs read (``result.h5:foot`` reads ``result.h5``, a set its sources),
    for the output checks; None and empty entries are skipped."""
    from linkedit.curves.sources import input_files

    return input_files([t for t in texts if t is not None and str(t)])


def register(app: typer.Typer) -> None:
    @app.command()
    @guard
    def features(
        inputs: list[str] = typer.Argument(..., help="Curves: result.h5:track, result.h5, .csv, curve-set .yaml, folders."),
        output: Path = typer.Option(None, "--output", "-o", help="Write the table: .h5, .csv or .json (- for CSV on stdout) [default: print it]."),
        samples: int = typer.Option(None, "--samples", "-n", min=8, max=4096, help=SAMPLES_HELP),
        harmonics: int = typer.Option(None, "--harmonics", min=1, max=64, help="Elliptic Fourier harmonics [default: 10]."),
        closed: bool = typer.Option(None, "--closed/--open", help=CLOSED_HELP),
        anchor: str = typer.Option(None, "--anchor", help="X,Y[,Z]: anchor point (e.g. the crank axle) for curves without one."),
        smooth: float = typer.Option(0.0, "--smooth", min=0.0, max=0.5, help=SMOOTH_HELP),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Per-curve features of normalized motion curves (one row per curve).

        An input that cannot be read is reported (named) and skipped; the exit code is then 2.
        """
        check_outputs([("--output", output)], _input_paths(inputs))
        refuse_json_with_stdout(output)
        failures: list[InputError] = []
        several = len(inputs) > 1 or any(Path(i).is_dir() for i in inputs)
        curves, desc = _load(inputs, closed, samples, harmonics, anchor, skip=_skipped(failures) if several else None,
                             smooth=smooth)
        if output is not None:
            options = {"samples": int(desc.points.shape[1]), "harmonics": int(desc.efd.shape[1]), "inputs": inputs}
            _write_features(output, curves, desc, options)
            if str(output) != "-":
                say(f"{len(curves)} curves → {output}")
        rows = _feature_rows(curves, desc)
        report({"output": str(output), "curves": len(curves)} if output is not None else rows,
               exit_code=2 if failures else 0, errors=[error_json(e) for e in failures])
        if output is None:
            _print_table(rows)
        if failures:
            raise typer.Exit(2)

    @app.command("compare-curves")
    @guard
    def compare_curves(
        inputs: list[str] = typer.Argument(None, help="Curves to compare with one another (as for `features`)."),
        query: list[str] = typer.Option(None, "--query", help="Rank the --library curves by distance to this curve (repeatable: several queries in one run)."),
        library: list[str] = typer.Option(None, "--library", help="Library curves (files or folders; repeatable)."),
        weights_file: Path = typer.Option(None, "--weights", help="Weights YAML (specs/curve-set.md) [default: all 1]."),
        weight: list[str] = typer.Option(None, "--weight", help="TERM=WEIGHT, overrides the file (repeatable)."),
        learn_pairs: Path = typer.Option(None, "--learn-weights", help="Labelled pairs YAML: fit the weights, write them to -o."),
        output: Path = typer.Option(None, "--output", "-o", help="Write the result: the distance matrix or the ranking "
                                    "as .csv, .h5 or .json (- for CSV on stdout); with --learn-weights the weights .yaml."),
        samples: int = typer.Option(None, "--samples", "-n", min=8, max=4096, help=SAMPLES_HELP),
        harmonics: int = typer.Option(None, "--harmonics", min=1, max=64, help="Elliptic Fourier harmonics [default: 10]."),
        closed: bool = typer.Option(None, "--closed/--open", help=CLOSED_HELP),
        anchor: str = typer.Option(None, "--anchor", help="X,Y[,Z]: anchor point for curves without one."),
        top: int = typer.Option(10, "--top", min=1, help="How many library curves to list with --query."),
        smooth: float = typer.Option(0.0, "--smooth", min=0.0, max=0.5, help=SMOOTH_HELP),
        mirror: bool = typer.Option(False, "--mirror", help=MIRROR_HELP),
        partial: bool = typer.Option(False, "--partial", help="Compare an open (partial) curve with closed ones by "
                                                              "where it fits best along them (points term only)."),
        svg: Path = typer.Option(None, "--svg", help="Overlay of the normalized curves (aligned to the first / the query)."),
        as_json: bool = JSON,
        quiet: bool = QUIET,
    ) -> None:
        """Distances between motion curves, each one's nearest neighbour, or a library ranked against a query."""
        check_outputs([("--output", output), ("--svg", svg)],
                      _input_paths([*(inputs or []), *(query or []), *(library or []), weights_file, learn_pairs]))
        refuse_json_with_stdout(output, svg)
        if learn_pairs is not None:
            if inputs or query or library:
                raise InputError("--learn-weights takes its curves from the pairs file", field="--learn-weights")
            _learn(learn_pairs, output, samples, harmonics, closed)
            return
        weights, w_samples, w_harmonics = _load_weights(weights_file, weight or [])
        samples, harmonics = samples or w_samples, harmonics or w_harmonics
        if query or library:
            if not query or not library or inputs:
                raise InputError("ranking needs --query and --library (and no other curves)", field="--query")
            _rank(query, library, weights, samples, harmonics, closed, anchor, top, svg, smooth, mirror, partial,
                  output)
            return
        if not inputs:
            raise InputError("give curves to compare, or --query and --library", field="INPUT")
        _matrix(inputs, weights, samples, harmonics, closed, anchor, svg, smooth, mirror, partial, output)


def _write_table(output: Path, kind: str, names: list[str], columns: list[str], values: Any, extra: dict[str, Any]) -> None:
    """A named table (rows ``names``, columns ``columns``) as CSV (17 digits), HDF5 or JSON, by suffix."""
    import numpy as np

    from linkedit.io.formats import output_format, write_out

    fmt = output_format(output, TABLE_FORMATS, stdout="csv")
    values = np.asarray(values, dtype=float)
    if fmt == "csv":
        from linkedit.io.csv_table import csv_text

        write_out(output, csv_text(["curve", *columns], [[name, *row] for name, row in zip(names, values.tolist())]))
    elif fmt == "json":
        write_out(output, json.dumps({"curves": names, "columns": columns, "values": values.tolist()} | extra,
                                     indent=2, allow_nan=False) + "\n")
    else:
        from linkedit.io.hdf5 import put, result_file, scale

        with result_file(output, kind=kind, units="", spec_text="", options=extra) as f:
            scale(f, "curve", names, "curve names (rows)")
            scale(f, "column", columns, "column names")
            put(f, "values", values, dims=("curve", "column"), units="1", description=f"{kind}: rows curves")


def _matrix(inputs, weights, samples, harmonics, closed, anchor, svg, smooth, mirror, partial,
            output=None) -> None:
    import numpy as np

    from linkedit.curves.compare import distances
    from linkedit.curves.distance import nearest

    if output is not None:
        from linkedit.io.formats import output_format

        output_format(output, TABLE_FORMATS, stdout="csv")
    curves, desc = _load(inputs, closed, samples, harmonics, anchor, smooth=smooth)
    if len(curves) < 2:
        raise InputError("compare-curves needs at least 2 curves", field="INPUT")
    w = _resolve(desc, weights)
    dist, _ = distances(desc, w, mirror=mirror, partial=partial)
    near = nearest(dist)
    names = [c.name for c in curves]
    rows = [{"curve": names[i], "nearest": names[j], "distance": float(dist[i, j])} for i, j in enumerate(near)]
    if svg is not None:
        medoid = int(np.argmin(dist.sum(axis=1)))  # the curve nearest all others: the picture's frame
        _overlay(svg, names, desc, medoid, f"curves aligned to {names[medoid]} (the medoid)", mirror=mirror)
    if output is not None:
        _write_table(output, "curve-distances", names, names, dist, {"weights": w})
        if str(output) != "-":
            say(f"{len(names)} × {len(names)} distances → {output}")
        report({"output": str(output), "curves": names, "weights": w, "nearest": rows})
        return
    report({"curves": names, "weights": w, "distance": dist, "nearest": rows})
    width = max(len(n) for n in names) + 2
    say(" " * width + "".join(f"{i:>10d}" for i in range(len(names))))
    for i, name in enumerate(names):
        say(f"{i:>3d} {name}".ljust(width + 4)[: width + 4] + "".join(f"{v:>10.4f}" for v in dist[i]))
    say("nearest neighbours:")
    for r in rows:
        say(f"  {r['curve']} → {r['nearest']} ({r['distance']:.4f})")


def _rank(queries, library, weights, samples, harmonics, closed, anchor, top, svg, smooth, mirror, partial,
          output=None) -> None:
    """Rank the library against each query; ``output`` gets every distance (rows library, columns queries)."""
    import numpy as np

    from linkedit.curves.compare import distances, placements
    from linkedit.curves.sources import load_inputs

    if output is not None:
        from linkedit.io.formats import output_format

        output_format(output, TABLE_FORMATS, stdout="csv")
    queried = []
    for query in queries:
        one = load_inputs([query], closed=closed)
        if len(one) != 1:
            raise InputError(f"the query {query} holds {len(one)} curves; name one (result.h5:track)", field="--query")
        queried += one

    def warn(exc: InputError) -> None:  # a library with a bad file: warn, skip it, rank the rest
        typer.echo(f"linkedit: warning: {exc} (skipped)", err=True)

    q = len(queried)
    curves, desc = _load([], closed, samples, harmonics, anchor, queried + load_inputs(library, closed=closed, skip=warn),
                         smooth=smooth)
    w = _resolve(desc, weights)
    dist, terms = distances(desc.take(range(q)), w, desc.take(range(q, len(curves))), mirror=mirror, partial=partial)
    results = []
    for n in range(q):
        order = np.argsort(dist[n], kind="stable")[:top]
        placed = placements(desc.take([n]), desc.take(q + order), mirror=mirror, partial=partial)
        ranking = [{"rank": k + 1, "curve": curves[q + i].name, "origin": curves[q + i].origin,
                    "distance": float(dist[n, i]), "terms": {t: float(m[n, i]) for t, m in terms.items()},
                    "placement": placed[k]}
                   for k, i in enumerate(order)]
        results.append({"query": curves[n].name, "weights": w, "ranking": ranking})
        if svg is not None and n == 0:
            chosen = [0] + [q + int(i) for i in order]
            _overlay(svg, [curves[i].name for i in chosen], desc.take(chosen), 0,
                     f"library ranked against {curves[0].name}", mirror=mirror,
                     labels=[f"query: {curves[0].name}"] + [f"{r['rank']}. {r['curve']} ({r['distance']:.4f})"
                                                            for r in ranking])
    if output is not None:
        _write_table(output, "curve-ranking", [c.name for c in curves[q:]], [c.name for c in curves[:q]], dist.T,
                     {"weights": w})
        if str(output) != "-":
            say(f"{len(curves) - q} library curves × {q} queries → {output}")
        report({"output": str(output), "queries": results})
        return
    report({"queries": results})
    for r in results:
        say(f"query {r['query']}: {len(curves) - q} library curves, nearest first")
        for x in r["ranking"]:
            p = x["placement"]
            turn = f"turn {p['rotation_deg']:.1f}°, " if "rotation_deg" in p else ""
            say(f"{x['rank']:>4d}. {x['curve']}  {x['distance']:.4f}  (scale {p['scale']:.4g}, {turn}"
                       f"move {', '.join(f'{v:.4g}' for v in p['translation'])}, phase {p['phase']:.3f}"
                       + (", reversed" if p["reversed"] else "") + (", mirrored" if p["mirrored"] else "") + ")")


def _overlay(path: Path, names: list[str], desc: Any, reference: int, title: str, labels: list[str] | None = None,
             mirror: bool = False) -> None:
    from linkedit.curves.distance import align
    from linkedit.curves.svg import overlay
    from linkedit.io.atomic import write_text

    pts = align(desc.points[reference], bool(desc.closed[reference]), desc.points, desc.closed, mirror=mirror)
    write_text(path, overlay(names, pts, desc.closed, title=title, highlight=reference, labels=labels))


def _learn(pairs_path: Path, output: Path | None, samples, harmonics, closed) -> None:
    from linkedit.curves.compare import describe_curves, learn
    from linkedit.curves.descriptors import DEFAULT_HARMONICS, DEFAULT_SAMPLES
    from linkedit.curves.sources import load_inputs
    from linkedit.io.atomic import write_text
    from linkedit.spec.curveset import LabelledPairs
    from linkedit.spec.yamlload import load_yaml, validate

    if output is None:
        raise InputError("--learn-weights needs -o WEIGHTS.yaml", field="--output")
    file = str(pairs_path)
    data, lines = load_yaml(pairs_path)
    spec = validate(LabelledPairs, data, file=file, lines=lines)
    samples = samples or spec.samples or DEFAULT_SAMPLES
    harmonics = harmonics or spec.harmonics or DEFAULT_HARMONICS
    sources = [str(pairs_path.parent / c) for c in spec.curves]
    check_outputs([("--output", output)], _input_paths(sources))
    curves = load_inputs(sources, closed=closed)
    desc = describe_curves(curves, samples=samples, harmonics=harmonics)
    try:
        fit = learn(desc, [c.name for c in curves], list(spec.similar), list(spec.dissimilar),
                    regularization=spec.regularization, terms=spec.terms, file=file)
    except InputError as exc:
        if exc.file == file and exc.line is None:
            exc.line = lines.line_of(exc.field)
        raise
    summary = (f"similar pairs: distance ≤ {fit.similar.max():.4g} (mean {fit.similar.mean():.4g}); "
               f"dissimilar pairs: distance ≥ {fit.dissimilar.min():.4g}; "
               + ("separated" if fit.separated else "NOT separated"))
    if fit.held_out_auc is not None:
        best_term = max(fit.term_auc, key=lambda term: fit.term_auc[term])
        summary += (f"; soft margin C = {fit.cost:g}, held-out AUC {fit.held_out_auc:.3f} (cross-validated; "
                    f"best single term {best_term} {fit.term_auc[best_term]:.3f}, points "
                    f"{fit.term_auc.get('points', float('nan')):.3f})")
    body = {"description": f"learned by linkedit compare-curves --learn-weights {pairs_path.name}: {summary}",
            "samples": samples, "harmonics": harmonics, "weights": {k: round(v, 12) for k, v in fit.weights.items()}}
    import yaml

    write_text(output, yaml.safe_dump(body, sort_keys=False, allow_unicode=True, width=100))
    report(body | {"output": str(output), "similar": fit.similar, "dissimilar": fit.dissimilar,
                   "separated": fit.separated, "cost": fit.cost, "held_out_auc": fit.held_out_auc,
                   "term_auc": fit.term_auc})
    say(summary)
    say(f"weights → {output}")
