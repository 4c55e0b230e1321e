"""Function generation (issue 23 §3): a four-bar whose rocker turns as prescribed when its crank turns.

Frame (ground length 1): crank pivot O = 0, rocker pivot D = 1 on +x, crank pin A = a·e^{iθ},
rocker tip B at distances b from A and c from D on the side s = ±1 of A→D (the branch,
:func:`linkedit.planar.law_of_cosines.dyad`). For an input φ the crank's angle is θ = α + φ and
the output is ψ = arg(B − D) − β. Absolute angles: α = β = 0 (both angles counter-clockwise
from the ground line O→D); relative angles: the offsets α, β are fitted too, and the rocker may
turn either way (ψ = β − arg(B − D), ``sense`` −1, when that fits better).

Parameters per linkage, columns of a (K, 6) array: a, b, c, s, α, β (lengths over the ground
length, angles in radians).

Freudenstein's equation (|B − A|² = b² with B = 1 + c·e^{iψ}):
``K1·cos ψ − K2·cos θ + K3 = cos(θ − ψ)``, K1 = 1/a, K2 = 1/c, K3 = (a² − b² + c² + 1)/(2ac),
is linear in K: exact through 3 pairs, least squares beyond. Its solutions (for a grid of
offsets α, β with relative angles) and a coarse grid of link lengths are the starts; the best
working ones are refined by nonlinear least squares on the actual output angle (the closed form
above), the linkage held working over the whole input range as :mod:`linkedit.synthesis.refine`
holds a curve synthesis: a wall where it does not, a log barrier near the margin.

The linkage works when the transmission angle μ at B stays within [μ_min, 180° − μ_min] over the
input range (d_s = sin²μ ≥ sin²μ_min, :func:`linkedit.planar.feasibility.works`). With
|A − D|² = a² + 1 − 2a·cos θ and cos μ = (b² + c² − |A − D|²)/(2bc), the extremes of μ over an
interval of θ lie at its ends or where θ crosses a multiple of π: a closed form, no sampling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import margin_of, works
from linkedit.planar.law_of_cosines import dyad
from linkedit.synthesis.multistart import solve
from linkedit.synthesis.refine import barrier

PARAMETERS = ("a", "b", "c", "branch", "input_offset", "output_offset")
#: offsets tried per angle with relative angles (a grid of α and β)
OFFSET_GRID = 24
#: link lengths tried per link (over the ground length, log-spaced in [0.2, 5])
LENGTH_GRID = 6
#: the best starts refined
STARTS = 32
#: Levenberg–Marquardt iterations of the refinement
ITERATIONS = 100
#: every link lies within this factor of the ground length
MAX_RATIO = 20.0


@dataclass(frozen=True)
class FunctionFit:
    """The fitted linkage: ``params`` (6,) (see the module), ``sense`` +1 when the output is
    ψ = arg(B − D) − β, −1 when it is β − arg(B − D) (the rocker turns the other way; relative
    angles only), ``errors`` (N,) output error at each pair (radians, linkage − prescribed,
    wrapped), ``lowest`` its smallest d_s over the input range."""

    params: np.ndarray
    sense: float
    errors: np.ndarray
    lowest: float


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles (any shape, radians) wrapped into (−π, π]."""
    return -np.angle(np.exp(-1j * np.asarray(angle)))


def output_angles(params: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """ψ = arg(B − D) − β, (K, N) radians, of linkages ``params`` (K, 6) at inputs ``phi`` (N,), or
    (K, N) each its own (not wrapped); NaN where B cannot be placed."""
    a, b, c, s, alpha, beta = (params[:, i:i + 1] for i in range(6))
    pin = a * np.exp(1j * (alpha + np.atleast_2d(phi)))
    with np.errstate(invalid="ignore", divide="ignore"):
        tip, _ = dyad(pin, np.ones_like(pin), 0.5 * (b * b - c * c), b * b, s)
    return np.angle(tip - 1.0) - beta


def cos_mu_range(params: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """The extreme values of cos μ (K,) each over inputs φ ∈ [lo, hi] (radians; scalars or (K,)): at the range's ends
    or where the crank angle α + φ crosses a multiple of π (|A − D| extreme there)."""
    a, b, c, alpha = params[:, 0], params[:, 1], params[:, 2], params[:, 4]
    t0, t1 = alpha + lo, alpha + hi
    cos = np.stack([np.cos(t0), np.cos(t1)], axis=1)
    low = np.min(cos, axis=1)
    high = np.max(cos, axis=1)
    high = np.where(np.floor(t1 / (2 * np.pi)) > np.floor(t0 / (2 * np.pi)), 1.0, high)  # crosses 2kπ
    low = np.where(np.floor((t1 - np.pi) / (2 * np.pi)) > np.floor((t0 - np.pi) / (2 * np.pi)), -1.0, low)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_mu = [(b * b + c * c - (a * a + 1.0 - 2.0 * a * k)) / (2.0 * b * c) for k in (low, high)]
    return cos_mu[0], cos_mu[1]


def lowest_singularity(params: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> np.ndarray:
    """min d_s = sin²μ over inputs [lo, hi] (scalars or (K,)), (K,), exact; −1 where B cannot be placed somewhere."""
    first, second = cos_mu_range(params, lo, hi)
    out = np.full(len(params), np.inf)
    for cos_mu in (first, second):
        out = np.minimum(out, np.where(np.abs(cos_mu) <= 1.0, 1.0 - cos_mu * cos_mu, -1.0))
    return np.where(np.isfinite(out), out, -1.0)


def transmission_range(params: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> tuple[float, float]:
    """(smallest, largest) transmission angle μ in degrees of one linkage (1, 6) over [lo, hi]."""
    first, second = cos_mu_range(params, lo, hi)
    mu = np.degrees(np.arccos(np.clip([first[0], second[0]], -1.0, 1.0)))
    return float(mu.min()), float(mu.max())


def freudenstein(theta: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """K (S, 3) of Freudenstein's equation through pairs (S, N) of crank and rocker angles (radians):
    exact for N = 3, least squares beyond (a batch of pseudo-inverses)."""
    m = np.stack([np.cos(psi), -np.cos(theta), np.ones_like(psi)], axis=-1)
    return (np.linalg.pinv(m) @ np.cos(theta - psi)[..., None])[..., 0]


def from_freudenstein(k: np.ndarray, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Parameter rows (2S, 6) of K (S, 3) at offsets α, β (S,): both branches; a negative crank or
    rocker length turns that link by π instead (its offset changes); NaN rows where b² ≤ 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, c = 1.0 / k[:, 0], 1.0 / k[:, 1]
        b2 = a * a + c * c + 1.0 - 2.0 * a * c * k[:, 2]
        b = np.where(b2 > 0, np.sqrt(np.abs(b2)), np.nan)
    alpha = alpha + np.where(a < 0, np.pi, 0.0)
    beta = beta + np.where(c < 0, np.pi, 0.0)
    rows = np.stack([np.abs(a), b, np.abs(c), np.ones_like(a), alpha, beta], axis=1)
    other = rows.copy()
    other[:, 3] = -1.0
    return np.concatenate([rows, other])


def _starts(phi: np.ndarray, psi: np.ndarray, relative: bool) -> np.ndarray:
    """Candidate parameter rows (K, 6): Freudenstein's solution at a grid of offsets (relative
    angles) or at α = β = 0, and a grid of link lengths (with relative angles at a grid of α, β
    then the mean output gap)."""
    if relative:
        grid = 2 * np.pi * np.arange(OFFSET_GRID) / OFFSET_GRID
        alpha, beta = (g.ravel() for g in np.meshgrid(grid, grid))
    else:
        alpha = beta = np.zeros(1)
    k = freudenstein(alpha[:, None] + phi[None, :], beta[:, None] + psi[None, :])
    exact = from_freudenstein(k, alpha, beta)
    if not relative:  # a link turned by π does not measure its angle from the ground line
        exact = exact[(exact[:, 4] == 0.0) & (exact[:, 5] == 0.0)]
    lengths = np.geomspace(0.2, 5.0, LENGTH_GRID)
    a, b, c, s = (g.ravel() for g in np.meshgrid(lengths, lengths, lengths, [1.0, -1.0], indexing="ij"))
    offsets = 2 * np.pi * np.arange(OFFSET_GRID // 2) / (OFFSET_GRID // 2) if relative else np.zeros(1)
    grid_rows = np.stack([np.repeat(v, len(offsets)) for v in (a, b, c, s)] + [np.tile(offsets, len(a))], axis=1)
    grid_rows = np.concatenate([grid_rows, np.zeros((len(grid_rows), 1))], axis=1)
    if relative:  # the output offset that centres the gaps
        gap = output_angles(grid_rows, phi) - psi[None, :]
        grid_rows[:, 5] = np.angle(np.mean(np.exp(1j * gap), axis=1))  # NaN where B cannot be placed
    return np.concatenate([exact, grid_rows])


def _score(rows: np.ndarray, phi: np.ndarray, psi: np.ndarray, margin: float) -> np.ndarray:
    """RMS output error (K,) of working rows; inf for the others."""
    err = wrap(output_angles(rows, phi) - psi[None, :])
    ok = works(lowest_singularity(rows, phi.min(), phi.max()), margin) & np.isfinite(err).all(axis=1)
    return np.where(ok, np.sqrt(np.mean(np.where(ok[:, None], err, 0.0) ** 2, axis=1)), np.inf)


def _refine(rows: np.ndarray, phi: np.ndarray, psi: np.ndarray, relative: bool, margin: float) -> np.ndarray:
    """The rows (K, 6) after nonlinear least squares on the output angle over ln a, ln b, ln c (and
    α, β), all at once (:func:`linkedit.synthesis.multistart.solve`), kept working over the input
    range: not finite (a wall) where they do not, a log barrier near the margin."""
    lo, hi = phi.min(), phi.max()
    scale = 1.0 / np.sqrt(len(phi))
    free = [0, 1, 2, 4, 5] if relative else [0, 1, 2]

    def unpack(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        p = rows[start].copy()
        p[:, free] = x
        p[:, :3] = np.exp(x[:, :3])
        return p

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        p = unpack(x, start)
        low = lowest_singularity(p, lo, hi)
        r = wrap(output_angles(p, phi) - psi[None, :]) * scale
        push = barrier(low, margin)
        ok = works(low, margin) & np.isfinite(push) & (low > margin)
        return np.where(ok[:, None], np.concatenate([r, push[:, None]], axis=1), np.inf)

    x0 = rows[:, free].copy()
    x0[:, :3] = np.log(x0[:, :3])
    bound = np.log(MAX_RATIO)
    lower = np.array([-bound] * 3 + [-np.inf] * (len(free) - 3))
    x, _ = solve(residuals, x0, iterations=ITERATIONS, lower=lower, upper=-lower)
    return unpack(x, np.arange(len(rows)))


def fit(phi: np.ndarray, psi: np.ndarray, *, relative: bool, margin_deg: float,
        sense: float | None = None) -> FunctionFit | None:
    """The working four-bar (transmission within [margin_deg, 180° − margin_deg] over the input
    range) whose output best follows ψ(φ) (N,) each, radians, in the least-squares sense; with
    relative angles the output may turn either way (``sense``) unless ``sense`` (+1 or −1) prescribes it.
    None when no start works."""
    margin = margin_of(margin_deg)
    found = []
    for way in (1.0, -1.0) if relative and sense is None else (sense or 1.0,):
        goal = way * psi
        rows = _starts(phi, goal, relative)
        score = _score(rows, phi, goal, margin)
        rows = rows[np.argsort(score)[:STARTS]]
        rows = rows[np.isfinite(_score(rows, phi, goal, margin))]
        if len(rows):
            refined = _refine(rows, phi, goal, relative, margin)
            score = _score(refined, phi, goal, margin)
            tie = 0.0 if way > 0 else 1e-9  # the prescribed way unless the other way fits better
            found.append((float(score.min()) + tie, way, refined[int(np.argmin(score))]))
    if not found or not np.isfinite(min(found, key=lambda f: f[0])[0]):
        return None
    _, way, best = min(found, key=lambda f: f[0])
    if relative:
        best[4:] = wrap(best[4:])
    errors = way * wrap(output_angles(best[None], phi)[0] - way * psi)
    return FunctionFit(best, way, errors, float(lowest_singularity(best[None], phi.min(), phi.max())[0]))
