"""Shared pieces of the input models: strict config, finite numbers."""

from __future__ import annotations

from typing import Annotated

import pydantic

#: Every spec model: unknown keys are errors, NaN/inf are errors, models are immutable.
STRICT = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

#: A finite real number; ``true``/``false`` or a quoted number are errors, not 1/0 (strict).
Finite = Annotated[float, pydantic.Strict(), pydantic.Field(allow_inf_nan=False)]
#: A whole number (sample counts, sizes); booleans and 3.0 are errors (strict).
Count = Annotated[int, pydantic.Strict()]
#: Largest weight of an objective or distance term: beyond it, sums of squares overflow.
MAX_WEIGHT = 1e12
Vec2 = tuple[Finite, Finite]
Vec3 = tuple[Finite, Finite, Finite]
#: A name of a joint, link, track, member…: becomes an HDF5 group name, so no "/", no leading "."
#: and no control characters (NUL ends a name in HDF5).
Name = Annotated[str, pydantic.StringConstraints(min_length=1, strip_whitespace=True, pattern=r"^[^/.\x00-\x1f][^/\x00-\x1f]*$")]


class SpecModel(pydantic.BaseModel):
    """Base of every spec model."""

    model_config = STRICT
