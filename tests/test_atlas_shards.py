"""Sharded atlases: workers write their shards, a Dask build equals the in-process one, an interrupted
build resumes to the same atlas, a query through the family's quantizer over the shards equals the exact scan."""

from __future__ import annotations

import json
import os
import re
import signal
import threading
import time

import h5py
import numpy as np
import pytest

from linkedit.synthesis import atlas, chunks, fourbar, shards, spatial, spherical
from linkedit.synthesis import index as atlas_index
from linkedit.synthesis import manifest as atlas_manifest
from linkedit.synthesis.index import Index, nearest_rows, target_variants
from tests.conftest import report_of

SMALL = 1000  # linkages per chunk in these tests (a chunk is a pure function of its index and size)


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(atlas, "CHUNK", SMALL)
    monkeypatch.setattr(chunks, "CHUNK", SMALL)
    monkeypatch.setattr(shards, "CHUNK", SMALL)




def _build(run_cli, out, count, *args):
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", str(count), "-o", out, "--seed", "8", *args)
    assert result.exit_code == 0, result.output
    return json.loads((out / shards.MANIFEST).read_text())


def _shard_arrays(folder, entry) -> dict[str, np.ndarray]:
    with h5py.File(folder / entry["file"]) as f:
        return {key: f[key][()] for key in ("params", "min_ds", "index", "cell")}


def _interrupt_at(monkeypatch, chunk: int):
    """A SIGINT to this process as chunk ``chunk`` is about to be built (a Ctrl-C mid-build); returns the
    real ``shards.build_chunk``, to put back for the resume."""
    build_chunk = shards.build_chunk

    def interrupted(name, seed, index, size, spec=None):
        if index == chunk:
            os.kill(os.getpid(), signal.SIGINT)
        return build_chunk(name, seed, index, size, spec)

    monkeypatch.setattr(shards, "build_chunk", interrupted)
    return build_chunk


def test_a_sharded_dask_build_equals_the_in_process_build(run_cli, tmp_path, small_chunks, cluster):
    """Two workers write the shards (9 chunks, the last partial), the client only the manifest: the same
    shards, byte for byte in content, as an in-process build into a folder and as the single-file atlas."""
    count = 8 * SMALL + SMALL // 3
    dask = _build(run_cli, tmp_path / "dask", count, "--scheduler", cluster.scheduler_address)
    local = _build(run_cli, tmp_path / "local", count)
    entries = dask["families"]["four-bar"]["shards"]
    assert entries == local["families"]["four-bar"]["shards"]
    assert [(e["chunk"], e["rows"]) for e in entries] == atlas.chunk_sizes(count)
    assert dask["build"] is None and dask["families"]["four-bar"]["pending"] == []
    for entry in entries:
        a, b = _shard_arrays(tmp_path / "dask", entry), _shard_arrays(tmp_path / "local", entry)
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    file = tmp_path / "a.h5"
    assert run_cli("atlas", "build", "--family", "four-bar", "-n", str(count), "-o", file, "--seed", "8").exit_code == 0
    read = shards.load(tmp_path / "dask").families["four-bar"]
    with h5py.File(file) as f:
        np.testing.assert_array_equal(read["params"], f["families/four-bar/params"][()])
        np.testing.assert_array_equal(read["index"], f["families/four-bar/index"][()])
        np.testing.assert_array_equal(read["min_ds"], f["families/four-bar/min_ds"][()].astype(np.float32))
    assert sorted(p.name for p in (tmp_path / "dask").rglob(".*")) == []  # no .part file left


def test_a_killed_build_resumes_to_the_same_atlas(run_cli, tmp_path, small_chunks, monkeypatch):
    """SIGINT while chunk 3 is built: exit 130, the shards written so far whole and listed (none
    half-written), the build recorded as pending; another build is refused, `--resume` finishes it, and
    the folder then equals an uninterrupted build's."""
    count = 6 * SMALL + 200
    whole = _build(run_cli, tmp_path / "whole", count)
    build_chunk = _interrupt_at(monkeypatch, 3)
    out = tmp_path / "cut"
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", str(count), "-o", out, "--seed", "8")
    assert result.exit_code == 130 and result.output.strip().splitlines()[-1] == "linkedit: error: interrupted"
    cut = json.loads((out / shards.MANIFEST).read_text())
    listed = [e["chunk"] for e in cut["families"]["four-bar"]["shards"]]
    assert listed == [0, 1, 2] and cut["build"] == {"count": count, "families": ["four-bar"]}
    assert sorted(p.name for p in (out / "four-bar").iterdir()) == [f"{k:08d}.h5" for k in listed] + ["quantizer.h5"]
    assert cut["families"]["four-bar"]["pending"] == [[3, SMALL], [4, SMALL], [5, SMALL], [6, 200]]
    monkeypatch.setattr(shards, "build_chunk", build_chunk)
    again = run_cli("atlas", "build", "--family", "four-bar", "-n", "10", "-o", out, "--seed", "8")
    assert again.exit_code == 2 and "finish it with --resume" in again.output
    found = run_cli("synthesize", _target(tmp_path), "--atlas", out, "-o", tmp_path / "syn")
    assert found.exit_code == 2 and "--resume" in found.output
    resumed = _build(run_cli, out, count, "--resume")
    assert resumed == whole
    for entry in whole["families"]["four-bar"]["shards"]:
        a, b = _shard_arrays(tmp_path / "whole", entry), _shard_arrays(out, entry)
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    nothing = run_cli("atlas", "build", "--family", "four-bar", "-o", out, "--seed", "8", "--resume")
    assert nothing.exit_code == 2 and "nothing to resume" in nothing.output


def test_a_query_over_shards_equals_the_exact_scan(run_cli, tmp_path, small_chunks):
    """The family's one quantizer (C = side² cells for its first build; an append keeps it), each shard's rows
    in its cells: every cell scanned gives the exact scan's rows and distances; the default probe finds the exact
    top 10 of held-out targets; `synthesize --atlas FOLDER` recovers a held-out four-bar."""
    first = _build(run_cli, tmp_path / "folder", 5 * SMALL)["families"]["four-bar"]["quantizer"]
    side = round(np.sqrt(2 * np.sqrt(5 * SMALL)))
    assert first["cells"] == side**2 == 144
    assert _build(run_cli, tmp_path / "folder", 3 * SMALL)["families"]["four-bar"]["quantizer"] == first
    book = shards.load(tmp_path / "folder", threads=2)
    arrays = book.families["four-bar"]
    assert arrays["centroids"].shape == (144, shards.WIDTH) and arrays["cell"].shape == (8 * SMALL,)
    index = Index(book, scan_limit=0)
    lists = index.lists[0]
    assert lists is not None
    np.testing.assert_array_equal(np.diff(lists.offsets), np.bincount(arrays["cell"], minlength=144))
    vectors = arrays["index"]
    columns, norms = np.ascontiguousarray(vectors.T), np.einsum("kd,kd->k", vectors, vectors)
    held = atlas.build_chunk("four-bar", 990, 0, 20).params
    recall = []
    for k, row in enumerate(held):
        v = target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0])
        truth, d2 = nearest_rows(v, columns, norms, 10)
        rows, dist = lists.query(v, 10, probe=10**6)
        np.testing.assert_allclose(dist, d2, atol=1e-5)  # float32 near-ties may swap rows
        assert set(rows[dist < d2[-1] - 1e-5]) <= set(truth)
        recall.append(len({h.row for h in index.query(v, 10)} & set(truth.tolist())) / 10)
    assert np.mean(recall) >= 0.95, recall
    result = run_cli("synthesize", _target(tmp_path), "--atlas", tmp_path / "folder", "-o", tmp_path / "out", "--top", "1")
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["options"]["atlas_size"] == 8 * SMALL and report["error"]["after"]["rms"] < 0.01


def _target(tmp_path):
    """A held-out four-bar's curve, moved and scaled, as a CSV file."""
    z = 3 - 2j + 25 * np.exp(0.7j) * fourbar.curves(atlas.build_chunk("four-bar", 991, 0, 1).params, 150, 0.2)[0]
    path = tmp_path / "target.csv"
    path.write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")
    return path


def test_the_manifest_bookkeeping_is_linear_in_the_shards(tmp_path, monkeypatch):
    """20,000 shards coming back (a runner that stores nothing), the manifest saved as often as its share of the
    time allows: under 2 s (each shard filtered the pending list, and the indenting JSON encoder took 1.7 s a save:
    23 s at 20,000); interrupted after 12,345 shards, the manifest lists exactly those, in order, and the rest as
    pending; whole, every shard and nothing pending."""
    import contextlib
    import time

    n, cut = 20_000, 12_345
    monkeypatch.setattr(shards, "SAVE_EVERY", 0.0)

    def runner(stop):
        def run(name, seed, jobs, task=None):
            for index, size in jobs:
                if index == stop:
                    raise KeyboardInterrupt
                yield index, {"chunk": index, "rows": size, "file": f"four-bar/{index:08d}.h5", "sha256": "0" * 64}
        return run

    for folder, stop in ((tmp_path / "whole", None), (tmp_path / "cut", cut)):
        folder.mkdir()
        manifest = atlas_manifest.new_manifest(8)
        jobs = manifest["families"]["four-bar"] = atlas_manifest.new_family("four-bar")
        jobs.update(chunks=n, pending=[[k, 10] for k in range(n)],
                    quantizer={"file": "four-bar/quantizer.h5", "cells": 16, "sha256": "0" * 64})
        manifest["build"] = {"count": 10 * n, "families": ["four-bar"]}
        start = time.perf_counter()
        with contextlib.suppress(KeyboardInterrupt):
            shards._run(folder, manifest, {"four-bar": [(k, 10) for k in range(n)]}, 8, None, runner(stop))
        assert time.perf_counter() - start < 2.0
        saved = shards.read_manifest(folder)["families"]["four-bar"]
        done = n if stop is None else cut
        assert [s["chunk"] for s in saved["shards"]] == list(range(done))
        assert saved["pending"] == [[k, 10] for k in range(done, n)]


def test_a_format_2_atlas_is_refused_with_a_rebuild_message(run_cli, tmp_path, small_chunks):
    """A sharded atlas of format 2 (a quantizer per shard, before the family's one quantizer): `synthesize`
    refuses it in one line telling the user to rebuild it (exit 2), and so does an append to it."""
    out = tmp_path / "old"
    manifest = _build(run_cli, out, SMALL)
    manifest["format_version"] = "2"
    (out / shards.MANIFEST).write_text(json.dumps(manifest))
    for result in (run_cli("synthesize", _target(tmp_path), "--atlas", out, "-o", tmp_path / "syn"),
                   run_cli("atlas", "build", "--family", "four-bar", "-n", "10", "-o", out, "--seed", "8")):
        assert result.exit_code == 2, result.output
        line = result.output.strip().splitlines()[-1]
        assert "format 2" in line and "rebuild it" in line and "Traceback" not in result.output


def _built_both_ways(run_cli, tmp_path, name, count):
    """The atlas file and folder of ``count`` linkages of family ``name`` (seed 3: the same linkages)."""
    paths = (tmp_path / "a.h5", tmp_path / "folder")
    for out in paths:
        built = run_cli("atlas", "build", "--family", name, "-n", str(count), "-o", out, "--seed", "3")
        assert built.exit_code == 0, built.output
    return paths


def test_a_folder_answers_a_planar_curve_as_the_file(run_cli, tmp_path):
    """An atlas built into a folder and into a file of the same linkages is scanned whole below SCAN_LIMIT
    either way: synthesize writes the same result.yaml with the same errors."""
    target, found = _target(tmp_path), []
    for out in _built_both_ways(run_cli, tmp_path, "four-bar", 3000):
        result = run_cli("synthesize", target, "--atlas", out, "-o", tmp_path / f"{out.stem}-out", "--top", "2")
        assert result.exit_code == 0, result.output
        report = json.loads((tmp_path / f"{out.stem}-out" / "report.json").read_text())
        found.append(((tmp_path / f"{out.stem}-out" / "result.yaml").read_text(), report["error"]))
    assert found[0] == found[1]


def test_a_folder_screens_an_open_3d_arc_as_the_file(run_cli, tmp_path):
    """An open 3D arc's candidates are screened by partial matching on the coarse curves a file stores and a
    folder makes from the params (as the build makes them: 64 samples, every second one): the same candidates
    in the same order either way (the folder's were made at refinement's 256 samples: another ranking, and a
    worse result: 0.161 % RMS against the file's 0.030 % on a 20,000-linkage atlas)."""
    points = np.loadtxt(_arc3d(tmp_path), delimiter=",", skiprows=1)
    unit = (points - 0.5 * (points.min(axis=0) + points.max(axis=0))) / np.ptp(points, axis=0).max()
    screened = []
    for out in _built_both_ways(run_cli, tmp_path, "spherical-four-bar", 3000):
        book = spatial.restrict(shards.open_atlas(out), 3)
        screened.append([(h.family, h.row) for h in spatial._screened(unit, book, Index(book), 20.0)])
    assert len(screened[0]) == spatial.OPEN_POOL and screened[0] == screened[1]


def _arc3d(tmp_path):
    """Half the cycle of a held-out spherical four-bar's curve (an open 3D arc), turned, scaled, moved, as CSV."""
    params = atlas.build_chunk("spherical-four-bar", 99, 0, 1).params
    turn = np.array([[0.0, -0.8, 0.6], [1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    points = np.array([40.0, -12.0, 7.0]) + 25.0 * spherical.curves(params, 480, 0.3)[0][:240] @ turn.T
    path = tmp_path / "arc.csv"
    np.savetxt(path, points, delimiter=",", header="x,y,z", comments="")
    return path


def test_a_resumed_build_reports_the_linkages_it_built(run_cli, tmp_path, small_chunks, monkeypatch):
    """After an interruption at chunk 2 of 4 (2 shards listed), `--resume` builds the other 2,000 linkages:
    its line and its JSON count those, with the build's -n and without, not the 4,000 of the whole build
    (the line said "4,000 linkages in", its rate twice too high)."""
    build_chunk = _interrupt_at(monkeypatch, 2)
    out = tmp_path / "cut"
    args = ("atlas", "build", "--family", "four-bar", "-o", out, "--seed", "8", "--resume")
    assert run_cli(*args[:-1], "-n", str(4 * SMALL)).exit_code == 130
    monkeypatch.setattr(shards, "build_chunk", build_chunk)
    cut = (out / shards.MANIFEST).read_text()
    resumed = run_cli(*args, "-n", str(4 * SMALL))
    assert resumed.exit_code == 0 and resumed.output.startswith("2,000 linkages in "), resumed.output
    (out / shards.MANIFEST).write_text(cut)  # interrupted again at the same place
    assert report_of(run_cli(*args, "--json"))["linkages"] == 2 * SMALL


def _files(folder) -> dict[str, int]:
    """Every file under ``folder`` (its path there → its size in bytes)."""
    return {str(p.relative_to(folder)): p.stat().st_size for p in sorted(folder.rglob("*")) if p.is_file()}


def _tasks_running(cluster) -> int:
    """Tasks the workers of ``cluster`` are running now, a cancelled one still running included."""
    from distributed import Client

    with Client(cluster) as client:
        return sum(client.run(lambda dask_worker: len(dask_worker.state.executing)).values())


def _cluster_build_interrupted(monkeypatch, tmp_path):
    """A build of 64 chunks of 5,000 four-bars into ``tmp_path / "cut"`` (~0.1 s a chunk: a Dask task of 4 still
    runs when the first shard appears), with a SIGINT to this process as its first shard appears; its count,
    folder and a deadline (2 minutes) for waiting on it."""
    size = 5 * SMALL
    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", size)
    out, deadline = tmp_path / "cut", time.monotonic() + 120
    first = out / "four-bar" / "00000000.h5"

    def interrupt() -> None:
        while not first.exists() and time.monotonic() < deadline:
            time.sleep(0.005)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt, daemon=True).start()
    return 64 * size, out, deadline


def test_an_interrupted_cluster_build_leaves_a_quiet_folder(run_cli, tmp_path, monkeypatch, cluster):
    """SIGINT as the first shard appears, while both workers are inside tasks of 4 chunks: when the command has
    returned (exit 130, its one line) nothing more is written into the folder, once every task the workers were
    running has ended (they went on writing shards for a second or so after the client had gone); the manifest
    lists only complete shards and `--resume` finishes the build."""
    count, out, deadline = _cluster_build_interrupted(monkeypatch, tmp_path)
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", str(count), "-o", out, "--seed", "8",
                     "--scheduler", cluster.scheduler_address)
    returned = _files(out)
    assert result.exit_code == 130 and result.output.strip().splitlines() == ["linkedit: error: interrupted"]
    while _tasks_running(cluster) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _files(out) == returned
    cut = json.loads((out / shards.MANIFEST).read_text())
    listed = {e["file"] for e in cut["families"]["four-bar"]["shards"]}
    assert listed <= set(returned) and len(cut["families"]["four-bar"]["pending"]) == 64 - len(listed)
    resumed = _build(run_cli, out, count, "--resume", "--scheduler", cluster.scheduler_address)
    assert [e["chunk"] for e in resumed["families"]["four-bar"]["shards"]] == list(range(64))


def test_an_interrupted_cluster_build_says_when_its_tasks_did_not_stop(run_cli, tmp_path, monkeypatch, cluster):
    """When the workers' running tasks have not stopped within the wait (none here: 0 s), the one line says so."""
    from linkedit.synthesis import cluster as runner

    monkeypatch.setattr(runner, "STOP_WAIT", 0.0)
    count, out, _ = _cluster_build_interrupted(monkeypatch, tmp_path)
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", str(count), "-o", out, "--seed", "8",
                     "--scheduler", cluster.scheduler_address)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 130 and len(lines) == 1, result.output
    assert re.fullmatch(r"linkedit: error: interrupted; [1-9]\d* Dask task\(s\) had not stopped 0 s later and may still "
                        r"write their shards", lines[0]), lines[0]


def test_a_new_folder_whose_build_stops_before_its_manifest_is_not_left(run_cli, tmp_path, small_chunks, monkeypatch):
    """Ctrl-C while the second family's quantizer is trained (before the manifest is first saved): the new
    folder is not left behind (it held the first family's quantizer and no manifest, and every later build
    into it was refused as "not a sharded atlas"); the same command then builds it."""
    write_quantizer = shards.write_quantizer

    def interrupted(folder, name, seed, count):
        if name == "slider-crank":
            raise KeyboardInterrupt
        return write_quantizer(folder, name, seed, count)

    monkeypatch.setattr(shards, "write_quantizer", interrupted)
    out = tmp_path / "new"
    args = ("atlas", "build", "--family", "four-bar,slider-crank", "-n", "300", "-o", out, "--seed", "8")
    assert run_cli(*args).exit_code == 130
    assert not out.exists()
    monkeypatch.setattr(shards, "write_quantizer", write_quantizer)
    again = run_cli(*args)
    assert again.exit_code == 0, again.output
    assert shards.counts(json.loads((out / shards.MANIFEST).read_text())) == {"four-bar": 300, "slider-crank": 300}


def test_a_folder_of_atlas_files_holding_a_sharded_atlas_is_refused(run_cli, tmp_path):
    """`--atlas atlas/` reads every *.h5 atlas in the folder; a sharded atlas built beside them (`-o atlas/legs`)
    was silently left out of the search (exit 0, the report's atlas_size without its linkages). One line naming
    it, exit 2."""
    folder = tmp_path / "atlas"
    for family, out in (("four-bar", folder / "four-bar.h5"), ("slider-crank", folder / "sliders")):
        built = run_cli("atlas", "build", "--family", family, "-n", "200", "-o", out, "--seed", "3", "-q")
        assert built.exit_code == 0, built.output
    result = run_cli("synthesize", _target(tmp_path), "--atlas", folder, "-o", tmp_path / "out")
    assert result.exit_code == 2, result.output
    line = result.output.strip().splitlines()[-1]
    assert "sliders" in line and "sharded atlas" in line and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_a_new_folder_being_built_is_named_busy_and_a_killed_first_build_is_built_again(run_cli, tmp_path,
                                                                                          monkeypatch):
    """A second build into a new folder while the first trains its quantizers (the folder holds the manifest's
    lock and no manifest yet): one line naming the other process (was: "exists and is not a sharded atlas").
    A first build killed there (SIGKILL: its lock file and a quantizer left, no manifest): the same command
    builds the atlas (was refused the same way, for good)."""
    from linkedit.io import atomic

    monkeypatch.setattr(atomic, "LOCK_WAIT", 0.1)
    out = tmp_path / "new"
    args = ("atlas", "build", "--family", "four-bar", "-n", "200", "-o", out, "--seed", "8")
    with atomic.locked(out / shards.MANIFEST):
        busy = run_cli(*args)
        (out / "four-bar").mkdir()
        (out / "four-bar" / "quantizer.h5").write_bytes(b"cut short")
    assert busy.exit_code == 2 and f"pid {os.getpid()}" in busy.output, busy.output
    (out / f".{shards.MANIFEST}.lock").write_text("12345\n")  # what a killed build leaves
    again = run_cli(*args)
    assert again.exit_code == 0, again.output
    assert shards.counts(shards.read_manifest(out)) == {"four-bar": 200}


def test_a_sharded_atlas_too_large_for_memory_is_refused_before_it_is_read(run_cli, tmp_path, small_chunks, monkeypatch):
    """`synthesize --atlas FOLDER` whose linkages (shard bytes + a query's 20 per linkage) exceed the memory
    available: exit 2 naming the bytes, before any shard is read (was a MemoryError, or the kernel's OOM kill, while
    the shards were concatenated); with the memory there, the same command finds its linkage."""
    from linkedit import resources

    _build(run_cli, tmp_path / "folder", 2 * SMALL)
    need = 2 * SMALL * (shards.shard_bytes("four-bar") + shards.QUERY_BYTES)
    memory, read_shard = resources.available_memory, shards.read_shard
    monkeypatch.setattr(resources, "available_memory", lambda: need - 1)
    read = []
    monkeypatch.setattr(shards, "read_shard", lambda *a: read.append(a))
    refused = run_cli("synthesize", _target(tmp_path), "--atlas", tmp_path / "folder", "-o", tmp_path / "out")
    assert refused.exit_code == 2 and read == [] and not (tmp_path / "out").exists()
    assert refused.output.strip() == (f"linkedit: error: {tmp_path / 'folder'}: a query over its 2,000 linkages would "
                                      f"need about {resources.size_text(need)} of memory; "
                                      f"{resources.size_text(need - 1)} are available")
    monkeypatch.setattr(resources, "available_memory", memory)
    monkeypatch.setattr(shards, "read_shard", read_shard)
    assert run_cli("synthesize", _target(tmp_path), "--atlas", tmp_path / "folder", "-o", tmp_path / "out",
                   "--top", "1").exit_code == 0


def test_a_query_through_the_cell_ordered_copy_equals_the_one_in_atlas_order(monkeypatch):
    """A family's lists keep a copy of its descriptors in cell order when it fits (a query's cells are then
    contiguous runs: ~4x faster than gathering rows at 2,000,000 four-bars) and gather from the atlas-order
    descriptors otherwise (100,000,000 four-bars): the same rows and distances either way, for any probe, and
    every cell probed is the exact scan."""
    vectors = atlas.build_chunk("four-bar", 3, 0, 6000).index
    centroids, rows, offsets = atlas_index.cells_of(vectors, 40)
    monkeypatch.setattr(atlas_index, "available_memory", lambda: 10**12)
    fits = atlas_index.Lists(vectors, centroids, rows, offsets)
    monkeypatch.setattr(atlas_index, "available_memory", lambda: 3 * vectors.nbytes)  # the copy beyond a quarter of it
    lean = atlas_index.Lists(vectors, centroids, rows, offsets)
    assert fits.cell_vectors is not None and lean.cell_vectors is None
    columns, norms = np.ascontiguousarray(vectors.T), np.einsum("kd,kd->k", vectors, vectors)
    for k, row in enumerate(atlas.build_chunk("four-bar", 992, 0, 12).params):
        v = target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0])
        for probe in (None, 3, 40):
            (a, da), (b, db) = fits.query(v, 10, probe=probe), lean.query(v, 10, probe=probe)
            np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(da, db)
        truth, d2 = nearest_rows(v, columns, norms, 10)
        np.testing.assert_allclose(da, d2, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(b, truth)
