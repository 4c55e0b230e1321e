"""The chunk builder: one chunk of an atlas, a pure function of (family, seed, chunk index).

A chunk's generator is seeded with ``[seed, family ID, index]``; it draws parameter rows from the
family's distribution until ``size`` of them turn the full cycle with the singularity margin (the one
planar predicate, :mod:`linkedit.planar.feasibility`), evaluates them in one array evaluation per block
(over linkages and samples), and describes each coupler curve. Chunks therefore give the same bytes
in-process or on a Dask worker (:mod:`linkedit.synthesis.cluster`), in any order; the atlas file
(:mod:`linkedit.synthesis.atlas`) and the sharded atlas (:mod:`linkedit.synthesis.shards`) store them.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from linkedit.curves.efd import polyline_efd
from linkedit.curves.normalize import normalize
from linkedit.errors import MechanismError
from linkedit.planar.feasibility import works
from linkedit.synthesis.families import of_text

#: Linkages per chunk (the unit of work and of seeding).
CHUNK = 10_000
#: Curve samples per cycle used for the descriptors (uniform in crank angle).
SAMPLES = 64
#: Every ``COARSE_STEP``-th sample is stored: curves at SAMPLES / COARSE_STEP points.
COARSE_STEP = 2
#: Elliptic Fourier harmonics of the index descriptor.
HARMONICS = 8
#: Linkages evaluated together inside a chunk (their working arrays stay in the CPU cache).
BLOCK = 1024
#: Drawn rows screened together first, and seconds a screening block aims at after that (see :func:`reporting`).
FIRST_SCREEN, SCREEN_SECONDS = 32, 0.5
#: A chunk gives up (MechanismError) once it has drawn at least ``HOPELESS_DRAWS`` rows and kept fewer than one in
#: ``HOPELESS_RATIO`` of them: a family around a design that locks up, whose atlas would take hours.
HOPELESS_DRAWS, HOPELESS_RATIO = 20_000, 1_000



def dimension(fam: object) -> int:
    """2 for a planar family (curves (K, T) complex), 3 for a spatial one (``DIM = 3``: curves (K, T, 3))."""
    return int(getattr(fam, "DIM", 2))


def index_efd(z: np.ndarray) -> np.ndarray:
    """Normalized arc-length EFDs (K, H, 4) of closed curves: planar z (K, T) complex
    (:func:`~linkedit.curves.efd.polyline_efd`), spatial (K, T, 3) those of their projection onto their
    principal plane (:func:`~linkedit.curves.normalize.normalize`, as ``linkedit features`` describes 3D curves)."""
    if z.ndim == 3:
        p = normalize(z, True, SAMPLES).points
        z = p[..., 0] + 1j * p[..., 1]
    return polyline_efd(z, HARMONICS)


def index_vector(efd: np.ndarray) -> np.ndarray:
    """Normalized EFDs (K, H, 4) → the index descriptor (K, 4H − 3): everything but the
    first harmonic's a₁ = 1, b₁ = c₁ = 0, which normalization fixes."""
    flat = efd.reshape(len(efd), -1)
    return np.ascontiguousarray(flat[:, 3:])


@dataclass(frozen=True)
class Chunk:
    """One chunk of an atlas (K linkages)."""

    params: np.ndarray  #: (K, P) float64 family parameters
    min_ds: np.ndarray  #: (K,) smallest d_s over the cycle
    index: np.ndarray  #: (K, 4H − 3) float32 index descriptor
    curves: np.ndarray  #: (K, SAMPLES / COARSE_STEP, 2 or 3) float32 coarse curves, family frame


def build_chunk(name: str, seed: int, index: int, size: int = CHUNK, spec: str | None = None) -> Chunk:
    """Chunk ``index`` of family ``name``'s atlas from ``seed`` (a pure function); ``spec``: the
    linkage spec text of a family made from a spec (:func:`~linkedit.synthesis.families.of_text`). MechanismError
    when its draws hardly ever work (:data:`HOPELESS_DRAWS`, :data:`HOPELESS_RATIO`)."""
    fam = of_text(name, spec)
    rng = np.random.default_rng([seed, fam.ID, index])
    margin = fam.margin()
    kept: list[np.ndarray] = []
    kept_ds: list[np.ndarray] = []
    have = drawn = 0
    step = FIRST_SCREEN
    while have < size:
        if drawn >= HOPELESS_DRAWS and have * HOPELESS_RATIO < drawn:
            raise MechanismError(f"family {name!r}: only {have} of {drawn:,} linkages drawn around its design turn the "
                                 f"full cycle with the atlas's singularity margin (d_s >= {margin:.3g}); make the "
                                 "design itself turn well clear of its lock-ups (`linkedit simulate` names them and "
                                 "its lowest d_s)")
        draw = fam.sample(rng, 2 * (size - have) + 16)
        drawn += len(draw)
        ds, screened, start = np.empty(len(draw)), have, 0
        while start < len(draw):  # a row's d_s is its own: the blocks change no byte
            began, part = time.perf_counter(), slice(start, start + step)
            ds[part] = fam.min_singularity(draw[part], margin)
            screened += int(works(ds[part], margin).sum())
            report_kept(min(size, screened))
            start += step
            step = int(np.clip(step * SCREEN_SECONDS / max(time.perf_counter() - began, 1e-6), step,
                               min(2 * step, len(draw))))
        keep = works(ds, margin)
        kept.append(draw[keep])
        kept_ds.append(ds[keep])
        have += int(keep.sum())
    params = np.concatenate(kept)[:size]
    desc = np.empty((size, 4 * HARMONICS - 3), dtype=np.float32)
    coarse = np.empty((size, SAMPLES // COARSE_STEP, dimension(fam)), dtype=np.float32)
    for start in range(0, size, BLOCK):
        z = fam.curves(params[start:start + BLOCK], SAMPLES)
        desc[start:start + BLOCK] = index_vector(index_efd(z))
        coarse[start:start + BLOCK] = coarse_curves(z)
    return Chunk(params, np.concatenate(kept_ds)[:size], desc, coarse)


#: each thread's progress callback (:func:`reporting`): a Dask worker may run a task in each of its threads
_local = threading.local()


@contextlib.contextmanager
def reporting(callback: Callable[[int], None]) -> Iterator[None]:
    """Within the block, a chunk built in this thread calls ``callback(kept)`` as its draws are screened
    (linkages of the chunk kept so far): a slow family's progress moves inside a chunk (on Dask, the client
    hears the tasks' counts: :func:`~linkedit.synthesis.cluster.chunk_runner`). The screening blocks grow from
    :data:`FIRST_SCREEN` rows towards :data:`SCREEN_SECONDS` each (at most doubling)."""
    before, _local.callback = getattr(_local, "callback", None), callback
    try:
        yield
    finally:
        _local.callback = before


def report_kept(kept: int) -> None:
    """``kept`` linkages screened so far, to this thread's :func:`reporting` callback, if any."""
    callback = getattr(_local, "callback", None)
    if callback is not None:
        callback(kept)


def coarse_curves(z: np.ndarray) -> np.ndarray:
    """The coarse curves an atlas stores (K, SAMPLES / COARSE_STEP, 2 or 3) of curves ``z`` at SAMPLES samples:
    planar (K, SAMPLES) complex or spatial (K, SAMPLES, 3); float64 (the atlas stores them as float32)."""
    part = z[:, ::COARSE_STEP]
    return part if part.ndim == 3 else np.stack([part.real, part.imag], axis=2)


#: Bytes a build holds whatever its size (it streams): the working arrays of one chunk being built (peak 17 MB
#: for four-bars, 50–75 MB for the catalog six- and eight-bars at 2,000 rows: tracemalloc), with room to spare,
#: and per chunk of the build the client's plan and manifest entry (:func:`build_memory`).
CHUNK_MEMORY = 256 << 20
PLAN_MEMORY = 1024


def build_memory(count: int) -> int:
    """Bytes of memory a build of ``count`` linkages (one family) needs in the client's process."""
    return CHUNK_MEMORY + PLAN_MEMORY * -(-count // CHUNK)


def chunk_sizes(count: int, first: int = 0) -> list[tuple[int, int]]:
    """(index, size) of the chunks holding ``count`` linkages, numbered from ``first``."""
    return [(first + k, min(CHUNK, count - k * CHUNK)) for k in range((count + CHUNK - 1) // CHUNK)]



def build_chunks(name: str, seed: int, jobs: list[tuple[int, int]], spec: str | None = None) -> list[Chunk]:
    """Chunks ``jobs`` ((index, size) pairs) of family ``name``'s atlas: one Dask task (``spec``: as
    :func:`build_chunk`'s, so a worker can make a family from a spec)."""
    return [build_chunk(name, seed, index, size, spec) for index, size in jobs]
