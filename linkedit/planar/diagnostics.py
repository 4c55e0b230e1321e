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

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


def degrees_text(value: float) -> str:
    """A motor angle in degrees as a designer reads it, reduced to [0°, 360°): ``460.9`` → ``100.9°``.
    (The numbers of a result, ``/motor_angle`` and a lock-up's ``record``, run on from the rest angle.)"""
    return f"{round(float(value) % 360.0, 1) % 360.0 + 0.0:.1f}°"


def passes_zero(values: list[float]) -> bool:
    """Whether a motor turning through the angles ``values`` (degrees, in order, as recorded) passes
    0° (a multiple of 360°) strictly between two of them."""
    return any(360.0 * (np.floor(min(a, b) / 360.0) + 1.0) < max(a, b) for a, b in zip(values, values[1:]))


@dataclass(frozen=True)
class LockUp:
    """An interval of the input where the linkage cannot be assembled, and the joint responsible.

    ``exact``: start and end are where it stops and starts assembling again (the boundaries between
    the samples, found on the evaluator; a sweep's end where the run reaches it). Not ``exact`` (a
    plan with a numeric group, whose continuation cannot restart between samples): they are the
    assembled samples either side of the failing run, bounds that hold the true interval."""

    start_deg: float  #: motor angle where the linkage stops assembling, degrees
    end_deg: float  #: motor angle where it assembles again, degrees
    joint: str  #: the joint whose triangle cannot close first (in evaluation order)
    inputs: tuple[str, str]  #: the two known joints it is rebuilt from
    stretched: bool  #: True: the known joints are too far apart; False: too close
    what: str = ""  #: for slider and group rules: why the joint(s) cannot be placed
    unit: str = "°"  #: unit of start/end: "°" (motor angle) or the spec's units (linear input)
    #: where a rocker input (``oscillate_deg``) turns back inside the run: the end of its swing
    #: (None: the input runs one way from start to end)
    turn_deg: float | None = None
    exact: bool = True  #: see the class
    #: the failing run's first and last sample (indices into the motion's samples; None: the run
    #: was found at other samples than the motion's, or is a toggle passed between two samples)
    run: tuple[int, int] | None = None

    def describe(self) -> str:
        """``the linkage cannot be assembled for motor angles 304.6°…55.4° (through 0°): why``; the angles
        reduced to [0°, 360°) (:func:`degrees_text`), "through 0°" where the interval wraps past it."""
        lead = "motor angles" if self.unit == "°" else "input positions"
        path = [self.start_deg] + ([] if self.turn_deg is None else [self.turn_deg]) + [self.end_deg]
        span = "…".join(self.show(v) for v in path)
        notes = ["through 0°"] if self.unit == "°" and passes_zero(path) else []
        if not self.exact:
            span = f"within {span}"
            notes.append("the assembled samples either side; more samples narrow it")
        if notes:
            span += f" ({'; '.join(notes)})"
        return f"the linkage cannot be assembled for {lead} {span}: " + (self.what or self.because())

    def record(self) -> dict:
        """This lock-up as numbers for a program (``simulate --json``'s ``lockup_intervals``, the HDF5
        result's ``lockup_intervals``): ``start``/``end``/``turn`` in ``units`` ("deg", or a linear
        input's spec units), ``joint``, ``inputs`` (null for slider and group rules), ``stretched``,
        ``reason`` (the text after the colon of :meth:`describe`), ``exact``, ``samples`` (the run)."""
        return {"start": self.start_deg, "end": self.end_deg, "turn": self.turn_deg,
                "units": "deg" if self.unit == "°" else self.unit, "joint": self.joint,
                "inputs": list(self.inputs) if any(self.inputs) else None, "stretched": self.stretched,
                "reason": self.what or self.because(), "exact": self.exact,
                "samples": None if self.run is None else list(self.run)}

    @classmethod
    def from_record(cls, r: dict) -> "LockUp":
        """The lock-up :meth:`record` wrote."""
        run, inputs = r["samples"], r["inputs"] or ("", "")
        lk = cls(start_deg=float(r["start"]), end_deg=float(r["end"]), joint=str(r["joint"]),
                 inputs=(str(inputs[0]), str(inputs[1])), stretched=bool(r["stretched"]),
                 unit="°" if r["units"] == "deg" else str(r["units"]),
                 turn_deg=None if r["turn"] is None else float(r["turn"]), exact=bool(r["exact"]),
                 run=None if run is None else (int(run[0]), int(run[1])))
        return lk if lk.because() == r["reason"] else dataclasses.replace(lk, what=str(r["reason"]))

    def show(self, value: float) -> str:
        """An input ``value`` as :meth:`describe` writes it: ``12.3°`` (:func:`degrees_text`) or ``5.25 mm``."""
        return degrees_text(value) if self.unit == "°" else f"{value:.6g} {self.unit}"

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


def lockups(bad: np.ndarray, own: np.ndarray, cyclic: bool,
            explain: Callable[[int, int], tuple[str, tuple[str, str], bool, str]],
            edges: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, bool]], unit: str = "°") -> list[LockUp]:
    """Lock-up intervals from the rules' failures, (T, N) each, N rules in evaluation order.

    ``bad``: the rule cannot place its joint(s) (< 0 or NaN d_s); ``own``: it fails on its own,
    not from a failed input. Each run of failing samples is blamed on the rule that fails
    first most often; ``explain(rule, sample)`` gives its (joint, inputs, stretched, what).
    ``edges(runs)``: from the runs' first and last failing samples (R, 2), the inputs where each
    run starts and ends (R, 2) (degrees, or spec units for a linear input), the input where a
    swing turns back inside it (R,) (NaN: none) and whether the ends are exact (:class:`LockUp`).
    """
    failing = np.asarray(bad.any(axis=1))
    first = np.where(own.any(axis=1), own.argmax(axis=1), bad.argmax(axis=1))
    found = _runs(failing, cyclic)
    ends, turns, exact = edges(np.array(found, dtype=int).reshape(-1, 2))
    out = []
    for (s, e), (start, end), turn in zip(found, ends, turns):
        span = np.arange(s, e + 1) if s <= e else np.r_[s:failing.size, 0:e + 1]
        r = int(np.bincount(first[span]).argmax())
        joint, inputs, stretched, what = explain(r, int(span[first[span] == r][0]))
        out.append(LockUp(start_deg=float(start), end_deg=float(end), joint=joint, inputs=inputs,
                          stretched=stretched, what=what, unit=unit,
                          turn_deg=None if np.isnan(turn) else float(turn), exact=exact, run=(s, e)))
    return out


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
