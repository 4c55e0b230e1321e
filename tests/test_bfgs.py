"""BFGS never accepts an infeasible step (energy +inf), and converges on smooth problems."""

from __future__ import annotations

import numpy as np

from linkedit.edit.bfgs import minimize


def test_converges_on_a_quadratic_to_precision():
    A = np.array([[3.0, 1.0], [1.0, 2.0]])
    b = np.array([1.0, -2.0])
    result = minimize(lambda x: (0.5 * x @ A @ x - b @ x, A @ x - b, None), np.zeros(2))
    assert result.converged
    assert np.allclose(result.x, np.linalg.solve(A, b), atol=1e-8)


def test_infeasible_steps_are_rejected_never_accepted():
    accepted: list[np.ndarray] = []

    def energy(x: np.ndarray):
        if x[0] >= 2.0:  # beyond this the "linkage cannot be assembled"
            return np.inf, None, None
        return float((x[0] - 3.0) ** 2 + x[1] ** 2), np.array([2 * (x[0] - 3.0), 2 * x[1]]), None

    def spy(it: int, e: float) -> None:
        accepted.append(e)

    start = np.array([0.0, 1.0])
    result = minimize(energy, start, callback=spy)
    assert result.rejected > 0  # it did try steps into the infeasible region
    assert accepted and np.isfinite(accepted).all()  # and accepted none of them
    assert np.all(np.diff(accepted) <= 0)
    assert result.x[0] < 2.0 and result.energy < energy(start)[0]
    assert abs(result.x[0] - 2.0) < 1e-2  # pressed against the boundary
