"""The manifest of a sharded atlas (``manifest.json``): the folder's layout (a family's folder, a shard's file),
its text (written atomically, the long lists a line per item) and its checks when read (every field, against itself
and against the families it names, a refusal naming the line). Layout: ``specs/atlas-hdf5.md``."""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from linkedit import __version__
from linkedit.errors import InputError
from linkedit.io.atomic import durable_path
from linkedit.io.h5read import open_result
from linkedit.synthesis.chunks import CHUNK, HARMONICS, SAMPLES
from linkedit.synthesis.families import FAMILIES, SPEC_TEXTS, family

FORMAT_VERSION = "3"
MANIFEST = "manifest.json"
#: a family's folder inside the atlas folder: its name when it is one of these, else a hash of it
_SAFE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]{0,63}")


def folder_of(name: str) -> str:
    """The folder of family ``name``'s shards inside the atlas folder."""
    return name if _SAFE.fullmatch(name) else "family-" + hashlib.sha256(name.encode()).hexdigest()[:16]


def shard_file(name: str, index: int) -> str:
    return f"{folder_of(name)}/{index:08d}.h5"


def new_manifest(seed: int) -> dict[str, Any]:
    return {"format_version": FORMAT_VERSION, "kind": "atlas", "generator": f"linkedit {__version__}", "seed": seed,
            "samples": SAMPLES, "harmonics": HARMONICS, "chunk": CHUNK, "build": None, "families": {}}


def new_family(name: str) -> dict[str, Any]:
    fam = family(name)
    return {"family_id": fam.ID, "margin": fam.margin(), "distribution": (fam.sample.__doc__ or "").strip(),
            "columns": list(fam.PARAMETERS), "spec": SPEC_TEXTS.get(name), "folder": folder_of(name),
            "chunks": 0, "partial_chunk": False, "quantizer": None, "shards": [], "pending": []}


def save(folder: Path, manifest: dict[str, Any]) -> None:
    """Write the manifest atomically, its shards in chunk order, at once (even inside ``together``)."""
    for entry in manifest["families"].values():
        entry["shards"].sort(key=lambda s: s["chunk"])
    with durable_path(folder / MANIFEST) as tmp:
        tmp.write_text(manifest_text(manifest), encoding="utf-8")


def manifest_text(manifest: dict[str, Any]) -> str:
    """``manifest`` as JSON, indented, each shard entry and pending chunk on a line of its own. The two lists
    (thousands of items) are written by json's C encoder, their items split into lines after (their strings,
    file names and hex digests, hold no brackets): json's indenting encoder is pure Python (3× slower: 0.2 s
    for 10,000 shards)."""
    lists: dict[str, str] = {}

    def placeholder(items: list[Any], between: str) -> str:  # a string no JSON text of the manifest's own contains
        key = f"\0{len(lists)}"
        lists[json.dumps(key)] = json.dumps(items).replace(between, between[0] + ",\n  " + between[-1])
        return key

    text = json.dumps(manifest | {"families": {
        name: entry | {"shards": placeholder(entry["shards"], "}, {"), "pending": placeholder(entry["pending"], "], [")}
        for name, entry in manifest["families"].items()}}, indent=1)
    for key, items in lists.items():
        text = text.replace(key, items, 1)
    return text + "\n"


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of the atlas folder ``folder``, checked field by field, against itself (every chunk listed once,
    as a shard or pending; pending ones only under an interrupted build's record) and against the families it names
    (their id, margin, columns; a spec only for a spec family): an InputError naming its line and field otherwise."""
    path = folder / MANIFEST
    try:
        text = path.read_text(encoding="utf-8")
        data = json.loads(text)
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read ({exc})", file=str(path)) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON: {exc.msg}", file=str(path), line=exc.lineno) from None

    def need(ok: bool, field: tuple[str | int, ...], what: str) -> None:
        if not ok:
            raise InputError(what, file=str(path), line=line_of(text, field), field=field)

    def integer(value: object, low: int, high: int) -> bool:
        return isinstance(value, int) and not isinstance(value, bool) and low <= value <= high

    need(isinstance(data, dict), (), "expected a JSON object")
    need(data.get("kind") == "atlas", ("kind",), "not a linkedit atlas manifest")
    need(data.get("format_version") != "2", ("format_version",),
         "a sharded atlas of format 2 (a quantizer per shard), which this linkedit no longer reads; rebuild it "
         "(`linkedit atlas build -o NAME --family ... -n ...`)")
    need(data.get("format_version") == FORMAT_VERSION, ("format_version",),
         f"not a linkedit atlas manifest of format {FORMAT_VERSION}")
    for key, value in (("chunk", CHUNK), ("samples", SAMPLES), ("harmonics", HARMONICS)):
        need(data.get(key) == value, (key,), f"expected {value} (another layout version: rebuild the atlas)")
    need(integer(data.get("seed"), 0, 2**63 - 1), ("seed",), "expected an integer from 0 to 2**63 - 1")
    need(isinstance(data.get("families"), dict), ("families",), "expected an object of families")
    build = data.get("build")
    need(build is None or (isinstance(build, dict) and integer(build.get("count"), 1, 2**62)
                           and isinstance(build.get("families"), list) and len(build["families"]) > 0
                           and all(isinstance(n, str) and n in data["families"] for n in build["families"])),
         ("build",), "expected null or a build record {count, families (names of families listed here)}")
    for name, entry in data["families"].items():
        _check_family(name, entry, build, path, need, integer)
    return data


def _check_family(name: str, entry: object, build: dict[str, Any] | None, path: Path,
                  need: Callable[[bool, tuple[str | int, ...], str], None], integer: Callable[[object, int, int], bool]
                  ) -> None:
    """:func:`read_manifest`'s checks of family ``name``'s ``entry`` (``need(ok, field, why)`` refuses)."""
    where: tuple[str | int, ...] = ("families", name)
    need(isinstance(entry, dict), where, "expected an object")
    assert isinstance(entry, dict)
    missing = [key for key in _new_family_keys() if key not in entry]
    need(not missing, where, f"{', '.join(missing)} missing")
    spec = entry["spec"]
    need(spec is None or isinstance(spec, str), (*where, "spec"), "expected null or a spec's text")
    need(spec is None or name not in FAMILIES, (*where, "spec"), f"expected null: {name} is a built-in family")
    fam = family(name, field=f"{path}: families/{name}", spec=spec)
    need(entry["family_id"] == fam.ID, (*where, "family_id"),
         f"expected {fam.ID}, the family's (its spec text or the manifest changed since the atlas was built)")
    need(isinstance(entry["margin"], float) and np.isclose(entry["margin"], fam.margin(), rtol=1e-12, atol=0),
         (*where, "margin"), f"expected {fam.margin()!r}, the family's")
    need(entry["columns"] == list(fam.PARAMETERS), (*where, "columns"), f"expected {list(fam.PARAMETERS)}")
    need(isinstance(entry["distribution"], str), (*where, "distribution"), "expected a text")
    need(entry["folder"] == folder_of(name), (*where, "folder"), f"expected {folder_of(name)!r}")
    need(integer(entry["chunks"], 0, 2**62), (*where, "chunks"), "expected a chunk count")
    need(isinstance(entry["partial_chunk"], bool), (*where, "partial_chunk"), "expected true or false")
    q = entry["quantizer"]
    need(isinstance(q, dict) and q.get("file") == f"{folder_of(name)}/quantizer.h5"
         and integer(q.get("cells"), 1, 2**16) and isinstance(q.get("sha256"), str), (*where, "quantizer"),
         "expected {file (<folder>/quantizer.h5), cells, sha256}")
    if (path.parent / q["file"]).is_file():  # a missing one is named when it is read
        with open_result(path.parent / q["file"], kind="atlas-quantizer") as f:
            held = f.dataset("centroids").shape[:1]
        need(held == (q["cells"],), (*where, "quantizer", "cells"), f"expected {held[0] if held else 0}, the cells "
             f"{q['file']} holds")
    for key in ("shards", "pending"):
        need(isinstance(entry[key], list), (*where, key), "expected a list")
    for k, shard in enumerate(entry["shards"]):
        ok = (isinstance(shard, dict) and integer(shard.get("chunk"), 0, entry["chunks"] - 1)
              and integer(shard.get("rows"), 1, CHUNK) and shard.get("file") == shard_file(name, shard["chunk"])
              and isinstance(shard.get("sha256"), str))
        need(ok, (*where, "shards", k), "expected {chunk, rows (1..chunk), file (<folder>/<chunk:08d>.h5), sha256}")
    for k, job in enumerate(entry["pending"]):
        need(isinstance(job, list) and len(job) == 2 and integer(job[0], 0, entry["chunks"] - 1)
             and integer(job[1], 1, CHUNK), (*where, "pending", k), "expected [chunk, size]")
    need(not entry["pending"] or (build is not None and name in build["families"]), (*where, "pending"),
         "chunks pending with no build of this family interrupted (build)")
    listed = [s["chunk"] for s in entry["shards"]] + [j[0] for j in entry["pending"]]
    need(len(set(listed)) == len(listed), (*where, "shards"), "a chunk is listed twice")
    absent = sorted(set(range(entry["chunks"])) - set(listed))
    if absent and absent[0] > max(listed, default=-1):  # the count raised past the chunks listed
        need(False, (*where, "chunks"), f"expected {absent[0]}: chunks {absent[0]}..{absent[-1]} are listed neither "
             "in shards nor pending")
    need(not absent, (*where, "shards"), f"chunk {absent[0] if absent else 0} is listed neither here nor in pending")


def _new_family_keys() -> tuple[str, ...]:
    """The keys of a family's manifest entry (:func:`new_family`)."""
    return ("family_id", "margin", "distribution", "columns", "spec", "folder", "chunks", "partial_chunk",
            "quantizer", "shards", "pending")


def line_of(text: str, field: tuple[str | int, ...]) -> int | None:
    """The line (from 1) in JSON ``text`` where the value at ``field`` (keys and list indices) starts, or where
    the deepest part of it that exists does; None if ``text`` is not a JSON object."""
    decoder = json.JSONDecoder()
    space = re.compile(r"[\s,:]*")

    def skip(at: int) -> int:
        return space.match(text, at).end()  # type: ignore[union-attr]

    at = skip(0)
    try:
        for step in field:
            opening = text[at]
            at = skip(at + 1)
            k = 0
            while text[at] not in "]}":
                key = None
                if opening == "{":
                    key, at = decoder.raw_decode(text, at)
                    at = skip(at)
                if (key if opening == "{" else k) == step:
                    break
                _, at = decoder.raw_decode(text, at)
                at, k = skip(at), k + 1
            else:
                break
    except (IndexError, ValueError):
        return None
    return text.count("\n", 0, at) + 1
