"""A passive degree of freedom (the RSSR coupler's idle spin about the line through its ball
joints) takes its canonical pose — the pose nearest the rest pose — at every step, whatever
``--steps``, and its written velocities are that pose's time derivatives (issue 22, defect 2:
the spin was kept still from step to step, so the coupler's off-axis point ``fin`` differed by
3.3e-4 of the size between 19 and 361 steps)."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.gcs import quaternions as quat
from linkedit.io.gcs_hdf5 import read_result
from linkedit.gcs.members import compile_mechanism
from linkedit.spec.mechanism3d import MechanismSpec
from linkedit.spec.yamlload import load_model
from tests import gcs_oracles as oracle
from tests.conftest import EXAMPLES

RSSR = EXAMPLES / "3d" / "rssr.yaml"


def _size() -> float:
    return compile_mechanism(load_model(MechanismSpec, RSSR))[0].length_scale


def _rssr_canonical(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The coupler's canonical rotation matrices (T, 3, 3) and fin (T, 3), in closed form: the
    crank tip A (the coupler's origin, its ball a) and the rocker tip B (oracle.rssr) fix the
    coupler up to its spin ψ about u = (B − A)/|B − A|; its position does not depend on ψ, so the
    pose nearest the rest pose is the rotation nearest the rest rotation R₀: the largest
    tr(R₀ᵀ Rot(u, ψ) R₁) = c + b cos ψ + s sin ψ (R₁ any rotation taking the coupler's x to u)."""
    theta = 2 * np.pi * t
    A = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=1)
    B = oracle.rssr(theta)
    u = (B - A) / np.linalg.norm(B - A, axis=1, keepdims=True)
    helper = np.cross(u, [0.0, 0.0, 1.0])
    helper /= np.linalg.norm(helper, axis=1, keepdims=True)
    R1 = np.stack([u, helper, np.cross(u, helper)], axis=2)  # columns: x → u
    axis = np.array([0, -0.88128, 0.472595])
    R0 = quat.to_matrix(np.r_[np.cos(np.radians(28.5)), np.sin(np.radians(28.5)) * axis / np.linalg.norm(axis)])
    Mx = R1 @ R0.T
    zero = np.zeros_like(theta)
    ux = np.stack([np.stack([zero, -u[:, 2], u[:, 1]], 1), np.stack([u[:, 2], zero, -u[:, 0]], 1),
                   np.stack([-u[:, 1], u[:, 0], zero], 1)], axis=1)  # [u]×
    trM = np.trace(Mx, axis1=1, axis2=2)
    uMu = np.einsum("ti,tij,tj->t", u, Mx, u)
    psi = np.arctan2(np.trace(ux @ Mx, axis1=1, axis2=2), trM - uMu)
    c, s = np.cos(psi)[:, None, None], np.sin(psi)[:, None, None]
    rot = c * np.eye(3) + s * ux + (1 - c) * u[:, :, None] * u[:, None, :]
    R = rot @ R1
    return R, A + R @ np.array([2.75, 0.8, 0.0])


def _solve(run_cli, tmp_path, steps: int, *extra: str):
    out = tmp_path / f"rssr-{steps}.h5"
    result = run_cli("solve3d", RSSR, "-o", out, "--steps", steps, "-q", *extra)
    assert result.exit_code == 0, result.output
    return read_result(out)


def _angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """The rotation angle between unit quaternions (..., 4), q ≡ −q (radians)."""
    return 2 * np.arcsin(np.clip(np.linalg.norm(quat.multiply(q1, quat.conjugate(q2))[..., 1:], axis=-1), 0, 1))


def test_the_canonical_oracle_is_a_nearest_pose():
    """The closed form's ψ is the spin whose rotation is nearest the rest rotation (a scan)."""
    t = np.array([0.0, 0.3, 0.7])
    R, _ = _rssr_canonical(t)
    axis = np.array([0, -0.88128, 0.472595])
    R0 = quat.to_matrix(np.r_[np.cos(np.radians(28.5)), np.sin(np.radians(28.5)) * axis / np.linalg.norm(axis)])
    B = oracle.rssr(2 * np.pi * t)
    A = np.stack([np.cos(2 * np.pi * t), np.sin(2 * np.pi * t), 0 * t], axis=1)
    for k in range(len(t)):
        u = (B[k] - A[k]) / np.linalg.norm(B[k] - A[k])
        best = np.trace(R0.T @ R[k])
        for psi in np.linspace(-np.pi, np.pi, 721):
            turn = quat.to_matrix(np.r_[np.cos(psi / 2), np.sin(psi / 2) * u])
            assert np.trace(R0.T @ turn @ R[k]) <= best + 1e-12


def test_rssr_passive_pose_does_not_depend_on_steps(run_cli, tmp_path):
    """fin and every member pose at --steps 361, 37, 19, 5 agree at shared times to 1e-9 of
    the size, and the coupler is at its closed-form canonical pose (nearest the rest pose)."""
    size = _size()
    runs = {n: _solve(run_cli, tmp_path, n) for n in (361, 37, 19, 5)}
    fine = runs[361]
    for n, res in runs.items():
        assert (res.diagnostics.status == 0).all()
        R, fin = _rssr_canonical(res.t)
        assert np.abs(res.tracks["fin"].position - fin).max() < 1e-9 * size, n
        coupler = res.member_names.index("coupler")
        assert np.abs(quat.to_matrix(res.orientation[:, coupler]) - R).max() < 1e-9, n
        every = (len(fine.t) - 1) // (n - 1)
        assert np.abs(res.tracks["fin"].position - fine.tracks["fin"].position[::every]).max() < 1e-9 * size, n
        assert np.abs(res.position - fine.position[::every]).max() < 1e-9 * size, n
        assert _angle(res.orientation, fine.orientation[::every]).max() < 1e-9, n


def test_rssr_velocities_are_the_canonical_motion(run_cli, tmp_path):
    """The written velocities (members and fin) equal fourth-order central differences of a
    fine run's poses (h = 1/2000: truncation and the poses' own error amplified, ~1e-9 of
    the size per unit t), and the coupler's and fin's those of the closed form (the old
    velocities, with the coupler's spin rate left out, were off by its rate: ~1 rad per unit t)."""
    size = _size()
    res = _solve(run_cli, tmp_path, 2001)
    h = res.t[1] - res.t[0]
    k = np.arange(2, len(res.t) - 2, 37)

    def d(x: np.ndarray) -> np.ndarray:
        return (x[k - 2] - 8 * x[k - 1] + 8 * x[k + 1] - x[k + 2]) / (12 * h)

    assert np.abs(res.tracks["fin"].velocity[k] - d(res.tracks["fin"].position)).max() < 2e-9 * size
    assert np.abs(res.velocity[k, :, :3] - d(res.position)).max() < 2e-9 * size
    # the angular velocity ω: q̇ = ½ (0, ω) ⊗ q
    w = 2 * quat.multiply(d(res.orientation), quat.conjugate(res.orientation[k]))[..., 1:]
    assert np.abs(res.velocity[k, :, 3:] - w).max() < 1e-7
    t, e = res.t[k], 3e-4  # a fourth-order stencil on the closed form: error ~1e-11
    R = [_rssr_canonical(t + j * e) for j in (-2, -1, 1, 2)]
    fin_rate = (R[0][1] - 8 * R[1][1] + 8 * R[2][1] - R[3][1]) / (12 * e)
    assert np.abs(res.tracks["fin"].velocity[k] - fin_rate).max() < 1e-9 * size
    W = (R[0][0] - 8 * R[1][0] + 8 * R[2][0] - R[3][0]) / (12 * e) @ np.swapaxes(_rssr_canonical(t)[0], 1, 2)
    coupler = res.member_names.index("coupler")  # Ṙ Rᵀ = [ω]×
    assert np.abs(res.velocity[k, coupler, 3:] - np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)).max() < 1e-9


@pytest.mark.slow
def test_waves_without_the_closed_form_split_j_inside_the_canonical_step():
    """Extrapolated waves of a passive DOF (the closed form off) whose first many-pose Jacobian
    is the canonical step's at 4B moved poses: J's blocks split there, the step's J taken before
    in one block (main: a broadcast ValueError traceback from ``solve3d
    examples/3d/spatial-slider-crank.yaml --steps 1000``); the run is the step-by-step one."""
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.structure import StructureCache
    from linkedit.gcs.tolerances import Options

    system = compile_mechanism(load_model(MechanismSpec, EXAMPLES / "3d" / "spatial-slider-crank.yaml"))[0]
    t = np.linspace(0.0, 1.0, 1000)
    cache = StructureCache(system)
    cache._closed = (None,)  # the waves' own predictions
    run = solve_run(system, t, cache=cache)
    assert (run.status == 0).all() and run.batched.sum() > 900 and cache.waves is not None and cache.waves.closed is None
    off = solve_run(system, t[:100], Options(waves=False))
    assert np.abs(run.position[:100] - off.position).max() <= 1e-9 * system.length_scale
