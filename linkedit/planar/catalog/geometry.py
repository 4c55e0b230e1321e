"""Exact rest poses: circle–circle intersections in double precision, and a spec from plain data."""

from __future__ import annotations

import math

from linkedit.spec.linkage import LinkageSpec


def meet(p: complex, r_p: float, q: complex, r_q: float, left: bool) -> complex:
    """The point at distance ``r_p`` from ``p`` and ``r_q`` from ``q``, on the left (or right) of p→q."""
    d = q - p
    dist = abs(d)
    along = (r_p * r_p - r_q * r_q + dist * dist) / (2.0 * dist)
    across = math.sqrt(r_p * r_p - along * along)
    return p + d / dist * complex(along, across if left else -across)


def xy(z: complex) -> tuple[float, float]:
    """A complex point as ``(x, y)``."""
    return (z.real, z.imag)


def linkage(joints: dict[str, complex], **fields: object) -> LinkageSpec:
    """Validate a spec given as plain data (joints as complex numbers)."""
    return LinkageSpec.model_validate({**fields, "joints": {n: xy(z) for n, z in joints.items()}})
