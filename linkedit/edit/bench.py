"""Benchmark of editing: iterations and milliseconds of optimization, Gauss–Newton vs BFGS.

Every example edit of ``examples/edits/`` plus a knee edit and a whole-mechanism scaling of the
10-pair Strandbeest, each solved by both solvers in the same run. Targets (issue 8): the Jansen
function-preserving edit in ≤ 30 iterations and ≤ 40 ms, every example in ≤ 60 iterations, the
10-pair edits converged in ≤ 1 s of optimization. Then the slider and complex-loop examples
(issue 10): displace a joint, keep a track (the lifting arm: a linear input). Times are the median of 3 runs (one in quick
mode); iteration counts do not depend on the machine. Last, a large linkage: the knee edit of the
89-pair Strandbeest (982 joints), timed whole (set-up, optimization, final check), since the set-up
grows faster than the optimization (its Jacobian colouring took 360 s of a 20 s edit, issue 26 §7).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from pathlib import Path

from linkedit.edit.runner import run_script
from linkedit.planar import catalog
from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.yamlload import load_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "edits"


def knee_edit(pairs: int, samples: int) -> tuple[LinkageSpec, EditScript]:
    """The ``pairs``-pair Strandbeest and a knee edit of its first leg pair (the feet kept)."""
    beest = catalog.strandbeest(pairs)
    c = beest.joints["C_0_L"]
    knee = {"samples": samples, "lock": ["O"], "operations": [
        {"name": "knee", "preserve": ["foot_0_L", "foot_0_R"], "displace": {"joint": "C_0_L", "to": [c[0] + 3, c[1] + 2]}}]}
    return beest, EditScript.model_validate(knee)


def strandbeest_cases() -> list[tuple[str, LinkageSpec, EditScript]]:
    """A knee edit and an 80 % scaling of the 10-pair Strandbeest, the crank free."""
    beest, knee = knee_edit(10, 60)
    scale = {"samples": 60, "lock": ["O"], "operations": [
        {"name": "scale", "preserve": list(beest.tracks), "transform": {"joints": "all", "scale": 0.8, "about": [0, 0]},
         "terms": {"preserve": 1000, "transform": 0.3}}]}
    return [("strandbeest-10 knee", beest, knee),
            ("strandbeest-10 scaling", beest, EditScript.model_validate(scale))]


#: edits of the slider and complex-loop examples: (example, track preserved, joint displaced, where to)
STEP_EDITS = [("slider-crank", "coupler_point", "B", [86, 10]), ("quick-return", "ram", "C", [28, 56]),
              ("scotch-yoke", "yoke", "Y1", [50, 5]), ("inverted-slider-crank", "arm_tip", "Q", [62, 2]),
              ("stephenson-slider", "output", "B", [65, 60]), ("complex-loop", "body_tip", "P2", [46, 7]),
              ("lifting-arm", "tip", "P", [42, -28])]


def step_cases() -> list[tuple[str, LinkageSpec, EditScript]]:
    """Displace a joint, preserve a track, on the slider and complex-loop examples."""
    out = []
    for name, track, joint, to in STEP_EDITS:
        script = {"samples": 90, "operations": [{"preserve": [track], "displace": {"joint": joint, "to": to}}]}
        out.append((f"{name} (steps)", load_model(LinkageSpec, EXAMPLES.parent / f"{name}.yaml"),
                    EditScript.model_validate(script)))
    return out


def cases() -> list[tuple[str, LinkageSpec, EditScript]]:
    out = []
    for path in sorted(EXAMPLES.glob("*.yaml")):
        script = load_model(EditScript, path)
        out.append((path.stem, load_model(LinkageSpec, path.parent / str(script.linkage)), script))
    return out + strandbeest_cases() + step_cases()


def measure(spec: LinkageSpec, script: EditScript, solver: str, runs: int) -> tuple[int, float, bool]:
    """(iterations, median ms of optimization, every operation converged)."""
    script = script.model_copy(update={"solver": solver})
    times, its, ok = [], 0, True
    for _ in range(runs):
        result = run_script(spec, script)
        times.append(sum(op.seconds for op in result.operations) * 1e3)
        its = sum(op.iterations for op in result.operations)
        ok = all(op.converged or op.stalled for op in result.operations)
    return its, statistics.median(times), ok


def run(echo: Callable[[str], None], quick: bool = False) -> None:
    runs = 1 if quick else 3
    todo = cases()[:1] if quick else cases()
    echo(f"{'edit (iterations, ms of optimization)':<30}{'GN its':>8}{'GN ms':>9}{'BFGS its':>10}{'BFGS ms':>9}"
         f"{'speed-up':>10}  target")
    targets = {"jansen-move-knee": "≤ 30 its, ≤ 40 ms", "strandbeest-10 knee": "converged, ≤ 1000 ms",
               "strandbeest-10 scaling": "converged, ≤ 1000 ms"}
    for name, spec, script in todo:
        gn = measure(spec, script, "gauss-newton", runs)
        if name.startswith(("complex-loop", "lifting-arm")):  # a numeric group makes each BFGS line-search step costly
            echo(f"{name:<30}{gn[0]:>7}{'' if gn[2] else '*':1}{gn[1]:>9.1f}{'—':>10}{'—':>9}{'':>10}  ≤ 60 its")
            continue
        bf = measure(spec, script, "bfgs", runs)
        flag = lambda r: "" if r[2] else "*"  # noqa: E731 - not converged within max_iterations
        echo(f"{name:<30}{gn[0]:>7}{flag(gn):1}{gn[1]:>9.1f}{bf[0]:>9}{flag(bf):1}{bf[1]:>9.1f}"
             f"{bf[1] / max(gn[1], 1e-9):>9.1f}×  {targets.get(name, '≤ 60 its')}")
    echo("(* = stopped at max_iterations; stalled operations count as finished)")
    if not quick:
        large(echo)


#: the large linkage's pairs, samples and whole-edit target (s)
LARGE = (89, 30, 60.0)


def large(echo: Callable[[str], None]) -> None:
    """Time the knee edit of the 89-pair Strandbeest whole, once: set-up and checks besides optimization."""
    pairs, samples, target = LARGE
    spec, script = knee_edit(pairs, samples)
    start = time.perf_counter()
    result = run_script(spec, script)
    whole = time.perf_counter() - start
    optimization = sum(op.seconds for op in result.operations)
    echo(f"strandbeest-{pairs} knee ({len(spec.joints)} joints, {samples} samples): {whole:.1f} s whole "
         f"({optimization:.1f} s optimization, {whole - optimization:.1f} s set-up and checks); target ≤ {target:g} s")
