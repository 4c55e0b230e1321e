"""The families an atlas can hold: name → module with the family interface.

A family module provides ``NAME``, ``PARAMETERS``, ``ID`` (a small integer mixed into chunk
seeds), ``margin()``, ``sample(rng, count)``, ``min_singularity(params)``,
``curves(params, samples, phase)`` (K, T) complex in the family frame, and ``to_spec(...)``.
"""

from __future__ import annotations

from types import ModuleType

from linkedit.errors import InputError
from linkedit.synthesis import fourbar

FAMILIES: dict[str, ModuleType] = {fourbar.NAME: fourbar}


def family(name: str, field: str = "--family") -> ModuleType:
    """The family module called ``name``; an InputError naming the known ones otherwise."""
    if name not in FAMILIES:
        raise InputError(f"unknown family {name!r} (families: {', '.join(FAMILIES)})", field=field)
    return FAMILIES[name]
