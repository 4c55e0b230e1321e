"""specs/*.schema.json are generated from the pydantic models and must stay in sync."""

from __future__ import annotations

import json

import pytest

from linkedit.spec.schema import PAGES, available_formats, schema_text
from tests.conftest import ROOT


@pytest.mark.parametrize("name", sorted(available_formats()))
def test_schema_file_matches_model(name):
    path = ROOT / "specs" / f"{name}.schema.json"
    assert path.is_file(), f"run `make schemas` to write {path.name}"
    assert path.read_text() == schema_text(available_formats()[name]), f"{path.name} is stale: run `make schemas`"
    assert json.loads(path.read_text())["additionalProperties"] is False


@pytest.mark.parametrize("name", sorted(available_formats()))
def test_every_format_has_a_reference_page(name):
    page = ROOT / "specs" / f"{PAGES.get(name, name)}.md"
    assert page.is_file()
    assert f"{name}.schema.json" in page.read_text() or name == PAGES.get(name, name)


def _objects(node):
    """Every JSON object in a schema, depth first."""
    if isinstance(node, dict):
        yield node
        for v in node.values():
            yield from _objects(v)
    elif isinstance(node, list):
        for v in node:
            yield from _objects(v)


@pytest.mark.parametrize("name", sorted(available_formats()))
def test_a_map_of_names_refuses_a_key_that_is_not_a_name(name):
    """The loader refuses a joint, link, member… named 'a/b'; the schema's map of names took any key that did
    not match the name pattern, with any value (patternProperties alone constrains only matching keys)."""
    schema = json.loads(schema_text(available_formats()[name]))
    for node in _objects(schema):
        if "patternProperties" in node:
            assert node.get("additionalProperties") is False, node


def test_the_linkage_schema_counts_joints_and_links_as_the_loader_does():
    """joints: at least 3, links: at least 1 (the loader's 'at least 3 items'); the schema said nothing."""
    props = json.loads(schema_text(available_formats()["linkage"]))["properties"]
    assert props["joints"]["minProperties"] == 3 and props["links"]["minProperties"] == 1
