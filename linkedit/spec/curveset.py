"""The curve comparison formats (see ``specs/curve-set.md``).

* :class:`CurveSet` — named curves given by their points or by a source file;
* :class:`CurveWeights` — the weights of the curve distance d = sqrt(Σ w_m Δf_m²);
* :class:`LabelledPairs` — curve pairs labelled similar / dissimilar, to learn weights from.
"""

from __future__ import annotations

from typing import Annotated

import pydantic

from linkedit.errors import InputError
from linkedit.spec.common import HARMONICS_RANGE, MAX_WEIGHT, SAMPLES_RANGE, Count, Finite, Name, SpecModel

NonNegative = Annotated[float, pydantic.Strict(), pydantic.Field(ge=0.0, allow_inf_nan=False)]
Weight = Annotated[float, pydantic.Strict(), pydantic.Field(ge=0.0, le=MAX_WEIGHT, allow_inf_nan=False)]
Samples = Annotated[Count, pydantic.Field(ge=SAMPLES_RANGE[0], le=SAMPLES_RANGE[1])]
Harmonics = Annotated[Count, pydantic.Field(ge=HARMONICS_RANGE[0], le=HARMONICS_RANGE[1])]

#: Term names of the curve distance (per-curve features and pairwise terms, 2D and 3D).
TERMS = ("length", "area", "ellipticity", "area_xy", "area_yz", "area_xz", "ellipticity_xy", "ellipticity_yz",
         "ellipticity_xz", "self_intersections", "anchor_distance", "anchor_angle", "points", "turning", "efd")


class CurveEntry(SpecModel):
    """One curve: its points, or a source (``file.csv`` or ``result.h5:track``, relative to the set)."""

    name: Name
    points: list[list[Finite]] | None = pydantic.Field(default=None, min_length=3)
    source: str | None = pydantic.Field(default=None, min_length=1)
    #: Closed (cyclic) or open; detected from the ends when not given.
    closed: bool | None = None
    #: A point compared along with the curve (e.g. the crank axle), same units and dimension.
    anchor: list[Finite] | None = None


class CurveSet(SpecModel):
    """A named set of motion curves to compare (2D or 3D, not mixed)."""

    name: Name | None = None
    description: str | None = None
    units: Name | None = None
    curves: list[CurveEntry] = pydantic.Field(min_length=1)

    @pydantic.model_validator(mode="after")
    def _check_curves(self) -> "CurveSet":
        seen: set[str] = set()
        for i, c in enumerate(self.curves):
            if c.name in seen:
                raise InputError(f"two curves are named {c.name!r}", field=("curves", i, "name"))
            seen.add(c.name)
            if (c.points is None) == (c.source is None):
                raise InputError("give either points or source", field=("curves", i))
            if c.points is not None:
                dim = len(c.points[0])
                for k, p in enumerate(c.points):
                    if len(p) not in (2, 3) or len(p) != dim:
                        raise InputError(f"every point needs the same 2 or 3 coordinates (the first has {dim})",
                                         field=("curves", i, "points", k))
            if c.anchor is not None and len(c.anchor) not in (2, 3):
                raise InputError("an anchor has 2 or 3 coordinates", field=("curves", i, "anchor"))
        return self


class CurveWeights(SpecModel):
    """Weights of the curve distance; terms not listed weigh 0."""

    description: str | None = None
    #: Resampling and harmonics the weights were fitted with (used unless the command line says otherwise).
    samples: Samples | None = None
    harmonics: Harmonics | None = None
    weights: dict[str, Weight] = pydantic.Field(min_length=1)

    @pydantic.field_validator("weights")
    @classmethod
    def _terms(cls, weights: dict[str, float]) -> dict[str, float]:
        for name in weights:
            if name not in TERMS:
                raise InputError(f"unknown term {name!r} (terms: {', '.join(TERMS)})", field=("weights", name))
        if not any(w > 0 for w in weights.values()):
            raise InputError("at least one weight must be positive", field=("weights",))
        return weights


class LabelledPairs(SpecModel):
    """Curve pairs labelled similar or dissimilar (Coros et al. 2013, §5.2)."""

    description: str | None = None
    #: Curve inputs (curve sets, CSV files, result.h5:track), relative to this file.
    curves: list[str] = pydantic.Field(min_length=1)
    similar: list[tuple[str, str]] = pydantic.Field(min_length=1)
    dissimilar: list[tuple[str, str]] = pydantic.Field(min_length=1)
    samples: Samples | None = None
    harmonics: Harmonics | None = None
    #: Weight of the regularizer λ Σ w_m (keeps weights small and sparse).
    regularization: NonNegative = 1e-3
    #: Terms to learn (default: all terms of the curves' dimension).
    terms: list[str] | None = pydantic.Field(default=None, min_length=1)

    @pydantic.field_validator("terms")
    @classmethod
    def _terms(cls, terms: list[str] | None) -> list[str] | None:
        if terms is not None:
            for i, name in enumerate(terms):
                if name not in TERMS:
                    raise InputError(f"unknown term {name!r} (terms: {', '.join(TERMS)})", field=("terms", i))
        return terms
