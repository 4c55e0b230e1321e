"""Benchmark of the 3D solver (``linkedit bench --section gcs``).

1. Numeric vs symbolic engine on the 3- and 10-pair Strandbeests, 360 samples: ms per step of
   each (positions only, as both engines solve them), and their ratio, in the same run (LinkEdit §5.1 reports 110× and 250×). Targets for
   the numeric engine: ≤ 0.5 and ≤ 2 ms per step.
2. The six-bar assembled once from a rough start (every member displaced by ~10 % of its
   length and turned by ~0.1 rad): Gauss–Newton with analytic Jacobians vs the paper's SLSQP
   with finite differences (target ≥ 100×).
3. The six-bar over 360 steps: ms per step.
4. Side by side with SolveSpace (python-solvespace, the optional ``bench`` extra), 360
   one-degree steps of the planar crank-rocker, Jansen leg and Klann linkage (through the 3D
   solver) and of the 3D six-bar, spherical four-bar and RSSR examples (the RSSR's coupler keeps
   its idle spin: a passive degree of freedom in both solvers). SolveSpace gets each mechanism as
   it would be sketched — joint points held at their link lengths (:data:`SPATIAL`), the
   ground and the input's driven point set at each step from linkedit's own run — once with
   those held points dragged (the baseline the issue measured) and once fixed in an earlier
   group (SolveSpace's leanest form). Both run in this process and are timed in CPU time (a
shared machine's waits left out), linkedit after one untimed run of each system (which builds
what waves keep on it, as SolveSpace's sketch is built before its timing). Printed: medians of interleaved runs of each, their
   ratio (target ≤ 1×, ≤ 2× with a passive DOF) and the largest difference of the compared
   points over the run, relative to the mechanism's size; and linkedit's time per step with the
   per-step diagnostics ``solve3d`` adds (status, degrees of freedom, redundant equations), how
   many steps it solved in waves (:mod:`linkedit.gcs.waves`), and whether they were predicted in
   closed form (:mod:`linkedit.gcs.closed_form`) or by extrapolation.
5. The variants of issue 22 (``examples/3d/bench/``: a cylinder-driven rocker, a crank-rocker
   whose coupler is a welded group, an offset slider-crank of joints, the Jansen leg with its
   pin axes in the xy plane, a steered spherical four-bar; with the spatial slider-crank and the
   passive-DOF RSSR examples): linkedit's CPU ms per step (median of repeats after an untimed
   run), and SolveSpace's where it is installed (sketches: :data:`VARIANTS`; a slider's point on
   a line, a driven length as a point on a circle whose radius is set at each step).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from linkedit.gcs import quaternions as quat
from linkedit.timing import best_time

if TYPE_CHECKING:
    from linkedit.gcs.solve import Run
    from linkedit.gcs.structure import StructureCache
    from linkedit.gcs.system import State, System

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
    from linkedit.gcs.continuation import Solver
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.structure import StructureCache
    from linkedit.gcs.tolerances import STATUS_NAMES, Options
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
    cache = StructureCache(system)
    sec = best_time(lambda: solve_run(system, t, table=table, cache=cache), 1 if quick else 3)
    run = solve_run(system, t, table=table, cache=cache)
    echo(f"{name} over {steps} steps: {sec / steps * 1e3:.3f} ms per step, "
         f"{run.iterations.mean():.2f} linear solves per step, max residual {np.abs(run.residual).max():.1e}")


@dataclass(frozen=True)
class PointModel:
    """A mechanism as SolveSpace sketches it: named points (world positions read from the
    linkedit run), held ones (ground and the input's driven point, set at each step), rigid
    links (every pair of a link's points at its rest distance, unless both are held), and
    points kept on a plane (``on_plane``: point → (plane point, unit normal))."""

    points: dict[str, tuple[str, str]]  #: name → (member, member point) in the linkedit system
    held: tuple[str, ...]
    links: tuple[tuple[str, ...], ...]
    planar: bool
    on_plane: dict[str, tuple[str, tuple[float, float, float]]] = field(default_factory=dict)
    #: points moved by a passive degree of freedom: each solver keeps them still its own way
    #: (SolveSpace: least change of its parameters), so they are not compared
    passive: tuple[str, ...] = ()
    #: points kept on a line (a slider): point → (world point on the line, direction)
    on_line: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = field(default_factory=dict)
    #: a driven length (a linear actuator): (point, centre); the point is kept on a circle about
    #: the held centre whose radius is set at each step from linkedit's run
    stroke: tuple[str, str] | None = None
    #: a planar sketch's workplane axes u, v in the world (rows (2, 3)) where the mechanism moves
    #: in another plane than xy
    plane: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None


#: spatial examples and their SolveSpace sketches (the RSSR coupler's fin keeps its idle spin:
#: a passive degree of freedom in both solvers)
SPATIAL = {
    "six-bar": PointModel(
        points={"A": ("crank", "A"), "B": ("crank", "B"), "C": ("coupler", "C"), "E": ("coupler", "E"),
                "D": ("rocker", "D"), "F": ("EF", "F"), "G": ("GFH", "G"), "H": ("GFH", "H")},
        held=("A", "D", "G", "B"), links=(("B", "C", "E"), ("C", "D"), ("E", "F"), ("G", "F", "H")), planar=True),
    "spherical-four-bar": PointModel(
        points={"o": ("crank", "o"), "a": ("crank", "a"), "b": ("crank", "b"), "c": ("coupler", "c"),
                "P": ("coupler", "P"), "d": ("rocker", "d")},
        held=("o", "a", "d", "b"), links=(("o", "b", "c", "P"), ("o", "c", "d")), planar=False),
    "rssr": PointModel(
        points={"O1": ("crank", "pivot"), "A": ("crank", "tip"), "O2": ("rocker", "pivot"),
                "B": ("rocker", "tip"), "fin": ("coupler", "fin")},
        held=("O1", "O2", "A"), links=(("O2", "B"), ("A", "B", "fin")), planar=False,
        on_plane={"B": ("O2", (1.0, 0.0, 0.0))}, passive=("fin",)),
}
#: planar linkages (examples/*.yaml) through the 3D solver
PLANAR = ("crank-rocker", "jansen", "klann")


def _solvespace_run(model: PointModel, xyz: np.ndarray, fixed: bool) -> tuple[float, np.ndarray] | None:
    """Seconds per step and point positions (T, P, 3) of a point model solved by SolveSpace
    from linkedit's positions ``xyz`` (T, P, 3): the held points are set to them at each step
    (the others start from step 0), either ``fixed`` (in an earlier group: parameters SolveSpace
    does not solve for) or dragged (unknowns it keeps where they were put, as the issue's
    baseline measured); None when SolveSpace fails."""
    import time

    from python_solvespace import Entity, ResultFlag, SolverSystem

    names = list(model.points)
    at = {n: i for i, n in enumerate(names)}
    world = xyz
    if model.plane is not None:  # the sketch's coordinates in its workplane
        xyz = np.concatenate([xyz @ np.asarray(model.plane).T, np.zeros(xyz.shape[:2] + (1,))], axis=2)
    s = SolverSystem()
    s.set_group(1)
    wp = s.create_2d_base() if model.planar else Entity.FREE_IN_3D
    if not fixed:
        s.set_group(2)
    pts: dict[str, Any] = {}  # SolveSpace entities

    def point(n: str) -> Any:
        x = xyz[0, at[n]]
        return s.add_point_2d(float(x[0]), float(x[1]), wp) if model.planar else s.add_point_3d(*map(float, x))

    for n in model.held:
        pts[n] = point(n)
        if not fixed:
            s.dragged(pts[n], wp)
    s.set_group(2)
    for n in names:
        if n not in pts:
            pts[n] = point(n)
    done = set()
    for link in model.links:
        for i, a in enumerate(link):
            for b in link[i + 1:]:
                if (a in model.held and b in model.held) or frozenset((a, b)) in done:
                    continue
                done.add(frozenset((a, b)))
                s.distance(pts[a], pts[b], float(np.linalg.norm(xyz[0, at[a]] - xyz[0, at[b]])), wp)
    for n, (origin, normal) in model.on_plane.items():
        s.set_group(1)
        axis, angle = _turn_z_onto(np.asarray(normal))
        turn = quat.from_axis_angle(axis, np.asarray(angle))
        nm = s.add_normal_3d(*map(float, turn))
        s.set_group(2)
        plane = s.add_work_plane(pts[origin], nm)
        s.coincident(pts[n], plane, Entity.FREE_IN_3D)
    for n, (through, direction) in model.on_line.items():
        s.set_group(1)
        ends = [np.asarray(through, dtype=float) + k * np.asarray(direction, dtype=float) for k in (0.0, 1.0)]
        if model.planar:
            line = s.add_line_2d(*(s.add_point_2d(float(e[0]), float(e[1]), wp) for e in ends), wp)
        else:
            line = s.add_line_3d(*(s.add_point_3d(*map(float, e)) for e in ends))
        s.set_group(2)
        s.coincident(pts[n], line, wp)
    radius = None
    if model.stroke is not None:
        tip, centre = model.stroke
        s.set_group(1)
        radius = s.add_distance(float(np.linalg.norm(xyz[0, at[tip]] - xyz[0, at[centre]])), wp)
        xy = s.add_normal_3d(1.0, 0.0, 0.0, 0.0)  # the workplane's normal
        s.set_group(2)
        s.coincident(pts[tip], s.add_circle(xy, pts[centre], radius, wp), wp)
        stroke = np.linalg.norm(xyz[:, at[tip]] - xyz[:, at[centre]], axis=1)
    held = [(pts[n], at[n]) for n in model.held]
    dim = 2 if model.planar else 3
    out = np.zeros((xyz.shape[0], len(names), 3))
    start = time.process_time()
    for k in range(xyz.shape[0]):
        for p, i in held:
            s.set_params(p.params, tuple(map(float, xyz[k, i, :dim])))
        if radius is not None:
            s.set_params(radius.params, (float(stroke[k]),))
        if s.solve() != ResultFlag.OKAY:
            return None
        for n, i in at.items():
            out[k, i, :dim] = s.params(pts[n].params)
    sec = (time.process_time() - start) / xyz.shape[0]
    if model.plane is not None:  # back in the world, off the workplane where linkedit has them
        u, v = np.asarray(model.plane)
        off = np.cross(u, v)
        out = out[..., :1] * u + out[..., 1:2] * v + (world @ off)[..., None] * off
    return sec, out


def _turn_z_onto(normal: np.ndarray) -> tuple[np.ndarray, float]:
    """Axis (3,) and angle of the rotation taking +z onto the unit ``normal``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, normal)
    if np.linalg.norm(axis) < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0 if normal[2] > 0 else np.pi
    return axis / np.linalg.norm(axis), float(np.arccos(np.clip(normal[2], -1.0, 1.0)))


def _linkedit_cases(steps: int) -> list[tuple[str, "System", PointModel, Callable[["Run"], np.ndarray]]]:
    """(name, system, SolveSpace sketch, world positions (T, P, 3) of the sketch's points from a run)."""
    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.planar_bridge import planar_model, point_positions
    from linkedit.spec.linkage import LinkageSpec
    from linkedit.spec.mechanism3d import MechanismSpec
    from linkedit.spec.yamlload import load_model

    cases: list[tuple[str, System, PointModel, Callable[[Run], np.ndarray]]] = []
    for name in PLANAR:
        spec = load_model(LinkageSpec, EXAMPLES.parent / f"{name}.yaml")
        pm = planar_model(spec)
        joints = {n: i for i, n in enumerate(pm.joint_names)}
        model = PointModel(points={n: ("", n) for n in spec.joints}, held=(*spec.ground, str(spec.motor.joint)),
                           links=tuple(tuple(m) for m in spec.links.values()), planar=True)
        pick = np.array([joints[n] for n in model.points])

        def world(run: Run, pm: Any = pm, pick: np.ndarray = pick) -> np.ndarray:
            return point_positions(pm.joint_member, pm.joint_point, run.position, run.orientation)[:, pick]

        cases.append((name + " (planar)", pm.system, model, world))
    for name, model in SPATIAL.items():
        system, _ = compile_mechanism(load_model(MechanismSpec, EXAMPLES / f"{name}.yaml"))
        member = np.array([system.member_names.index(m) for m, _ in model.points.values()])
        local = np.array([system.points[m][p] for m, p in model.points.values()])

        def spatial(run: Run, member: np.ndarray = member, local: np.ndarray = local) -> np.ndarray:
            R = quat.to_matrix(run.orientation[:, member])
            return run.position[:, member] + np.einsum("tpij,pj->tpi", R, local)

        cases.append((name, system, model, spatial))
    return cases


def _solvespace(echo: Callable[[str], None], quick: bool) -> None:
    import time

    from linkedit.gcs.diagnostics import run_diagnostics
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.structure import StructureCache

    try:
        import python_solvespace  # noqa: F401
    except ImportError:
        echo("SolveSpace side by side: python-solvespace is not installed (pip install 'linkedit[bench]')")
        return
    steps = 24 if quick else 360
    repeats = 1 if quick else 5
    t = np.arange(steps) / steps
    echo(f"vs SolveSpace (python-solvespace), {steps} steps of {360 / steps:g}°, CPU ms per step, medians of {repeats} "
         "interleaved runs; "
         "SolveSpace holds the ground and the driven point dragged (the target's baseline) or fixed (an earlier group)")
    echo(f"{'mechanism':<26}{'unknowns':>9}  {'linkedit':>9}  {'SolveSpace':>11}  {'ratio':>6}  {'target':>7}  "
         f"{'SolveSpace':>11}  {'ratio':>6}  {'max |Δp| / size':>16}  {'+ diagnostics':>14}  {'in waves':>8}  predicted")
    echo(f"{'':<26}{'':>9}  {'ms/step':>9}  {'dragged':>11}  {'':>6}  {'':>7}  {'fixed':>11}  {'':>6}  {'':>16}  "
         f"{'ms/step':>14}")
    for name, system, model, world in _linkedit_cases(steps):
        table, cache = system.step_table(t), StructureCache(system)
        run = solve_run(system, t, table=table, cache=cache)
        xyz = world(run)
        times: dict[str, list[float]] = {"ours": [], "dragged": [], "fixed": [], "solve3d": []}
        got = {}
        for _ in range(repeats):
            start = time.process_time()
            again = solve_run(system, t, table=table, cache=cache)
            times["ours"].append((time.process_time() - start) / steps)
            run_diagnostics(system, again, table)  # as solve3d: status, dof, redundant per step
            times["solve3d"].append((time.process_time() - start) / steps)
            for mode in ("dragged", "fixed"):
                ran = got[mode] = _solvespace_run(model, xyz, fixed=mode == "fixed")
                if ran is not None:
                    times[mode].append(ran[0])
        ms = {k: float(np.median(v)) * 1e3 if v else float("nan") for k, v in times.items()}
        keep = [i for i, n in enumerate(model.points) if n not in model.passive]
        size = float(np.ptp(xyz.reshape(-1, 3), axis=0).max())
        diffs = [float(np.abs(xyz[:, keep] - g[1][:, keep]).max()) / size for g in got.values() if g is not None]
        target = 2.0 if model.passive else 1.0
        cells = [f"{ms['dragged']:>11.3f}  {ms['ours'] / ms['dragged']:>5.2f}×" if got["dragged"] else f"{'failed':>11}  {'':>6}",
                 f"{ms['fixed']:>11.3f}  {ms['ours'] / ms['fixed']:>5.2f}×" if got["fixed"] else f"{'failed':>11}  {'':>6}"]
        echo(f"{name:<26}{system.n_unknowns:>9}  {ms['ours']:>9.3f}  {cells[0]}  {'≤ ' + format(target, 'g') + '×':>7}  "
             f"{cells[1]}  {max(diffs, default=float('nan')):>16.1e}  {ms['solve3d']:>14.3f}  "
             f"{f'{int(run.batched.sum())}/{steps}':>8}  "
             f"{_predicted(cache)}"
             f"{' (passive DOF)' if model.passive else ''}")


def _predicted(cache: "StructureCache") -> str:
    """How the waves predicted a system's steps (after its runs)."""
    kept = cache.waves
    return "—" if kept is None else "extrapolated" if kept.closed is None else "closed form"


#: the variants' specs (examples/3d/...) and their SolveSpace sketches
VARIANTS: dict[str, PointModel] = {
    "bench/cylinder-rocker": PointModel(
        points={"O": ("arm", "pivot"), "L": ("arm", "lug"), "B": ("barrel", "base")},
        held=("O", "B"), links=(("O", "L"),), planar=True, stroke=("L", "B")),
    "bench/welded-crank-rocker": PointModel(
        points={"O": ("crank", "pivot"), "A": ("crank", "tip"), "B": ("bar", "b"), "D": ("rocker", "pivot"),
                "P": ("plate", "P")},
        held=("O", "D", "A"), links=(("A", "B", "P"), ("B", "D")), planar=True),
    "bench/offset-slider-crank": PointModel(
        points={"O": ("crank", "pivot"), "A": ("crank", "tip"), "C": ("slider", "c")},
        held=("O", "A"), links=(("A", "C"),), planar=True, on_line={"C": ((0.0, 0.5, 0.0), (1.0, 0.0, 0.0))}),
    "bench/jansen-xy-pins": PointModel(
        points={n: (m, n) for m, js in (("crank", "OA"), ("upper", "BCE"), ("lower", "DFG")) for n in js},
        held=("O", "B", "A"), links=(("A", "C"), ("A", "D"), ("B", "C", "E"), ("B", "D"), ("E", "F"), ("D", "F", "G")),
        planar=True, plane=((0.0, 1.0, 0.0), (0.0, 0.0, 1.0))),
    "bench/steered-spherical-four-bar": SPATIAL["spherical-four-bar"],
    "spatial-slider-crank": PointModel(
        points={"O": ("crank", "pivot"), "A": ("crank", "tip"), "C": ("slider", "c")},
        held=("O", "A"), links=(("A", "C"),), planar=False, on_line={"C": ((2.5, 0.5, 1.0), (1.0, 0.0, 0.0))}),
    "rssr": SPATIAL["rssr"],
}


def _variants(echo: Callable[[str], None], quick: bool) -> None:
    import time

    from linkedit.gcs.members import compile_mechanism
    from linkedit.gcs.solve import solve_run
    from linkedit.gcs.structure import StructureCache
    from linkedit.spec.mechanism3d import MechanismSpec
    from linkedit.spec.yamlload import load_model

    try:
        import python_solvespace  # noqa: F401
        solvespace = True
    except ImportError:
        solvespace = False
    steps = 24 if quick else 360
    repeats = 1 if quick else 5
    t = np.arange(steps) / steps
    echo(f"variants (issue 22), {steps} steps, CPU ms per step, medians of {repeats}"
         f"{'' if solvespace else ' (SolveSpace: not installed)'}")
    echo(f"{'mechanism':<26}{'unknowns':>9}  {'linkedit':>9}  {'in waves':>8}  {'SolveSpace':>11}  {'ratio':>6}  "
         f"{'max |Δp| / size':>16}")
    for name, model in VARIANTS.items():
        system, _ = compile_mechanism(load_model(MechanismSpec, EXAMPLES / f"{name}.yaml"))
        table, cache = system.step_table(t), StructureCache(system)
        run = solve_run(system, t, table=table, cache=cache)
        times = []
        for _ in range(repeats):
            start = time.process_time()
            solve_run(system, t, table=table, cache=cache)
            times.append((time.process_time() - start) / steps)
        ours = float(np.median(times)) * 1e3
        cell = f"{'—':>11}  {'':>6}"
        if solvespace:
            member = np.array([system.member_names.index(m) for m, _ in model.points.values()])
            local = np.array([system.points[m][p] for m, p in model.points.values()])
            R = quat.to_matrix(run.orientation[:, member])
            xyz = run.position[:, member] + np.einsum("tpij,pj->tpi", R, local)
            ran = _solvespace_run(model, xyz, fixed=False)
            keep = [i for i, n in enumerate(model.points) if n not in model.passive]
            diff = float("nan") if ran is None else float(np.abs(xyz[:, keep] - ran[1][:, keep]).max()) / float(
                np.ptp(xyz.reshape(-1, 3), axis=0).max())
            cell = (f"{'failed':>11}  {'':>6}" if ran is None else f"{ran[0] * 1e3:>11.3f}  {ours / (ran[0] * 1e3):>5.2f}×"
                    ) + f"  {diff:>16.1e}"
        echo(f"{name.removeprefix('bench/'):<26}{system.n_unknowns:>9}  {ours:>9.3f}  "
             f"{f'{int(run.batched.sum())}/{steps}':>8}  {cell}")


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    _strandbeests(echo, quick)
    _six_bar(echo, quick)
    _solvespace(echo, quick)
    _variants(echo, quick)
