"""The motion as a differentiable function of the rest pose, in forward mode.

:class:`RestPoseKinematics` evaluates every point of a plan at motor phases for a rest pose x̄:
link lengths, rigid-link coefficients and the motor arm all come from x̄, and the motor turns
from the rest pose (phase 0 *is* x̄, exactly as in ``simulate``). With tangents, it also
propagates ∂z/∂x̄ through the levels in C directions at once, batched like the positions:
arrays (R, C, T) for R rules, C directions, T samples.

The directions are *coloured* columns of the rest-pose parametrization (see
:mod:`linkedit.edit.variables`): variables that never influence the same point share one
direction (the legs of a Strandbeest), so C is the size of the largest dependency set, not the
number of variables.

Complex notation: z = x + iy; a tangent Dz has the same shape with a direction axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.edit import steps as es
from linkedit.edit.feasibility import failure
from linkedit.errors import MechanismError
from linkedit.planar.kinematics import GROUP_STEP_DEG, GROUP_STEP_LENGTH, continuation_grid
from linkedit.planar.plan import Plan
from linkedit.planar.rules import RestFrame, Step


@dataclass
class Evaluation:
    """One evaluation at a rest pose.

    ``rest`` (J,) complex joints; ``z`` (P, T) complex points in internal rows; ``ds`` (N, T)
    singularity distance per d_s row of the plan (``Plan.ds_rows``; 1 for rigid rules); with
    tangents, ``dz`` (P, C, T) and ``dlnds`` (N, C, T) = ∂ln d_s (rows the barrier guards,
    :attr:`RestPoseKinematics.guarded`; 0 elsewhere); ``why`` is None when the linkage works
    (:func:`linkedit.edit.feasibility.failure`).
    """

    rest: np.ndarray
    z: np.ndarray
    ds: np.ndarray
    dz: np.ndarray | None
    dlnds: np.ndarray | None
    why: str | None

    @property
    def works(self) -> bool:
        return self.why is None


class RestPoseKinematics:
    """Points of ``plan`` at inputs ``inputs`` (T,) from the rest pose: motor rotations
    (radians; spin = exp(i·rotation)) or, for a linear input, strokes (the driven joint's
    displacement along its slot, spec units: fixed in length, whatever the rest pose).

    ``drest`` (J, C) complex: the rest-pose tangent in each direction (constant: the
    parametrization is affine); ``arm``: the crank's rest direction when its angle is fixed.
    """

    def __init__(self, plan: Plan, inputs: np.ndarray, drest: np.ndarray, arm: complex | None = None) -> None:
        self.plan = plan
        inputs = np.asarray(inputs, dtype=float)
        self.linear = plan.linear
        self.spin = np.exp(1j * inputs) if not self.linear else np.ones(inputs.size, dtype=complex)
        self.stroke = inputs / plan.scale if self.linear else np.zeros(inputs.size)  # normalized frame
        self.drest = drest
        #: (T,) for messages: the rotation in degrees, or the stroke in spec units
        self.turn_deg = inputs if self.linear else np.degrees(np.angle(self.spin))
        self.arm = arm  # the crank's rest direction when its angle is fixed
        self.J = plan.n_joints
        g = plan.graph
        self.ground = np.array(g.ground)
        self.motor, self.pivot = g.motor, g.pivot
        # tracked points on links keep their coefficient in the frame of their two joints
        self.fixed = {id(rule): kept for rule, const in zip(plan.rules, plan.geometry().constants)
                      if (kept := rule.kept(const, self.J)) is not None}
        self.steps = es.RestPoseSteps(plan) if plan.steps else None
        #: (N,) rows of ``ds`` the barrier guards (dyad rules, slider rules) and the point row
        #: each depends through (its written joint)
        self.guarded = np.zeros(plan.n_ds, dtype=bool)
        self.guard_rows = np.zeros(plan.n_ds, dtype=int)
        for rule, rows in zip(plan.rules, plan.ds_rows):
            self.guarded[rows] = rule.guarded
            self.guard_rows[rows] = plan.row_of[rule.placed()]
        # a numeric group is continued from the rest pose at most GROUP_STEP_DEG apart (as in simulate)
        self.keep = None
        if plan.has_groups and self.linear:
            self.stroke, self.keep = continuation_grid(0.0, self.stroke, GROUP_STEP_LENGTH)
            self.spin = np.ones(self.stroke.size, dtype=complex)
        elif plan.has_groups:
            turn = np.unwrap(np.concatenate([[0.0], np.angle(self.spin)]))[1:]
            fine, self.keep = continuation_grid(0.0, turn, np.radians(GROUP_STEP_DEG))
            self.spin = np.exp(1j * fine)
            self.stroke = np.zeros(fine.size)

    @property
    def directions(self) -> int:
        return self.drest.shape[1]

    def evaluate(self, x: np.ndarray, tangents: bool = False) -> Evaluation:
        """Evaluate at rest pose ``x`` (J, 2); with ``tangents``, also ∂z and ∂ln d_s."""
        plan = self.plan
        world = x[:, 0] + 1j * x[:, 1]
        rest = world if self.steps is None else self.steps.normalized(world)
        T, C = self.spin.size, self.directions
        N = plan.n_ds
        alloc = np.zeros if plan.steps else np.empty  # steps' rows multiply unknown joints by 0
        z = alloc((plan.n_points, T), dtype=complex)
        ds = np.ones((N, T))
        dz = alloc((plan.n_points, C, T), dtype=complex) if tangents else None
        dlnds = np.zeros((N, C, T)) if tangents else None
        D = self.drest if self.steps is None else self.drest / self.steps.scale
        graph, why = None, None
        steps: dict[int, Step] = {}
        if self.steps is not None:
            compiled: tuple = ()
            try:
                graph, compiled = self.steps.compile(rest)
            except MechanismError as exc:
                why = str(exc)
            why = why or self.steps.changed(compiled)
            if why is not None:
                return Evaluation(rest=world, z=z, ds=ds, dz=dz, dlnds=dlnds, why=why)
            steps = {id(old): new for old, new in zip(plan.steps, compiled)}
        z[plan.ground_rows] = rest[self.ground, None]
        if dz is not None:
            dz[plan.ground_rows] = D[self.ground][:, :, None]
        if not self.linear:  # a linear input's driven joint is placed by its step
            arm = rest[self.motor] - rest[self.pivot]
            z[plan.motor_row] = rest[self.pivot] + arm * self.spin
            if dz is not None:
                darm = D[self.motor] - D[self.pivot]
                dz[plan.motor_row] = D[self.pivot][:, None] + darm[:, None] * self.spin
        frame = RestFrame(z=z, ds=ds, dz=dz, dlnds=dlnds, rest=rest, D=D, joints=plan.row_of[: self.J],
                          s=self.stroke, graph=graph, steps=steps, fixed=self.fixed)
        with np.errstate(invalid="ignore", divide="ignore"):
            for rule, rows in zip(plan.rules, plan.ds_rows):
                rule.at_rest(frame, rows)
        if self.keep is not None:
            z, ds = z[:, self.keep], ds[:, self.keep]
            dz = None if dz is None else dz[..., self.keep]
            dlnds = None if dlnds is None else dlnds[..., self.keep]
        if self.steps is not None:
            z = self.steps.origin + self.steps.scale * z
            if dz is not None:
                dz *= self.steps.scale
        why = failure(plan, world, ds, self.turn_deg, self.arm)
        return Evaluation(rest=world, z=z, ds=ds, dz=dz, dlnds=dlnds, why=why)
