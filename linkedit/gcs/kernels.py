"""The elementary kinds' kernels as a system evaluates them: what a kernel sees (a
:class:`Block` of constraints of one kind, a step's :class:`StepParameters`), one adapter per
kind (:data:`EVALUATE`) and the custom (Python) constraints' residuals and Jacobians."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from linkedit.errors import MechanismError
from linkedit.gcs import constraints as kinds
from linkedit.gcs import quaternions as quat
from linkedit.gcs.inputs import Schedule


#: custom residual: fn(positions (k, 3), orientations (k, 4), t) -> residual (m,)
CustomFn = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


@dataclass(frozen=True)
class Custom:
    """A custom constraint on ``members``: a Python residual function (and optional Jacobian
    ``jac(positions, orientations, t) -> (m, 6k)`` in the members' local coordinates)."""

    owner: int
    members: tuple[int, ...]
    fn: CustomFn
    size: int
    jac: Callable[[np.ndarray, np.ndarray, float], np.ndarray] | None = None


@dataclass
class Block:
    """Elementary constraints of one kind: index and parameter arrays, (n,) / (n, 3) / (n, 4)."""

    kind: str
    owner: np.ndarray
    a: np.ndarray
    b: np.ndarray  # WORLD mapped to M
    sa: np.ndarray
    sb: np.ndarray
    rel: np.ndarray
    nb: np.ndarray
    value: np.ndarray  # (n,) targets of the kinds with a value (constraints.VALUE_KINDS)
    rows: np.ndarray  # (n, k) residual row indices (contiguous)
    start: int
    stop: int
    scheduled: np.ndarray  # positions (in this block) of constraints driven by an input
    schedules: tuple[Schedule, ...]
    vectors: tuple[slice, ...]  # where the kind's vectors (constraints.VECTORS) are in the system's table
    on_world: bool  # every constraint is against the world


@dataclass
class StepParameters:
    """What an evaluation needs from one time step."""

    t: float
    vectors: np.ndarray  #: (K, 9) member-space vectors (driven ones at this step), each 3 times: [v, v, v]
    rel_inverse: np.ndarray  #: (n, 4) inverse relative orientations of the orientation block (driven ones at this step)
    active: list[np.ndarray | None]  #: per block (n,) bool, None when all are active
    inactive_rows: np.ndarray  #: residual rows of inputs outside their window
    values: dict[str, np.ndarray]  #: per kind with a value, the targets (n,) of its block (driven ones at this step)


def _location(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
              jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.location(X[v[0]], X[v[1]], W[v[0]], W[v[1]], out, jacobian)


def _orientation(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
                 jacobian: bool) -> np.ndarray | None:
    qb = None if blk.on_world else Q.take(blk.b, axis=0)
    return kinds.orientation(Q.take(blk.a, axis=0), qb, par.rel_inverse, out, jacobian)


def _axis(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
          jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.axis(W[v[0]], W[v[1]], out, jacobian)


def _plane(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
           jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.plane(X[v[0]], X[v[1]], W[v[0]], W[v[1]], W[v[2]], out, jacobian)


def _line(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
          jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.line(X[v[0]], X[v[1]], W[v[0]], W[v[1]], W[v[2]], out, jacobian)


def _distance(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
              jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.distance(X[v[0]], X[v[1]], W[v[0]], W[v[1]], par.values["distance"], out, jacobian)


def _angle(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
           jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.angle(W[v[0]], W[v[1]], par.values["angle"], out, jacobian)


def _parallel(blk: Block, X: np.ndarray, W: np.ndarray, Q: np.ndarray, par: StepParameters, out: np.ndarray,
              jacobian: bool) -> np.ndarray | None:
    v = blk.vectors
    return kinds.parallel(W[v[0]], W[v[1]], out, jacobian)


#: how a block of each kind is evaluated, from what :meth:`~linkedit.gcs.system.System.evaluate` gathered once for all
#: kinds — the block, world points X (K, 3) and world vectors W (K, 3) of the system's member
#: vectors (the block's at ``blk.vectors``, in the order of ``constraints.VECTORS``), quaternions
#: Q (M+1, 4) with the world last, the step's parameters — writing its residual rows into
#: ``out`` (n, k) and returning its Jacobian (n, k, 2, 6) when ``jacobian``: a new kind is one
#: entry here (and its rows in ``constraints``)
EVALUATE = {"location": _location, "orientation": _orientation, "axis": _axis, "plane": _plane,
            "line": _line, "distance": _distance, "angle": _angle, "parallel": _parallel}


def custom(c: Custom, name: str, P: np.ndarray, Q: np.ndarray, t: float,
            jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Residual (size,) of the custom constraint ``name`` and its Jacobian (size, 6k) (given,
    or by central differences). A user function that raises, or returns a wrong-sized or
    non-finite array, is a :class:`~linkedit.errors.MechanismError` naming the constraint and
    the time."""
    res = _call(c.fn, name, "residual", (c.size,), P, Q, t)
    if not jacobian:
        return res, None
    k = len(P)
    if c.jac is not None:
        return res, _call(c.jac, name, "Jacobian", (c.size, 6 * k), P, Q, t)
    h = 1e-6
    jac = np.empty((c.size, 6 * k))
    for i in range(6 * k):
        cols = []
        for sgn in (1.0, -1.0):
            d = np.zeros((k, 6))
            d[i // 6, i % 6] = sgn * h
            q = quat.turned(Q, d[:, 3:])  # as State.moved
            cols.append(_call(c.fn, name, "residual", (c.size,), P + d[:, :3], q, t))
        jac[:, i] = (cols[0] - cols[1]) / (2 * h)
    return res, jac


def _call(fn: Callable[..., object], name: str, what: str, shape: tuple[int, ...], P: np.ndarray,
          Q: np.ndarray, t: float) -> np.ndarray:
    """``fn(P, Q, t)`` as a finite float array of ``shape``, or a MechanismError saying why not."""
    where = f"custom constraint {name!r} at t = {t:.4f}"
    try:
        out = np.asarray(fn(P.copy(), Q.copy(), t), dtype=float)
    except Exception as exc:  # noqa: BLE001 — user code (or an output that is not numbers): reported, not a traceback
        text = (str(exc).strip().splitlines() or [""])[0]
        raise MechanismError(f"{where}: its {what} function failed: {type(exc).__name__}"
                             + (f": {text}" if text else "")) from None
    if out.size != int(np.prod(shape)):
        raise MechanismError(f"{where}: its {what} function returned {out.size} values, expected "
                             f"{' x '.join(map(str, shape))}")
    if not np.isfinite(out).all():
        raise MechanismError(f"{where}: its {what} function returned a non-finite value (NaN or inf)")
    return out.reshape(shape)
