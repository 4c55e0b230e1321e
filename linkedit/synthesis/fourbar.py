"""The four-bar family: a crank-driven four-bar with a coupler point anywhere on the coupler plane.

Family frame (ground length 1): crank axle O = 0, rocker pivot D = 1, crank pin
A = a·e^{iθ} turning counter-clockwise (θ = 2π t, t = 0 the rest pose), coupler pin B at
distances b from A and c from D on the side ``branch`` = ±1 of A→D, coupler point
P = A + (u + iv)(B − A).

Parameters per linkage, columns of a (K, 6) array: a, b, c, u, v, branch. They are the constants
of one compiled plan (dyad A, D → B, P rigid on the coupler): curves and poses are the planar
engine's evaluation of K linkages (:class:`~linkedit.synthesis.legs.CatalogFamily`), as for every family.

The crank turns the full cycle with a transmission angle μ (the angle at B, d_s = sin²μ)
inside [MU_MIN, 180° − MU_MIN] exactly when cos μ = (b² + c² − |A − D|²)/(2bc) stays within
±cos MU_MIN for |A − D| between |1 − a| and 1 + a (its extremes, at θ = 0 and π): a closed
form, no sampling.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.feasibility import margin_of
from linkedit.planar.plan import Geometry
from linkedit.spec.linkage import LinkageSpec
from linkedit.synthesis.legs import CatalogFamily, constant_geometry, expect_rules

NAME = "four-bar"
ID = 1
PARAMETERS = ("a", "b", "c", "u", "v", "branch")
#: Smallest transmission angle kept in an atlas (degrees); the singularity margin is sin² of it.
MU_MIN_DEG = 20.0
#: The catalog four-bars (family frame) the distribution also samples around: crank-rocker, Hoekens.
SEEDS = np.array([[25 / 75, 70 / 75, 60 / 75, 0.2926414, 0.5, 1.0],
                  [0.5, 1.25, 1.25, 2.0, 0.0, 1.0]])
#: Shares of a draw (:func:`sample`): crank shorter than the ground, drag links, around the catalog designs.
SHARES = (5 / 8, 1 / 8, 1 / 4)


def margin(margin_deg: float = MU_MIN_DEG) -> float:
    """The singularity margin min d_s = sin² μ its linkages keep in the transmission band [μ, 180° − μ]
    (μ = ``margin_deg``; an atlas linkage's: MU_MIN_DEG)."""
    return margin_of(margin_deg)


def min_singularity(params: np.ndarray, margin: float | None = None) -> np.ndarray:
    """min over the continuous cycle of d_s = sin²μ at B, (K,), exact (so ``margin``, which lets a
    sampled family skip work, is not needed); −1 where the crank cannot turn fully."""
    a, b, c = params[:, 0], params[:, 1], params[:, 2]
    out = np.full(len(params), np.inf)
    for d in (np.abs(1.0 - a), 1.0 + a):
        cos_mu = (b * b + c * c - d * d) / (2.0 * b * c)
        out = np.minimum(out, np.where(np.abs(cos_mu) <= 1.0, 1.0 - cos_mu * cos_mu, -1.0))
    return out


def sample(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` parameter rows from the family's distribution (not yet filtered), three kinds by
    Grashof type in fixed shares of the draw (:data:`SHARES`):

    * crank shorter than the ground (crank-rockers, 5/8): a log-uniform in [0.05, 1], b, c
      log-uniform in [0.2, 4];
    * drag links (ground the shortest link, crank and rocker both turn fully; 1/8): a
      log-uniform in [1.5, 5] (below 1.5 none keeps the 20° band), b/a, c/a log-uniform in [0.5, 2];
    * around the catalog designs (crank-rocker, Hoekens; 1/4): lengths times e^{N(0, 0.2²)},
      u, v plus N(0, 0.3²), branch kept.

    The first two take u uniform in [−1.5, 2.5], v uniform in [−2, 2], branch ±1. Of the rows that
    keep the 20° band about 16 % are drag links, 32 % the wide crank-rockers, 52 % near the catalog.
    """
    crank, drag = (int(count * share) for share in SHARES[:2])
    wide = crank + drag
    out = np.empty((count, 6))
    out[:crank, 0] = np.exp(rng.uniform(np.log(0.05), 0.0, crank))
    out[:crank, 1:3] = np.exp(rng.uniform(np.log(0.2), np.log(4.0), (crank, 2)))
    out[crank:wide, 0] = np.exp(rng.uniform(np.log(1.5), np.log(5.0), drag))
    out[crank:wide, 1:3] = out[crank:wide, :1] * np.exp(rng.uniform(np.log(0.5), np.log(2.0), (drag, 2)))
    out[:wide, 3] = rng.uniform(-1.5, 2.5, wide)
    out[:wide, 4] = rng.uniform(-2.0, 2.0, wide)
    out[:wide, 5] = rng.choice([-1.0, 1.0], wide)
    near = count - wide
    base = SEEDS[rng.integers(0, len(SEEDS), near)]
    out[wide:, :3] = base[:, :3] * np.exp(rng.normal(0.0, 0.2, (near, 3)))
    out[wide:, 3:5] = base[:, 3:5] + rng.normal(0.0, 0.3, (near, 2))
    out[wide:, 5] = base[:, 5]
    return out


class _Core(CatalogFamily):
    """The four-bar's topology (:func:`_topology`) evaluated by the planar engine: a parameter row
    gives the plan's constants directly (dyad A, D → B with l_AB = b, l_DB = c on the side
    ``branch``; P = A + (u + iv)(B − A) rigid on the coupler)."""

    def geometry(self, params: np.ndarray) -> Geometry:
        """The constants of K rows (K, 6)."""
        a, b, c, u, v, branch = (params[None, :, i:i + 1] for i in range(6))  # (1, K, 1) each
        b2, c2 = b * b, c * c
        return constant_geometry(self.plan, pivot=0.0, arm=a[0], ground=(0.0, 1.0),
                                 constants=((b2, c2, 0.5 * (b2 - c2), branch), (u + 1j * v,)))


def _topology() -> LinkageSpec:
    """O, A, B, D and the coupler point P (a joint of the coupler, tracked as ``target``): the
    topology only, every linkage's dimensions come from its row."""
    return LinkageSpec.model_validate({
        "name": NAME, "units": "1", "joints": {"O": [0, 0], "A": [0.5, 0], "B": [1, 1], "D": [1, 0], "P": [0.5, 1]},
        "ground": ["O", "D"], "links": {"crank": ["O", "A"], "coupler": ["A", "B", "P"], "rocker": ["D", "B"]},
        "motor": {"joint": "A", "pivot": "O"}, "tracks": {"target": {"joint": "P"}}})


CORE = _Core(NAME, ID, _topology, "target")
expect_rules(CORE.plan, ("dyad", ("A", "D", "B")), ("rigid", ("A", "B", "P")))


def curves(params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    """Coupler-point curves (K, T) complex in the family frame at θ = 2π(phase + t/T), t = 0..T−1
    (``phase`` a number or (K,)): the planar engine's one evaluation of K linkages; NaN where B
    cannot be placed."""
    return CORE.curves(params, samples, phase)


def to_spec(row: np.ndarray, *, phase: float, scale: float, turn: complex, shift: complex, mirrored: bool,
            name: str, units: str, description: str, reversed: bool = False) -> LinkageSpec:
    """The linkage of parameter ``row`` at crank phase ``phase``, placed by z ↦ shift + scale·turn·z
    (z conjugated first when ``mirrored``, which also reverses the motor; ``reversed`` reverses
    it again), track ``target`` = P.

    ``turn`` is a unit complex number (the rotation).
    """
    pose = dict(zip(CORE.plan.joint_names, CORE.pose(row, phase)))

    def place(z: complex) -> list[float]:
        w = shift + scale * turn * (z.conjugate() if mirrored else z)
        return [float(w.real), float(w.imag)]

    return LinkageSpec.model_validate({
        "name": name, "units": units, "description": description,
        "joints": {k: place(z) for k, z in pose.items() if k != "P"},
        "ground": ["O", "D"],
        "links": {"crank": ["O", "A"], "coupler": ["A", "B"], "rocker": ["D", "B"]},
        "motor": {"joint": "A", "pivot": "O", "direction": "cw" if mirrored != reversed else "ccw"},
        "tracks": {"target": {"link": "coupler", "at": place(pose["P"])}},
    })
