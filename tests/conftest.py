"""Shared test helpers."""

from __future__ import annotations

import os

# BLAS on one thread, as the CLI runs it (linkedit/cli.py sets this before numpy loads; here a test module would
# load numpy first): linkedit's dense algebra is small, threads only spin, the more so with two test workers on
# two cores (a 333×222 SVD: 0.4 s threaded on a busy machine, 0.02 s single). The environment overrides it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import re  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


@pytest.fixture
def run_cli():
    """Run the linkedit CLI in-process: ``run_cli("simulate", "x.yaml")`` → click Result."""
    from linkedit.cli import app

    runner = CliRunner()

    def run(*args: str):
        return runner.invoke(app, [str(a) for a in args], catch_exceptions=False)

    return run


def report_of(result) -> object:
    """The ``result`` of a command's ``--json`` report (specs/cli-json.md), after checking the envelope."""
    import json

    data = json.loads(result.stdout)
    assert data["ok"] is (result.exit_code == 0) and data["exit_code"] == result.exit_code, data
    return data["result"]


@pytest.fixture(scope="session")
def cluster():
    """One local Dask cluster of 2 single-threaded worker processes (what ``--workers 2`` starts)
    for every Dask test of the session: a cluster takes about 10 s to start."""
    pytest.importorskip("dask.distributed")
    from linkedit.synthesis.cluster import local_cluster

    with local_cluster(2) as cluster:
        yield cluster


def svg_texts(svg: str) -> list[str]:
    """The texts of an SVG drawing's <text> elements, in order."""
    return re.findall(r"<text[^>]*>([^<]*)</text>", svg)


def svg_legend(svg: str) -> list[str]:
    """The entries of an SVG drawing's legend (its ``<g class="legend">``)."""
    block = re.search(r'<g class="legend"[^>]*>(.*?)</g>', svg, re.S)
    assert block, "no legend"
    return svg_texts(block.group(1))


@pytest.fixture(scope="session")
def four_bar_atlas(tmp_path_factory) -> Path:
    """An atlas file of 20,000 four-bars (seed 1), built once per test process."""
    from linkedit.synthesis import atlas

    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 2 * atlas.CHUNK, seed=1)
    return path
