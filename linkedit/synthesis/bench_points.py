"""The synthesis bench's point tasks (``linkedit bench -s synthesis``): precision points drawn from held-out
four-bars, the published precision-point problems (:mod:`linkedit.synthesis.published`) and function
generation, each scored as the user's result is (the written linkage's curve or output)."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from linkedit.curves.polyline import distances_to
from linkedit.curves.sources import make_curve
from linkedit.planar import compile_plan, simulate
from linkedit.synthesis import atlas, fourbar
from linkedit.synthesis.index import Index
from linkedit.synthesis.synthesize import MARGIN_DEG, synthesize

#: the figure-eight's and the published problems' extra row: --margin 10
WIDE_BAND_DEG = 10.0


def top_of(quick: bool) -> int:
    """The synthesis bench's ``--top`` (candidates refined per target): 5, or 1 with ``--quick``."""
    return 1 if quick else 5


#: Precision-point problems: (points, seed of the uneven draw) from held-out four-bars (atlas seed 4242, not the
#: atlas's); the reference is the generating linkage (error 0). Published problems: :func:`published_points`.
PRECISION_PROBLEMS = ((6, 1), (8, 2), (10, 3), (12, 4), (18, 5), (25, 6))


def precision_points(echo: Callable[[str], None], book: atlas.Atlas, index: Index, quick: bool) -> None:
    """Precision points drawn unevenly from held-out four-bars' curves: the mean distance of the points to the
    written result's curve over their RMS radius (max in parentheses), the generating linkage's by the same
    measure, the same points synthesized as a curve (the polygon; scored by the points), and CPU seconds; ``quick``:
    the first problem only (a smoke run)."""
    rows = atlas.build_chunk("four-bar", 4242, 0, len(PRECISION_PROBLEMS)).params
    top = top_of(quick)
    echo(f"precision points, --top {top} (mean point-to-curve distance over the points' RMS radius, max in parentheses; "
         "held-out four-bars, points drawn unevenly; reference: the generating linkage):")
    echo(f"  {'points':>6s}  {'ours (--points)':>22s}  {'as a curve (polygon)':>22s}  {'generating':>10s}  CPU s")
    for (count, seed), row in list(zip(PRECISION_PROBLEMS, rows))[: 1 if quick else None]:
        curve = 5 - 2j + 30 * np.exp(0.7j * seed) * fourbar.curves(row[None], 3600)[0]
        z = curve[np.sort(np.random.default_rng(seed).choice(len(curve), count, replace=False))]
        radius = float(np.sqrt(np.mean(np.abs(z - z.mean()) ** 2)))
        target = make_curve("points", np.stack([z.real, z.imag], axis=1), closed=True, origin="bench")
        cpu = time.process_time()
        ours = synthesize(target, book, index, top=top, points=True)
        cpu = time.process_time() - cpu
        assert ours.point_distances is not None
        d = ours.point_distances / ours.size
        drawn = simulate(compile_plan(synthesize(target, book, index, top=top, points=False).spec), 20000)
        p = drawn.tracks["target"].position
        polygon = distances_to(z, p[:, 0] + 1j * p[:, 1], True) / radius
        truth = simulate(compile_plan(fourbar.to_spec(row, phase=0.0, scale=30.0, turn=np.exp(0.7j * seed),
                                                      shift=5 - 2j, mirrored=False, name="generating", units="mm",
                                                      description="")), 20000).tracks["target"].position
        generating = distances_to(z, truth[:, 0] + 1j * truth[:, 1], True) / radius
        echo(f"  {count:>6d}  {d.mean():10.2e} ({d.max():8.2e})  {polygon.mean():10.2e} ({polygon.max():8.2e})  "
             f"{generating.mean():10.1e}  {cpu:5.2f}")


#: The published problem also run with a 10° band (its exact crank-rocker's transmission angle falls to 12.1°).
WIDE_BAND_PROBLEM = "Wampler et al. 1992, nine points on two circles"


def published_points(echo: Callable[[str], None], book: atlas.Atlas, index: Index, quick: bool) -> None:
    """Published precision-point problems (:mod:`linkedit.synthesis.published`): ours (``--points``, --top 5, 1
    with ``quick``, the 20° band) by the mean distance of the points to the written result's curve over their RMS radius (max in
    parentheses), against the best published linkage's by the same measure (exact solutions: 0), with CPU
    seconds; ``quick``: the first problem only."""
    from linkedit.synthesis.published import PROBLEMS

    top = top_of(quick)
    echo(f"published precision-point problems, --points --top {top} (mean point-to-curve distance over the points' RMS "
         "radius, max in parentheses; published: the best published linkage, scored the same way; sources: "
         "linkedit/synthesis/published.py):")
    echo(f"  {'problem':<52s} {'ours':>21s}  {'published':>9s}  CPU s  published solution")
    rows = [(p, MARGIN_DEG) for p in PROBLEMS[: 1 if quick else None]]
    if not quick:
        rows += [(p, WIDE_BAND_DEG) for p in PROBLEMS if p.name == WIDE_BAND_PROBLEM]
    for problem, margin_deg in rows:
        z = problem.array()
        target = make_curve("points", np.stack([z.real, z.imag], axis=1), closed=True, origin="bench")
        cpu = time.process_time()
        ours = synthesize(target, book, index, top=top, points=True, margin_deg=margin_deg)
        cpu = time.process_time() - cpu
        assert ours.point_distances is not None
        d = ours.point_distances / ours.size
        name = problem.name + ("" if margin_deg == MARGIN_DEG else f", --margin {margin_deg:g}")
        best = problem.best()
        published = f"{0.0:9.1g}" if best is None else f"{best[1].mean():9.2e}"
        solution = problem.published if best is None else f"{best[0].label}; of {problem.published}"
        echo(f"  {name:<52s} {d.mean():9.2e} ({d.max():8.2e})  {published:>9s}  {cpu:5.2f}  {solution}")


def function_generation(echo: Callable[[str], None], quick: bool) -> None:
    """``synthesize --function`` on y = log10 x and a square law, x in [1, 10] (25 pairs) mapped to 60° of crank and
    60° of rocker, with relative angles: max (RMS) output error with the output's sense free and prescribed (the
    output turning the way the pairs do), in the 20° and (not ``quick``) 10° transmission bands; and the Watt II
    six-bar (``--family six-bar``) with the sense prescribed in the 20° band; ``quick``: log10 x only."""
    from linkedit.synthesis import function, function_six

    x = np.linspace(1.0, 10.0, 25)
    echo("function generation over 60° (25 pairs, --relative; max (RMS) output error, degrees; target ≤ 0.5° max):")

    def cell(fit: function.FunctionFit | function_six.SixBarFit | None, sense: str) -> str:
        e = np.degrees(np.abs(fit.errors)) if fit is not None else np.array([np.nan])
        way = "" if fit is None or not sense else " same" if fit.sense > 0 else " opposite"
        return f"{e.max():.3f}° ({np.sqrt(np.mean(e * e)):.3f}°){way}"

    laws = (("log10 x", np.log10(x)), ("((x − 1)/9)²", ((x - 1.0) / 9.0) ** 2))
    for name, y in laws[: 1 if quick else None]:
        phi, psi = np.radians(60 * (x - 1) / 9), np.radians(60 * (y - y.min()) / (y.max() - y.min()))
        cells = []
        for margin_deg in (MARGIN_DEG,) if quick else (MARGIN_DEG, WIDE_BAND_DEG):
            cells.append(cell(function.fit(phi, psi, relative=True, margin_deg=margin_deg), "free"))
            cells.append(cell(function.fit(phi, psi, relative=True, margin_deg=margin_deg, sense=1.0), ""))
        six = cell(function_six.fit(phi, psi, margin_deg=MARGIN_DEG, sense=1.0), "")
        wide = "" if quick else f"; band 10°: sense free {cells[2]}, same sense {cells[3]}"
        echo(f"  {name:<13s} band 20°: sense free {cells[0]}, same sense {cells[1]}, six-bar same sense {six}{wide}")