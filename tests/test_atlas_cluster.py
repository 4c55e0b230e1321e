"""An atlas on a Dask cluster: a build streams (a few tasks ahead of the client, never all of them), and
`synthesize --atlas FOLDER --scheduler ADDRESS` searches the shards on the workers and finds what the
in-process search finds."""

from __future__ import annotations

import json
import os
import re
import time

import numpy as np
import pytest
import yaml

from linkedit.synthesis import atlas, chunks, fourbar, shards
from linkedit.synthesis import cluster as runner
from linkedit.synthesis import manifest as atlas_manifest
from linkedit.synthesis.index import Index, target_variants
from linkedit.synthesis.shard_search import remote_atlas
from tests.conftest import EXAMPLES

SMALL = 1000  # linkages per chunk here (a chunk is a pure function of its index and size)


@pytest.fixture
def folder(run_cli, tmp_path, monkeypatch):
    """A sharded atlas of 7,500 four-bars in 8 shards (the last partial), built in-process."""
    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", SMALL)
    out = tmp_path / "atlas"
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", "7500", "-o", out, "--seed", "8")
    assert result.exit_code == 0, result.output
    return out


def test_a_dask_build_streams(cluster):
    """When the first chunk comes back, the scheduler knows only the tasks submitted ahead (IN_FLIGHT per
    worker thread), not all 20 of the build (the old runner submitted every task at once: a 100-million
    build's chunks piled up on the workers); the chunks are the in-process ones, in order."""
    jobs = [(k, 10) for k in range(40)]
    with runner.chunk_runner(cluster.scheduler_address) as run:
        built = run("four-bar", 3, jobs)
        first = next(built)
        time.sleep(0.5)  # whatever the client submitted has reached the scheduler
        known = len(cluster.scheduler.tasks)
        rest = list(built)
    assert len(runner.dask_tasks(jobs, 2)) == 20 and known <= 6 == runner.IN_FLIGHT * 2
    assert [index for index, _ in [first, *rest]] == list(range(40))
    for index, chunk in [first, *rest][::13]:
        np.testing.assert_array_equal(chunk.index, chunks.build_chunk("four-bar", 3, index, 10).index)


def _variants(count: int) -> list[np.ndarray]:
    held = atlas.build_chunk("four-bar", 990, 0, count).params
    return [target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0]) for k, row in enumerate(held)]


@pytest.mark.parametrize("scan_limit", [10**6, 0], ids=["scanned whole", "family quantizer"])
def test_the_cluster_search_equals_the_in_process_one(folder, cluster, scan_limit):
    """The shards searched on 2 workers, the union ranked on the client: the in-process search's hits (rows, and
    squared distances to the in-process float32 rounding), whether the family is scanned whole or through its
    quantizer (each run of shards scans the rows of the cells the in-process query probes); the hits' params are the
    atlas's."""
    book = shards.load(folder)
    local = Index(book, scan_limit=scan_limit)
    with remote_atlas(folder, cluster.scheduler_address, scan_limit=scan_limit) as (remote, index):
        assert remote.size == book.size == 7500
        for v in _variants(6):
            near, far = local.query(v, 40), index.query(v, 40)
            d_near, d_far = (np.array([h.distance for h in hits]) ** 2 for hits in (near, far))
            np.testing.assert_allclose(d_far, d_near, rtol=0, atol=1e-6)  # in-process: float32 |x|² − 2 v·x
            for inner, outer, d in ((far, near, d_far), (near, far, d_near)):  # float32 near-ties may swap rows
                sure = {h.row for h, dh in zip(inner, d) if dh < d[-1] - 1e-6}
                assert len(sure) >= 20 and sure <= {h.row for h in outer}
            rows = [h.row for h in far]
            np.testing.assert_array_equal(remote.families["four-bar"]["params"][rows],
                                          book.families["four-bar"]["params"][rows])


def test_synthesize_with_a_scheduler_writes_the_in_process_result(run_cli, folder, cluster, tmp_path):
    """`synthesize --atlas FOLDER --scheduler ADDRESS`: the same linkage (result.yaml) and errors as without
    --scheduler, the scheduler recorded; an atlas file and a 3D target on a planar-only atlas are refused (exit 2)."""
    z = 3 - 2j + 25 * np.exp(0.7j) * fourbar.curves(atlas.build_chunk("four-bar", 991, 0, 1).params, 150, 0.2)[0]
    target = tmp_path / "target.csv"
    target.write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")
    here = run_cli("synthesize", target, "--atlas", folder, "-o", tmp_path / "here", "--top", "1")
    there = run_cli("synthesize", target, "--atlas", folder, "-o", tmp_path / "there", "--top", "1",
                    "--scheduler", cluster.scheduler_address)
    assert here.exit_code == 0 and there.exit_code == 0, there.output
    assert yaml.safe_load((tmp_path / "there" / "result.yaml").read_text()) == \
        yaml.safe_load((tmp_path / "here" / "result.yaml").read_text())
    a, b = (json.loads((tmp_path / out / "report.json").read_text()) for out in ("here", "there"))
    assert b["error"] == a["error"] and b["options"]["scheduler"] == cluster.scheduler_address
    assert [c["atlas_row"] for c in b["candidates"]] == [c["atlas_row"] for c in a["candidates"]]
    file = tmp_path / "file.h5"
    assert run_cli("atlas", "build", "--family", "four-bar", "-n", "10", "-o", file).exit_code == 0
    refused = run_cli("synthesize", target, "--atlas", file, "-o", tmp_path / "no", "--scheduler",
                      cluster.scheduler_address)
    assert refused.exit_code == 2 and "sharded atlas" in refused.output
    spatial = tmp_path / "t3.csv"
    spatial.write_text("x,y,z\n" + "\n".join(f"{np.cos(t)},{np.sin(t)},{0.1 * np.sin(2 * t)}"
                                             for t in np.linspace(0, 2 * np.pi, 60, endpoint=False)) + "\n")
    refused = run_cli("synthesize", spatial, "--atlas", folder, "-o", tmp_path / "no", "--scheduler",
                      cluster.scheduler_address)
    assert refused.exit_code == 2 and "holds no spatial linkages" in refused.output


@pytest.mark.parametrize("out", ["atlas", "atlas.h5"])
def test_a_100_million_build_that_does_not_fit_is_refused_up_front(run_cli, tmp_path, monkeypatch, out):
    """`atlas build -n 100000000` on a disk of 10 GiB free (shards: 172 B, a file: 428 B per four-bar) or in
    64 MiB of memory (a build holds one chunk's working arrays, 256 MiB allowed, and 1 KiB per chunk): exit 2
    naming the bytes, nothing written; -n 10**12 into a folder was a MemoryError traceback (its 10⁸ chunks were
    planned before the disk was checked)."""
    from linkedit import resources

    target = tmp_path / out
    per = shards.shard_bytes("four-bar") if out == "atlas" else atlas.stored_bytes("four-bar")
    monkeypatch.setattr(resources, "available_disk", lambda path: 10 * 2**30)
    line = run_cli("atlas", "build", "--family", "four-bar", "-n", 10**8, "-o", target).output.strip()
    assert line == (f"linkedit: error: --count: 100,000,000 linkages would need about {10**8 * per / 2**30:,.1f} GiB of "
                    f"disk at {target / shards.MANIFEST if out == 'atlas' else target}; 10.0 GiB are free")
    monkeypatch.setattr(resources, "available_disk", lambda path: 2**50)
    monkeypatch.setattr(resources, "available_memory", lambda: 64 * 2**20)
    result = run_cli("atlas", "build", "--family", "four-bar", "-n", 10**8, "-o", target)
    need = (chunks.CHUNK_MEMORY + 10**4 * chunks.PLAN_MEMORY) / 2**20
    assert result.exit_code == 2 and result.output.strip() == (
        f"linkedit: error: --count: 100,000,000 linkages would need about {need:,.0f} MiB of memory; 64 MiB are "
        "available")
    monkeypatch.undo()
    huge = run_cli("atlas", "build", "--family", "four-bar", "-n", 10**12, "-o", target)
    assert huge.exit_code == 2 and "GiB of disk" in huge.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow  # a minute on 2 loaded cores (a build and 3 × 50 queries)
def test_the_bench_times_a_query_over_a_large_sharded_atlas(cluster, monkeypatch):
    """`bench -s synthesis --large N` (here its section on 20 shards of 1,000, on the 2-worker cluster): bytes per
    linkage on disk, the query at the first 5 shards and at N, in threads and on the cluster, the recall of the
    exact top 10, the extrapolation to 100M through both figures."""
    from linkedit.synthesis import bench_scale

    for module in (atlas, chunks, shards, bench_scale):
        monkeypatch.setattr(module, "CHUNK", SMALL)
    monkeypatch.setattr(bench_scale, "SMALL", 5 * SMALL)
    lines: list[str] = []
    bench_scale.run(lines.append, 20 * SMALL, 2, scheduler=cluster.scheduler_address)
    text = "\n".join(lines)
    assert re.search(r"sharded atlas of 20,000 four-bars .* 1\d\d bytes per linkage on disk \(1\d\d stored", text), text
    assert re.search(r"\(\d+ cores usable of the machine's \d+, load average", text), text
    recall = float(re.search(r"recall of the exact top 10 (\d\.\d+)", text).group(1))
    assert recall >= 0.9 and re.search(r"\d+ ms at 5,000, \d+ ms at 20,000", text), text
    assert re.search(r"on the cluster at 20,000: \d+ ms median \(2 workers", text), text
    assert "extrapolated to 100,000,000: " in text and "the line through the 5,000 and 20,000 figures" in text


def test_the_bench_times_the_query_over_an_atlas_built_before(folder, cluster, monkeypatch, run_cli):
    """`bench -s synthesis --large-atlas FOLDER`'s section on a folder built before (7,500 four-bars): no build, the
    same figures (its peak memory per linkage among them); its exact top 10, found block by block over the family
    (a 100,000,000 one has no room for a second copy), is the whole scan's; --large and --large-atlas together, or a
    folder without four-bars, are refused."""
    from linkedit.synthesis import bench_scale
    from linkedit.synthesis.index import Lists, nearest_rows

    for module in (atlas, chunks, shards, bench_scale):
        monkeypatch.setattr(module, "CHUNK", SMALL)
    monkeypatch.setattr(bench_scale, "SMALL", 5 * SMALL)
    monkeypatch.setattr(bench_scale, "TARGETS", 5)
    lines: list[str] = []
    bench_scale.run(lines.append, None, 2, scheduler=cluster.scheduler_address, folder=folder)
    text = "\n".join(lines)
    assert re.search(rf"sharded atlas of 7,500 four-bars .*: built before in {re.escape(str(folder))}, 1\d\d bytes per "
                     r"linkage on disk .* peak memory then [\d.,]+ [MG]iB \(\d+ bytes per linkage\)", text), text
    assert float(re.search(r"recall of the exact top 10 (\d\.\d+)", text).group(1)) >= 0.8, text
    assert re.search(r"on the cluster at 7,500: \d+ ms median \(2 workers", text), text
    # a small family's lists keep the cell-ordered copy: the extrapolation is timed without it, as 100,000,000's
    assert re.search(r"; \d+ and \d+ ms with the rows gathered from the atlas order", text), text
    lists = Index(shards.load(folder), scan_limit=0).lists[0]
    assert isinstance(lists, Lists)
    for v in _variants(3):
        whole = nearest_rows(v, np.ascontiguousarray(lists.vectors.T), lists.norms, 10)[0]
        np.testing.assert_array_equal(bench_scale._exact_top(lists, v, 10, block=1234), whole)
    both = run_cli("bench", "-s", "synthesis", "--large", "5", "--large-atlas", folder)
    assert both.exit_code == 2 and both.output.strip() == (
        "linkedit: error: --large-atlas: give --large N (build one) or --large-atlas FOLDER (one built before), not both")
    assert run_cli("atlas", "build", "--family", "slider-crank", "-n", "100", "-o", folder.parent / "sc").exit_code == 0
    with pytest.raises(shards.InputError, match="holds no four-bars"):
        bench_scale.run(lines.append, None, 2, scheduler=cluster.scheduler_address, folder=folder.parent / "sc")


@pytest.mark.parametrize("option", ["--large", "--large-atlas", "--workers"])
def test_bench_large_and_workers_apply_to_the_synthesis_section(run_cli, option):
    refused = run_cli("bench", "-s", "planar", option, "5")
    assert refused.exit_code == 2
    assert refused.output.strip() == f"linkedit: error: {option}: applies to the synthesis section (-s synthesis)"


def test_bench_workers_counts_from_one(run_cli):
    refused = run_cli("bench", "-s", "synthesis", "--workers", "0")
    assert refused.exit_code == 2
    assert refused.output.strip() == "linkedit: error: --workers: must be ≥ 1"


def test_bench_workers_is_refused_where_quick_starts_no_cluster(run_cli):
    """--quick times no Dask build (only --large's query at scale starts a cluster): --workers there would
    change nothing, so it is refused, not ignored (it ran the whole quick section and exit 0)."""
    refused = run_cli("bench", "-s", "synthesis", "--quick", "--workers", "3")
    assert refused.exit_code == 2
    assert refused.output.strip() == ("linkedit: error: --workers: --quick starts no local cluster (with --large N "
                                      "it sizes the query at scale's)")


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this system")
def test_the_bench_workers_default_to_the_cores_this_process_may_use():
    """Restricted to one core (as ``taskset -c 0`` or a container's CPU set would), the process may use one,
    whatever the machine has; the bench's default worker count is that."""
    allowed = os.sched_getaffinity(0)
    try:
        os.sched_setaffinity(0, {min(allowed)})
        assert runner.usable_cores() == 1
    finally:
        os.sched_setaffinity(0, allowed)
    assert runner.usable_cores() == len(allowed)


@pytest.mark.slow  # 15 s on 2 loaded cores (the float64 brute force)
def test_the_exact_ranking_is_exact_for_near_neighbours():
    """Held-out targets lie ~1e-7 (squared) from their nearest of 100,000 four-bars, float32's rounding of
    |x|² − 2 v·x: nearest_rows ranked in float32 swapped the exact top 10's rows out (its float32 ranks reached 73); its top 10
    is the float64 brute force's |x − v|²."""
    from linkedit.synthesis.index import nearest_rows

    vectors = np.concatenate([chunks.build_chunk("four-bar", 1, i).index for i in range(10)])
    columns, norms = np.ascontiguousarray(vectors.T), np.einsum("kd,kd->k", vectors, vectors)
    wide = vectors.astype(np.float64)
    for k, row in enumerate(chunks.build_chunk("four-bar", 988, 0, 30).params):
        v = target_variants(fourbar.curves(row[None], 300, 0.1 * k)[0])
        exact = ((wide[:, None, :] - v.astype(np.float64)[None]) ** 2).sum(axis=2).min(axis=1)
        rows, _ = nearest_rows(v, columns, norms, 10)
        assert sorted(rows.tolist()) == sorted(np.argsort(exact)[:10].tolist()), k


def test_an_in_process_build_has_the_workers_malloc_thresholds():
    """The in-process runner sets WORKER_MALLOC's fixed glibc thresholds (as the Dask workers have them), so
    its chunks' temporaries stay in the heap rather than being mmapped and page-faulted afresh, whatever the
    process allocated before: a 256 MiB array then comes from the heap (glibc's adaptive mmap threshold
    stops at 32 MiB: the old runner mmapped it). In a fresh process: the setting is process-wide."""
    import ctypes
    import subprocess
    import sys

    if not sys.platform.startswith("linux") or not hasattr(ctypes.CDLL(None), "mallinfo2"):
        pytest.skip("glibc ≥ 2.33 on Linux only")
    probe = """
import ctypes, numpy as np
from linkedit.synthesis.cluster import chunk_runner

class Info(ctypes.Structure):
    _fields_ = [(k, ctypes.c_size_t) for k in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

mallinfo2 = ctypes.CDLL(None).mallinfo2
mallinfo2.restype = Info
with chunk_runner() as run:
    list(run("four-bar", 1, [(0, 10)]))
big = np.empty(256 << 20, dtype=np.uint8)
print(mallinfo2().hblkhd)
"""
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert int(out.stdout) < 256 << 20, "the 256 MiB array was mmapped: no fixed mmap threshold in-process"


def _kept_runs(cluster, folder) -> int:
    """Runs of shards of ``folder`` the cluster's workers hold read (each read once per worker)."""
    from dask.distributed import Client

    from linkedit.synthesis import shard_search

    with Client(cluster.scheduler_address) as client:
        held = client.run(lambda: [key[0] for key in shard_search._kept])
    return sum(place == str(folder.absolute()) for places in held.values() for place in places)


def test_a_query_goes_to_the_worker_holding_its_shards(folder, cluster):
    """Two queries from two clients (two `synthesize` runs) on 2 workers, one of them busy for a second when the
    second query comes: each run of shards is read once, by the worker its tasks are pinned to, which the second
    query waits for (the scheduler sent both tasks to the free worker, which read the other's shards again);
    both equal the in-process search's rows."""
    from dask.distributed import Client

    v = _variants(1)[0]
    local = [h.row for h in Index(shards.load(folder)).query(v, 10)]
    with remote_atlas(folder, cluster.scheduler_address) as (_, index):
        assert [h.row for h in index.query(v, 10)] == local
    with Client(cluster.scheduler_address) as client:
        busy = client.submit(time.sleep, 1.5, workers=sorted(client.nthreads())[:1], pure=False)
        while busy.status == "pending" and not any(client.processing().values()):
            time.sleep(0.01)
        with remote_atlas(folder, cluster.scheduler_address) as (_, index):
            assert [h.row for h in index.query(v, 10)] == local
        busy.result()
    assert _kept_runs(cluster, folder) == 2


def test_a_query_pinned_to_a_worker_that_left_runs_elsewhere(folder, cluster, monkeypatch):
    """A run of the shards pinned to a worker no longer in the cluster (it left after the client counted the
    workers): its task is submitted again to any worker within a REPIN_CHECK, and the hits are the in-process ones."""
    from linkedit.synthesis import shard_search

    monkeypatch.setattr(shard_search, "REPIN_CHECK", 0.2)
    v = _variants(1)[0]
    local = [h.row for h in Index(shards.load(folder)).query(v, 10)]
    with remote_atlas(folder, cluster.scheduler_address) as (book, index):
        gone = shard_search.ClusterIndex(index.client, {"tcp://127.0.0.1:9": 1} | index.client.nthreads(), folder,
                                         shards.read_manifest(folder), book, index.direct)
        assert "tcp://127.0.0.1:9" in gone.slots and len(gone.runs["four-bar"]) == 3
        assert [h.row for h in gone.query(v, 10)] == local


@pytest.mark.parametrize("closed", [pytest.param(True, id="closed", marks=pytest.mark.slow),  # ≈ 9 s; the open arc runs
                                    pytest.param(False, id="open-arc")])
def test_synthesize_a_3d_target_with_a_scheduler_writes_the_in_process_result(run_cli, tmp_path, cluster, monkeypatch,
                                                                              closed):
    """A 3D target (a closed curve, or an open arc: its hits screened on their stored coarse curves, fetched from
    the workers) against a sharded atlas of 1,500 spherical four-bars (3 shards) with --scheduler: its spatial
    shards searched on the workers (the command refused 3D targets with --scheduler), the same result.yaml,
    errors and candidates as in-process, the scheduler recorded; result.yaml draws the target (solve3d)."""
    from scipy.spatial.transform import Rotation

    from linkedit.io.gcs_hdf5 import read_result
    from linkedit.synthesis import spherical
    from linkedit.synthesis.spatial import curve_error

    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", 500)
    folder = tmp_path / "spatial"
    assert run_cli("atlas", "build", "--family", "spherical-four-bar", "-n", "1500", "-o", folder).exit_code == 0
    row = shards.load(folder).families["spherical-four-bar"]["params"][7].copy()
    row[:4] *= np.array([1.02, 0.98, 1.01, 0.985])  # not in the atlas
    points = np.array([3.0, 1.0, -2.0]) + 0.4 * spherical.curves(row[None], 200, 0.1)[0] @ \
        Rotation.random(random_state=5).as_matrix().T
    points = points if closed else points[:110]
    target = tmp_path / "t.csv"
    np.savetxt(target, points, delimiter=",", header="x,y,z", comments="")
    here = run_cli("synthesize", target, "--atlas", folder, "-o", tmp_path / "here", "--top", "1")
    there = run_cli("synthesize", target, "--atlas", folder, "-o", tmp_path / "there", "--top", "1",
                    "--scheduler", cluster.scheduler_address)
    assert here.exit_code == 0 and there.exit_code == 0, there.output
    assert (tmp_path / "there" / "result.yaml").read_text() == (tmp_path / "here" / "result.yaml").read_text()
    a, b = (json.loads((tmp_path / out / "report.json").read_text()) for out in ("here", "there"))
    assert b["error"] == a["error"] and b["options"] == a["options"] | {"scheduler": cluster.scheduler_address}
    assert b["candidates"] == a["candidates"] and b["error"]["after"]["rms"] < 0.01
    assert run_cli("solve3d", tmp_path / "there" / "result.yaml", "-o", tmp_path / "s.h5").exit_code == 0
    track = read_result(tmp_path / "s.h5").tracks["target"].position[:-1]
    assert b["target"]["closed"] is closed
    assert curve_error(points, closed, track, b["target"]["size"])[0] == pytest.approx(b["error"]["after"]["rms"],
                                                                                        rel=1e-6)


def test_a_cluster_searches_atlases_of_two_linkages_of_one_name(run_cli, tmp_path, cluster, monkeypatch):
    """Two atlases of spec families called 'arm' (two users' linkages), each built and searched by its own
    `linkedit` run: the same long-lived workers search both (they kept the first one's 'arm' and refused the
    second's, exit 2 "--family: two different linkages are called 'arm'" though the input was right)."""
    from linkedit.synthesis import families

    text = (EXAMPLES / "crank-rocker.yaml").read_text().replace("name: crank-rocker", "name: arm")
    z = 25 * fourbar.curves(atlas.build_chunk("four-bar", 991, 0, 1).params, 150, 0.2)[0]
    target = tmp_path / "target.csv"
    target.write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")
    for k, spec in enumerate((text, text + "# the other user's arm\n")):
        monkeypatch.setattr(families, "SPECS", {})  # a new `linkedit` process
        monkeypatch.setattr(families, "SPEC_TEXTS", {})
        for module in (atlas, shards, atlas_manifest, runner):
            monkeypatch.setattr(module, "SPEC_TEXTS", families.SPEC_TEXTS)
        (tmp_path / f"arm{k}.yaml").write_text(spec)
        built = run_cli("atlas", "build", "--family", tmp_path / f"arm{k}.yaml", "-n", "100", "-o", tmp_path / f"a{k}",
                        "--seed", "3", "-q")
        assert built.exit_code == 0, built.output
        found = run_cli("synthesize", target, "--atlas", tmp_path / f"a{k}", "-o", tmp_path / f"out{k}", "--top", "1",
                        "--scheduler", cluster.scheduler_address)
        assert found.exit_code == 0, found.output


def test_a_threaded_worker_builds_two_linkages_of_one_name_at_once(monkeypatch):
    """One worker of 4 threads builds chunks of two atlases' spec families both called 'arm' at the same time (two
    `linkedit` runs sharing a cluster): each chunk is its own linkage's (the worker kept one family per name: a task
    adopting its 'arm' threw out the other's under a running task, which then failed, 'two different linkages are
    called arm', or raised KeyError)."""
    distributed = pytest.importorskip("dask.distributed")
    from linkedit.synthesis import families

    text = (EXAMPLES / "crank-rocker.yaml").read_text().replace("name: crank-rocker", "name: arm")
    specs = [text, text + "# the other user's arm\n"]
    jobs = [(spec, k) for k in range(12) for spec in specs]
    expected = {}
    for spec in specs:  # each as its own `linkedit` process builds it
        monkeypatch.setattr(families, "SPECS", {})
        monkeypatch.setattr(families, "SPEC_TEXTS", {})
        for k in range(12):
            expected[spec, k] = chunks.build_chunk("arm", 3, k, 4, spec).params
    monkeypatch.setattr(families, "SPECS", {})
    monkeypatch.setattr(families, "SPEC_TEXTS", {})

    class Slow(runner._Published):  # a task starts slowly (a busy worker): the others run meanwhile
        def __init__(self, *args):
            time.sleep(0.02)
            super().__init__(*args)

    monkeypatch.setattr(runner, "_Published", Slow)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=4, processes=False, dashboard_address=":0") as c, \
            distributed.Client(c) as client:
        for _ in range(3):
            futures = [client.submit(runner._timed, chunks.build_chunks, "b", "arm", 3, [(k, 4)], spec, 60.0,
                                     pure=False) for spec, k in jobs]
            for (spec, k), (built, _) in zip(jobs, client.gather(futures)):
                np.testing.assert_array_equal(built[0].params, expected[spec, k])


def test_a_threaded_worker_searches_two_linkages_of_one_name_at_once(run_cli, tmp_path, monkeypatch):
    """Two sharded atlases of different linkages both called 'arm' (a four-bar and a six-bar: 8 and 12 columns),
    searched at once on one worker of 4 threads: every shard is read with its own linkage's columns
    (the worker looked the family up by name in a registry the other atlas's tasks were replacing: "unknown family
    'arm'", or the other's columns)."""
    distributed = pytest.importorskip("dask.distributed")
    from linkedit.synthesis import families, shard_search

    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", 25)
    texts = [(EXAMPLES / f"{stem}.yaml").read_text().replace(f"name: {stem}", "name: arm")
             for stem in ("crank-rocker", "watt-six-bar")]
    runs = []
    for k, text in enumerate(texts):
        monkeypatch.setattr(families, "SPECS", {})  # a new `linkedit` process
        monkeypatch.setattr(families, "SPEC_TEXTS", {})
        for module in (atlas, shards, atlas_manifest, runner):
            monkeypatch.setattr(module, "SPEC_TEXTS", families.SPEC_TEXTS)
        (tmp_path / f"arm{k}.yaml").write_text(text)
        assert run_cli("atlas", "build", "--family", tmp_path / f"arm{k}.yaml", "-n", "200", "-o", tmp_path / f"a{k}",
                       "--seed", "3", "-q").exit_code == 0
        entry = shards.read_manifest(tmp_path / f"a{k}")["families"]["arm"]
        runs += [(str((tmp_path / f"a{k}").absolute()), text, entry["quantizer"], shard, len(entry["columns"]))
                 for shard in entry["shards"]]
    assert len({run[-1] for run in runs}) == 2
    half = len(runs) // 2
    runs = [run for pair in zip(runs[:half], runs[half:]) for run in pair]  # the two atlases by turns
    read_shard = shards.read_shard

    def slow(*args):  # a shard on a slow file system: the other threads run meanwhile
        time.sleep(0.05)
        return read_shard(*args)

    monkeypatch.setattr(shards, "read_shard", slow)
    monkeypatch.setattr(families, "SPECS", {})
    monkeypatch.setattr(families, "SPEC_TEXTS", {})
    variants = np.zeros((1, shards.WIDTH), dtype=np.float32)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=4, processes=False, dashboard_address=":0") as c, \
            distributed.Client(c) as client:
        futures = [client.submit(shard_search.search_shards, folder, "arm", text, 3, quantizer, [shard], 0, variants, 5,
                                 True, pure=False) for folder, text, quantizer, shard, _ in runs]
        for (*_, width), found in zip(runs, client.gather(futures)):
            assert found["params"].shape == (5, width)
