"""Motion generation by a slider-crank (issue 23 §2): its coupler passes through poses.

Poses as in :mod:`linkedit.synthesis.motion` (normalized: p_j complex, θ_j radians). A **slider
dyad** is a moving point m on the coupler (coupler frame) whose positions M_j = p_j + e^{iθ_j}·m
lie on one straight line (Burmester's circle point whose centre is at infinity): the line
Im(e^{−iα}·z) = c fitted to the M_j by total least squares, the residuals the M_j's distances
from it. With 4 unknowns (m, α, c): through 3 poses a one-parameter family, through 4 finitely
many (generically one real), beyond that least squares. They are solved from a grid of m, all
starts at once (:func:`linkedit.synthesis.multistart.solve`); crank and slider dyads from the four-bar's two
grids, the wider only where the first gives no working slider-crank or misses a pose
(:func:`linkedit.synthesis.motion.widening`).

A circle-point dyad (:func:`linkedit.synthesis.motion.dyads`) as the crank O-A and a slider dyad as
the pin B on a ground guide make a slider-crank: the coupler A-B carries the coupler point. Its
**model**, x = (O, A, B, P, κ, α, δ₂..δ_N) (complex points as two reals): the rest pose O, A, B,
coupler point P, the coupler's angle arg(B − A) + κ, the guide's direction α (through B at rest)
and the crank's turn δ_j from rest at pose j (δ₁ = 0, signed). At pose j the crank pin is
A_j = O + (A − O)·e^{iδ_j} and the slider B_j the closed form of
:mod:`linkedit.planar.rules.slider` on the rest pose's side: with u = e^{iα} and
q = ū·(A_j − B), B_j = B + u·(Re q + σ·sqrt(l² − (Im q)²)), σ = sign Re(ū·(B − A)), l = |B − A|.
Its d_s is that rule's, 1 − p²/l² with p = Im q the pin's signed distance from the guide; the
transmission angle μ = arccos(p/l) (the rod's angle from the guide's normal: 90° when the rod
lies along the guide) has sin² μ = d_s. p = Im(ū·(O − B)) + |A − O|·sin(arg(ū·(A − O)) + δ) is
extreme at the sweep's ends or where the sine is ±1: the lowest d_s over the sweep in closed form.
The model works under :func:`linkedit.synthesis.motion.model`'s conditions; every pair of a
crank dyad and a slider dyad, the crank turning either way, is a start
(:func:`linkedit.synthesis.motion.best`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import margin_of
from linkedit.synthesis.motion import (DYAD_ITERATIONS, GRID, REACH, SHORTEST, SPREAD, Kept, best, distinct, dyads,
                                       in_order, reach_of, widening)
from linkedit.synthesis.multistart import solve


@dataclass(frozen=True)
class SliderFit:
    """The fitted slider-crank in the normalized frame: rest joints ``O``, ``A``, ``B`` and coupler
    point ``P`` (complex), ``kappa`` (coupler angle = arg(B − A) + κ, radians), ``alpha`` the guide's
    direction (radians), ``turns`` (N,) the crank's turn from rest at each pose (radians, signed),
    ``position`` (N,) complex and ``angle`` (N,) radians: the pose errors, ``lowest`` the smallest
    d_s over the sweep."""

    O: complex
    A: complex
    B: complex
    P: complex
    kappa: float
    alpha: float
    turns: np.ndarray
    position: np.ndarray
    angle: np.ndarray
    lowest: float


def _line(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direction α ∈ [0, π) and offset c (K,) each of the total-least-squares lines Im(e^{−iα}·z) = c
    through points z (K, N): the principal axis about the centroid."""
    centre = z.mean(axis=1)
    alpha = np.mod(0.5 * np.angle(np.sum((z - centre[:, None]) ** 2, axis=1)), np.pi)
    return alpha, (np.exp(-1j * alpha) * centre).imag


def slider_dyads(p: np.ndarray, theta: np.ndarray, spread: float = SPREAD, reach: float = REACH) -> np.ndarray:
    """Distinct slider dyads (S, 5) fitting poses p (N,) complex, θ (N,): columns m.x, m.y, α ∈ [0, π),
    c and the RMS distance of the M_j from the line, best first; the M_j spread along the line by at
    least SHORTEST (a slider that slides); moving pivots started over ±``spread``, within ``reach`` (sizes)."""
    turn = np.exp(1j * theta)
    grid = np.linspace(-spread, spread, GRID)
    m0 = (grid[:, None] + 1j * grid[None, :]).ravel()
    alpha, c = _line(p[None, :] + turn[None, :] * m0[:, None])
    x0 = np.stack([m0.real, m0.imag, alpha, c], axis=1)

    def moving(x: np.ndarray) -> np.ndarray:
        return np.exp(-1j * x[:, 2:3]) * (p[None, :] + turn[None, :] * (x[:, 0] + 1j * x[:, 1])[:, None])

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        return moving(x).imag - x[:, 3:4]

    bound = np.array([reach, reach, np.inf, reach])
    x, _ = solve(residuals, x0, iterations=DYAD_ITERATIONS, lower=-bound, upper=bound)
    x = np.concatenate([x, x0])
    half = np.floor(x[:, 2] / np.pi)  # α into [0, π): the line's normal, and c, flip with each half turn
    x[:, 2] -= np.pi * half
    x[:, 3] *= 1.0 - 2.0 * np.mod(half, 2.0)
    rms = np.sqrt(np.mean(residuals(x, np.arange(len(x))) ** 2, axis=1))
    keep = np.isfinite(rms) & (np.ptp(moving(x).real, axis=1) >= SHORTEST) & (np.abs(x[:, 0] + 1j * x[:, 1]) <= reach)
    return distinct(x[keep], rms[keep], 4)


def _unpack(x: np.ndarray) -> tuple[np.ndarray, ...]:
    """Rest joints O, A, B, P (K,) complex, κ, α (K,) and the turns δ (K, N) (δ₁ = 0) of x (K, N + 9)."""
    z = x[:, 0:8:2] + 1j * x[:, 1:8:2]
    turns = np.concatenate([np.zeros((len(x), 1)), x[:, 10:]], axis=1)
    return z[:, 0], z[:, 1], z[:, 2], z[:, 3], x[:, 8], x[:, 9], turns


def reach(O: np.ndarray, A: np.ndarray, B: np.ndarray, alpha: np.ndarray, lo: np.ndarray | float,
          hi: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """The smallest and largest p (K,) each, the crank pin's signed distance from the guide
    (direction α through B), over crank turns δ ∈ [lo, hi] (radians, scalars or (K,)) from rest."""
    u = np.exp(-1j * alpha)
    base, arm = (u * (O - B)).imag, u * (A - O)
    t0, t1 = np.angle(arm) + lo, np.angle(arm) + hi
    ends = np.stack([np.sin(t0), np.sin(t1)], axis=1)
    top = np.where(np.floor((t1 - 0.5 * np.pi) / (2 * np.pi)) > np.floor((t0 - 0.5 * np.pi) / (2 * np.pi)), 1.0,
                   ends.max(axis=1))
    bottom = np.where(np.floor((t1 + 0.5 * np.pi) / (2 * np.pi)) > np.floor((t0 + 0.5 * np.pi) / (2 * np.pi)), -1.0,
                      ends.min(axis=1))
    return base + np.abs(arm) * bottom, base + np.abs(arm) * top


def lowest_singularity(O: np.ndarray, A: np.ndarray, B: np.ndarray, alpha: np.ndarray, lo: np.ndarray | float,
                       hi: np.ndarray | float) -> np.ndarray:
    """min d_s = 1 − p²/l² over crank turns [lo, hi] (:func:`reach`), (K,), exact; −1 where the rod
    (l = |B − A|) cannot reach the guide somewhere."""
    low, high = reach(O, A, B, alpha, lo, hi)
    l2 = np.abs(B - A) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        out = 1.0 - np.maximum(low * low, high * high) / l2
    return np.where(np.isfinite(out) & (out >= 0.0), out, -1.0)


def transmission_range(found: SliderFit) -> tuple[float, float]:
    """(smallest, largest) transmission angle μ = arccos(p/l) in degrees over the fit's sweep."""
    sweep = (min(0.0, float(found.turns[-1])), max(0.0, float(found.turns[-1])))
    O, A, B, alpha = (np.array([v]) for v in (found.O, found.A, found.B, found.alpha))
    low, high = reach(O, A, B, alpha, *sweep)
    rod = abs(found.B - found.A)
    mu = np.degrees(np.arccos(np.clip([high[0] / rod, low[0] / rod], -1.0, 1.0)))
    return float(mu.min()), float(mu.max())


def poses_of(x: np.ndarray, reach: float = REACH) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coupler point (K, N) complex and coupler angle (K, N) at each crank turn of models x,
    the smallest d_s over the sweep (K,) and whether each model works apart from the margin
    (poses in order within one turn, links not degenerate, joints within ``reach`` sizes)."""
    O, A, B, P, kappa, alpha, turns = _unpack(x)
    u = np.exp(1j * alpha)[:, None]
    pin = O[:, None] + (A - O)[:, None] * np.exp(1j * turns)
    rod2 = np.abs(B - A) ** 2
    side = np.sign((np.conj(u[:, 0]) * (B - A)).real)
    q = np.conj(u) * (pin - B[:, None])
    with np.errstate(invalid="ignore", divide="ignore"):
        slide = B[:, None] + u * (q.real + side[:, None] * np.sqrt(rod2[:, None] - q.imag ** 2))
        point = pin + (slide - pin) / (B - A)[:, None] * (P - A)[:, None]
        angle = kappa[:, None] + np.angle(slide - pin)
    shape = ((np.minimum(np.abs(A - O), np.sqrt(rod2)) >= SHORTEST)
             & (np.maximum.reduce([np.abs(O), np.abs(A), np.abs(B)]) <= reach) & (side != 0))
    low = lowest_singularity(O, A, B, alpha, turns.min(axis=1), turns.max(axis=1))
    return point, angle, low, in_order(turns) & shape


def _pairs(p: np.ndarray, theta: np.ndarray, cranks: np.ndarray, sliders: np.ndarray) -> np.ndarray:
    """Models (K, N + 9) of every pair of a crank dyad and a slider dyad, the crank turning either
    way: the rest pose is pose 1, the turns the crank's angles at the poses counted one way from it."""
    m = cranks[:, 0] + 1j * cranks[:, 1]
    f = cranks[:, 2] + 1j * cranks[:, 3]
    i, k = (g.ravel() for g in np.meshgrid(np.arange(len(cranks)), np.arange(len(sliders)), indexing="ij"))
    moving = p[None, :] + np.exp(1j * theta)[None, :] * m[:, None]  # (C, N)
    raw = np.angle((moving[i] - f[i, None]) / (moving[i, :1] - f[i, None]))  # (K, N), raw[:, 0] = 0
    A = moving[i, 0]
    B = p[0] + np.exp(1j * theta[0]) * (sliders[k, 0] + 1j * sliders[k, 1])
    joints = np.stack([f[i], A, B, np.full(len(i), p[0])], axis=1)
    flat = np.stack([joints.real, joints.imag], axis=2).reshape(len(i), 8)
    fixed = np.concatenate([flat, (theta[0] - np.angle(B - A))[:, None], sliders[k, 2:3]], axis=1)
    return np.concatenate([np.concatenate([fixed, sense * np.mod(sense * raw, 2 * np.pi)[:, 1:]], axis=1)
                           for sense in (1.0, -1.0)])


def fit(p: np.ndarray, theta: np.ndarray, *, margin_deg: float) -> SliderFit | None:
    """The working slider-crank whose coupler best passes through the poses p (N,) complex
    (normalized), θ (N,) radians, in order; None when no pair of dyads gives one."""
    margin, reach = margin_of(margin_deg), reach_of(p, theta)

    def search(spread: float) -> Kept | None:
        cranks, sliders = dyads(p, theta, spread, reach), slider_dyads(p, theta, spread, reach)
        if not len(cranks) or not len(sliders):
            return None
        return best(lambda x: poses_of(x, reach), _pairs(p, theta, cranks, sliders), p, theta, margin)

    kept = widening(search)
    if kept is None:
        return None
    x, position, turn_error, low = kept
    O, A, B, P, kappa, alpha, turns = (v[0] for v in _unpack(x[None]))
    return SliderFit(complex(O), complex(A), complex(B), complex(P), float(kappa), float(alpha), turns,
                     position, turn_error, low)
