"""Shared pieces of the input models: strict config, finite numbers."""

from __future__ import annotations

import operator
from collections.abc import Callable
from typing import Annotated, ClassVar

import pydantic

from linkedit.errors import InputError

#: Every spec model: unknown keys are errors, NaN/inf are errors, models are immutable.
STRICT = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

#: A finite real number; ``true``/``false`` or a quoted number are errors, not 1/0 (strict).
Finite = Annotated[float, pydantic.Strict(), pydantic.Field(allow_inf_nan=False)]
#: A whole number (sample counts, sizes); booleans and 3.0 are errors (strict).
Count = Annotated[int, pydantic.Strict()]
#: Sample counts of a curve's descriptors (``--samples``) and its elliptic Fourier harmonics (``--harmonics``).
SAMPLES_RANGE, HARMONICS_RANGE = (8, 4096), (1, 64)
#: Largest weight of an objective or distance term: beyond it, sums of squares overflow.
MAX_WEIGHT = 1e12
Vec2 = tuple[Finite, Finite]
Vec3 = tuple[Finite, Finite, Finite]
#: A name of a joint, link, track, member…: becomes an HDF5 group name, so no "/", no leading "."
#: and no control characters (NUL ends a name in HDF5). Errors say so in words (:func:`name_problem`).
NAME_PATTERN = r"^[^/.\x00-\x1f][^/\x00-\x1f]*$"
Name = Annotated[str, pydantic.StringConstraints(min_length=1, strip_whitespace=True, pattern=NAME_PATTERN)]


def name_problem(text: str) -> str:
    """What is wrong with ``text`` as a :data:`Name`, in words (``""`` if nothing is)."""
    if not text:
        what = "is empty"
    elif "/" in text:
        what = "has a '/'"
    elif text.startswith("."):
        what = "begins with '.'"
    elif any(ord(c) < 0x20 for c in text):
        bad = next(c for c in text if ord(c) < 0x20)
        what = f"has the control character {bad!r}"
    else:
        return ""
    return (f"the name {text!r} {what}: a name may hold any characters but '/' and control characters, "
            "and may not begin with '.' (it becomes an HDF5 group name)")


#: a custom constraint's ``python:`` reference, ``package.module:function``
PYTHON_PATTERN = r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$"

#: the words a pattern's mismatch is reported in, by pattern (never the pattern itself)
PATTERN_WORDS: dict[str, Callable[[str], str]] = {
    NAME_PATTERN: name_problem,
    PYTHON_PATTERN: lambda text: (f"{text!r} is not module:function: a Python module path (letters, digits, '_' "
                                  "and '.'), a ':', then a function name (letters, digits and '_')"),
}


#: the kinds of mechanism spec: (what it is, the command that reads it, the top-level keys only it has)
SPEC_KINDS: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "planar": ("a planar linkage spec", "linkedit simulate", ("ground", "links", "motor", "sliders")),
    "3d": ("a 3D mechanism spec", "linkedit solve3d", ("shapes", "members", "constraints", "inputs", "outputs")),
}


class SpecModel(pydantic.BaseModel):
    """Base of every spec model."""

    model_config = STRICT
    #: for a top-level mechanism spec, its key in :data:`SPEC_KINDS` (a document of another kind is named so)
    spec_kind: ClassVar[str | None] = None


def require_count(value: object, field: str, low: int, high: int | None = None) -> int:
    """``value`` as a whole number in [low, high] (a library caller's count, as the CLI's options
    check theirs); InputError naming ``field`` otherwise: 0, 2.5 or True is not a count."""
    try:
        count = operator.index(value) if not isinstance(value, bool) else None  # type: ignore[arg-type]
    except TypeError:
        count = None
    if count is None or count < low or (high is not None and count > high):
        span = f"between {low:,} and {high:,}" if high is not None else f"at least {low:,}"
        raise InputError(f"{field} must be a whole number {span}, not {value!r}", field=field)
    return count
