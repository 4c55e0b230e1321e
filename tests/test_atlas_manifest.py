"""A sharded atlas's manifest edited by hand: `synthesize` and `atlas build` check it against the family it
names and against itself, and refuse an inconsistent one in one line ``manifest.json:LINE: field: why``, exit 2
(it was read as it stood: wrong columns, a family's id or margin, a shard left out or chunks made up, a spec on a
built-in family, a build record naming another family were all accepted, with exit 0; quantizer cells
were blamed on a shard)."""

from __future__ import annotations

import json
import re
import shutil

import h5py
import pytest

from linkedit.synthesis import atlas, chunks, fourbar, shards

SMALL = 100


@pytest.fixture
def small_chunks(monkeypatch):
    for module in (atlas, chunks, shards):
        monkeypatch.setattr(module, "CHUNK", SMALL)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A sharded atlas of 250 four-bars in 3 shards (the last partial), and a target curve of a four-bar."""
    from typer.testing import CliRunner

    from linkedit.cli import app

    root = tmp_path_factory.mktemp("manifest")
    with pytest.MonkeyPatch.context() as patch:
        for module in (atlas, chunks, shards):
            patch.setattr(module, "CHUNK", SMALL)
        r = CliRunner().invoke(app, ["atlas", "build", "--family", "four-bar", "-n", "250", "-o", str(root / "atlas"),
                                     "-q"])
    assert r.exit_code == 0, r.output
    z = 30 * fourbar.curves(atlas.build_chunk("four-bar", 991, 0, 1).params, 150, 0.2)[0]
    (root / "t.csv").write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in z) + "\n")
    return root


def _four_bar(m):
    return m["families"]["four-bar"]


EDITS = {
    "columns": lambda m: _four_bar(m).update(columns=["a", "b"]),
    "family_id": lambda m: _four_bar(m).update(family_id=7),
    "margin": lambda m: _four_bar(m).update(margin=0.5),
    "chunks": lambda m: _four_bar(m).update(chunks=5),
    "shards": lambda m: _four_bar(m)["shards"].pop(1),
    "spec": lambda m: _four_bar(m).update(spec="name: x\n"),
    "partial_chunk": lambda m: _four_bar(m).update(partial_chunk="yes"),
    "build": lambda m: m.update(build={"count": 100, "families": ["slider-crank"]}),
    "pending": lambda m: _four_bar(m).update(pending=[[3, 100]], chunks=4),
    "distribution": lambda m: _four_bar(m).pop("distribution"),
    "cells": lambda m: _four_bar(m)["quantizer"].update(cells=81),
}


def _refused(run_cli, command: str, built, folder, out):
    """``command`` (synthesize, or an append by atlas build) on the atlas ``folder``: exit 2 in one line, the folder
    left byte for byte and nothing written to ``out``. Returns the run."""
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    args = (["synthesize", built / "t.csv", "--atlas", folder, "-o", out] if command == "synthesize"
            else ["atlas", "build", "--family", "four-bar", "-n", "100", "-o", folder])
    r = run_cli(*args)
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and len(r.output.strip().splitlines()) == 1, r.output
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before  # nothing written
    assert not out.exists()
    return r


@pytest.mark.parametrize("field", list(EDITS))
@pytest.mark.parametrize("command", ["synthesize", "atlas build"])
def test_an_edited_manifest_is_refused_naming_the_line_and_field(run_cli, built, tmp_path, small_chunks, field,
                                                                 command):
    folder = tmp_path / "atlas"
    shutil.copytree(built / "atlas", folder)
    manifest = json.loads((folder / shards.MANIFEST).read_text())
    EDITS[field](manifest)
    text = json.dumps(manifest, indent=2)
    (folder / shards.MANIFEST).write_text(text)
    r = _refused(run_cli, command, built, folder, tmp_path / "out")
    found = re.search(r"manifest\.json:(\d+): (\S+): ", r.output)
    assert found, r.output
    line, named = int(found.group(1)), found.group(2)
    assert named.split(".")[-1].split("[")[0] == field or (field, named) == ("distribution", "families.four-bar")
    shown = text.splitlines()[line - 1]
    assert f'"{field}"' in shown or (field == "distribution" and '"four-bar"' in shown), (shown, r.output)


def test_the_unedited_manifest_is_read(run_cli, built, tmp_path, small_chunks):
    folder = tmp_path / "atlas"
    shutil.copytree(built / "atlas", folder)
    (folder / shards.MANIFEST).write_text(json.dumps(json.loads((folder / shards.MANIFEST).read_text()), indent=2))
    assert run_cli("atlas", "build", "--family", "four-bar", "-n", "100", "-o", folder, "-q").exit_code == 0
    assert shards.counts(shards.read_manifest(folder)) == {"four-bar": 350}


def _shard_rows(folder, chunk: int, rows: int) -> None:
    """Shard ``chunk``'s datasets cut to their first ``rows`` (its attributes and the manifest left as they were)."""
    with h5py.File(folder / "four-bar" / f"{chunk:08d}.h5", "r+") as f:
        for key in ("params", "min_ds", "index", "cell"):
            data = f[key][:rows]
            del f[key]
            f.create_dataset(key, data=data)


def _rows_attribute(folder, chunk: int, rows: int) -> None:
    with h5py.File(folder / "four-bar" / f"{chunk:08d}.h5", "r+") as f:
        f.attrs["rows"] = rows


ROW_EDITS = {  # (edit, the shard named)
    "manifest rows": (lambda folder: _edit_manifest(folder, lambda m: _four_bar(m)["shards"][1].update(rows=50)), 1),
    "manifest rows of the last": (lambda folder: _edit_manifest(folder, lambda m: _four_bar(m)["shards"][2]
                                                                .update(rows=100)), 2),
    "shard rows attribute": (lambda folder: _rows_attribute(folder, 1, 60), 1),
    "shard datasets cut": (lambda folder: _shard_rows(folder, 1, 60), 1),
}


def _edit_manifest(folder, edit) -> None:
    manifest = json.loads((folder / shards.MANIFEST).read_text())
    edit(manifest)
    (folder / shards.MANIFEST).write_text(json.dumps(manifest, indent=2))


@pytest.mark.parametrize("edit", list(ROW_EDITS))
@pytest.mark.parametrize("command", ["synthesize", "atlas build"])
def test_a_shard_whose_rows_disagree_is_refused_naming_it(run_cli, built, tmp_path, small_chunks, edit, command):
    """An append (`atlas build -n` into the folder) checks the shards as a query reads them: a shard whose rows
    disagree with its manifest entry (the entry's rows, its file's ``rows`` attribute, its datasets' length) is
    refused naming the shard's file, exit 2, nothing written (an append went through, exit 0, and listed 50 more
    or fewer linkages than the folder held; an edited ``rows`` attribute was read by queries too)."""
    folder = tmp_path / "atlas"
    shutil.copytree(built / "atlas", folder)
    change, chunk = ROW_EDITS[edit]
    change(folder)
    r = _refused(run_cli, command, built, folder, tmp_path / "out")
    assert f"four-bar/{chunk:08d}.h5: " in r.output and ("rows" in r.output or "shape" in r.output), r.output
    assert not (tmp_path / "out").exists()
