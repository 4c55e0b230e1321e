"""What an edit may change: the rest pose as an affine function of the free variables.

x̄ = x₀ + B·v, x̄ (J, 2) flattened to (2J,), v (n,). A free joint has one variable per free axis
(``lock`` fixes a joint or one of its axes). Unless the script frees the motor's rest angle,
the motor joint stays on the ray from its pivot at the original angle: its one variable is the
crank radius, and it follows its pivot.

Columns are *coloured* for forward-mode derivatives: two variables may share a colour when no
residual depends on both (the joints of different legs), so a Jacobian needs as many directions
as the largest dependency set, not as many as there are variables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.plan import Plan


@dataclass(frozen=True)
class Variables:
    """The free variables of one operation. ``B`` (2J, n); ``labels`` like ``C.x``, ``A.radius``."""

    x0: np.ndarray  # (J, 2) rest pose at v = 0
    B: np.ndarray
    labels: tuple[str, ...]

    @property
    def n(self) -> int:
        return self.B.shape[1]

    def rest(self, v: np.ndarray) -> np.ndarray:
        """Rest pose (J, 2) for variables ``v`` (n,)."""
        return self.x0 + (self.B @ v).reshape(-1, 2)

    def uses(self) -> np.ndarray:
        """(J, n) bool: which variables move each joint."""
        return (self.B.reshape(-1, 2, self.n) != 0).any(axis=1)


def parametrize(plan: Plan, x: np.ndarray, locked: dict[int, str], free_angle: bool) -> Variables:
    """Variables for rest pose ``x`` (J, 2); ``locked`` maps joint → locked axes ("xy", "x", "y").

    With the motor angle fixed, a motor joint locked on any axis is locked entirely. A linear
    input's driven joint keeps its slot line unless ``free_angle``: its one variable ``.along``
    is its rest position on the slot (where the stroke, fixed in length units, starts from).
    """
    names = plan.joint_names
    motor, pivot = plan.graph.motor, plan.graph.pivot
    columns: list[np.ndarray] = []
    labels: list[str] = []
    J = len(names)
    follows_pivot = not free_angle and motor not in locked and not plan.linear
    for j in range(J):
        if j == motor and not free_angle and motor not in locked:
            if plan.linear:
                label, direction = "along", np.exp(1j * plan.graph.sliders[plan.graph.drive].angle)
            else:
                label, direction = "radius", complex(*(x[motor] - x[pivot]))
            col = np.zeros(2 * J)
            col[2 * motor:2 * motor + 2] = np.array([direction.real, direction.imag]) / abs(direction)
            columns.append(col)
            labels.append(f"{names[j]}.{label}")
            continue
        if j == motor and not free_angle:  # partly locked, angle fixed: the crank pin stays
            continue
        for a, axis in enumerate("xy"):
            if axis in locked.get(j, ""):
                continue
            col = np.zeros(2 * J)
            col[2 * j + a] = 1.0
            if j == pivot and follows_pivot:
                col[2 * motor + a] = 1.0
            columns.append(col)
            labels.append(f"{names[j]}.{axis}")
    B = np.column_stack(columns) if columns else np.zeros((2 * J, 0))
    return Variables(x0=x.copy(), B=B, labels=tuple(labels))


def colour(sets: np.ndarray) -> np.ndarray:
    """Greedy colouring of variables so that no set (rows of ``sets`` (S, n) bool) repeats a colour:
    variable v, in order, takes the lowest colour none of the variables sharing a set with it has.

    The conflicts are a sparse (n, n) product: a big linkage's sets are small (a joint depends on
    its own leg and the crank), and the dense product cost O(S n²) (minutes for 1,000 joints)."""
    from scipy import sparse

    n = sets.shape[1]
    s = sparse.csr_matrix(sets, dtype=np.int32)
    conflict = (s.T @ s).tocsr()
    start, neighbours = conflict.indptr, conflict.indices
    colours = np.full(n, -1)
    for v in range(n):
        near = colours[neighbours[start[v]:start[v + 1]]]
        taken = np.zeros(near.size + 1, dtype=bool)
        taken[near[(near >= 0) & (near < taken.size)]] = True
        colours[v] = int(np.argmin(taken))
    return colours


def column_map(sets: np.ndarray, colours: np.ndarray, C: int) -> np.ndarray:
    """(S, C) int: for each set and colour, the variable of that colour in the set, or −1."""
    out = np.full((sets.shape[0], C), -1)
    rows, cols = np.nonzero(sets)
    out[rows, colours[cols]] = cols
    return out


def seeds(var: Variables, colours: np.ndarray, C: int) -> np.ndarray:
    """(J, C) complex rest-pose tangent of each colour: the sum of its variables' columns."""
    S = np.zeros((var.n, C))
    S[np.arange(var.n), colours] = 1.0
    D = (var.B @ S).reshape(-1, 2, C)
    return D[:, 0] + 1j * D[:, 1]
