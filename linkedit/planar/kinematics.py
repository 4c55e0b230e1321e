"""Evaluate a plan over many motor angles at once: positions, velocities, accelerations.

All arrays are complex (x + iy) with rows in the plan's internal order: shape (P, T) for P
points and T samples. One Python iteration per rule of the plan's sequence (a level's rigid or
dyad batch is one rule), never per sample; each rule writes its own rows
(:mod:`linkedit.planar.rules`). Derivatives are with respect to the motor angle, propagated analytically through
the same rules: positions and derivatives are stacked in one array (order+1, P, T), so a rigid
batch places all orders in one operation and a dyad batch differentiates its placement in a few
(:func:`linkedit.planar.law_of_cosines.dyad_rates`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from linkedit.planar.constraints import Rows, linkage_rows
from linkedit.planar.feasibility import assembles
from linkedit.planar.plan import Geometry, Plan
from linkedit.planar.rules import Frame
from linkedit.planar.rules.pool import Pool

#: largest input change between two samples a numeric group is continued across: motor
#: degrees, or a fraction of the characteristic length for a linear input
GROUP_STEP_DEG = 1.0
GROUP_STEP_LENGTH = 0.005
_I = np.array(1j)  # a 0-d operand: a Python scalar costs numpy a conversion per call


#: :meth:`Workspace.kernels`: each rule's positions kernel, the motor row, the ground rows or None
Compiled = tuple[list[Callable[[tuple[Any, ...]], None]], np.ndarray, np.ndarray | None]


@dataclass
class State:
    """Evaluated plan. ``z``, ``dz``, ``ddz``: (P, T) complex in internal rows; ``ds``: (N, T)."""

    z: np.ndarray
    dz: np.ndarray | None  # None when evaluated with order 0
    ddz: np.ndarray | None  # None when evaluated with order < 2
    #: singularity distance per d_s row (``Plan.ds_rows``; 1 for rigid rules); < 0 or NaN: cannot place
    ds: np.ndarray
    #: with numeric groups: whether every intermediate continuation sample assembled too
    between_ok: bool = True

    def derivatives(self) -> tuple[np.ndarray, np.ndarray]:
        """(dz, ddz), (P, T) each, of an evaluation with order 2."""
        if self.dz is None or self.ddz is None:
            raise ValueError("the plan was evaluated without its derivatives (order < 2)")
        return self.dz, self.ddz


class Workspace:
    """Preallocated arrays for repeated :func:`positions` or :func:`evaluate` calls at T samples.

    The hot path then allocates nothing: every rule writes into these buffers (``out=``), so
    large batches do not pay for fresh memory pages on each call. For :func:`evaluate` up to
    derivative ``order``, of ``linkages`` = (K,) linkages or () for one: ``orders`` (order+1,
    P, *L, T) stacks positions and derivatives, ``ds`` (N, *L, T). The rules' scratch (and
    :func:`positions`' buffers) share one :class:`~linkedit.planar.rules.base.Pool`.
    """

    def __init__(self, plan: Plan, samples: int, order: int = 0, linkages: tuple[int, ...] = ()) -> None:
        rows = max((r.batch_rows() for r in plan.rules), default=0)
        self.samples, self.order, self.linkages = samples, order, tuple(linkages)
        shape = (*self.linkages, samples)
        self.orders, self.ds = Pool.carve(lambda pool: (pool((order + 1, plan.n_points, *shape), complex),
                                                        pool((plan.n_ds, *shape))))
        self.z = self.orders[0]
        self.pair, self.e, self.w, self.d2, self.u, self.a, self.b, self.scratch = Pool.carve(
            lambda pool: self._scratch(pool, plan, rows, self.orders, shape))
        self._kernels: tuple[Plan, Compiled] | None = None
        self._ground: tuple[Plan, slice | None] | None = None
        self._zeros = np.zeros(0)
        self._motor: tuple[Geometry | None, tuple[Any, Any, Any]] = (None, (0.0, 0.0, 0.0))
        #: :func:`_evaluate`'s frame on these buffers, kept for the last (plan, geometry, distances)
        self.frame: tuple[Plan, Geometry, bool, Frame] | None = None
        #: a plan with numeric groups: the workspace of its continuation grid (:func:`evaluate`)
        self.fine: Workspace | None = None

    @staticmethod
    def _scratch(pool: Pool, plan: Plan, rows: int, Z: np.ndarray, shape: tuple[int, ...]) -> tuple[Any, ...]:
        """:func:`positions`' buffers, then each rule's scratch by ``id`` of the rule, all
        overlapping (never used at the same time); ``Z`` the stacked orders the rules write."""
        own = [pool((2 * rows, shape[-1]), complex)] + [pool((rows, shape[-1]), complex) for _ in range(2)] + [
            pool((rows, shape[-1])) for _ in range(4)]
        scratch: dict[int, Any] = {}
        for rule in plan.rules:
            pool.reset()
            scratch[id(rule)] = rule.scratch(pool, Z)
        return (*own, scratch)

    def kernels(self, plan: Plan) -> Compiled:
        """:func:`positions`' kernel of each rule of ``plan`` (:meth:`Rule.positions`), the motor
        row of ``z`` ((T,) view) and its ground rows ((G, T) view where consecutive, else None),
        made on the first call and kept."""
        if self._kernels is None or self._kernels[0] is not plan:
            ground = self.ground(plan)
            self._kernels = (plan, ([rule.positions(self) for rule in plan.rules], self.z[plan.motor_row],
                                    None if ground is None else self.z[ground]))
        return self._kernels[1]

    def ground(self, plan: Plan) -> slice | None:
        """``plan``'s ground rows as a slice where they are consecutive (a view, not a gather), else None."""
        if self._ground is None or self._ground[0] is not plan:
            g = plan.ground_rows
            run = bool(g.size) and np.array_equal(g, np.arange(g[0], g[0] + g.size))
            self._ground = (plan, slice(int(g[0]), int(g[0]) + g.size) if run else None)
        return self._ground[1]

    def motor(self, geom: Geometry) -> tuple[Any, Any, Any]:
        """``geom``'s rest angle, arm and pivot as 0-d arrays for one linkage (a Python scalar
        operand costs numpy a conversion per call), kept for the last geometry; as they are for K."""
        if self._motor[0] is not geom:
            many = bool(geom.linkages)
            rest_angle, arm, pivot = (v if many else np.array(v) for v in (geom.rest_angle, geom.arm, geom.pivot))
            self._motor = (geom, (rest_angle, arm, pivot))
        return self._motor[1]

    def zeros(self, shape: tuple[int, ...]) -> np.ndarray:
        """Zeros of ``shape`` (the linear input of a rotary plan), kept."""
        if self._zeros.shape != shape:
            self._zeros = np.zeros(shape)
        return self._zeros

    def fits(self, order: int, linkages: tuple[int, ...], samples: int) -> bool:
        """Whether it holds an evaluation of this derivative order and shape."""
        return self.order == order and self.linkages == linkages and self.samples == samples


def positions(plan: Plan, geom: Geometry, angle: np.ndarray, work: Workspace | None = None) -> np.ndarray:
    """Positions only, (P, T) complex, for absolute motor angles ``angle`` (T,) in radians.

    NaN where the linkage cannot be assembled (see :func:`evaluate` for diagnostics). Pass a
    :class:`Workspace` to evaluate repeatedly without allocating; the result is then
    ``work.z`` (with numeric groups, a view of its continuation grid's: :func:`evaluate`),
    overwritten by the next call.
    """
    if plan.steps:
        fit = work is not None and work.fits(0, geom.linkages, np.shape(angle)[-1])
        return evaluate(plan, geom, angle, 0, work if fit else None).z
    w = work if work is not None and work.samples == angle.shape[0] else Workspace(plan, angle.shape[0])
    z, (kernels, arm, ground) = w.z, w.kernels(plan)
    if ground is None:
        z[plan.ground_rows] = geom.ground
    else:
        np.copyto(ground, geom.ground)
    rest_angle, turn, pivot = w.motor(geom)
    np.add(turn_arm(geom, angle, arm, rest_angle, turn), pivot, out=arm)
    with np.errstate(invalid="ignore", divide="ignore"):
        for kernel, const in zip(kernels, geom.constants):
            kernel(const)
    return z


def continuation_grid(start: float | np.ndarray, values: np.ndarray, max_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Input values from ``start`` through ``values`` (T,) at most ``max_step`` apart, and where
    each of ``values`` is in them (T,). K linkages' (``start`` (K, 1) or ``values`` (K, T)):
    one grid (K, T') each, a move cut into as many pieces for all of them (the most any needs),
    so that ``values`` sit at the same places (T,) in every one."""
    if np.ndim(start) or values.ndim > 1:
        count = max(np.size(start), values.shape[0] if values.ndim > 1 else 1)
        path = np.concatenate([np.broadcast_to(np.reshape(start, (-1, 1)), (count, 1)),
                               np.broadcast_to(values, (count, values.shape[-1]))], axis=1)
    else:
        path = np.concatenate([[start], values])
    moves = np.abs(path[..., 1:] - path[..., :-1])
    if float(moves.max(initial=0.0)) / max_step - 1e-9 <= 1.0:  # fine enough already: each value is its own piece
        return path, np.arange(1, path.shape[-1])
    parts = np.ceil(moves / max_step - 1e-9).reshape(-1, values.shape[-1]).max(axis=0)
    parts = np.maximum(parts, 1).astype(int)
    first = np.concatenate([[0], np.cumsum(parts)])
    piece = np.repeat(np.arange(values.shape[-1]), parts)  # the move each fine value belongs to
    within = np.arange(first[-1]) - first[piece]
    fine = path[..., piece] + (path[..., piece + 1] - path[..., piece]) * within / parts[piece]
    return np.concatenate([fine, path[..., -1:]], axis=-1), first[1:]


def evaluate(plan: Plan, geom: Geometry, angle: np.ndarray, order: int = 2, work: Workspace | None = None) -> State:
    """Positions and up to ``order`` (0, 1, 2) derivatives, plus singularity distances.

    ``angle`` (T,): absolute motor angles, radians (for a linear input: displacements along the
    slot in the normalized frame); (K, T) or (T,) with a geometry of K linkages (then every array
    has a linkage axis after its row, see :func:`_evaluate`). A plan with slider steps needs a
    geometry in the normalized frame (``Geometry.of(plan, plan.normalized_points())``). A numeric group is continued from
    the rest pose through every sample in order, at most GROUP_STEP_DEG (GROUP_STEP_LENGTH)
    apart: intermediate inputs are evaluated and dropped. With a :class:`Workspace` of this
    order and shape (``Workspace(plan, T, order, geom.linkages)``) nothing is allocated; the
    state's arrays are then its buffers, overwritten by the next call (with numeric groups it
    keeps the continuation grid's workspace instead, and the state's arrays are views of it, or
    copies where the grid has samples between the given ones).
    """
    if not plan.has_groups:
        return _evaluate(plan, geom, angle, order, work)
    angle = np.asarray(angle, dtype=float)
    rest = np.asarray(geom.rest_angle, dtype=float)
    start: float | np.ndarray = 0.0
    if not plan.linear:  # K linkages at different rest angles: a grid each (K, T')
        start = float(rest.flat[0]) if angle.ndim == 1 and (rest == rest.flat[0]).all() else rest
    step = GROUP_STEP_LENGTH if plan.linear else np.radians(GROUP_STEP_DEG)
    fine, keep = continuation_grid(start, angle, step)
    sub = None
    if work is not None:
        if work.fine is None or not work.fine.fits(order, geom.linkages, fine.shape[-1]):
            work.fine = Workspace(plan, fine.shape[-1], order, geom.linkages)
        sub = work.fine
    full = _evaluate(plan, geom, fine, order, sub)

    run: slice | np.ndarray = keep  # the samples kept: a view when they follow each other
    if keep.size and keep[-1] - keep[0] == keep.size - 1:
        run = slice(keep[0], keep[-1] + 1)

    def pick(a: np.ndarray) -> np.ndarray:
        return a[..., run]

    between_ok = bool(np.isfinite(full.z).all() and assembles(full.ds).all())
    return State(z=pick(full.z), dz=None if full.dz is None else pick(full.dz),
                 ddz=None if full.ddz is None else pick(full.ddz), ds=pick(full.ds), between_ok=between_ok)


def _step_rows(plan: Plan, geom: Geometry) -> dict[int, Rows]:
    """Each step's constraint rows at ``geom``'s rest pose (each of K linkages'), by ``id`` of the
    step (their derivatives come from these rows, :meth:`~linkedit.planar.rules.Step.velocity`)."""
    rest = geom.rest[: plan.n_joints]
    all_rows = linkage_rows(plan.graph, rest=rest)
    return {id(st): st.rows_at(all_rows, rest) for st in plan.steps}


def _moved(plan: Plan, geom: Geometry) -> bool:
    """Whether ``geom`` has steps at a rest pose other than the one they were compiled at (K
    linkages always): their derivatives then need their rows there (:func:`_step_rows`)."""
    return bool(plan.steps) and (bool(geom.linkages) or not np.array_equal(geom.rest[: plan.n_joints], plan.steps_rest))


def turn_arm(geom: Geometry, angle: np.ndarray, out: np.ndarray, rest_angle: Any = None, arm: Any = None) -> np.ndarray:
    """The motor arm turned to absolute angles ``angle``: arm·e^{i(angle − rest angle)} into ``out``
    (*L, T) complex. K linkages at common angles (T,) take K + T exponentials, not K·T; otherwise
    e^{iφ} is written as cos φ + i sin φ into ``out`` (numpy's complex exp gives the same bits, at
    twice the cost). ``rest_angle``, ``arm``: ``geom``'s, as :meth:`Workspace.motor` keeps them."""
    if geom.linkages and angle.ndim == 1:
        return np.multiply(geom.arm * np.exp(-1j * geom.rest_angle), np.exp(1j * angle), out=out)
    phi = np.subtract(angle, geom.rest_angle if rest_angle is None else rest_angle)
    np.cos(phi, out=out.real)
    np.sin(phi, out=out.imag)
    return np.multiply(out, geom.arm if arm is None else arm, out=out)


def _evaluate(plan: Plan, geom: Geometry, angle: np.ndarray, order: int, work: Workspace | None = None,
              distances: bool = True) -> State:
    """The one evaluation of a plan: every rule in order. With a geometry of K linkages
    (:attr:`Geometry.linkages`), arrays carry a linkage axis after the row: (P, K, T), and
    ``angle`` may be (K, T); every rule but a numeric group places K linkages at once, with
    their derivatives. ``work``: see :func:`evaluate`. Without ``distances`` the dyads' d_s are
    not formed (a caller that wants positions alone): the state's ``ds`` then has no rows."""
    lead = geom.linkages
    T = angle.shape[-1]
    if work is None or not work.fits(order, lead, T):
        work = Workspace(plan, T, order, lead)
    Z, ds = work.orders, work.ds
    if (plan.steps or plan.linear) and (order > 0 or not lead):
        Z.fill(0.0)  # a step's derivative rows multiply not-yet-known joints by 0 (K linkages' positions alone
        # read only the joints placed before them: every row is written before it is read)
    if distances:
        ds.fill(1.0)
    run = work.ground(plan)
    ground = plan.ground_rows if run is None else run
    Z[0, ground] = geom.ground
    Z[1:, ground] = 0.0
    if not plan.linear:
        arm = Z[0, plan.motor_row]
        rest_angle, turn, pivot = work.motor(geom)
        turn_arm(geom, angle, arm, rest_angle, turn)
        if order >= 1:
            np.multiply(arm, _I, out=Z[1, plan.motor_row])
        if order >= 2:
            np.negative(arm, out=Z[2, plan.motor_row])
        np.add(arm, pivot, out=arm)
    s = angle if plan.linear else work.zeros(angle.shape)
    dz, ddz = (Z[1] if order >= 1 else None), (Z[2] if order >= 2 else None)
    held = work.frame
    if held is None or held[0] is not plan or held[1] is not geom or held[2] != distances:
        frame = Frame(z=Z[0], dz=dz, ddz=ddz, ds=ds, joints=plan.row_of[: plan.n_joints], s=s,
                      drive=1.0 if plan.linear else 0.0, rest=geom.rest, orders=Z, scratch=work.scratch,
                      rows=_step_rows(plan, geom) if order > 0 and _moved(plan, geom) else {}, distances=distances)
        work.frame = (plan, geom, distances, frame)
    else:
        frame = held[3]
        frame.s = s
    with np.errstate(invalid="ignore", divide="ignore"):
        for rule, rows, const in zip(plan.rules, plan.ds_rows, geom.constants):
            rule.evaluate(frame, const, rows)
    return State(z=Z[0], dz=dz, ddz=ddz, ds=ds if distances else ds[:0])
