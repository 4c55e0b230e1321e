"""Shared test helpers."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

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
