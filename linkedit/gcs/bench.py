"""Benchmark of the 3D solver (``linkedit bench --section gcs``).

1. Numeric vs symbolic engine on the 3- and 10-pair Strandbeests, 360 samples: ms per step of
   each (positions only, as both engines solve them), and their ratio, in the same run (LinkEdit §5.1 reports 110× and 250×). Targets for
   the numeric engine: ≤ 0.5 and ≤ 2 ms per step.
2. The six-bar assembled once from a rough start (every member displaced by ~10 % of its
   length and turned by ~0.1 rad): Gauss–Newton with analytic Jacobians vs the paper's SLSQP
   with finite differences (target ≥ 100×).
3. The six-bar over 360 steps: ms per step.
4. Side by side with SolveSpace (python-solvespace, the optional ``bench`` extra): planar
   linkages over 360 one-degree steps, each built in both solvers (linkedit: members with pins
   in 3D; SolveSpace: joint points in a 2D sketch held by link distances, ground points and the
   crank pin dragged to their positions), ms per step of each, their ratio, and the largest
   difference of the joint positions.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.timing import best_time

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "3d"


def _strandbeests(echo: Callable[[str], None], quick: bool) -> None:
    from linkedit.gcs.planar_bridge import planar_model, simulate_numeric
    from linkedit.planar import catalog, compile_plan, simulate
    from linkedit.planar.kinematics import Workspace, positions
    from linkedit.planar.simulate import motor_angles

    samples = 24 if quick else 360
    repeats = 1 if quick else 3
    echo(f"{'mechanism':<22}{'joints':>7}{'members':>8}{'unknowns':>9}  {'symbolic ms/step':>17}  "
         f"{'numeric ms/step':>16}  {'ratio':>7}  {'iter/step':>9}  {'max |Δp|':>9}  target")
    for name, pairs, target in (("Strandbeest 3 pairs", 3, 0.5), ("Strandbeest 10 pairs", 10, 2.0)):
        spec = catalog.strandbeest(pairs)
        plan = compile_plan(spec)
        t, angle = motor_angles(spec, samples)
        geom, work = plan.geometry(), Workspace(plan, samples)
        # like for like: both engines solve positions only
        sym = best_time(lambda: positions(plan, geom, angle, work), 20 * repeats) / samples * 1e3
        model = planar_model(spec)
        runs = [simulate_numeric(spec, t, model=model) for _ in range(repeats)]
        num = min(r.ms_per_step for r in runs)
        diff = float(np.abs(runs[0].positions - simulate(plan, samples).positions).max())
        s = model.system
        echo(f"{name:<22}{len(spec.joints):>7}{s.n_members:>8}{s.n_unknowns:>9}  {sym:>17.4f}  {num:>16.3f}  "
             f"{num / sym:>6.0f}×  {runs[0].iterations.mean():>9.2f}  {diff:>9.1e}  ≤ {target} ms")


def _rough_start(system, rng: np.random.Generator) -> "State":
    """Every member displaced by ~10 % of its length (in the plane) and turned by ~0.1 rad."""
    from linkedit.gcs.system import State

    P = system.rest.position.copy()
    Q = system.rest.orientation.copy()
    for m, name in enumerate(system.member_names):
        pts = np.array(list(system.points.get(name, {}).values()) or [[0.0, 0.0, 0.0]])
        length = max(float(np.ptp(pts, axis=0).max()), 1e-3)
        angle = rng.uniform(0, 2 * np.pi)
        P[m, :2] += 0.1 * length * np.array([np.cos(angle), np.sin(angle)])
        Q[m] = quat.multiply(quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), rng.choice([-0.1, 0.1])), Q[m])
    return State(P, Q)


def _six_bar(echo: Callable[[str], None], quick: bool) -> None:
    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.solver import STATUS_NAMES, Options, Solver, solve_run
    from linkedit.spec.mechanism3d import MechanismSpec
    from linkedit.spec.yamlload import load_model

    name = "crank-rocker" if quick else "six-bar"
    spec = load_model(MechanismSpec, EXAMPLES / f"{name}.yaml")
    system, _ = compile_mechanism(spec)
    t = np.zeros(1)
    table = system.step_table(t)
    start = _rough_start(system, np.random.default_rng(1))
    r0 = system.evaluate(start, table, 0).r
    figures = {}
    # best of many for the sub-millisecond solve (a few repeats on a shared machine mostly
    # measure the scheduler), best of two for the ~0.1 s SLSQP run
    for solver, repeats in (("lm", 50), ("slsqp-fd", 1 if quick else 2)):
        holder = {}
        engine = Solver(system, Options(solver=solver))  # compiled once, like the spec

        def once() -> None:
            holder["out"] = engine.solve(start, table, 0)

        figures[solver] = (best_time(once, repeats), holder["out"])
    echo(f"{name} from a rough start (residual {np.linalg.norm(r0):.3g}): one solve")
    for solver, (sec, (_, r, info)) in figures.items():
        echo(f"  {solver:<9} {sec * 1e3:>10.2f} ms  residual {np.linalg.norm(r):.1e}  "
             f"({STATUS_NAMES[info.status]}, {info.iterations} iterations)")
    ratio = figures["slsqp-fd"][0] / figures["lm"][0]
    echo(f"  analytic Gauss–Newton is {ratio:.0f}× faster than slsqp-fd (target ≥ 100×); each judged by its own "
         f"tolerance (largest scaled residual ≤ {Options().satisfied_tol:.0e} for lm, "
         f"≤ {Options(solver='slsqp-fd').satisfied_tol:.0e} for slsqp-fd)")

    steps = 24 if quick else 360
    t = np.arange(steps) / steps
    table = system.step_table(t)
    sec = best_time(lambda: solve_run(system, t, table=table), 1 if quick else 3)
    run = solve_run(system, t, table=table)
    echo(f"{name} over {steps} steps: {sec / steps * 1e3:.3f} ms per step, "
         f"{run.iterations.mean():.2f} linear solves per step, max residual {np.abs(run.residual).max():.1e}")


def _solvespace_run(spec, angle: np.ndarray) -> tuple[float, np.ndarray] | None:
    """Seconds per step and joint positions (T, J, 2) of a planar linkage solved by SolveSpace
    with the crank pin set (and dragged) at each motor angle (T,); None when SolveSpace fails."""
    import time

    from python_solvespace import ResultFlag, SolverSystem

    s = SolverSystem()
    wp = s.create_2d_base()
    names = list(spec.joints)
    pts = {n: s.add_point_2d(float(x), float(y), wp) for n, (x, y) in spec.joints.items()}
    tip, pivot = spec.motor.joint, spec.motor.pivot
    held = set(spec.ground) | {tip}  # dragged: a distance between two of them would be redundant
    for n in held:
        s.dragged(pts[n], wp)
    for members in spec.links.values():
        for i, a in enumerate(members):
            for b in members[i + 1:]:
                if not (a in held and b in held):
                    s.distance(pts[a], pts[b], float(np.hypot(*np.subtract(spec.joints[a], spec.joints[b]))), wp)
    c = np.asarray(spec.joints[pivot], dtype=float)
    r = float(np.hypot(*(np.asarray(spec.joints[tip]) - c)))
    out = np.empty((angle.size, len(names), 2))
    start = time.perf_counter()
    for k, a in enumerate(angle):
        s.set_params(pts[tip].params, (c[0] + r * np.cos(a), c[1] + r * np.sin(a)))
        if s.solve() != ResultFlag.OKAY:
            return None
        out[k] = [s.params(pts[n].params) for n in names]
    return (time.perf_counter() - start) / angle.size, out


def _solvespace(echo: Callable[[str], None], quick: bool) -> None:
    from linkedit.gcs.planar_bridge import planar_model, point_positions
    from linkedit.gcs.solver import solve_run
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.yamlload import load_model

    try:
        import python_solvespace  # noqa: F401
    except ImportError:
        echo("SolveSpace side by side: python-solvespace is not installed (pip install 'linkedit[bench]')")
        return
    steps = 24 if quick else 360
    repeats = 1 if quick else 3
    echo(f"{'vs SolveSpace, ' + str(steps) + ' steps':<26}{'unknowns':>9}  {'linkedit ms/step':>17}  "
         f"{'SolveSpace ms/step':>19}  {'ratio':>6}  {'max |Δp| / size':>16}")
    for name in ("crank-rocker", "hoekens", "jansen", "klann"):
        spec = load_model(LinkageSpec, EXAMPLES.parent / f"{name}.yaml")
        model = planar_model(spec)
        t = np.arange(steps) / steps
        angle = model.motor_rest_angle + model.direction * 2.0 * np.pi * t
        ours = best_time(lambda: solve_run(model.system, t), repeats) / steps
        run = solve_run(model.system, t)
        xyz = point_positions(model.joint_member, model.joint_point, run.position, run.orientation)[..., :2]
        runs = [_solvespace_run(spec, angle) for _ in range(repeats)]
        if runs[0] is None:
            echo(f"{name:<26}{model.system.n_unknowns:>9}  {ours * 1e3:>17.3f}  SolveSpace could not solve it")
            continue
        theirs, their_xy = min(runs, key=lambda x: x[0])
        size = float(np.ptp(xyz.reshape(-1, 2), axis=0).max())
        diff = float(np.abs(xyz - their_xy).max()) / size
        echo(f"{name:<26}{model.system.n_unknowns:>9}  {ours * 1e3:>17.3f}  {theirs * 1e3:>19.3f}  "
             f"{ours / theirs:>5.1f}×  {diff:>16.1e}")


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    _strandbeests(echo, quick)
    _six_bar(echo, quick)
    _solvespace(echo, quick)
