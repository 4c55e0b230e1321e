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


def test_malformed_yaml_names_the_line():
    with pytest.raises(InputError) as info:
        load_yaml("x.yaml", "a: [1, 2\nb: 3\n")
    assert info.value.file == "x.yaml" and info.value.line is not None
    assert "malformed YAML" in str(info.value)


def test_empty_file():
    with pytest.raises(InputError, match="empty"):
        load_yaml("x.yaml", "")
