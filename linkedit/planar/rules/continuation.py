"""The numeric groups' continuation (:func:`trace`): its tolerances, where it is continued
sequentially (:func:`coarse`), how the samples between are predicted (:func:`predict`) and when a
Newton solve is accepted as the continuation of its predictor (:func:`accepted`) — one loop for the
general group (:mod:`.group`, in its joints' coordinates) and the triad (:mod:`.triad`, in its
body's pose), each a :class:`Continued`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

#: Newton's method stops when every row is within this of 0 (rows are in units of the
#: linkage's characteristic length, squared for distance rows)
GROUP_TOLERANCE = 1e-13
GROUP_ITERATIONS = 12
#: a numeric group is continued sequentially only through the samples where its inputs (known
#: joints, linear input) have moved this far (of the linkage's size) since the last one, however
#: dense the samples; the samples between are predicted from those and polished all at once
GROUP_STRIDE = 0.08
#: the sequential continuation's tolerance before every sample is polished to GROUP_TOLERANCE:
#: enough to follow the branch (the samples between start further off, from :data:`STENCIL`'s predictor)
COARSE_TOLERANCE = 1e-4
#: the samples between are predicted by the polynomial through this many solved samples nearest
#: each (:func:`predict`): quintic (the complex loop's rows from their predictor: 1e-3 with a cubic
#: and whole strides at the ends, 1.2e-4 with this and half strides; three polishing steps → two)
STENCIL = 6


def accepted(moved: np.ndarray | float, first: np.ndarray | float) -> np.ndarray | bool:
    """Whether Newton ended close to where it started: within 1.5× its first step, itself at most
    0.1 (of the linkage's size): it converged to the solution nearest its predictor."""
    return (moved <= 1.5 * first + 1e-9) & (first <= 0.1)


def advance(attempt: Callable[[float], bool], piece: float = 1.0) -> bool:
    """One move of a sequential continuation, from one sample to the next: a homotopy in the inputs.
    ``attempt(f)`` tries to reach the fraction f of the move from where its last accepted attempt
    left (keeping the result when it returns True: Newton converged, accepted), first f = ``piece``
    (0.5 once the whole move has failed); a failed piece is halved (down to 1/256 of the move), a
    piece after a success doubled. Returns whether the whole move was made."""
    done = 0.0
    while done < 1.0:
        f = min(done + piece, 1.0)
        if attempt(f):
            done = f
            piece = min(2.0 * piece, 1.0)
        else:
            piece *= 0.5
            if piece < 1.0 / 256:
                return False
    return True


def largest(*parts: np.ndarray) -> np.ndarray:
    """max |a| (N,) along the last axis of every ``a`` (N, c) of ``parts`` (NaN where any is NaN),
    column by column: a few columns, many rows — a reduction along the short axis costs several
    times more."""
    out = np.abs(parts[0][:, 0])
    for a in parts:
        for n in range(1 if a is parts[0] else 0, a.shape[1]):
            np.maximum(out, np.abs(a[:, n]), out=out)
    return out


def predict(travel: np.ndarray, known: np.ndarray, solved: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Positions (len(want), k) at samples ``want`` (none of them in ``known``) by the polynomial, in
    the inputs' ``travel`` (T,) (:func:`coarse`: repeated inputs are one point of it, not two),
    through the STENCIL solved samples nearest each (fewer when fewer are solved): ``known``
    (indices, increasing), ``solved`` (len(known), k). Each interval's polynomial in
    Newton's form: its divided differences c_j (over the intervals at once) times the Newton basis
    ∏_{i<j} (t − x_i) at every wanted sample (one running product): no per-sample loop."""
    n, p = known.size, min(STENCIL, known.size)
    if n < 2:
        return np.broadcast_to(solved[:1], (want.size, solved.shape[1])).copy()
    first = np.arange(1 - p // 2, n - p // 2)  # each interval's stencil: its first node
    np.maximum(first, 0, out=first)
    np.minimum(first, n - p, out=first)
    nodes = first + np.arange(p)[:, None]  # (p, intervals)
    x, c = travel[known[nodes]], solved[nodes]  # (p, intervals), (p, intervals, k)
    for j in range(1, p):  # divided differences, in place
        c[j:] -= c[j - 1:-1]
        c[j:] /= (x[j:] - x[:p - j])[..., None]
    inside = np.searchsorted(known, want)  # 1 + the interval of each wanted sample
    np.maximum(inside, 1, out=inside)
    np.minimum(inside, n - 1, out=inside)
    inside -= 1
    basis = np.subtract(travel[want], x[: p - 1].take(inside, axis=1))  # (p − 1, len(want))
    np.multiply.accumulate(basis, axis=0, out=basis)
    c = c.take(inside, axis=1)  # (p, len(want), k)
    c[1:] *= basis[..., None]
    return c.sum(axis=0)


def coarse(known: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples (increasing, the first and the last among them) the group is continued through
    sequentially: one each time the inputs ``known`` (J_in, T) complex and ``s`` (T,) have moved
    GROUP_STRIDE since the one before (their largest move, summed sample to sample: their travel
    (T,), also returned), and half that into the first move and before the last sample (the end
    intervals, where :func:`predict`'s stencil is one-sided); the last sample unless its inputs
    have not moved since the one before (no two of them at one travel: :func:`predict`'s
    abscissae; the samples after the last are it again: :func:`trace` copies it). Inputs NaN from
    some sample on (a joint before the group not placed) make the travel NaN from there: the strides
    are marked over its finite part, and the last sample stays a node, where the sequential
    continuation stops."""
    T = s.size
    moved = np.abs(known[:, 1:] - known[:, :-1]).max(axis=0, initial=0.0)
    np.maximum(moved, np.abs(s[1:] - s[:-1]), out=moved)
    travel = np.empty(T)
    travel[0] = 0.0
    np.cumsum(moved, out=travel[1:])
    end = float(travel[-1])
    if end != end:  # NaN from some sample on
        end = float(np.nanmax(travel))  # travel[0] = 0
    marks = np.arange(0.0, end, GROUP_STRIDE).tolist()  # a few: Python numbers from here
    if marks:
        marks[0] = 0.5 * GROUP_STRIDE
    if end > GROUP_STRIDE:
        marks.append(end - 0.5 * GROUP_STRIDE)
        marks.sort()
    nodes = [0, *np.minimum(np.searchsorted(travel, marks), T - 1).tolist(), T - 1]
    along = travel[nodes].tolist()  # a node at the travel of the one before is that node again (a NaN node kept)
    return np.array([nodes[0], *(n for n, a, b in zip(nodes[1:], along[1:], along) if not a <= b)]), travel


def closes(known: np.ndarray, s: np.ndarray) -> bool:
    """Whether the samples of the inputs ``known`` (J_in, T) complex and ``s`` (T,) close a cycle: the
    last sample's inputs within GROUP_STRIDE (of the linkage's size) of the first's (a full turn, a
    rocker's swing there and back), so that the samples before the first are the last ones."""
    gap = max(float(np.abs(known[:, -1] - known[:, 0]).max(initial=0.0)), abs(float(s[-1] - s[0])))
    return gap <= GROUP_STRIDE


class Continued(Protocol):
    """A group's unknowns along the samples of K linkages."""

    @property
    def width(self) -> int:
        """Its coordinates per sample."""

    def start(self, c: int) -> np.ndarray:
        """Linkage ``c``'s unknowns (width,) at its rest pose."""

    def follow(self, c: int, x: np.ndarray, path: np.ndarray, out: np.ndarray, travel: np.ndarray,
               tol: float) -> int:
        """Continue linkage ``c`` from ``x`` (known at sample ``path[0]``) through the samples ``path`` in
        order, each move made by :func:`advance` and accepted as :func:`accepted` says, Newton to
        ``tol``, writing rows ``out`` (T, width); ``travel`` (T,) as :func:`coarse` gives it. Returns the
        position in ``path`` where it fails, or −1."""

    def polish(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Newton's method on every sample (K, T, width) at once from the predictions in ``X`` (updated
        in place; NaN rows left alone): which samples (K, T) are accepted (converged close to their
        prediction, on their rest pose's branch), and a value (K, T) of each accepted one for the
        caller (NaN elsewhere)."""


def trace(group: Continued, known: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continue K linkages' ``group`` from their rest poses through the samples of its inputs ``known``
    (J_in, K, T) complex and ``s`` (K, T), in order.

    Each linkage's samples :func:`coarse` picks are continued sequentially (``group.follow``, to
    COARSE_TOLERANCE: enough to follow the branch; a loop over the linkages, a few samples each);
    then every sample of every linkage is polished by Newton's method all at once
    (``group.polish``), the ones between from the polynomial through those (:func:`predict`), each checked
    like a sequential move; a sample that fails the check is continued sequentially from the one
    before it, and a linkage whose coarse continuation stopped is continued sample by sample from
    there; a linkage that fails inside a cycle that closes (:func:`closes`) is continued back from
    its first sample through the last ones, down to where it fails that way (the samples between
    the two failures are its lock-up). Returns the unknowns (K, T, width) (NaN where a linkage fails),
    ``group.polish``'s value (K, T) at each polished sample (NaN elsewhere), and which samples are
    placed (K, T): a linkage that fails does not spoil the others."""
    K, T = s.shape
    out = np.empty((K, T, group.width))  # each linkage's coarse continuation, predicted between
    ends = []
    for c in range(K):
        through, travel = coarse(known[:, c], s[c])
        stop = group.follow(c, group.start(c), through, out[c], travel, COARSE_TOLERANCE)
        last = through[stop - 1] if stop > 0 else (T - 1 if stop < 0 else -1)  # predicted up to here
        ends.append((stop, last, travel))
        out[c, last + 1:] = np.nan
        if last >= 0:
            solved = through[through <= last]
            end = solved[-1]  # the samples after it have its inputs (:func:`coarse`): they are it
            out[c, end + 1: last + 1] = out[c, end]
            between = np.ones(end + 1, dtype=bool)
            between[solved] = False
            inner = np.flatnonzero(between)
            if inner.size:
                out[c, inner] = predict(travel, solved, out[c, solved], inner)
    accept, value = group.polish(out)
    if accept.all():  # every sample of every linkage placed by the polish
        return out, value, accept
    out[~accept] = np.nan
    placed = np.zeros((K, T), dtype=bool)
    for c, (stop, last, travel) in enumerate(ends):
        fail = -1
        for t in np.flatnonzero(~accept[c, : last + 1]):  # a sequential move from the sample before
            x, path = (group.start(c), np.array([0])) if t == 0 else (out[c, t - 1], np.array([t - 1, t]))
            if group.follow(c, x, path, out[c], travel, GROUP_TOLERANCE) >= 0:
                fail = int(t)
                break
        if fail < 0 and stop >= 0:  # the coarse continuation stopped: go on sample by sample
            x = group.start(c) if last < 0 else out[c, last]
            path = np.arange(max(last, 0), T)
            at = group.follow(c, x, path, out[c], travel, GROUP_TOLERANCE)
            fail = int(path[at]) if at >= 0 else -1
        placed[c, : fail if fail >= 0 else T] = True
        if fail > 0 and closes(known[:, c], s[c]):  # back from sample 0 through the cycle's end to the lock-up
            back = np.arange(T - 1, fail, -1)
            at = group.follow(c, out[c, 0], np.concatenate([[0], back]), out[c], travel, GROUP_TOLERANCE)
            placed[c, back[: at - 1 if at > 0 else (None if at < 0 else 0)]] = True
    out[~placed] = np.nan
    value[~placed] = np.nan
    return out, value, placed
