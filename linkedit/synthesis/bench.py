"""Benchmark of synthesis (``linkedit bench -s synthesis``).

* atlas building, four-bar family, in-process: linkages per second including sampling,
  rejection, the batched evaluation and the index descriptors (chunks only, and the whole
  ``atlas build`` with HDF5 writing); per core, ``atlas build`` in-process, as N in-process
  builds side by side and on a local Dask cluster of N workers (``--workers N``, default the cores this
  process may use) if ``dask.distributed`` is installed
  (:func:`~linkedit.synthesis.bench_cluster.dask_comparison`); a sharded build in-process and on those workers: the
  parallel efficiency, the CPU-time efficiency and the busy fraction (:func:`~linkedit.synthesis.bench_cluster.shard_scaling`);
* a query of the index of a 1,000,000-curve atlas (built in memory, chunk by chunk);
* ``synthesize`` end to end (query, re-ranking, refinement of the best 5, final check) for
  targets drawn by held-out four-bars, against that atlas;
* the quality table: classic curves (Hoekens' coupler curve, Chebyshev's straight line, a
  straight segment, figure-eights, an ellipse, a D-shaped walking foot path) and curves of
  held-out linkages of every family (another seed than the atlas's), synthesized against an
  atlas of every family (the four-bars above and 20,000 linkages of each catalog family); and
  Gerono's 2:1 figure-eight once more with a 10° transmission band (``--margin 10``: the 20°
  band's optimum is 4.15 %, README); both figure-eights with a six-bar family that draws them inside the 20°
  band (``atlas build --family examples/figure-eight-six-bar.yaml``, :data:`EIGHT_SPEC`);
* slider specs as families (``atlas build --family examples/quick-return.yaml``): the build rate of
  a quick-return atlas in-process, and held-out timed paths (the quick-return's ram, the
  Scotch-yoke-driven coupler point) synthesized against atlases of their specs (:func:`spec_families`);
* precision points (6–25, drawn unevenly from held-out four-bars' curves): ours with ``--points`` against the
  same points synthesized as a curve and the generating linkage, by the mean point-to-curve distance over the
  points' RMS radius, with CPU seconds;
* spatial targets (:func:`spatial`): held-out spherical four-bar and RSSR curves, turned, scaled and moved, synthesized
  against an atlas of both families, with the error as placed, refined and of ``result.yaml`` solved by ``solve3d``.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from linkedit.curves.sources import make_curve
from linkedit.io.atomic import commit
from linkedit.planar import catalog, compile_plan, simulate
from linkedit.synthesis import atlas, bench_motion, bench_points, bench_scale, families, fourbar
from linkedit.synthesis.bench_cluster import dask_comparison
from linkedit.synthesis.cluster import usable_cores
from linkedit.synthesis.index import Index, target_variants
from linkedit.synthesis.synthesize import MARGIN_DEG, synthesize
from linkedit.timing import median_time

BUILD_TARGET = 100_000  # linkages / s
QUERY_TARGET = 0.050  # s on 1,000,000 curves
SYNTHESIZE_TARGET = 10.0  # s with --top 5
#: The example six-bar made a family for the figure-eights' six-bar rows.
EIGHT_SPEC = "figure-eight-six-bar.yaml"


def chebyshev_straight_line(points: int) -> np.ndarray:
    """The midpoint of Chebyshev's straight-line linkage (crossed rockers 5 on pivots 4 apart,
    coupler 2) while it runs between the verticals of the pivots, y ≈ 4 (M,) complex."""
    phi = np.radians(np.linspace(np.degrees(np.arctan2(4.0, 3.0)), 90.0, points))
    b, d = 5.0 * np.exp(1j * phi), 4.0
    gap = np.abs(b - d)
    along = (25.0 - 4.0 + gap ** 2) / (2.0 * gap)
    c = d + (along - 1j * np.sqrt(25.0 - along ** 2)) * (b - d) / gap  # the crossed branch
    return 10.0 * (b + c) / 2.0


def classic_curves(points: int = 400) -> dict[str, tuple[np.ndarray, bool]]:
    """Classic target curves (name → (points (M,) complex, closed))."""
    from linkedit.planar import catalog, compile_plan, simulate

    t = np.linspace(0.0, 2.0 * np.pi, points, endpoint=False)
    hoekens = simulate(compile_plan(catalog.hoekens()), points).tracks["tracer"].position
    bottom = np.linspace(30.0, -30.0, points // 2, endpoint=False)
    arc = np.linspace(np.pi, 2.0 * np.pi, points - points // 2, endpoint=False)
    d_shape = np.concatenate([bottom + 0j, 30.0 * np.cos(arc) - 12j * np.sin(arc)])  # flat stance, arched swing
    return {
        "Hoekens coupler curve (straight stretch)": (hoekens[:, 0] + 1j * hoekens[:, 1], True),
        "Chebyshev straight line (open)": (chebyshev_straight_line(points // 2), False),
        "straight segment (open)": (np.linspace(0.0, 40.0, points // 4) + 5j, False),
        "figure-eight (Gerono, 2:1)": (20.0 * np.cos(t) + 10j * np.sin(2.0 * t), True),
        "figure-eight (Gerono, 5:2)": (20.0 * np.cos(t) + 8j * np.sin(2.0 * t), True),
        "ellipse 2:1": (20.0 * np.cos(t) + 10j * np.sin(t), True),
        "D-shaped foot path": (np.conj(d_shape), True),
    }


def _planar() -> list[str]:
    """The built-in planar families (the spatial ones have their own section)."""
    return [name for name in families.FAMILIES if atlas.dimension(families.family(name)) == 2]


def held_out_targets(per_family: int = 2) -> dict[str, tuple[np.ndarray, bool]]:
    """Curves of linkages drawn with another seed (987) than any atlas, moved, turned, scaled and
    started at another phase: ``per_family`` for each family."""
    out = {}
    for name in _planar():
        fam = families.family(name)
        rows = atlas.build_chunk(name, 987, 0, per_family).params
        for k, row in enumerate(rows):
            z = fam.curves(row[None], 300, 0.13 + 0.3 * k)[0]
            out[f"held-out {name} #{k + 1}"] = (3 + 1j + 40 * np.exp((0.4 + k) * 1j) * z, True)
    return out


def arrays(name: str, count: int, text: str | None = None) -> dict[str, np.ndarray]:
    """An atlas's arrays of ``count`` linkages (seed 1) of family ``name`` (``text``: its spec, for a family made
    from one), built in memory chunk by chunk."""
    built = [atlas.build_chunk(name, 1, i, size, text) for i, size in atlas.chunk_sizes(count)]
    return {key: np.concatenate([getattr(c, key) for c in built]) for key in ("params", "min_ds", "index", "curves")}


def spec_atlas(path: Path, count: int) -> atlas.Atlas:
    """An in-memory atlas of ``count`` linkages (seed 1) of the family made from the linkage spec at ``path``."""
    name = families.spec_family(path)
    return atlas.Atlas(Path("memory"), {name: arrays(name, count, families.SPEC_TEXTS[name])}, 1)


def quality(echo: Callable[[str], None], four_bars: atlas.Atlas, index: Index, every: atlas.Atlas, quick: bool) -> None:
    """The quality table: normalized RMS (max) error before → after refinement, family, seconds —
    classic curves against the four-bar atlas, the figure-eights against the six-bar family of
    :data:`EIGHT_SPEC` too, held-out linkages against the atlas of every family."""
    from linkedit.examples import examples_dir

    sizes = ", ".join(f"{name} {len(arrays['params']):,}" for name, arrays in every.families.items())
    six_bars = spec_atlas(examples_dir() / EIGHT_SPEC, 2_000 if quick else 20_000)
    (six_name, six_rows), = ((n, len(a["params"])) for n, a in six_bars.families.items())
    top = bench_points.top_of(quick)
    echo(f"quality, --top {top} (normalized RMS error by the target's size, max in parentheses: the atlas candidate "
         "as placed → refined → polished through edit); classic curves: four-bar atlas (figure-eights also "
         f"{six_name}: {six_rows:,} six-bars around examples/{EIGHT_SPEC}); held-out linkages: atlas of {sizes}:")
    held = held_out_targets(1 if quick else 2)
    classic = classic_curves()
    rows = [(name, z, closed, four_bars, index, MARGIN_DEG)
            for name, (z, closed) in list(classic.items())[: 1 if quick else None]]
    if not quick:
        eight = "figure-eight (Gerono, 2:1)"
        rows.append((f"{eight}, --margin {bench_points.WIDE_BAND_DEG:g}", *classic[eight], four_bars, index, bench_points.WIDE_BAND_DEG))
    six_index = Index(six_bars)
    rows += [(f"{name}, six-bar", z, closed, six_bars, six_index, MARGIN_DEG) for name, (z, closed) in classic.items()
             if "figure-eight" in name and (not quick or "2:1" in name)]
    every_index = Index(every)
    rows += [(name, z, closed, every, every_index, MARGIN_DEG) for name, (z, closed) in held.items()
             if not quick or "four-bar" in name]
    echo(f"  {'target':<42s} {'atlas candidate':>17s}   {'refined':>17s}   {'polished by edit':>17s}  family")
    for name, z, closed, book, book_index, margin_deg in rows:
        curve = make_curve(name, np.stack([z.real, z.imag], axis=1), closed=closed, origin="bench")
        t0 = time.perf_counter()
        result = synthesize(curve, book, book_index, top=top, margin_deg=margin_deg)
        best, polish = result.best, result.polish
        polished = ("not polished (open)" if polish is None else
                    f"{100 * polish.error[0]:6.3f} % ({100 * polish.error[1]:5.2f} %)" if polish.error else "edit failed")
        if polish is not None and polish.error and not polish.kept:
            polished += " ✗" + (" margin" if "margin" in polish.why else "")
        echo(f"  {name:<42s} {100 * best.before[0]:6.2f} % ({100 * best.before[1]:5.2f} %) → "
             f"{100 * best.after[0]:6.3f} % ({100 * best.after[1]:5.2f} %) → {polished:<20s} {best.family:<20s} "
             f"{time.perf_counter() - t0:5.2f} s")
    echo("  (✗: the polish is not kept — no lower error, or ' margin': it crossed the singularity margin; the result "
         "is then the refined linkage)")


def lists_figures(echo: Callable[[str], None], parts: list[atlas.Chunk], repeats: int) -> None:
    """The coarse quantizers on the curves of ``parts`` (chunks): one trained on them all
    (:class:`~linkedit.synthesis.index.Lists`) and, as a sharded atlas has it, the family's two-level quantizer
    trained on its own sample and each chunk's rows assigned to its cells (:func:`~linkedit.synthesis.index.assign`):
    build time, median query time and recall of the exact top 10 over 200 held-out four-bar targets, against the
    whole scan."""
    from linkedit.synthesis.index import SAMPLE_PER_CELL, Lists, assign, nearest_rows, quantizer_side, train_quantizer
    from linkedit.synthesis.shards import TRAIN_CHUNK

    vectors = np.concatenate([p.index for p in parts])
    t0 = time.perf_counter()
    lists = Lists.trained(vectors)
    t_lists = time.perf_counter() - t0
    t0 = time.perf_counter()
    side = quantizer_side(len(vectors))
    top, leaves = train_quantizer(atlas.build_chunk("four-bar", 1, TRAIN_CHUNK, SAMPLE_PER_CELL * side**2).index, side, 1)
    t_train = time.perf_counter() - t0
    t0 = time.perf_counter()
    cell = np.concatenate([assign(p.index, top, leaves) for p in parts])
    t_cells = time.perf_counter() - t0
    sharded = Index(atlas.Atlas(Path("memory"), {"four-bar": {"index": vectors, "centroids": leaves, "cell": cell}}, 1),
                    scan_limit=0)
    columns, norms = np.ascontiguousarray(vectors.T), np.einsum("kd,kd->k", vectors, vectors)
    held = atlas.build_chunk("four-bar", 988, 0, 200).params
    recall, exact, probed, shard_recall, shard_time = [], [], [], [], []
    for k, row in enumerate(held):
        v = target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0])
        t0 = time.perf_counter()
        truth = set(nearest_rows(v, columns, norms, 10)[0].tolist())
        exact.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        found = lists.query(v, 10)[0]
        probed.append(time.perf_counter() - t0)
        recall.append(len(truth & set(found.tolist())) / 10)
        t0 = time.perf_counter()
        hits = sharded.query(v, 10)
        shard_time.append(time.perf_counter() - t0)
        shard_recall.append(len(truth & {h.row for h in hits}) / 10)
    echo(f"index query through {len(lists.centroids):,} cells of {len(vectors):,} curves ({t_lists:.1f} s to build): "
         f"{1e3 * statistics.median(probed):.1f} ms median against {1e3 * statistics.median(exact):.1f} ms for the "
         f"whole scan, recall of the exact top 10 {np.mean(recall):.3f} over {len(held)} held-out targets "
         f"(target ≥ 0.99)")
    echo(f"  as a sharded atlas stores it: the family's quantizer ({len(leaves):,} cells, {t_train:.1f} s to draw its "
         f"sample and train it, once per atlas), each shard's rows assigned to its cells ({t_cells:.2f} s for "
         f"{len(parts)} shards, inside the build tasks): {1e3 * statistics.median(shard_time):.1f} ms median, recall "
         f"of the exact top 10 {np.mean(shard_recall):.3f} (target ≥ 0.99)")


def run(echo: Callable[[str], None], quick: bool = False, large: int | None = None, workers: int | None = None,
        large_atlas: Path | None = None) -> None:
    """The section's figures; ``large``: also the query at scale over a sharded atlas of that many four-bars
    (:mod:`linkedit.synthesis.bench_scale`, opt-in: minutes to build), or over the one in folder ``large_atlas``;
    ``workers``: the local Dask clusters'
    worker processes (default: the cores this process may use, :func:`~linkedit.synthesis.cluster.usable_cores`)."""
    workers = workers or usable_cores()
    chunks, big, repeats = (1, 2 * atlas.CHUNK, 1) if quick else (10, 1_000_000, 5)
    atlas.build_chunk("four-bar", 1, 0)  # warm up
    t_chunks = median_time(lambda: [atlas.build_chunk("four-bar", 1, i) for i in range(chunks)], repeats)
    rate = chunks * atlas.CHUNK / t_chunks
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.h5"
        t0 = time.perf_counter()
        atlas.build(path, ["four-bar"], chunks * atlas.CHUNK, seed=1)
        commit()  # the command's outputs are renamed together at its end; this file lives in a folder about to go
        t_file = time.perf_counter() - t0
    echo(f"atlas build, four-bar, in-process: {rate:,.0f} linkages/s in chunks (median of {repeats}; target ≥ "
         f"{BUILD_TARGET:,}), {chunks * atlas.CHUNK / t_file:,.0f} linkages/s writing the HDF5 atlas")
    if not quick:
        dask_comparison(echo, 4 * chunks, repeats, workers)

    t0 = time.perf_counter()
    parts = [atlas.build_chunk("four-bar", 1, i, size) for i, size in atlas.chunk_sizes(big)]
    t_big = time.perf_counter() - t0
    merged = {key: np.concatenate([getattr(p, key) for p in parts]) for key in ("params", "min_ds", "index", "curves")}
    book = atlas.Atlas(Path("memory"), {"four-bar": merged}, 1)
    index = Index(book)
    held = atlas.build_chunk("four-bar", 987, 0, 4).params
    targets = [3 + 1j + 20 * np.exp(0.4j * k) * fourbar.curves(held[k][None], 300, 0.2 * k)[0] for k in range(4)]
    variants = [target_variants(z) for z in targets]

    def query_time(v: np.ndarray) -> float:
        return median_time(lambda: index.query(v, 64), repeats)

    t_query = statistics.median(query_time(v) for v in variants)
    echo(f"index query, {big:,} curves ({t_big:.1f} s to build them, {big / t_big:,.0f} linkages/s): "
         f"{1e3 * t_query:.1f} ms median (target ≤ {1e3 * QUERY_TARGET:.0f} ms)")
    if not quick:
        lists_figures(echo, parts, repeats)
    if large or large_atlas:
        bench_scale.run(echo, large, workers, folder=large_atlas)

    runs, top = [], bench_points.top_of(quick)
    for z in targets[: 1 if quick else 4]:
        curve = make_curve("target", np.stack([z.real, z.imag], axis=1), closed=True, origin="bench")
        t0 = time.perf_counter()
        result = synthesize(curve, book, index, top=top)
        runs.append((time.perf_counter() - t0, result.error[0]))
    echo(f"synthesize end to end, --top {top}, held-out four-bar targets against {big:,} curves: "
         f"{statistics.median(t for t, _ in runs):.2f} s median (target ≤ {SYNTHESIZE_TARGET:g} s); "
         f"normalized RMS error after refinement: max {max(e for _, e in runs):.2g}")
    bench_points.precision_points(echo, book, index, quick)
    bench_points.published_points(echo, book, index, quick)
    bench_points.function_generation(echo, quick)
    bench_motion.motion_generation(echo, quick)
    every = atlas.Atlas(Path("memory"), dict(book.families), 1)
    for name in _planar():
        if name != "four-bar":
            every.families[name] = arrays(name, 2_000 if quick else 20_000)
    quality(echo, book, index, every, quick)
    spec_families(echo, quick)
    spatial(echo, quick)


def spec_families(echo: Callable[[str], None], quick: bool) -> None:
    """Slider specs as families: each example's atlas built in-process (its rate, linkages/s with
    sampling, the 1440-sample check and the descriptors), then a held-out design's tracked path
    (seed 987, turned, scaled, moved) synthesized with --timing against it; ``quick``: the quick-return only."""
    count, top = (500, 1) if quick else (20_000, 2)
    for file in ("quick-return.yaml", "scotch-yoke-coupler.yaml")[: 1 if quick else None]:
        example = next(e for e in catalog.EXAMPLES if e.file == file)
        text = example.text()
        fam = families.from_spec_text(example.build().name, text)
        t0, c0 = time.perf_counter(), time.process_time()
        book = atlas.Atlas(Path("memory"), {fam.NAME: arrays(fam.NAME, count, text)}, 1)
        rate, cpu = count / (time.perf_counter() - t0), count / (time.process_time() - c0)
        row = atlas.build_chunk(fam.NAME, 987, 0, 1, text).params[0]
        z = 3 + 1j + 40 * np.exp(0.4j) * fam.curves(row[None], 256, 0.13)[0]
        curve = make_curve("target", np.stack([z.real, z.imag], axis=1), closed=True, origin="bench",
                           times=np.arange(256) / 256.0)
        t0 = time.perf_counter()
        result = synthesize(curve, book, Index(book), top=top, timing=True)
        timed = result.timed_error or (np.nan, np.nan)
        echo(f"spec family {file}: atlas build {rate:,.0f} linkages/s in-process ({cpu:,.0f} per CPU second, {count:,}); a held-out design's "
             f"path with --timing: {100 * timed[0]:.3g} % RMS ({100 * timed[1]:.3g} % max) at the target's times, "
             f"{time.perf_counter() - t0:.1f} s")


#: The spatial families (``atlas build --family spherical-four-bar,rssr``) and the error the bench aims at.
SPATIAL = ("spherical-four-bar", "rssr")
SPATIAL_TARGET = 0.01  # normalized RMS


def spatial(echo: Callable[[str], None], quick: bool) -> None:
    """Held-out spatial curves: linkages of each spatial family drawn with another seed (987) than the atlas's,
    turned by a random rotation, scaled and moved, their whole cycles and the first half of each as an open arc,
    synthesized (:func:`~linkedit.synthesis.spatial.synthesize3d`,
    as ``linkedit synthesize target3d.csv``) against an in-memory atlas of both families; per target the found
    family, the normalized RMS (max) error as placed from the atlas, refined, and of ``result.yaml`` solved by
    ``solve3d``'s solver (what the CLI reports), and CPU seconds."""
    from scipy.spatial.transform import Rotation

    from linkedit.synthesis.spatial import synthesize3d

    count, top, per_family = (1_500, 1, 1) if quick else (6_000, 5, 4)
    book = atlas.Atlas(Path("memory"), {name: arrays(name, count) for name in SPATIAL}, 1)
    echo(f"spatial targets, --top {top}, against {count:,} linkages of each of {', '.join(SPATIAL)} (held-out "
         f"linkages, seed 987, turned, scaled ×25, moved; normalized RMS (max) error, target ≤ "
         f"{100 * SPATIAL_TARGET:g} % RMS; solved: result.yaml by solve3d, as the CLI reports it):")
    echo(f"  {'target':<34s} {'found':<19s} {'as placed':>17s}   {'refined':>17s}   {'solved':>17s}  CPU s")
    worst = 0.0
    for name in SPATIAL:
        fam = families.family(name)
        for k, row in enumerate(atlas.build_chunk(name, 987, 0, per_family).params):
            matrix = Rotation.random(random_state=k).as_matrix()
            points = np.array([40.0, -12.0, 7.0]) + 25.0 * fam.curves(row[None], 240, 0.3 + 0.2 * k)[0] @ matrix.T
            for label, part, closed in ((f"{name} #{k + 1}", points, True),
                                        (f"half arc of {name} #{k + 1}", points[:120], False)):
                target = make_curve(name, part, closed=closed, origin="bench")
                cpu = time.process_time()
                result = synthesize3d(target, book, top=top)
                cpu = time.process_time() - cpu
                best, worst = result.best, max(worst, result.error[0])
                echo(f"  {label:<34s} {best.family:<19s} " + "   ".join(
                    f"{100 * e[0]:7.3f} % ({100 * e[1]:5.2f} %)" for e in (best.before, best.after, result.error)) +
                    f"  {cpu:5.2f}")
    echo(f"  worst solved RMS {100 * worst:.3f} % ({'within' if worst <= SPATIAL_TARGET else 'ABOVE'} the "
         f"{100 * SPATIAL_TARGET:g} % target)")
