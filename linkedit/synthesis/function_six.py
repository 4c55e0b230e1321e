"""Function generation by a Watt II six-bar (issue 23 §3): two four-bars in series.

Frame (ground length 1): crank pivot O = 0, the first rocker's pivot D = 1, the output's pivot
F = 2, all on the x axis. The first four-bar O-A-B-D (:mod:`linkedit.synthesis.function`, its
output offset 0) turns the bell crank D-B-C; its rocker angle x = arg(B − D) is the second
four-bar D-C-E-F's input: the bell crank's arm D→C lies at α₂ from D→B, so C = D + a₂·e^{i(α₂ + x)}
(the second four-bar of :mod:`linkedit.synthesis.function` with pivots D, F, its input x). The
output ψ = σ·(arg(E − F) − β₂), σ = ±1 the output's sense.

Parameters per linkage, columns of a (K, 11) array: a₁, b₁, c₁, s₁, α₁, a₂, b₂, c₂, s₂, α₂, β₂
(lengths over the ground length O-D, angles in radians, s the branches); relative angles only
(α₁, β₂ fitted).

The six-bar works when both transmission angles (at B over the input range, at E over the bell
crank's range of x) stay within [μ_min, 180° − μ_min], both in closed form
(:func:`linkedit.synthesis.function.lowest_singularity`): μ at E depends on x alone, so its extremes
over the input range are those over x's range [x_min, x_max] (x is continuous in φ), and x's
extremes lie at the range's ends or at the first stage's toggles (O, A, B collinear, where x turns
back), found in closed form (:func:`toggles`).

The starts compose four-bar fits: the first fitted to the prescribed function (either sense), the
second to what is left (the prescribed output against the first's x); the best are refined together, as :func:`linkedit.synthesis.function.fit` refines
one four-bar (a wall where either stage stops working, a log barrier near the margin for each).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import margin_of, works
from linkedit.synthesis import function
from linkedit.synthesis.multistart import solve
from linkedit.synthesis.refine import barrier

#: evenly spaced inputs through which the bell crank's angle is unwrapped (besides the pairs and their midpoints)
BELL_SAMPLES = 64


@dataclass(frozen=True)
class SixBarFit:
    """The fitted six-bar: ``params`` (11,) (see the module), ``sense`` σ, ``errors`` (N,) output
    error at each pair (radians, linkage − prescribed, wrapped), ``lowest`` (2,) the smallest
    d_s of each stage over the input range."""

    params: np.ndarray
    sense: float
    errors: np.ndarray
    lowest: np.ndarray


def stages(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two four-bars' parameter rows (K, 6) each of six-bar rows (K, 11) (the first with output offset 0)."""
    first = np.concatenate([params[:, :5], np.zeros((len(params), 1))], axis=1)
    return first, params[:, 5:]


def toggles(params: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Inputs φ (K, 4), radians, in [lo, hi], where the first stage of six-bars ``params`` (K, 11) may stand at a
    toggle (O, A, B collinear: |B| = a₁ ± b₁, the rocker's turning points, dx/dφ = 0), ``lo`` where none can be.
    Candidates for either branch: B = D + c₁·e^{ix} with 1 + c₁² + 2c₁·cos x = (a₁ ± b₁)², A = ±a₁·B/|B|."""
    a, b, c, alpha = (params[:, i:i + 1] for i in (0, 1, 2, 4))
    reach = np.concatenate([a + b, a - b, a + b, a - b], axis=1)  # signed: A on B's side of O or opposite
    way = np.array([1.0, 1.0, -1.0, -1.0])
    with np.errstate(invalid="ignore"):
        x = way * np.arccos((reach * reach - 1.0 - c * c) / (2.0 * c))
    tip = 1.0 + c * np.exp(1j * x)
    phi = np.angle(np.sign(reach) * tip) - alpha
    phi = lo + np.mod(phi - lo, 2 * np.pi)
    return np.where(np.isfinite(phi) & (phi <= hi), phi, lo)


def bell_crank_range(params: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest and largest rocker angle x = arg(B − D) (K,) each, radians, of six-bars ``params`` (K, 11)
    over the input range of ``phi`` (N,), exact: x at the range's ends and at the first stage's toggles in it
    (:func:`toggles`), unwrapped along the inputs through the pairs, the midpoints between them and
    ``BELL_SAMPLES`` evenly spaced inputs; NaN where the first stage cannot be placed."""
    lo, hi = float(phi.min()), float(phi.max())
    common = np.concatenate([phi, 0.5 * (phi[1:] + phi[:-1]), np.linspace(lo, hi, BELL_SAMPLES)])
    inputs = np.sort(np.concatenate([np.broadcast_to(common, (len(params), len(common))),
                                     toggles(params, lo, hi)], axis=1), axis=1)
    x = np.unwrap(function.output_angles(stages(params)[0], inputs), axis=1)
    return x.min(axis=1), x.max(axis=1)


def output_angles(params: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """arg(E − F) − β₂, (K, N) radians, of six-bars ``params`` (K, 11) at inputs ``phi`` (N,); NaN where either
    stage cannot be placed."""
    first, second = stages(params)
    x = function.output_angles(first, phi)
    return function.output_angles(second, x)


def lowest_singularity(params: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """min d_s (K, 2) of each stage over the input range of ``phi`` (N,) (the second over the bell crank's
    range, see the module); −1 where a stage cannot be placed."""
    first, second = stages(params)
    low1 = function.lowest_singularity(first, phi.min(), phi.max())
    lo, hi = bell_crank_range(params, phi)
    low2 = function.lowest_singularity(second, lo, hi)
    return np.stack([low1, np.where(np.isfinite(lo + hi), low2, -1.0)], axis=1)


def _score(rows: np.ndarray, phi: np.ndarray, goal: np.ndarray, margin: float) -> np.ndarray:
    """RMS output error (K,) of working rows; inf for the others."""
    err = function.wrap(output_angles(rows, phi) - goal[None, :])
    ok = works(lowest_singularity(rows, phi), margin).all(axis=1) & np.isfinite(err).all(axis=1)
    return np.where(ok, np.sqrt(np.mean(np.where(ok[:, None], err, 0.0) ** 2, axis=1)), np.inf)


def _starts(phi: np.ndarray, goal: np.ndarray, margin_deg: float) -> np.ndarray:
    """Six-bar rows (S, 11) composed of four-bar fits: the first stage fitted to ±goal, the second to ``goal``
    against the first's rocker angle x (from −goal: nearly a reversal, the best start of the log and square
    laws either way; fitting ±φ first added nothing there); and the four-bar fitted to ``goal`` with a
    parallelogram second stage (the six-bar is then that four-bar: never worse than it)."""
    rows = []
    for target in (goal, -goal):
        one = function.fit(phi, target, relative=True, margin_deg=margin_deg, sense=1.0)
        if one is None:
            continue
        first = one.params.copy()
        first[5] = 0.0
        two = function.fit(function.output_angles(first[None], phi)[0], goal, relative=True, margin_deg=margin_deg,
                           sense=1.0)
        if two is not None:
            rows.append(np.concatenate([first[:5], two.params]))
        if target is goal:  # the four-bar itself: a parallelogram D-C-E-F passes x on, μ at E = α₂ + x
            x = function.output_angles(first[None], phi)[0]
            alpha = 0.5 * np.pi - 0.5 * (x.min() + x.max())
            rows += [np.concatenate([first[:5], [1.0, 1.0, 1.0, s, alpha, alpha + one.params[5]]]) for s in (1.0, -1.0)]
    return np.array(rows).reshape(-1, 11)


def _refine(rows: np.ndarray, phi: np.ndarray, goal: np.ndarray, margin: float) -> np.ndarray:
    """The rows (K, 11) after nonlinear least squares on the output angle over the six lengths' logarithms
    and the three angles, all at once, both stages kept working (a wall, a log barrier near the margin)."""
    scale = 1.0 / np.sqrt(len(phi))
    free = [0, 1, 2, 4, 5, 6, 7, 9, 10]
    logs = [0, 1, 2, 4, 5, 6]  # the lengths' columns among the free ones

    def unpack(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        p = rows[start].copy()
        p[:, free] = x
        p[:, [0, 1, 2, 5, 6, 7]] = np.exp(x[:, logs])
        return p

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        p = unpack(x, start)
        low = lowest_singularity(p, phi)
        r = function.wrap(output_angles(p, phi) - goal[None, :]) * scale
        push = barrier(low, margin)
        ok = np.all(works(low, margin) & np.isfinite(push) & (low > margin), axis=1)
        return np.where(ok[:, None], np.concatenate([r, push], axis=1), np.inf)

    x0 = rows[:, free].copy()
    x0[:, logs] = np.log(x0[:, logs])
    bound = np.log(function.MAX_RATIO)
    lower = np.where(np.isin(np.arange(len(free)), logs), -bound, -np.inf)
    x, _ = solve(residuals, x0, iterations=function.ITERATIONS, lower=lower, upper=-lower)
    return unpack(x, np.arange(len(rows)))


def fit(phi: np.ndarray, psi: np.ndarray, *, margin_deg: float, sense: float | None = None) -> SixBarFit | None:
    """The working Watt II six-bar (both transmission angles within [margin_deg, 180° − margin_deg]) whose
    output best follows ψ(φ) (N,) each, radians, relative angles, in the least-squares sense; the output
    turns either way unless ``sense`` (+1 or −1) prescribes it. None when no start works."""
    margin = margin_of(margin_deg)
    found = []
    for way in (1.0, -1.0) if sense is None else (sense,):
        goal = way * psi
        rows = _starts(phi, goal, margin_deg)
        rows = rows[np.isfinite(_score(rows, phi, goal, margin))]
        if len(rows):
            refined = _refine(rows, phi, goal, margin)
            score = _score(refined, phi, goal, margin)
            tie = 0.0 if way > 0 else 1e-9
            found.append((float(score.min()) + tie, way, refined[int(np.argmin(score))]))
    if not found or not np.isfinite(min(found, key=lambda f: f[0])[0]):
        return None
    _, way, best = min(found, key=lambda f: f[0])
    best[[4, 9, 10]] = function.wrap(best[[4, 9, 10]])
    errors = way * function.wrap(output_angles(best[None], phi)[0] - way * psi)
    return SixBarFit(best, way, errors, lowest_singularity(best[None], phi)[0])
