"""What can go wrong during a cycle, and how close it comes: lock-up, singularity, transmission.

* **Lock-up**: a dyad's triangle cannot be closed (its two links are too short or too long
  for the distance between the known joints); d_s < 0 there (what counts as assembled:
  :mod:`linkedit.planar.feasibility`).
* **Singularity distance** d_s = sin²α (LinkEdit Eq. 6), α the angle at the rebuilt joint:
  0 at a toggle position, 1 when the two links are perpendicular.
* **Transmission angle**: α itself, in radians; designers want it near 90°. A rigid rule has none:
  90° there, as its d_s is 1.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LockUp:
    """A run of samples where the linkage cannot be assembled, and the joint responsible."""

    start_deg: float  #: motor angle at the first failing sample, degrees
    end_deg: float  #: motor angle at the last failing sample, degrees
    joint: str  #: the joint whose triangle cannot close first (in evaluation order)
    inputs: tuple[str, str]  #: the two known joints it is rebuilt from
    stretched: bool  #: True: the known joints are too far apart; False: too close
    what: str = ""  #: for slider and group rules: why the joint(s) cannot be placed
    unit: str = "°"  #: unit of start/end: "°" (motor angle) or the spec's units (linear input)
    #: where a rocker input (``oscillate_deg``) turns back inside the run: the furthest angle it
    #: reaches there (None: the input runs one way from start to end)
    turn_deg: float | None = None

    def describe(self) -> str:
        u = self.unit if self.unit == "°" else f" {self.unit}"
        lead = "motor angles" if self.unit == "°" else "input positions"
        fmt = ".1f" if self.unit == "°" else ".6g"
        turn = "" if self.turn_deg is None else f"{self.turn_deg:{fmt}}{u}…"
        head = (f"the linkage cannot be assembled for {lead} {self.start_deg:{fmt}}{u}…{turn}"
                f"{self.end_deg:{fmt}}{u}: ")
        return head + (self.what or self.because())

    def because(self) -> str:
        """Why a dyad's joint cannot be placed."""
        i, j = self.inputs
        how = "too far apart" if self.stretched else "too close together"
        return f"joint {self.joint} cannot be placed ({i} and {j} are {how} for its links)"


def _runs(mask: np.ndarray, cyclic: bool) -> list[tuple[int, int]]:
    """Inclusive (start, end) index runs of True in ``mask``; a run may wrap when ``cyclic``."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    runs = list(zip(starts.tolist(), ends.tolist()))
    if cyclic and len(runs) > 1 and runs[0][0] == 0 and runs[-1][1] == mask.size - 1:
        runs = [(runs[-1][0], runs[0][1])] + runs[1:-1]
    return runs


def lockups(bad: np.ndarray, own: np.ndarray, angle: np.ndarray, cyclic: bool,
            explain: Callable[[int, int], tuple[str, tuple[str, str], bool, str]], unit: str = "°") -> list[LockUp]:
    """Lock-up intervals from the rules' failures, (T, N) each, N rules in evaluation order.

    ``bad``: the rule cannot place its joint(s) (< 0 or NaN d_s); ``own``: it fails on its own,
    not from a failed input. Each run of failing samples is blamed on the rule that fails
    first most often; ``explain(rule, sample)`` gives its (joint, inputs, stretched, what).
    ``angle`` (T,): the input at each sample (degrees, or spec units for a linear input).
    """
    failing = np.asarray(bad.any(axis=1))
    first = np.where(own.any(axis=1), own.argmax(axis=1), bad.argmax(axis=1))
    out = []
    for s, e in _runs(failing, cyclic):
        span = np.arange(s, e + 1) if s <= e else np.r_[s:failing.size, 0:e + 1]
        r = int(np.bincount(first[span]).argmax())
        joint, inputs, stretched, what = explain(r, int(span[first[span] == r][0]))
        out.append(LockUp(start_deg=float(angle[s]), end_deg=float(angle[e]), joint=joint, inputs=inputs,
                          stretched=stretched, what=what, unit=unit, turn_deg=_turn(angle[span])))
    return out


def _turn(angle: np.ndarray) -> float | None:
    """The furthest of ``angle`` (a run's inputs in sample order) from its first where the input
    turns back inside the run (steps of both signs; a full turn's wrap, over 180°, is no step); else None."""
    steps = np.diff(angle)
    steps = steps[np.abs(steps) < 180.0]
    if not ((steps > 0).any() and (steps < 0).any()):
        return None
    return float(angle[np.argmax(np.abs(angle - angle[0]))])


def triangle_orientation(p: np.ndarray, rules: np.ndarray) -> np.ndarray:
    """Sign of the orientation of every rule's triangle (i, j, k), (T, R) int8, from positions (T, J, 2)."""
    u = p[:, rules[:, 1]] - p[:, rules[:, 0]]
    v = p[:, rules[:, 2]] - p[:, rules[:, 0]]
    cross = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    scale = np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1)
    return np.where(np.abs(cross) <= 1e-12 * scale, 0, np.sign(cross)).astype(np.int8)


def transmission_angle(p: np.ndarray, rules: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """Angle at the rebuilt joint k between k→i and k→j, radians, (T, R), from positions (T, J, 2); π/2 for the
    ``rigid`` (R,) rules (a welded triangle transmits no force through an angle: d_s is 1 by construction),
    NaN where the positions are."""
    a = p[:, rules[:, 0]] - p[:, rules[:, 2]]
    b = p[:, rules[:, 1]] - p[:, rules[:, 2]]
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    dot = (a * b).sum(axis=-1)
    angle = np.abs(np.arctan2(cross, dot))
    return np.where(rigid[None, :] & np.isfinite(angle), 0.5 * np.pi, angle)
