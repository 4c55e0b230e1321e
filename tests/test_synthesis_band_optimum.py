"""The README's claim about Gerono's 2:1 figure-eight, checked outside the synthesis pipeline: the best full-turn
four-bar with every transmission angle in [μ, 180° − μ] draws it to 4.15 % at μ = 20° (so no search reaches 3 %
there) and to 2.85 % at μ = 10°. Own kinematics and metric (nothing from linkedit.synthesis): random four-bars
screened by their normalized shape, then SLSQP with the band as a constraint from the best distinct ones."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial import cKDTree

CRANK = 256  # samples of a candidate's curve
POINTS = 160  # points each way of the distance


def even(z: np.ndarray, n: int) -> np.ndarray:
    """(K, M) closed polylines → (K, n) points evenly spaced along their length."""
    ring = np.concatenate([z, z[:, :1]], axis=1)
    s = np.concatenate([np.zeros((len(z), 1)), np.cumsum(np.abs(np.diff(ring, axis=1)), axis=1)], axis=1)
    out = np.empty((len(z), n), complex)
    for k in range(len(z)):
        at = np.linspace(0.0, s[k, -1], n, endpoint=False)
        out[k] = np.interp(at, s[k], ring[k].real) + 1j * np.interp(at, s[k], ring[k].imag)
    return out


_T = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
GERONO = np.cos(_T) + 0.5j * np.sin(2 * _T)  # size (x extent) 2
TREE = cKDTree(np.column_stack([GERONO.real, GERONO.imag]))
GOAL = even(GERONO[None], POINTS)[0]


def four_bar(x: np.ndarray, branch: float, samples: int = CRANK) -> tuple[np.ndarray, np.ndarray]:
    """x (K, 9): log a, log b, log c, u, v (ground O = 0, D = 1; crank A = a e^{iθ}; |AB| = b, |DB| = c; coupler
    point A + (u + iv)(B − A)), then log s, φ, tx, ty (placed by z ↦ t + s e^{iφ} z) → curves (K, samples), NaN
    where B cannot be placed, and min over the cycle of sin² of the angle at B (K,), −1 if the crank cannot turn."""
    a, b, c = np.exp(x[:, :3].T[..., None])
    pin = a * np.exp(2j * np.pi * np.arange(samples) / samples)
    gap = np.abs(1 - pin)
    with np.errstate(invalid="ignore"):
        along = (b * b - c * c + gap * gap) / (2 * gap)
        joint = pin + (along + 1j * branch * np.sqrt(b * b - along * along)) * (1 - pin) / gap
    point = pin + (x[:, 3:4] + 1j * x[:, 4:5]) * (joint - pin)
    ds = np.full(len(x), np.inf)
    for d in (np.abs(1 - a[:, 0]), 1 + a[:, 0]):
        cos_mu = (b[:, 0] ** 2 + c[:, 0] ** 2 - d * d) / (2 * b[:, 0] * c[:, 0])
        ds = np.minimum(ds, np.where(np.abs(cos_mu) <= 1, 1 - cos_mu ** 2, -1.0))
    return x[:, 7:8] + 1j * x[:, 8:9] + np.exp(x[:, 5:6] + 1j * x[:, 6:7]) * point, ds


def residuals(x: np.ndarray, branch: float) -> np.ndarray:
    """Distances (K, 2·POINTS) over the size (2), scaled so their root sum of squares is the normalized RMS:
    target → curve (nearest of 4 points per crank step) and the curve (evenly spaced) → target."""
    curve, _ = four_bar(x, branch)
    bad = ~np.isfinite(curve).all(axis=1)
    curve[bad] = 0.0
    fine = (curve[:, :, None] + (np.roll(curve, -1, 1) - curve)[:, :, None] * np.arange(4) / 4).reshape(len(x), -1)
    there = np.abs(GOAL[None, :, None] - fine[:, None, :]).min(axis=2)
    back = TREE.query(np.stack([(p := even(curve, POINTS)).real, p.imag], axis=2))[0]
    r = np.concatenate([there, back], axis=1) / (2.0 * np.sqrt(2 * POINTS))
    r[bad] = 1.0
    return r


def screen(count: int, margin: float, rng: np.random.Generator) -> list[tuple[float, np.ndarray, float]]:
    """``count`` random four-bars per branch, the working ones placed on the target by their principal axes:
    (shape distance: nearest points both ways, x, branch), best first."""
    found = []
    for branch in (1.0, -1.0):
        x = np.column_stack([rng.uniform(np.log(0.05), np.log(2.5), count),
                             rng.uniform(np.log(0.2), np.log(5), (count, 2)), rng.uniform(-4, 4, (count, 2)),
                             np.zeros((count, 4))])
        x = x[four_bar(x, branch, 4)[1] >= margin]
        for rows in np.array_split(x, max(1, len(x) // 1000)):
            w = even(four_bar(rows, branch, 128)[0], 64)
            centre = w.mean(axis=1, keepdims=True)
            turn = np.exp(-0.5j * np.angle(np.mean((w - centre) ** 2, axis=1)))  # the principal axis onto x
            q = (w - centre) * turn[:, None]
            mid = 0.5 * (q.real.max(1) + q.real.min(1)) + 0.5j * (q.imag.max(1) + q.imag.min(1))
            scale = 2.0 / (q.real.max(1) - q.real.min(1))
            placed = (q - mid[:, None]) * scale[:, None]
            shift = -(centre[:, 0] * turn + mid) * scale
            rows[:, 5:] = np.column_stack([np.log(scale), np.angle(turn), shift.real, shift.imag])
            gaps = np.abs(GOAL[None, :, None] - placed[:, None, :])  # (K, POINTS, 64)
            d = np.concatenate([gaps.min(axis=2), gaps.min(axis=1)], axis=1)
            found += [(float(e), r, branch) for e, r in zip(np.sqrt(np.mean(d * d, axis=1)) / 2, rows)]
    return sorted(found, key=lambda f: f[0])


def optimize(x0: np.ndarray, branch: float, margin: float, iterations: int) -> tuple[float, np.ndarray]:
    """SLSQP on the squared normalized RMS with min sin² μ ≥ ``margin`` as a constraint (forward differences, all
    9 steps in one batch) → (normalized RMS, x); inf if it ends outside the band."""
    memo: dict[bytes, tuple[np.ndarray, np.ndarray, float, np.ndarray]] = {}

    def at(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        if x.tobytes() not in memo:
            h = 1e-6 * np.maximum(1.0, np.abs(x))
            rows = np.vstack([x, x + np.diag(h)])
            r, ds = residuals(rows, branch), four_bar(rows, branch, 4)[1]
            memo.clear()
            memo[x.tobytes()] = (r[0], ((r[1:] - r[0]) / h[:, None]).T, ds[0], (ds[1:] - ds[0]) / h)
        return memo[x.tobytes()]

    with np.errstate(all="ignore"):
        x = minimize(lambda x: float(np.sum(at(x)[0] ** 2)), x0, jac=lambda x: 2 * at(x)[1].T @ at(x)[0],
                     method="SLSQP", options={"maxiter": iterations, "ftol": 1e-12},
                     constraints=[{"type": "ineq", "fun": lambda x: at(x)[2] - margin, "jac": lambda x: at(x)[3]}]).x
        error = float(np.sqrt(np.sum(residuals(x[None], branch) ** 2)))
        ok = four_bar(x[None], branch, 4)[1][0] >= margin - 1e-6 and np.isfinite(error)
    return (error if ok else np.inf), x


def best_in_band(degrees: float, count: int = 150_000, starts: int = 12) -> float:
    """The smallest normalized RMS found from the best ``starts`` distinct screened four-bars."""
    margin = np.sin(np.radians(degrees)) ** 2
    chosen: list[tuple[float, np.ndarray, float]] = []
    for e, x, branch in screen(count, margin, np.random.default_rng(1)):
        if all(b != branch or np.sqrt(np.mean((x[:5] - y[:5]) ** 2)) > 0.08 for _, y, b in chosen):
            chosen.append((e, x, branch))
        if len(chosen) == starts:
            break
    short = sorted((optimize(x, branch, margin, 30) + (branch,) for _, x, branch in chosen), key=lambda r: r[0])
    return min(optimize(x, branch, margin, 200)[0] for _, x, branch in short[:2])


@pytest.mark.slow
@pytest.mark.parametrize("degrees, low, high", [(20.0, 0.0410, 0.0420), (10.0, 0.0280, 0.0290)])
def test_the_figure_eight_optimum_per_transmission_band(degrees, low, high):
    assert low <= best_in_band(degrees) <= high
