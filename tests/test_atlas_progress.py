"""The progress of `atlas build`: a slow family's bar moves inside a chunk (a complex loop builds at ~20
linkages/s: a 10,000-linkage chunk showed 0 for 7–10 minutes), in-process and on Dask, and the atlas stays the
same bytes."""

from __future__ import annotations

import pytest

from linkedit.commands import synthesis as command
from linkedit.synthesis import atlas, chunks, shards
from linkedit.synthesis import cluster as runner


@pytest.mark.parametrize("out", ["a.h5", "folder"])
def test_the_bar_moves_inside_a_chunk(run_cli, tmp_path, monkeypatch, out):
    """A one-chunk build of a catalog family (the kind a spec family is) into a file or a folder: the bar's
    callback gets counts between 0 and the chunk's size before the chunk is stored, rising, ending at the total."""
    seen: list[tuple[int, int]] = []
    monkeypatch.setattr(command._Progress, "__call__", lambda self, done, total, seconds: seen.append((done, total)))
    result = run_cli("atlas", "build", "--family", "jansen", "-n", "300", "-o", tmp_path / out, "--seed", "2")
    assert result.exit_code == 0, result.output
    done = [d for d, _ in seen]
    assert {t for _, t in seen} == {300} and done[-1] == 300
    assert any(0 < d < 300 for d in done), seen
    assert done == sorted(done)


@pytest.mark.parametrize("out", [pytest.param("a.h5", marks=pytest.mark.slow), "folder"])  # ≈ 4 s each on a cluster
def test_the_bar_moves_inside_a_dask_task(run_cli, tmp_path, monkeypatch, cluster, out):
    """The same on the 2-worker cluster (two chunks of 300, a task each, built at once): the workers publish
    the linkages their task has screened (here as often as they can) and the client reports them while it
    waits for the first task, before its result; the counts rise (what both tasks screened counts, up to the
    first chunk: the count reported when it is read) and end at the total."""
    seen: list[tuple[int, int]] = []
    monkeypatch.setattr(command._Progress, "__call__", lambda self, done, total, seconds: seen.append((done, total)))
    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", 300)
    monkeypatch.setattr(runner, "REPORT_EVERY", 0.01, raising=False)
    result = run_cli("atlas", "build", "--family", "jansen", "-n", "600", "-o", tmp_path / out, "--seed", "2",
                     "--scheduler", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    done = [d for d, _ in seen]
    assert {t for _, t in seen} == {600} and done[-1] == 600
    assert any(0 < d < 600 and d != 300 for d in done), seen
    assert done == sorted(done)


def test_a_chunk_is_the_same_whether_its_progress_is_reported(monkeypatch):
    """The screening blocks that report progress change no byte: a chunk screened in blocks of 1 row at first
    (every row its own min_singularity call) equals one screened in blocks of 4,096."""
    built = []
    for first in (1, 4096):
        monkeypatch.setattr(chunks, "FIRST_SCREEN", first)
        with chunks.reporting(lambda kept: None):
            built.append(chunks.build_chunk("klann", 4, 1, 120))
    for key in ("params", "min_ds", "index", "curves"):
        assert getattr(built[0], key).tobytes() == getattr(built[1], key).tobytes(), key


def test_the_bar_labels_the_time_left_and_fits_80_columns():
    """The bar reads '28747/100000 linkages 5,749/s 0:00:46 left', whole in an 80-column terminal (the label
    'left' stood between the time elapsed and the time left: '0:00:19 left 0:00:46' showed the time elapsed as
    the time left)."""
    import io
    import re

    from rich.console import Console

    bar = command._Progress(live=False)
    bar.live = True  # as on a terminal
    with bar:
        bar(28747, 100000, 5.0)
        console = Console(record=True, width=80, file=io.StringIO())
        console.print(bar.bar.make_tasks_table(bar.bar.tasks))
    text = console.export_text().strip()
    assert re.search(r" 28747/100000 linkages 5,749/s (\d+:\d\d:\d\d|-:--:--) left$", text), text
