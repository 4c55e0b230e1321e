"""The Python examples of the format pages (specs/*-hdf5.md) run as written on the results the
CLI writes (the README's run in tests/test_readme.py)."""

from __future__ import annotations

import re

import pytest

from tests.conftest import EXAMPLES, ROOT


@pytest.mark.parametrize("page, spec, result", [
    ("planar-hdf5.md", "jansen.yaml", "jansen.h5"),
    ("gcs-hdf5.md", "3d/crank-rocker.yaml", "crank-rocker.h5"),
])
def test_every_python_block_of_a_format_page_runs(page, spec, result, run_cli, tmp_path, monkeypatch):
    """planar-hdf5.md read a joint with ``xr.open_dataset(..., group="joints")["position"].sel(joint="C")``:
    KeyError 'joint' (the group alone has no ``joint`` coordinate: the dimension scale is at the root)."""
    pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    monkeypatch.chdir(tmp_path)
    command = "solve3d" if spec.startswith("3d/") else "simulate"
    assert run_cli(command, EXAMPLES / spec, "-o", f"out/{result}", "-q").exit_code == 0
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "specs" / page).read_text(encoding="utf-8"), re.DOTALL)
    assert blocks
    for block in blocks:
        exec(compile(block, page, "exec"), {})
