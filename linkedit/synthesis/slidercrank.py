"""The slider-crank family: a crank-driven offset slider-crank with a coupler point anywhere on the rod's plane.

Family frame (rod length 1): crank axle O = 0, crank pin A = a·e^{iθ} turning
counter-clockwise (θ = 2π t, t = 0 the rest pose), slider pin B on the slot line y = e
(direction +x) at distance 1 from A, on the side ``branch`` = ±1 (B_x − A_x = branch·sqrt(1 − p²),
p = e − A_y: :mod:`linkedit.planar.rules.slider`), coupler point P = A + (u + iv)(B − A).

Parameters per linkage, columns of a (K, 5) array: a, e, u, v, branch. They are the constants
of one compiled plan (slider A → B, P rigid on the rod): curves and poses are the planar engine's
evaluation of K linkages (:class:`~linkedit.synthesis.legs.CatalogFamily`), as for every family.

The rod reaches the line at every crank angle with d_s = 1 − p² (the engine's slider d_s:
sin² of the angle between rod and slot normal) at least sin² MU_MIN exactly when
|e| + a ≤ cos MU_MIN: p's extreme over the cycle is |e| + a (at θ = ±90°) — a closed form.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.feasibility import margin_of
from linkedit.planar.plan import Geometry
from linkedit.spec.linkage import LinkageSpec
from linkedit.synthesis.legs import CatalogFamily, constant_geometry, expect_rules

NAME = "slider-crank"
ID = 6
PARAMETERS = ("a", "e", "u", "v", "branch")
#: Smallest transmission angle kept in an atlas (degrees); the singularity margin is sin² of it.
MU_MIN_DEG = 20.0
#: The catalog slider-crank (crank 20, rod 70, offset 12, coupler point at (0.5 + 0.3i) along the rod), family frame.
SEEDS = np.array([[20 / 70, 12 / 70, 0.5, 0.3, 1.0]])


def margin(margin_deg: float = MU_MIN_DEG) -> float:
    """The singularity margin min d_s = sin² μ its linkages keep in the transmission band [μ, 180° − μ]
    (μ = ``margin_deg``; an atlas linkage's: MU_MIN_DEG)."""
    return margin_of(margin_deg)


def min_singularity(params: np.ndarray, margin: float | None = None) -> np.ndarray:
    """min over the continuous cycle of d_s = 1 − p² at the slider, (K,), exact (``margin`` is not
    needed); −1 where the rod cannot reach the line."""
    reach = np.abs(params[:, 1]) + params[:, 0]
    return np.where(reach <= 1.0, 1.0 - reach * reach, -1.0)


def sample(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` parameter rows from the family's distribution (not yet filtered):

    three quarters over a wide range — a log-uniform in [0.05, 0.95], e uniform in [−0.9, 0.9],
    u uniform in [−1.5, 2.5], v uniform in [−2, 2], branch ±1 — and one quarter around the
    catalog slider-crank: a times e^{N(0, 0.2²)}, e, u and v plus N(0, 0.1²), N(0, 0.3²), branch kept.
    """
    wide = count - count // 4
    out = np.empty((count, 5))
    out[:wide, 0] = np.exp(rng.uniform(np.log(0.05), np.log(0.95), wide))
    out[:wide, 1] = rng.uniform(-0.9, 0.9, wide)
    out[:wide, 2] = rng.uniform(-1.5, 2.5, wide)
    out[:wide, 3] = rng.uniform(-2.0, 2.0, wide)
    out[:wide, 4] = rng.choice([-1.0, 1.0], wide)
    near = count - wide
    base = SEEDS[rng.integers(0, len(SEEDS), near)]
    out[wide:, 0] = base[:, 0] * np.exp(rng.normal(0.0, 0.2, near))
    out[wide:, 1] = base[:, 1] + rng.normal(0.0, 0.1, near)
    out[wide:, 2:4] = base[:, 2:4] + rng.normal(0.0, 0.3, (near, 2))
    out[wide:, 4] = base[:, 4]
    return out


class _Core(CatalogFamily):
    """The slider-crank's topology (:func:`_topology`) evaluated by the planar engine: a parameter row
    gives the plan's constants directly (B on the slot y = e, direction +x, at distance 1 from A on
    the side ``branch``; P = A + (u + iv)(B − A) rigid on the rod)."""

    def geometry(self, params: np.ndarray) -> Geometry:
        """The constants of K rows (K, 5)."""
        a, e, u, v, branch = (params[:, i:i + 1] for i in range(5))  # (K, 1) each
        one = np.ones_like(a)
        return constant_geometry(self.plan, pivot=0.0, arm=a, ground=(0.0,),
                                 constants=((one + 0j, 1j * e, one, branch), (u[None] + 1j * v[None],)))


def _topology() -> LinkageSpec:
    """O, A, the slider pin B and the coupler point P (a joint of the rod, tracked as ``target``):
    the topology only, every linkage's dimensions come from its row."""
    return LinkageSpec.model_validate({
        "name": NAME, "units": "1", "joints": {"O": [0, 0], "A": [0.5, 0], "B": [1.5, 0.2], "P": [1, 1]},
        "ground": ["O"], "links": {"crank": ["O", "A"], "rod": ["A", "B", "P"]},
        "sliders": {"piston": {"joint": "B", "guide": "ground", "angle_deg": 0.0}},
        "motor": {"joint": "A", "pivot": "O"}, "tracks": {"target": {"joint": "P"}}})


CORE = _Core(NAME, ID, _topology, "target")
expect_rules(CORE.plan, ("slider", ("A", "B")), ("rigid", ("A", "B", "P")))


def curves(params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    """Coupler-point curves (K, T) complex in the family frame at θ = 2π(phase + t/T), t = 0..T−1
    (``phase`` a number or (K,)): the planar engine's one evaluation of K linkages; NaN where the
    rod cannot reach the line."""
    return CORE.curves(params, samples, phase)


def to_spec(row: np.ndarray, *, phase: float, scale: float, turn: complex, shift: complex, mirrored: bool,
            name: str, units: str, description: str, reversed: bool = False) -> LinkageSpec:
    """The linkage of parameter ``row`` at crank phase ``phase``, placed by z ↦ shift + scale·turn·z
    (z conjugated first when ``mirrored``, which also reverses the motor; ``reversed`` reverses
    it again), track ``target`` = P on the rod.

    ``turn`` is a unit complex number (the rotation); the slot's direction is turn·1 (a mirror keeps the x axis).
    """
    _, pin, slider, point = CORE.pose(row, phase)

    def place(z: complex) -> list[float]:
        w = shift + scale * turn * (z.conjugate() if mirrored else z)
        return [float(w.real), float(w.imag)]

    return LinkageSpec.model_validate({
        "name": name, "units": units, "description": description,
        "joints": {"O": place(0j), "A": place(pin), "B": place(slider)},
        "ground": ["O"],
        "links": {"crank": ["O", "A"], "rod": ["A", "B"]},
        "sliders": {"piston": {"joint": "B", "guide": "ground", "angle_deg": float(np.degrees(np.angle(turn)))}},
        "motor": {"joint": "A", "pivot": "O", "direction": "cw" if mirrored != reversed else "ccw"},
        "tracks": {"target": {"link": "rod", "at": place(point)}},
    })
