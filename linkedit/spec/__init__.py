"""Input formats: pydantic models, YAML loading with line-accurate errors, JSON Schemas."""

from linkedit.spec.yamlload import load_model, load_yaml

__all__ = ["load_model", "load_yaml"]
