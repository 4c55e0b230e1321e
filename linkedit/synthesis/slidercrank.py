"""The slider-crank family: a crank-driven offset slider-crank with a coupler point anywhere on the rod's plane.

Family frame (rod length 1): crank axle O = 0, crank pin A = a·e^{iθ} turning
counter-clockwise (θ = 2π t, t = 0 the rest pose), slider pin B on the slot line y = e
(direction +x) at distance 1 from A, on the side ``branch`` = ±1 (B_x − A_x = branch·sqrt(1 − p²),
p = e − A_y: :mod:`linkedit.planar.rules.slider`), coupler point P = A + (u + iv)(B − A).

Parameters per linkage, columns of a (K, 5) array: a, e, u, v, branch.

The rod reaches the line at every crank angle with d_s = 1 − p² (the engine's slider d_s:
sin² of the angle between rod and slot normal) at least sin² MU_MIN exactly when
|e| + a ≤ cos MU_MIN: p's extreme over the cycle is |e| + a (at θ = ±90°) — a closed form.
"""

from __future__ import annotations

import numpy as np

from linkedit.planar.feasibility import margin_of
from linkedit.spec.linkage import LinkageSpec

NAME = "slider-crank"
ID = 6
PARAMETERS = ("a", "e", "u", "v", "branch")
#: Smallest transmission angle kept in an atlas (degrees); the singularity margin is sin² of it.
MU_MIN_DEG = 20.0
#: The catalog slider-crank (crank 20, rod 70, offset 12, coupler point at (0.5 + 0.3i) along the rod), family frame.
SEEDS = np.array([[20 / 70, 12 / 70, 0.5, 0.3, 1.0]])


def margin() -> float:
    """The singularity margin min d_s = sin² MU_MIN of an atlas linkage."""
    return margin_of(MU_MIN_DEG)


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


def _pins(params: np.ndarray, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Crank pins A and slider pins B (K, T) complex at crank angles ``angle`` (K or 1, T)."""
    a, e, branch = params[:, 0:1], params[:, 1:2], params[:, 4:5]
    pin = a * np.exp(1j * angle)
    p = e - pin.imag
    with np.errstate(invalid="ignore"):
        slider = pin.real + branch * np.sqrt(1.0 - p * p) + 1j * e
    return pin, slider


def curves(params: np.ndarray, samples: int, phase: np.ndarray | float = 0.0) -> np.ndarray:
    """Coupler-point curves (K, T) complex in the family frame at θ = 2π(phase + t/T), t = 0..T−1.

    One array evaluation over linkages and samples; NaN where the rod cannot reach the line.
    """
    angle = 2.0 * np.pi * (np.asarray(phase, dtype=float).reshape(-1, 1) + np.arange(samples)[None, :] / samples)
    pin, slider = _pins(params, angle)
    return pin + (params[:, 2:3] + 1j * params[:, 3:4]) * (slider - pin)


def to_spec(row: np.ndarray, *, phase: float, scale: float, turn: complex, shift: complex, mirrored: bool,
            name: str, units: str, description: str, reversed: bool = False) -> LinkageSpec:
    """The linkage of parameter ``row`` at crank phase ``phase``, placed by z ↦ shift + scale·turn·z
    (z conjugated first when ``mirrored``, which also reverses the motor; ``reversed`` reverses
    it again), track ``target`` = P on the rod.

    ``turn`` is a unit complex number (the rotation); the slot's direction is turn·1 (a mirror keeps the x axis).
    """
    pin, slider = (complex(z[0, 0]) for z in _pins(row[None], np.array([[2.0 * np.pi * phase]])))
    point = pin + complex(row[2], row[3]) * (slider - pin)

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
