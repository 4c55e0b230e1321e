"""Which atlas hits and candidates go on to refinement: the hits of several queries merged (:func:`union`), those
whose linkage works with the asked margin (:func:`within`), and a shortlist of distinct candidates (:func:`diverse`):
planar (:mod:`linkedit.synthesis.synthesize`) and spatial (:mod:`linkedit.synthesis.spatial`)."""

from __future__ import annotations

from typing import Protocol, TypeVar

import numpy as np

from linkedit.errors import MechanismError
from linkedit.planar import feasibility
from linkedit.synthesis.atlas import Atlas
from linkedit.synthesis.families import family
from linkedit.synthesis.index import Hit

#: Candidates of one family whose parameters differ by less than this (RMS, family frame) are near-copies:
#: the refined shortlist takes distinct ones first (several starts, not one start several times).
NEAR = 0.05


def union(*found: list[Hit]) -> list[Hit]:
    """The hits of several queries, each linkage once (at its smallest distance), nearest first."""
    best: dict[tuple[str, int], Hit] = {}
    for h in (h for hits in found for h in hits):
        if (h.family, h.row) not in best or h.distance < best[h.family, h.row].distance:
            best[h.family, h.row] = h
    return sorted(best.values(), key=lambda h: h.distance)


def within(hits: list[Hit], atlas: Atlas, margin_deg: float) -> list[Hit]:
    """The hits whose linkage turns the full cycle with its lowest d_s ≥ its family's margin at the band
    ``margin_deg`` (``fam.margin(margin_deg)``: sin² μ, a numeric group's at most its design's own; by the
    one planar predicate: the atlas may have been built by a version that checked fewer samples);
    MechanismError if none does (a band narrower than the atlas's, or an atlas edited by hand)."""
    kept = []
    for fam_name in dict.fromkeys(h.family for h in hits):
        mine = [h for h in hits if h.family == fam_name]
        fam = family(fam_name)
        margin = fam.margin(margin_deg)
        ds = fam.min_singularity(atlas.families[fam_name]["params"][[h.row for h in mine]], margin)
        kept += [h for h, ok in zip(mine, feasibility.works(ds, margin)) if ok]
    if not kept:
        raise MechanismError(f"none of the {len(hits)} nearest atlas linkages turns the full cycle with the "
                             f"transmission angle within [{margin_deg:g}°, {180 - margin_deg:g}°] (--margin "
                             f"{margin_deg:g}): rebuild the atlas with `linkedit atlas build`, or ask for a wider band")
    return sorted(kept, key=lambda h: h.distance)


class _Choice(Protocol):
    family: str
    params: np.ndarray


#: a candidate of any kind :func:`diverse` chooses among (planar, or spatial: :mod:`linkedit.synthesis.spatial`)
C = TypeVar("C", bound=_Choice)


def diverse(candidates: list[C], count: int) -> list[C]:
    """The first ``count`` of ``candidates`` (best first) that are not near-copies of one taken
    before: same family and parameters within ``NEAR`` (RMS over the parameters, family frame);
    near-copies fill up the list only if too few distinct ones remain."""
    taken: list[C] = []
    for c in candidates:
        if len(taken) == count:
            break
        if all(t.family != c.family or np.sqrt(np.mean((t.params - c.params) ** 2)) > NEAR for t in taken):
            taken.append(c)
    rest = [c for c in candidates if all(c is not t for t in taken)]
    return taken + rest[:count - len(taken)]
