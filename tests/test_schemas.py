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
