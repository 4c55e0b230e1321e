"""Fuzz: mutated example specs, edit scripts, 3D specs, curve sets and other tools' files through the CLI.

Mutations: delete a key, swap a value's type, perturb a number across 1e-300…1e300, repeat a
value (an alias in the YAML text), rename a key to odd unicode; in a pyslvs expression, cut,
repeat or insert a piece of text. For every run: exit code in {0, 1, 2}; no traceback; on exit ≠ 0
no output written; on exit 0 every number of the outputs finite, and a planar result keeps its
link lengths to 1e-9 relative. An imported file (``examples/import/``) that imports is simulated.

The default profile runs ``FUZZ_EXAMPLES`` (40) inputs; ``LINKEDIT_FUZZ_EXAMPLES=2000 pytest
tests/test_fuzz.py -m slow`` runs the long one. ``LINKEDIT_FUZZ_REPORT=path.json`` writes the
counts of exit codes per kind of input.
"""

from __future__ import annotations

import collections
import copy
import csv
import io
import json
import os
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from tests.conftest import EXAMPLES

FUZZ_EXAMPLES = int(os.environ.get("LINKEDIT_FUZZ_EXAMPLES", "40"))
LONG_EXAMPLES = int(os.environ.get("LINKEDIT_FUZZ_EXAMPLES", "1500"))
COUNTS: collections.Counter = collections.Counter()

SEEDS = {
    "linkage": sorted(p for p in EXAMPLES.glob("*.yaml") if p.stem != "strandbeest-10"),
    "edit": sorted((EXAMPLES / "edits").glob("*.yaml")),
    "mechanism3d": sorted((EXAMPLES / "3d").glob("*.yaml")),
    "curve-set": [EXAMPLES / "curves" / "foot-paths.yaml"],
    "import": sorted(p for p in (EXAMPLES / "import").iterdir() if not p.name.endswith(".dimensions.json")),
}
EXPRESSION_PIECES = [",", "[", "]", "(", ")", "A[", "P[1, 2]", "L[]", "J[R, P[0, 0], L[ground, L1]]", "1e999",
                     "9" * 400, "-", "#", "\n", "ground", "é"]
ODD_NAMES = ["ß", "名前", "a b", "\u200b", "é\u0301", "x" * 300, "-", "1e5", "true", "~", "\U0001F600"]
ODD_VALUES = [True, False, None, "x", "", [], {}, [1, 2], {"a": 1}, 0, -1, 1e308, -1e308, 5e-324, 10**30]


def _paths(data, prefix=()):
    """Every (path, value) in a YAML document."""
    yield prefix, data
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _paths(v, prefix + (i,))


def _get(data, path):
    for p in path:
        data = data[p]
    return data


@st.composite
def mutated(draw):
    kind = draw(st.sampled_from(sorted(SEEDS)))
    seed = draw(st.sampled_from(SEEDS[kind]))
    data = yaml.safe_load(seed.read_text())
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(data) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _get(data, path[:-1]), path[-1]
        value = parent[key]
        how = draw(st.sampled_from(["delete", "swap", "number", "number", "number", "alias", "rename"]))
        if how == "delete":
            del parent[key]
        elif how == "swap":
            parent[key] = copy.deepcopy(draw(st.sampled_from(ODD_VALUES)))
        elif how == "number":
            numbers = [p for p, v in _paths(data) if p and isinstance(v, (int, float)) and not isinstance(v, bool)]
            if numbers:
                target = draw(st.sampled_from(numbers))
                holder = _get(data, target[:-1])
                exponent = draw(st.integers(-300, 300))
                factor = draw(st.sampled_from([1.0, -1.0, 3.7])) * 10.0 ** exponent
                holder[target[-1]] = draw(st.sampled_from([holder[target[-1]] * factor, factor, holder[target[-1]] + factor]))
        elif how == "alias":
            others = [p for p in paths if p != path and not _is_prefix(p, path) and not _is_prefix(path, p)]
            if others:
                parent[key] = _get(data, draw(st.sampled_from(others)))  # same object → &anchor / *alias
        elif how == "rename" and isinstance(parent, dict):
            parent[draw(st.sampled_from(ODD_NAMES))] = parent.pop(key)
    if kind == "edit" and isinstance(data, dict):
        _bounded_edit(data)
    if kind == "import" and isinstance(data, dict) and isinstance(data.get("mechanism"), str) and draw(st.booleans()):
        data["mechanism"] = _mutated_text(draw, data["mechanism"])
    if seed.suffix == ".json":
        return kind, seed, json.dumps(data, ensure_ascii=False)
    return kind, seed, yaml.safe_dump(data, allow_unicode=True, sort_keys=False)


def _mutated_text(draw, text: str) -> str:
    """A pyslvs expression with a piece cut out, repeated, or a piece of syntax put in."""
    a = draw(st.integers(0, len(text)))
    b = draw(st.integers(a, min(len(text), a + 40)))
    how = draw(st.sampled_from(["cut", "repeat", "insert"]))
    if how == "cut":
        return text[:a] + text[b:]
    if how == "repeat":
        return text[:b] + text[a:b] * draw(st.integers(1, 3)) + text[b:]
    return text[:a] + draw(st.sampled_from(EXPRESSION_PIECES)) + text[a:]


def _is_prefix(a, b):
    return len(a) <= len(b) and tuple(b[: len(a)]) == tuple(a)


def _bounded_edit(data: dict) -> None:
    """Keep a fuzzed edit quick: few samples, few iterations (the fuzz is about inputs, not convergence)."""
    if "samples" not in data or isinstance(data["samples"], int) and not isinstance(data["samples"], bool):
        data["samples"] = 16
    operations = data.get("operations")
    for op in operations if isinstance(operations, list) else []:
        if isinstance(op, dict):
            op["max_iterations"] = 15


def _command(kind: str, spec: Path, work: Path, seed: Path) -> list[str]:
    out = work / "out"
    if kind == "import":
        dimensions = work / "in" / seed.name.replace(".graph.json", ".dimensions.json")
        return ["import", str(spec), "-o", str(out / "s.yaml")] + (
            ["--dimensions", str(dimensions)] if seed.name.endswith(".graph.json") else [])
    if kind == "linkage":
        return ["simulate", str(spec), "-o", str(out / "r.h5"), "--svg", str(out / "r.svg"), "--samples", "48"]
    if kind == "edit":
        return ["edit", str(spec), "-o", str(out)]
    if kind == "mechanism3d":
        return ["solve3d", str(spec), "-o", str(out / "r.h5"), "--svg", str(out / "r.svg"), "--steps", "6"]
    return ["features", str(spec), "-o", str(out / "f.csv")]


def _finite_outputs(out: Path) -> None:
    for path in out.rglob("*"):
        if path.suffix == ".h5":
            with h5py.File(path, "r") as f:
                def check(name, obj):
                    if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f":
                        assert np.isfinite(obj[()]).all(), f"{path}:{name} holds NaN or inf"
                f.visititems(check)
        elif path.suffix == ".csv":
            for row in csv.DictReader(io.StringIO(path.read_text())):
                for key, cell in row.items():
                    try:
                        value = float(cell)
                    except ValueError:
                        continue
                    assert np.isfinite(value), f"{path}: {key} = {cell}"
        elif path.suffix == ".svg":
            bad = re.search(r'="[^"]*\b(nan|inf)\b', path.read_text(), re.IGNORECASE)
            assert bad is None, f"{path}: {bad and bad.group(0)}"


def _link_lengths_kept(h5: Path) -> None:
    with h5py.File(h5, "r") as f:
        pos = f["joints/position"][()]
        assembled = f["diagnostics/assembled"][()] if "diagnostics/assembled" in f else np.ones(len(pos), bool)
        pos = pos / np.abs(pos[0]).max()  # in units of the linkage's extent: no overflow at 1e300
        size = np.ptp(pos[0], axis=0).max()
        for link in f["links/joints"].values():
            idx = link[()]
            for a in range(len(idx)):
                for b in range(a + 1, len(idx)):
                    d = np.linalg.norm(pos[assembled, idx[a]] - pos[assembled, idx[b]], axis=-1)
                    assert np.abs(d - d[0]).max() <= 1e-9 * max(d[0], size), f"link {link.name} changes length"


def _run(kind: str, seed: Path, text: str, work: Path) -> int:
    from linkedit.cli import app

    if work.exists():
        shutil.rmtree(work)
    shutil.copytree(seed.parent, work / "in")
    if kind == "edit":  # the scripts name ../jansen.yaml and friends
        for linkage in SEEDS["linkage"]:
            shutil.copy(linkage, work / linkage.name)
    spec = work / "in" / f"fuzzed{seed.suffix}"
    spec.write_text(text, encoding="utf-8")
    r = CliRunner().invoke(app, _command(kind, spec, work, seed), catch_exceptions=False)
    if kind == "import" and r.exit_code == 0:  # the user's next step: simulate what was imported
        COUNTS[(kind, 0)] += 1
        assert (work / "out" / "s.yaml").exists(), r.output
        shutil.move(work / "out" / "s.yaml", work / "in" / "imported.yaml")
        kind, r = "linkage", CliRunner().invoke(app, _command("linkage", work / "in" / "imported.yaml", work, seed),
                                                catch_exceptions=False)
    COUNTS[(kind, r.exit_code)] += 1
    assert r.exit_code in (0, 1, 2), r.output
    assert "Traceback" not in r.output, r.output
    out = work / "out"
    if r.exit_code != 0:
        if kind == "edit" and r.exit_code == 1 and any(out.glob("*-edited.yaml")):
            return r.exit_code  # an edit that stopped keeps its last working linkage (documented)
        written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
        assert written == [], f"exit {r.exit_code} but wrote {written}: {r.output}"
        return r.exit_code
    _finite_outputs(out)
    if kind == "linkage":
        _link_lengths_kept(out / "r.h5")
    return r.exit_code


def _report() -> None:
    target = os.environ.get("LINKEDIT_FUZZ_REPORT")
    if target:
        Path(target).write_text(json.dumps({f"{k} exit {c}": n for (k, c), n in sorted(COUNTS.items())}, indent=1))


@settings(max_examples=FUZZ_EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=mutated())
def test_fuzzed_inputs_fail_cleanly_or_give_finite_results(tmp_path, case):
    _run(*case, tmp_path / "w")
    _report()


@pytest.mark.slow
@settings(max_examples=LONG_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=mutated())
def test_fuzzed_inputs_long_profile(tmp_path, case):
    _run(*case, tmp_path / "w")
    _report()


def _scaled(factor: float) -> str:
    data = yaml.safe_load((EXAMPLES / "crank-rocker.yaml").read_text())
    data["joints"] = {n: [c * factor for c in p] for n, p in data["joints"].items()}
    for track in data["tracks"].values():
        if "at" in track:
            track["at"] = [c * factor for c in track["at"]]
    return yaml.safe_dump(data)


@pytest.mark.parametrize("factor", [1e-100, 1e-10, 1e100, 1e150, 1e300])
def test_a_scaled_four_bar_simulates_with_finite_results(tmp_path, factor):
    """The fuzz's assertions on the crank-rocker at extreme scales: any representable scale simulates
    (issue 10's scale-free engine)."""
    assert _run("linkage", EXAMPLES / "crank-rocker.yaml", _scaled(factor), tmp_path / "w") == 0
