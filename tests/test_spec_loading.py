"""YAML loading: line-accurate errors, duplicate keys, malformed files."""

from __future__ import annotations

import pytest

from linkedit.errors import InputError
from linkedit.spec.yamlload import load_yaml


def test_lines_are_recorded_for_nested_fields():
    data, lines = load_yaml("x.yaml", "a: 1\nb:\n  c: [1, 2]\n  d:\n    - 3\n    - 4\n")
    assert data == {"a": 1, "b": {"c": [1, 2], "d": [3, 4]}}
    assert lines[("a",)] == 1
    assert lines[("b", "c")] == 3
    assert lines[("b", "d", 1)] == 6
    assert lines.line_of(("b", "c", 7, "zz")) == 3


def test_duplicate_key_is_an_error_with_its_line():
    with pytest.raises(InputError) as info:
        load_yaml("x.yaml", "joints:\n  A: [0, 0]\n  A: [1, 0]\n")
    assert str(info.value) == "x.yaml:3: joints.A: duplicate key 'A'"


def test_names_that_differ_only_by_surrounding_spaces_are_duplicate_keys(run_cli, tmp_path):
    """A name is read without its surrounding spaces, so ``"B "`` is B: the second silently replaced the
    other (joint B of crank-rocker.yaml: the first one, [41, 5], was dropped, exit 0)."""
    from tests.conftest import EXAMPLES

    text = (EXAMPLES / "crank-rocker.yaml").read_text()
    spec = tmp_path / "s.yaml"
    spec.write_text(text.replace("  B: [63", '  " B": [41, 5]\n  B: [63', 1))
    r = run_cli("validate", spec)
    assert r.exit_code == 2, r.output
    assert r.output.strip() == (f"linkedit: error: {spec}:12: joints.B: duplicate key 'B' "
                                "(' B' above is the same name: names are read without surrounding spaces)")


@pytest.mark.parametrize("old, new, expected", [
    ("  D: [75, 0]\n  A: [25, 0]\n  B: [63, 58.787753826796276]\n", "  D: [75, 0]\n", ":7: joints: needs at least 3 entries, not 2"),
    ("ground: [O, D]", "ground: []", ":12: ground: needs at least 1 entry, not 0"),
])
def test_too_few_entries_are_said_in_words(run_cli, tmp_path, old, new, expected):
    """Two joints were 'Dictionary should have at least 3 items after validation, not 2'."""
    from tests.conftest import EXAMPLES

    text = (EXAMPLES / "crank-rocker.yaml").read_text()
    assert old in text
    spec = tmp_path / "s.yaml"
    spec.write_text(text.replace(old, new, 1))
    r = run_cli("validate", spec)
    assert r.exit_code == 2 and r.output.strip() == f"linkedit: error: {spec}{expected}", r.output


def test_malformed_yaml_names_the_line():
    with pytest.raises(InputError) as info:
        load_yaml("x.yaml", "a: [1, 2\nb: 3\n")
    assert info.value.file == "x.yaml" and info.value.line is not None
    assert "malformed YAML" in str(info.value)


def test_empty_file():
    with pytest.raises(InputError, match="empty"):
        load_yaml("x.yaml", "")


RULE = ("a name may hold any characters but '/' and control characters, and may not begin with '.' "
        "(it becomes an HDF5 group name)")


@pytest.mark.parametrize("old, new, expected", [
    ("  B: [63", '  "B/x": [0, 50]\n  B: [63', ":11: joints.B/x: the name 'B/x' has a '/': "),
    ("name: crank-rocker", "name: .hidden", ":2: name: the name '.hidden' begins with '.': "),
    ("name: crank-rocker", 'name: "a\\tb"', ":2: name: the name 'a\\tb' has the control character '\\t': "),
    ("  crank: [O, A]", "  crank: [O, A]\n  'a/b': [O, A]", ":15: links.a/b: the name 'a/b' has a '/': "),
])
def test_a_bad_name_is_explained_in_words_not_as_a_regex(run_cli, tmp_path, old, new, expected):
    from tests.conftest import EXAMPLES

    spec = tmp_path / "s.yaml"
    text = (EXAMPLES / "crank-rocker.yaml").read_text()
    assert old in text
    spec.write_text(text.replace(old, new, 1))
    r = run_cli("simulate", spec, "-o", tmp_path / "o.h5")
    assert r.exit_code == 2 and r.output.strip() == f"linkedit: error: {spec}{expected}{RULE}"


def test_a_bad_track_name_and_python_reference_are_explained_in_words(run_cli, tmp_path):
    from tests.conftest import EXAMPLES

    r = run_cli("solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "--track", "a/b=crank:1,0,0", "-o", tmp_path / "o.h5")
    assert r.exit_code == 2 and r.output.strip() == f"linkedit: error: --track: 'a/b=crank:1,0,0': the name 'a/b' has a '/': {RULE}"
    spec = tmp_path / "py.yaml"
    spec.write_text((EXAMPLES / "3d" / "crank-rocker.yaml").read_text().replace(
        "constraints:\n", "constraints:\n  circle: {type: custom, python: 'os.path/join', members: [crank], size: 1}\n", 1))
    r = run_cli("solve3d", spec, "--allow-python", "-o", tmp_path / "o.h5")
    assert r.exit_code == 2 and "constraints.circle.python: 'os.path/join' is not module:function: " in r.output
    assert "pattern" not in r.output and "\\w" not in r.output


@pytest.mark.parametrize("at, expected", [
    ("[20.5, 44.6, 1]", ":19: tracks.coupler_point.at: Tuple should have at most 2 items after validation, not 3"),
    ("[.nan, 44.6]", ":19: tracks.coupler_point.at[0]: Input should be a finite number"),
])
def test_a_bad_point_of_a_link_track_is_named_not_a_missing_joint(run_cli, tmp_path, at, expected):
    """A track is a joint ({joint}) or a point on a link ({link, at}): a bad ``at`` of the second kind
    was reported as the first kind's missing field ('tracks.coupler_point.joint: required field is
    missing'), the union member whose keys do not fit the entry."""
    from tests.conftest import EXAMPLES

    spec = tmp_path / "s.yaml"
    text = (EXAMPLES / "crank-rocker.yaml").read_text()
    old = "at: [20.48489846928149, 44.59387691339814]"
    assert old in text
    spec.write_text(text.replace(old, f"at: {at}"))
    r = run_cli("validate", spec)
    assert r.exit_code == 2 and r.output.strip().startswith(f"linkedit: error: {spec}{expected}"), r.output


@pytest.mark.parametrize("command, spec, field, line, use", [
    ("simulate", "3d/compound-crank-rocker.yaml", "shapes", 11, "this is a 3D mechanism spec, not a planar linkage spec: use `linkedit solve3d`"),
    ("validate", "3d/crank-rocker.yaml", None, None, "this is a 3D mechanism spec, not a planar linkage spec: use `linkedit solve3d`"),
    ("solve3d", "crank-rocker.yaml", None, None, "this is a planar linkage spec, not a 3D mechanism spec: use `linkedit simulate`"),
])
def test_a_spec_of_the_other_kind_is_named_with_the_command_to_use(run_cli, tmp_path, command, spec, field, line, use):
    """A 3D mechanism spec given to ``simulate`` (a planar one to ``solve3d``) says what it is and which
    command reads it, at the first key only the other format has, not ``shapes: unknown field;
    did you mean 'samples'?``."""
    from tests.conftest import EXAMPLES
    from linkedit.spec.yamlload import load_yaml

    path = EXAMPLES / spec
    data, lines = load_yaml(path)
    first = field or next(k for k in data if k in {"shapes", "members", "constraints", "inputs", "outputs",
                                                   "ground", "links", "motor", "sliders"})
    args = (command, path) if command == "validate" else (command, path, "-o", tmp_path / "x.h5")
    r = run_cli(*args)
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert r.stderr.strip() == f"linkedit: error: {path}:{line or lines[(first,)]}: {first}: {use}"
    assert not (tmp_path / "x.h5").exists()
