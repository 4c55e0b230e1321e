"""The families an atlas can hold: name → module with the family interface.

Besides the built-in ones, any planar linkage spec with a cyclic input (a full-turn crank, an
oscillating crank, a linear input out and back) — dyads, rigid links, sliders, slots, slotted links, or
numeric groups (complex loops: each linkage continued from its own rest pose, K linkages per call,
:func:`~linkedit.planar.rules.general_group.solve_group`) — is a family (:func:`spec_family`: ``atlas build --family examples/klann.yaml``): its rest pose is
sampled around the design like the catalog families (:class:`~linkedit.synthesis.legs.CatalogFamily`),
its first joint track is the curve, and the atlas keeps its spec text so that synthesis (and a Dask
worker) rebuilds it by name.

A family (a module, or a :class:`~linkedit.synthesis.legs.CatalogFamily`) provides ``NAME``,
``PARAMETERS``, ``ID`` (a small integer mixed into chunk seeds), ``margin()``, ``sample(rng, count)``,
``min_singularity(params, margin=None)`` (the lowest d_s over the cycle, which the one planar
predicate :func:`linkedit.planar.feasibility.works` holds to a margin: exact in closed form, or
:func:`~linkedit.planar.feasibility.lowest` at its samples), ``curves(params, samples, phase)``
(K, T) complex in the family frame, and ``to_spec(...)``. A spatial family (:mod:`~linkedit.synthesis.spherical`,
:mod:`~linkedit.synthesis.rssr`) has ``DIM = 3``: its curves are (K, T, 3) and its ``to_spec`` gives a 3D
mechanism spec (:mod:`linkedit.synthesis.spatial`).
"""

from __future__ import annotations

from typing import Any

import threading
import zlib
from pathlib import Path

import numpy as np

from linkedit.errors import InputError, LinkeditError
from linkedit.planar.plan import compile_plan
from linkedit.spec.linkage import JointTrack, LinkageSpec
from linkedit.spec.yamlload import load_yaml, read_text, validate
from linkedit.synthesis import fourbar, rssr, slidercrank, spherical
from linkedit.synthesis.legs import JANSEN, KLANN, STEPHENSON, WATT, CatalogFamily

FAMILIES: dict[str, Any] = {fourbar.NAME: fourbar, slidercrank.NAME: slidercrank,
                            **{f.NAME: f for f in (JANSEN, KLANN, WATT, STEPHENSON)},
                            spherical.NAME: spherical, rssr.NAME: rssr}


#: families made from linkage specs, by name (:func:`spec_family`)
SPECS: dict[str, CatalogFamily] = {}
#: the spec text each of them was made from (stored in an atlas, sent to Dask workers)
SPEC_TEXTS: dict[str, str] = {}
#: every family made from a spec in this process, by (name, text) (:func:`of_text`), and the lock of both registers
_MADE: dict[tuple[str, str], CatalogFamily] = {}
_MAKING = threading.RLock()


def family(name: str, field: str = "--family", spec: str | None = None) -> Any:
    """The family called ``name`` (built in, or made from a spec: with ``spec``, its YAML text, it
    is made here if it is not yet); an InputError naming the known ones otherwise."""
    if name in FAMILIES:
        return FAMILIES[name]
    if spec is not None:
        return from_spec_text(name, spec, field=field)
    if name in SPECS:
        return SPECS[name]
    raise InputError(f"unknown family {name!r} (families: {', '.join(FAMILIES)}, or a linkage spec file)", field=field)


def of_text(name: str, spec: str | None) -> Any:
    """The family called ``name`` of spec text ``spec`` (a built-in one when None), whatever this process knows by
    that name: what a task uses (each carries its atlas's text; a Dask worker's threads serve many ``linkedit`` runs
    and atlases at once, two of whose linkages may share a name). Made once per text, shared by the threads."""
    if spec is None:
        return family(name)
    with _MAKING:
        fam = _MADE.get((name, spec))
    return fam if fam is not None else from_spec_text(name, spec, register=False)


def spec_family(path: Path, field: str = "--family") -> str:
    """Make the family of the linkage spec at ``path`` and return its name (the spec's ``name``)."""
    text = read_text(path)
    data, lines = load_yaml(str(path), text)
    spec = validate(LinkageSpec, data, file=str(path), lines=lines)
    return from_spec_text(spec.name, text, field=field, file=str(path)).NAME


def from_spec_text(name: str, text: str, *, field: str = "--family", file: str | None = None,
                   register: bool = True) -> CatalogFamily:
    """The family ``name`` of the linkage spec ``text``: a cyclic input (a crank's full turn or
    swing, a linear input's stroke out and back), a joint track (its
    first) as the curve. InputError (one line naming the spec and why) otherwise, or when a
    different spec was already made under that name (``register``: this run's family of that name from now on)
    or it is a built-in family's name."""
    where = file or field
    if name in FAMILIES:
        raise InputError(f"the spec's name {name!r} is a built-in family's: rename the linkage", file=file, field=field)
    with _MAKING:
        if register and name in SPECS:
            if SPEC_TEXTS[name] != text:
                raise InputError(f"two different linkages are called {name!r} (their spec texts differ; an atlas keeps "
                                 "the text it was built from): rename one", file=file, field=field)
            return SPECS[name]
        if (name, text) in _MADE:
            fam = _MADE[name, text]
            if register:
                SPECS[name], SPEC_TEXTS[name] = fam, text
            return fam
    data, lines = load_yaml(where, text)
    spec = validate(LinkageSpec, data, file=where, lines=lines)
    cannot = f"linkage {name!r} cannot be a family"
    if spec.motor.range_deg is not None:
        raise InputError(f"{cannot}: its motor sweeps range_deg once, not a cycle (give oscillate_deg "
                         "for a swing back and forth)", file=file, field=field)
    track, joint = next(((n, t.joint) for n, t in spec.tracks.items() if isinstance(t, JointTrack)), (None, None))
    if track is None:
        raise InputError(f"{cannot}: it tracks no joint (a family's curve is its first joint track)",
                         file=file, field=field)
    try:
        compile_plan(spec)
    except LinkeditError as exc:
        raise InputError(f"{cannot}: {exc}", file=file, field=field) from None
    made = CatalogFamily(name, 1000 + zlib.crc32(text.encode()) % 100_000, lambda: spec, track)
    z = made.curves(made.base[None], 64)[0]
    z = z[np.isfinite(z)]
    if z.size and np.abs(z - z[0]).max() <= 1e-9:  # family frame: the design's largest extent is 1
        raise InputError(f"{cannot}: its first joint track {track!r} (joint {joint!r}) does "
                         "not move over the cycle (its curve is one point): track a moving joint first",
                         file=file, field=field)
    with _MAKING:
        fam = _MADE.setdefault((name, text), made)
        if register:
            SPECS[name], SPEC_TEXTS[name] = fam, text
    return fam
