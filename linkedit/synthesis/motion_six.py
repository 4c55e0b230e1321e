"""Motion generation with prescribed timing (issue 23 §2): a Watt II six-bar whose second coupler
passes through poses at prescribed motor angles.

Two four-bars in series. Stage 2 (:func:`linkedit.synthesis.motion.fit`) is a four-bar O2-A2-B2-D2
whose coupler A2-B2 carries the coupler point through the poses, its crank at turns δ_j from rest
(δ₁ = 0). Stage 1 (:func:`linkedit.synthesis.function.fit`, relative angles) is a four-bar
O1-A1-B1-D1 whose rocker D1-B1 turns by δ_j when the motor (crank O1-A1) turns by φ_j; the
rocker is rigid with stage 2's crank (the ternary link D1-B1-A2, D1 = O2), so stage 2's crank turns
as stage 1's rocker does, back and forth (stage 2 is fitted with its crank turning one way
through the poses, then, unless that is exact, free to turn back between them). Exact through 5
timed poses (stage 2: the Burmester pairs; stage 1: 5 free parameters through 5 pairs), least
squares beyond.

Stage 1's function-fit frame (O = 0, D = 1) is placed by z ↦ O2 + L·e^{iγ}·(m(z) − 1): scaled to
stage 2's longest link L, its pivot O1 on the far side of O2 from stage 2's joints, mirrored
(m = conj) when its rocker turns against its crank (the motor then turns clockwise). Its output
offset is set so that δ(0) = 0: the rest pose is the first pose.

Beyond 5 poses, or where stage 1 is not exact, the two stages are refined together (15 parameters:
stage 1's ln a, ln b, ln c, crank offset; stage 2's rest joints, coupler point and coupler angle
offset) on the poses met at the prescribed motor turns, both stages kept working over the motor's
sweep (a wall, a log barrier near the margin), polished as stage 2 is (full Gauss–Newton steps). The timing
achieved is the motor turn at which each pose is met best nearest its prescribed turn: the local minimum of the
pose error over ``GRID`` turns of the sweep nearest it, polished by Gauss–Newton between its grid neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.feasibility import margin_of, works
from linkedit.synthesis import function, function_six, motion
from linkedit.synthesis.multistart import solve
from linkedit.synthesis.refine import barrier

#: motor turns over the sweep searched for the turn at which each pose is met best
GRID = 721
#: evenly spaced motor turns through which stage 1's rocker angle is unwrapped
SWEEP = 64
#: Gauss–Newton steps polishing that turn
NEWTON = 12


@dataclass(frozen=True)
class SixMotionFit:
    """The fitted six-bar in the normalized frame: rest ``joints`` O1, A1, B1, D1, A2, B2, D2 and the
    coupler point P (complex), ``kappa`` (coupler 2's angle = arg(B2 − A2) + κ, radians), ``direction``
    (+1: the motor turns counter-clockwise, −1 clockwise), ``turns`` (N,) the prescribed motor turns
    φ_j (radians, ≥ 0, from the first pose), ``achieved`` (N,) the motor turns at which each pose is met
    best, ``position`` (N,) complex and ``angle`` (N,) radians the pose errors at the prescribed turns,
    ``lowest`` (2,) each stage's smallest d_s over the sweep, ``crank2`` (2,) the smallest and largest
    turn of stage 2's crank over the sweep (radians), ``stage1`` (6,) stage 1's function-fit row (in
    its frame, output offset 0)."""

    joints: dict[str, complex]
    kappa: float
    direction: float
    turns: np.ndarray
    achieved: np.ndarray
    position: np.ndarray
    angle: np.ndarray
    lowest: np.ndarray
    crank2: np.ndarray
    stage1: np.ndarray


def _six(rows: np.ndarray) -> np.ndarray:
    """Stage-1 rows (K, 6) as the six-bar rows (K, 11) :func:`linkedit.synthesis.function_six.bell_crank_range`
    reads (its first stage)."""
    return np.concatenate([rows[:, :5], np.zeros((len(rows), 6))], axis=1)


def _crank2(rows: np.ndarray, sense: float, phi: np.ndarray) -> np.ndarray:
    """Stage 2's crank turn δ (K, M) at motor turns ``phi`` (M,) in [0, φ_max] of stage-1 rows (K, 6), from its
    turn at φ = 0: stage 1's rocker angle unwrapped along the inputs through ``SWEEP`` evenly spaced ones."""
    inputs = np.concatenate([[0.0], phi, np.linspace(0.0, phi.max(), SWEEP)])
    order = np.argsort(inputs, kind="stable")
    x = np.empty((len(rows), len(inputs)))
    x[:, order] = np.unwrap(function.output_angles(rows, inputs[order]), axis=1)
    return sense * (x[:, 1:len(phi) + 1] - x[:, :1])


def _sweep(stage1: np.ndarray, sense: float, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stage 1's lowest d_s (K,) over the motor's sweep [0, φ_N] of stage-1 rows (K, 6) (output offset 0), and
    the smallest and largest turn of stage 2's crank (K, 2) over it (exact:
    :func:`linkedit.synthesis.function_six.bell_crank_range`)."""
    low1 = function.lowest_singularity(stage1, 0.0, float(phi.max()))
    xmin, xmax = function_six.bell_crank_range(_six(stage1), phi)
    x0 = function.output_angles(stage1, np.zeros(1))[:, 0]
    ends = sense * (np.stack([xmin, xmax], axis=1) - x0[:, None])
    return low1, np.sort(ends, axis=1)


def _evaluate(x: np.ndarray, sense: float, branch: float, phi: np.ndarray, reach: float):
    """Joint models x (K, 15) → coupler point (K, N) complex, coupler angle (K, N), lowest d_s (K, 2) over
    the sweep and whether each works apart from the margin (stage 2's joints within ``reach`` sizes)."""
    stage1 = np.concatenate([np.exp(x[:, :3]), np.full((len(x), 1), branch), x[:, 3:4], np.zeros((len(x), 1))], axis=1)
    turns = _crank2(stage1, sense, phi[1:])
    model = np.concatenate([x[:, 4:], turns], axis=1)
    point, angle, _, ok = motion.poses_of(model, ordered=False, reach=reach)  # the motor keeps the order
    low1, ends = _sweep(stage1, sense, phi)
    O, D, A, B = (model[:, i] + 1j * model[:, i + 1] for i in (0, 2, 4, 6))
    low2 = function.lowest_singularity(motion.frame_rows(O, A, B, D), ends[:, 0], ends[:, 1])
    return point, angle, np.stack([low1, np.where(np.isfinite(ends).all(axis=1), low2, -1.0)], axis=1), ok


def _refine(x0: np.ndarray, sense: float, branch: float, p: np.ndarray, theta: np.ndarray, phi: np.ndarray,
            margin: float, reach: float) -> np.ndarray:
    """The joint models (K, 15) after least squares on the poses at the prescribed motor turns, both stages
    kept working over the sweep."""

    def residuals(x: np.ndarray, start: np.ndarray) -> np.ndarray:
        point, angle, low, ok = _evaluate(x, sense, branch, phi, reach)
        gap = point - p[None, :]
        push = barrier(low, margin)
        r = np.concatenate([gap.real, gap.imag, function.wrap(angle - theta[None, :]), push], axis=1)
        ok = ok & np.all(works(low, margin) & (low > margin), axis=1) & np.isfinite(r).all(axis=1)
        return np.where(ok[:, None], r, np.inf)

    bound = np.log(function.MAX_RATIO)
    lower = np.array([-bound] * 3 + [-np.inf] * 12)
    x, _ = solve(residuals, x0, iterations=motion.ITERATIONS, lower=lower, upper=-lower, polish=motion.POLISH)
    return x


def _best_turns(x: np.ndarray, sense: float, branch: float, p: np.ndarray, theta: np.ndarray,
                phi: np.ndarray) -> np.ndarray:
    """The motor turn (N,) in the sweep [0, φ_N] at which the joint model x (15,) meets each pose best: the local
    minimum of the pose error nearest the prescribed turn φ (N,) (a coupler may pass a pose twice)."""

    def error(turn: np.ndarray) -> np.ndarray:  # (N, M) turns → (N, M, 3) pose errors
        stage1 = np.array([[*np.exp(x[:3]), branch, x[3], 0.0]])
        delta = _crank2(stage1, sense, turn.ravel())
        point, angle, _, _ = motion.poses_of(np.concatenate([x[None, 4:], delta], axis=1))
        point, angle = point[0, 1:].reshape(turn.shape), angle[0, 1:].reshape(turn.shape)
        gap = point - p[:, None]
        return np.stack([gap.real, gap.imag, function.wrap(angle - theta[:, None])], axis=-1)

    grid = np.linspace(0.0, phi.max(), GRID)
    err = np.sum(error(np.broadcast_to(grid, (len(p), GRID))) ** 2, axis=-1)
    err = np.pad(np.where(np.isfinite(err), err, np.inf), ((0, 0), (1, 1)), constant_values=np.inf)
    local = (err[:, 1:-1] <= err[:, :-2]) & (err[:, 1:-1] <= err[:, 2:]) & np.isfinite(err[:, 1:-1])
    near = np.argmin(np.where(local, np.abs(grid[None, :] - phi[:, None]), np.inf), axis=1)  # the nearest local best
    turn = grid[near]
    low, high = grid[np.maximum(near - 1, 0)], grid[np.minimum(near + 1, GRID - 1)]
    step = 1e-7
    for _ in range(NEWTON):  # Gauss–Newton on each pose's turn, all poses at once
        r = error(np.stack([turn, turn + step], axis=1))
        slope = (r[:, 1] - r[:, 0]) / step
        with np.errstate(invalid="ignore", divide="ignore"):
            move = -np.sum(slope * r[:, 0], axis=1) / np.sum(slope * slope, axis=1)
        turn = np.clip(turn + np.where(np.isfinite(move), move, 0.0), low, high)
    return turn


def fit(p: np.ndarray, theta: np.ndarray, phi: np.ndarray, *, margin_deg: float) -> SixMotionFit | None:
    """The working Watt II six-bar whose second coupler passes through the poses p (N,) complex
    (normalized), θ (N,) radians, at motor turns φ (N,) radians (increasing from 0, within one turn);
    None when stage 2 or stage 1 finds no working four-bar, or the two do not work together. Stage 2's
    crank (the ternary link, driven by stage 1's rocker) first turning one way through the poses, then,
    unless that is exact, free to turn back between them: the better is kept."""
    found = [f for f in (_fit(p, theta, phi, margin_deg, True),) if f is not None]
    if not found or found[0][1] > motion.EXACT:
        found += [f for f in (_fit(p, theta, phi, margin_deg, False),) if f is not None]
    if not found:
        return None
    return min(found, key=lambda f: f[1])[0]


def _fit(p: np.ndarray, theta: np.ndarray, phi: np.ndarray, margin_deg: float,
         ordered: bool) -> tuple[SixMotionFit, float] | None:
    """:func:`fit` from the stage-2 four-bar of :func:`linkedit.synthesis.motion.fit` (``ordered``: its
    crank turning one way through the poses) and its worst pose error (size or radians); None when none works."""
    margin, reach = margin_of(margin_deg), motion.reach_of(p, theta)
    two = motion.fit(p, theta, margin_deg=margin_deg, ordered=ordered)
    if two is None:
        return None
    one = function.fit(phi, two.turns, relative=True, margin_deg=margin_deg)
    if one is None:
        return None
    row = one.params
    x0 = np.array([*np.log(row[:3]), row[4], *(np.array([[two.O, two.D, two.A, two.B, two.P]]).view(float)[0]),
                   two.kappa])
    x = x0[None]
    point, angle, low, ok = _evaluate(x, one.sense, row[3], phi, reach)
    worst = max(np.abs(point - p).max(), np.abs(function.wrap(angle - theta)).max())
    if not (ok[0] and works(low[0], margin).all() and worst <= motion.EXACT):
        refined = _refine(x, one.sense, row[3], p, theta, phi, margin, reach)
        point, angle, low, ok = _evaluate(refined, one.sense, row[3], phi, reach)
        if not (ok[0] and works(low[0], margin).all()):
            return None
        x = refined
        worst = max(np.abs(point - p).max(), np.abs(function.wrap(angle - theta)).max())
    return _place(x[0], one.sense, row[3], p, theta, phi, point[0], angle[0], low[0]), float(worst)


def _place(x: np.ndarray, sense: float, branch: float, p: np.ndarray, theta: np.ndarray, phi: np.ndarray,
           point: np.ndarray, angle: np.ndarray, low: np.ndarray) -> SixMotionFit:
    """The six-bar of joint model x (15,): stage 1's frame placed on stage 2 (see the module)."""
    O2, D2, A2, B2, P = (complex(x[4 + 2 * i], x[5 + 2 * i]) for i in range(5))
    a, b, c, alpha = np.exp(x[0]), np.exp(x[1]), np.exp(x[2]), x[3]
    pin = a * np.exp(1j * alpha)
    rocker = float(function.output_angles(np.array([[a, b, c, branch, alpha, 0.0]]), np.zeros(1))[0, 0])
    tip = 1.0 + c * np.exp(1j * rocker)
    away = O2 - (A2 + B2 + D2) / 3
    u = away / abs(away) if abs(away) > 0 else 1.0 + 0j
    length = max(abs(D2 - O2), abs(A2 - O2), abs(B2 - A2), abs(D2 - B2))  # stage 2's longest link

    def world(z: complex) -> complex:
        return O2 - length * u * ((z if sense > 0 else z.conjugate()) - 1.0)

    joints = {"O1": world(0j), "A1": world(pin), "B1": world(tip), "D1": O2, "A2": A2, "B2": B2, "D2": D2, "P": P}
    stage1 = np.array([a, b, c, branch, alpha, 0.0])
    achieved = _best_turns(x, sense, branch, p, theta, phi)
    _, ends = _sweep(stage1[None], sense, phi)
    return SixMotionFit(joints, float(x[14]), sense, phi, achieved, point - p, function.wrap(angle - theta), low,
                        ends[0], stage1)
