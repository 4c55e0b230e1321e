"""JSON Schema export of every input format (``specs/*.schema.json``)."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pydantic
from pydantic.json_schema import GenerateJsonSchema, JsonSchemaValue
from pydantic_core import core_schema

from linkedit.io.atomic import write_text

#: format name → "module:Model". Each format's reference page is ``specs/<page>.md`` (PAGES).
FORMATS = {
    "linkage": "linkedit.spec.linkage:LinkageSpec",
    "edit-script": "linkedit.spec.edit_script:EditScript",
    "mechanism3d": "linkedit.spec.mechanism3d:MechanismSpec",
    "curve-set": "linkedit.spec.curveset:CurveSet",
    "curve-weights": "linkedit.spec.curveset:CurveWeights",
    "curve-pairs": "linkedit.spec.curveset:LabelledPairs",
}
#: formats documented on another format's page
PAGES = {"curve-weights": "curve-set", "curve-pairs": "curve-set"}


def available_formats() -> dict[str, type]:
    """The formats whose models exist, name → pydantic model class."""
    out = {}
    for name, ref in FORMATS.items():
        module_name, cls = ref.split(":")
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue
        out[name] = getattr(module, cls)
    return out


class _Schema(GenerateJsonSchema):
    """pydantic's schema, with a map keyed by names (``patternProperties``) closed to other keys: the
    loader refuses a joint named ``a/b``, and a pattern alone constrains only the keys it matches."""

    def dict_schema(self, schema: core_schema.DictSchema) -> JsonSchemaValue:
        out = super().dict_schema(schema)
        if "patternProperties" in out:
            out.setdefault("additionalProperties", False)
        return out


def schema_text(model: type[pydantic.BaseModel]) -> str:
    """The JSON Schema of a model, as stable pretty-printed text."""
    return json.dumps(model.model_json_schema(schema_generator=_Schema), indent=2, sort_keys=True) + "\n"


def write_schemas(out_dir: str | Path) -> list[Path]:
    """Write ``<out_dir>/<format>.schema.json`` for every format; returns the paths."""
    paths = []
    for name, model in available_formats().items():
        path = Path(out_dir) / f"{name}.schema.json"
        write_text(path, schema_text(model))
        paths.append(path)
    return paths
