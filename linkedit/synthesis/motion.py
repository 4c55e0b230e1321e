"""Motion generation (rigid-body guidance, issue 23 §2): a four-bar whose coupler passes through poses.

Poses j = 1..N (positions normalized: centroid 0, size 1): the coupler point p_j (complex) and the
coupler's angle θ_j. A **dyad** — a fixed pivot f and a moving pivot m on the coupler, m in the
coupler's frame, at M_j = p_j + e^{iθ_j}·m in pose j — fits when every M_j lies on one circle about
f: the dyad equations |M_j − f| = ℓ, j = 1..N (Burmester). With 5 unknowns (m, f, ℓ): through 3
poses a two-parameter family, 4 poses the circle-point curve, 5 poses finitely many (the
Burmester points), beyond that least squares. They are solved from a grid of moving pivots m (f
and ℓ from the circle fitted to the M_j), all starts at once
(:func:`linkedit.synthesis.multistart.solve`); the grid's circle fits join them as candidates
(starts for least squares through many poses, where the best pair need not be two best dyads). Where that grid
(±SPREAD sizes) gives no working linkage, a wider one (±WIDE·SPREAD) is searched. Every joint lies within
REACH levers of the poses (:func:`reach_of`: the poses' size, or more where the coupler turns little).

Two dyads make a four-bar: crank O = f₁, A = M₁, rocker D = f₂, B = M₂, the coupler A-B carrying
the coupler point. Its **model**, x = (O, D, A, B, P, κ, δ₂..δ_N) (complex points as two reals):
the rest pose O, A, B, D, coupler point P, the coupler's angle arg(B − A) + κ, the crank's turn δ_j
from rest at pose j (δ₁ = 0; signed: positive counter-clockwise). At pose j the crank pin is
A_j = O + (A − O)·e^{iδ_j}, B_j the law of cosines on the rest pose's branch, and the coupler
point P_j = A_j + (B_j − A_j)/(B − A)·(P − A). Residuals: P_j − p_j (over the size) and the
coupler angle's error (radians). The model works when the poses come in order (δ_j strictly
monotone, within one turn) and the transmission angle stays in the band over the crank's sweep
from 0 to δ_N (closed form, :func:`linkedit.synthesis.function.lowest_singularity`); it never
changes branch (the rest pose's, held by the law of cosines). Every ordered pair of the best
dyads, both ways round, is a start; the best are refined all at once on the model (a wall where
it does not work, a log barrier near the margin), then polished by POLISH full Gauss–Newton steps (an
ill-conditioned root, such as a held-out Watt II's stage 2, is met to rounding, not ~1e-8).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import margin_of, works
from linkedit.planar.law_of_cosines import dyad
from linkedit.synthesis.function import lowest_singularity, wrap
from linkedit.synthesis.multistart import solve
from linkedit.synthesis.refine import barrier

#: moving pivots tried per axis (a grid over ±SPREAD sizes about the coupler point; where it gives no
#: working linkage, or its best misses a pose by more than MISSES (of the size, or radians), a second pass over
#: ±WIDE·SPREAD: moving pivots farther out; the better of the two is kept)
GRID = 15
SPREAD = 2.0
WIDE = 3.0
MISSES = 1e-3
#: the best distinct dyads paired (pivots apart by more than DISTINCT sizes)
DYADS = 40
DISTINCT = 1e-4
#: the best pairs refined
STARTS = 24
#: Levenberg–Marquardt iterations: dyads, four-bars
DYAD_ITERATIONS = 60
ITERATIONS = 150
#: full Gauss–Newton steps after them (:func:`linkedit.synthesis.multistart.solve`): a root whose rocker dyad is
#: ill-conditioned is met to rounding, not ~1e-8
POLISH = 6
#: every joint within REACH levers of the poses' centroid (:func:`reach_of`), every link at least this long (sizes)
REACH = 20.0
SHORTEST = 1e-3
#: the lever's largest value (sizes): a coupler that barely turns (a translation) has its pivots far but not at infinity
LEVER = 1e3
#: a pose met to this (size, radians) counts as exact: among exact linkages the best transmission wins
EXACT = 1e-9


@dataclass(frozen=True)
class MotionFit:
    """The fitted four-bar in the normalized frame: rest joints ``O``, ``A``, ``B``, ``D`` and
    coupler point ``P`` (complex), ``kappa`` (coupler angle = arg(B − A) + κ, radians), ``turns``
    (N,) the crank's turn from rest at each pose (radians, signed), ``position`` (N,) complex
    and ``angle`` (N,) radians: the pose errors, ``lowest`` the smallest d_s over the sweep."""

    O: complex
    A: complex
    B: complex
    D: complex
    P: complex
    kappa: float
    turns: np.ndarray
    position: np.ndarray
    angle: np.ndarray
    lowest: float


def _circle(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (K,) and radii (K,) of the circles fitted to points z (K, N) (algebraic fit:
    |z|² = 2 Re(c̄ z) + k, exact through 3 points)."""
    m = np.stack([2 * z.real, 2 * z.imag, np.ones(z.shape)], axis=-1)
    sol = (np.linalg.pinv(m) @ (np.abs(z) ** 2)[..., None])[..., 0]
    centre = sol[:, 0] + 1j * sol[:, 1]
    with np.errstate(invalid="ignore"):
        return centre, np.sqrt(np.maximum(sol[:, 2] + np.abs(centre) ** 2, 0.0))


def reach_of(p: np.ndarray, theta: np.ndarray) -> float:
    """How far from the poses' centroid a joint may lie (sizes): REACH levers, the lever the poses' natural
    scale max(1, 1/Δθ) (sizes; Δθ the largest turn of the coupler between two poses, radians: a body turning by
    Δθ over a span s turns about a pole ≈ s/Δθ away), at most LEVER. Poses spanning little of a large
    linkage's motion turn little: its joints lie many sizes out."""
    spread = float(np.abs(wrap(theta[:, None] - theta[None, :])).max())
    return REACH * float(np.clip(1.0 / max(spread, 1.0 / LEVER), 1.0, LEVER))


def dyads(p: np.ndarray, theta: np.ndarray, spread: float = SPREAD, reach: float = REACH) -> np.ndarray:
    """Distinct dyads (D, 6) fitting poses p (N,) complex, θ (N,): columns m.x, m.y, f.x, f.y, ℓ
    and the RMS of |M_j − f| − ℓ, best first; moving pivots started on a grid over ±``spread`` about the
    coupler point, every joint within ``reach`` (sizes)."""
    turn = np.exp(1j * theta)
    grid = np.linspace(-spread, spread, GRID)
    m0 = (grid[:, None] + 1j * grid[None, :]).ravel()
    centre, radius = _circle(p[None, :] + turn[None, :] * m0[:, None])
    x0 = np.stack([m0.real, m0.imag, centre.real, centre.imag, radius], axis=1)

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        moving = p[None, :] + turn[None, :] * (x[:, 0] + 1j * x[:, 1])[:, None]
        return np.abs(moving - (x[:, 2] + 1j * x[:, 3])[:, None]) - x[:, 4:5]

    x0 = x0[np.isfinite(x0).all(axis=1)]
    bound = np.array([reach] * 4 + [2 * reach])
    x, _ = solve(residuals, x0, iterations=DYAD_ITERATIONS, lower=np.append(-bound[:4], SHORTEST), upper=bound)
    x = np.concatenate([x, x0])  # the circle fits of the grid too: starts for least squares through many poses
    rms = np.sqrt(np.mean(residuals(x, np.arange(len(x))) ** 2, axis=1))
    keep = (np.isfinite(rms) & (x[:, 4] >= SHORTEST) & (np.abs(x[:, 2] + 1j * x[:, 3]) <= reach)
            & (np.abs(x[:, 0] + 1j * x[:, 1]) <= reach))
    return distinct(x[keep], rms[keep], 4)


def distinct(x: np.ndarray, rms: np.ndarray, columns: int) -> np.ndarray:
    """The best DYADS rows of dyads x (K, n) by ``rms`` (K,) whose first ``columns`` apart by more
    than DISTINCT, with their RMS appended: (D, n + 1), best first."""
    order = np.argsort(rms, kind="stable")
    picked: list[int] = []
    for i in order:
        if all(np.abs(x[i, :columns] - x[j, :columns]).max() > DISTINCT for j in picked):
            picked.append(int(i))
        if len(picked) == DYADS:
            break
    return np.concatenate([x[picked], rms[picked, None]], axis=1)


def _unpack(x: np.ndarray) -> tuple[np.ndarray, ...]:
    """Rest joints O, D, A, B, P (K,) complex, κ (K,) and the turns δ (K, N) (δ₁ = 0) of x (K, N + 10)."""
    z = x[:, 0:10:2] + 1j * x[:, 1:10:2]
    turns = np.concatenate([np.zeros((len(x), 1)), x[:, 11:]], axis=1)
    return z[:, 0], z[:, 1], z[:, 2], z[:, 3], z[:, 4], x[:, 10], turns


def frame_rows(O: np.ndarray, A: np.ndarray, B: np.ndarray, D: np.ndarray) -> np.ndarray:
    """The four-bars of rest joints O, A, B, D (K,) complex as rows (K, 6) of
    :mod:`linkedit.synthesis.function` (its frame: O = 0, D = 1): a, b, c over |D − O|, the branch
    (the side of A→D that B is on), the crank's angle from the ground line, 0."""
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.abs(D - O)
        side = np.sign(((B - A) / (D - A)).imag)
        return np.stack([np.abs(A - O) / d, np.abs(B - A) / d, np.abs(B - D) / d, side,
                         np.angle((A - O) / (D - O)), np.zeros(len(O))], axis=1)


def in_order(turns: np.ndarray) -> np.ndarray:
    """Whether the crank's turns (K, N) (radians, δ₁ = 0) reach the poses in order, one way, within one
    turn: (K,)."""
    step = np.diff(turns, axis=1) * np.sign(turns[:, -1:])
    return (step > 0).all(axis=1) & (np.abs(turns[:, -1]) < 2 * np.pi)


def poses_of(x: np.ndarray, ordered: bool = True,
             reach: float = REACH) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coupler point (K, N) complex and coupler angle (K, N) at each crank turn of models x,
    the smallest d_s over the sweep (K,) and whether each model works apart from the margin
    (poses in order within one turn — ``ordered`` False: the crank may turn back between poses,
    over less than a turn —, links not degenerate, joints within ``reach`` sizes)."""
    O, D, A, B, P, kappa, turns = _unpack(x)
    pin = O[:, None] + (A - O)[:, None] * np.exp(1j * turns)
    rows = frame_rows(O, A, B, D)
    b, c, d, side = rows[:, 1] * np.abs(D - O), rows[:, 2] * np.abs(D - O), np.abs(D - O), rows[:, 3]
    with np.errstate(invalid="ignore", divide="ignore"):
        tip, _ = dyad(pin, np.broadcast_to(D[:, None], pin.shape), (0.5 * (b * b - c * c))[:, None],
                      (b * b)[:, None], side[:, None])
        point = pin + (tip - pin) / (B - A)[:, None] * (P - A)[:, None]
        angle = kappa[:, None] + np.angle(tip - pin)
    inorder = in_order(turns) if ordered else np.ptp(turns, axis=1) < 2 * np.pi
    shape = ((np.minimum.reduce([np.abs(A - O), b, c, d]) >= SHORTEST)
             & (np.maximum.reduce([np.abs(O), np.abs(A), np.abs(B), np.abs(D)]) <= reach) & (side != 0))
    low = lowest_singularity(rows, turns.min(axis=1), turns.max(axis=1))
    return point, angle, low, inorder & shape


Poses = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
#: :func:`best`'s result: the kept model x (n,), position errors (N,) complex, angle errors (N,) radians, lowest d_s
Kept = tuple[np.ndarray, np.ndarray, np.ndarray, float]


def model(poses: Poses, p: np.ndarray, theta: np.ndarray, margin: float):
    """The residual function of models x (K, n) whose ``poses`` (:func:`poses_of`'s outputs) are
    fitted to p, θ: (K, 3N + 1) — position gaps (x, y), angle gaps, the barrier — not finite where
    a model does not work."""

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        point, angle, low, ok = poses(x)
        gap = point - p[None, :]
        r = np.concatenate([gap.real, gap.imag, wrap(angle - theta[None, :]), barrier(low, margin)[:, None]], axis=1)
        ok = ok & works(low, margin) & (low > margin) & np.isfinite(r).all(axis=1)
        return np.where(ok[:, None], r, np.inf)

    return residuals


def _pairs(p: np.ndarray, theta: np.ndarray, found: np.ndarray, ordered: bool = True) -> np.ndarray:
    """Models (K, N + 10) of every ordered pair of dyads (crank, rocker), both ways round: the rest
    pose is pose 1, the turns the crank's angles at the poses counted one way from it (``ordered``
    False: the nearest way, within half a turn)."""
    m = found[:, 0] + 1j * found[:, 1]
    f = found[:, 2] + 1j * found[:, 3]
    i, k = (g.ravel() for g in np.meshgrid(np.arange(len(found)), np.arange(len(found)), indexing="ij"))
    i, k = i[i != k], k[i != k]
    moving = p[None, :] + np.exp(1j * theta)[None, :] * m[:, None]  # (D, N)
    raw = np.angle((moving[i] - f[i, None]) / (moving[i, :1] - f[i, None]))  # (K, N), raw[:, 0] = 0
    A, B = moving[i, 0], moving[k, 0]
    out = []
    for sense in (1.0, -1.0) if ordered else (0.0,):
        turns = sense * np.mod(sense * raw, 2 * np.pi) if ordered else raw
        joints = np.stack([f[i], f[k], A, B, np.full(len(i), p[0])], axis=1)
        flat = np.stack([joints.real, joints.imag], axis=2).reshape(len(i), 10)
        out.append(np.concatenate([flat, (theta[0] - np.angle(B - A))[:, None], turns[:, 1:]], axis=1))
    return np.concatenate(out)


def fit(p: np.ndarray, theta: np.ndarray, *, margin_deg: float, ordered: bool = True) -> MotionFit | None:
    """The working four-bar whose coupler best passes through the poses p (N,) complex (normalized),
    θ (N,) radians, in order (``ordered`` False: its crank may turn back between poses, as a six-bar's
    second stage driven by a rocker); None when no pair of dyads gives one."""
    margin, reach = margin_of(margin_deg), reach_of(p, theta)

    def search(spread: float) -> Kept | None:
        found = dyads(p, theta, spread, reach)
        if len(found) < 2:
            return None
        return best(lambda x: poses_of(x, ordered, reach), _pairs(p, theta, found, ordered), p, theta, margin)

    kept = widening(search)
    if kept is None:
        return None
    x, position, turn_error, low = kept
    O, D, A, B, P, kappa, turns = (v[0] for v in _unpack(x[None]))
    return MotionFit(complex(O), complex(A), complex(B), complex(D), complex(P), float(kappa), turns,
                     position, turn_error, low)


def widening(search: Callable[[float], Kept | None]) -> Kept | None:
    """``search``'s result (:func:`best`'s) over a grid of moving pivots ±SPREAD sizes about the coupler point;
    where that gives no working linkage or misses a pose by more than MISSES, also over ±WIDE·SPREAD (moving
    pivots farther out), keeping the one that misses least: None where neither works."""
    kept: Kept | None = None
    for spread in (SPREAD, WIDE * SPREAD):
        found = search(spread)
        if found is not None and (kept is None or _miss(found) < _miss(kept)):
            kept = found
        if kept is not None and _miss(kept) <= MISSES:
            break
    return kept


def _miss(kept: Kept) -> float:
    """The largest pose error of :func:`best`'s result: position (of the size) or angle (radians)."""
    return float(max(np.abs(kept[1]).max(), np.abs(kept[2]).max()))


def best(poses: Poses, starts: np.ndarray, p: np.ndarray, theta: np.ndarray, margin: float) -> Kept | None:
    """The STARTS best of the models ``starts`` (K, n) refined all at once on :func:`model`; the
    kept one — among those exact to EXACT the best transmission, else the least cost — as its x (n,),
    position errors (N,) complex, angle errors (N,) radians and lowest d_s; None when none works."""
    residuals = model(poses, p, theta, margin)
    cost = 0.5 * np.sum(residuals(starts, np.arange(len(starts))) ** 2, axis=1)
    order = np.argsort(np.where(np.isfinite(cost), cost, np.inf), kind="stable")[:STARTS]
    starts = starts[order[np.isfinite(cost[order])]]
    if not len(starts):
        return None
    x, cost = solve(residuals, starts, iterations=ITERATIONS, polish=POLISH)
    point, angle, low, _ = poses(x)
    position = point - p[None, :]
    turn_error = wrap(angle - theta[None, :])
    worst = np.maximum(np.abs(position).max(axis=1), np.abs(turn_error).max(axis=1))
    exact = np.isfinite(cost) & (worst <= EXACT)
    kept = int(np.argmax(np.where(exact, low, -np.inf))) if exact.any() else int(np.argmin(cost))
    if not np.isfinite(cost[kept]):
        return None
    return x[kept], position[kept], turn_error[kept], float(low[kept])
