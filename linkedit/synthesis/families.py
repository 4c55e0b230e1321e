"""The families an atlas can hold: name → module with the family interface.

A family (a module, or a :class:`~linkedit.synthesis.legs.CatalogFamily`) provides ``NAME``,
``PARAMETERS``, ``ID`` (a small integer mixed into chunk seeds), ``margin()``, ``sample(rng, count)``,
``min_singularity(params, margin=None)`` (the lowest d_s over the cycle, which the one planar
predicate :func:`linkedit.planar.feasibility.works` holds to a margin: exact in closed form, or
:func:`~linkedit.planar.feasibility.lowest` at its samples), ``curves(params, samples, phase)``
(K, T) complex in the family frame, and ``to_spec(...)``.
"""

from __future__ import annotations

from typing import Any

from linkedit.errors import InputError
from linkedit.synthesis import fourbar, slidercrank
from linkedit.synthesis.legs import JANSEN, KLANN, STEPHENSON, WATT

FAMILIES: dict[str, Any] = {fourbar.NAME: fourbar, slidercrank.NAME: slidercrank,
                            **{f.NAME: f for f in (JANSEN, KLANN, WATT, STEPHENSON)}}


def family(name: str, field: str = "--family") -> Any:
    """The family module called ``name``; an InputError naming the known ones otherwise."""
    if name not in FAMILIES:
        raise InputError(f"unknown family {name!r} (families: {', '.join(FAMILIES)})", field=field)
    return FAMILIES[name]
