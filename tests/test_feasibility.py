"""The one feasibility predicate (linkedit.planar.feasibility): the atlas, the synthesized result and `edit`
keep what `simulate` shows at any density, between the checked samples too."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import yaml

from linkedit.edit.feasibility import failure
from linkedit.planar import catalog, compile_plan, simulate
from linkedit.planar.feasibility import CHECK_SAMPLES, TOGGLE, lowest
from linkedit.synthesis import fourbar
from linkedit.synthesis.families import family

BAND = np.sin(np.radians(20.0)) ** 2  # the atlas's and synthesize's default margin: transmission in [20°, 160°]

#: A Klann leg whose transmission angle at E stays at or above 20° at 64 crank samples but dips to 19.77° between
#: them (a `klann` atlas row that the 64-sample check let in).
DIP = {"name": "klann-dip", "units": "mm",
       "joints": {"A": [0.0, 0.0], "B": [-34.526594, -11.749930], "D": [-11.759710, 37.813171],
                  "C": [16.402882, -0.531654], "H": [-19.455914, 3.791352], "F": [-50.654076, -2.119926],
                  "E": [-43.018294, 50.270763], "G": [-28.030227, -51.367891]},
       "ground": ["A", "B", "D"],
       "links": {"crank": ["A", "C"], "lower_rocker": ["B", "H"], "connecting_rod": ["C", "H", "F"],
                 "upper_rocker": ["D", "E"], "leg": ["E", "F", "G"]},
       "motor": {"joint": "C", "pivot": "A", "direction": "ccw"}, "tracks": {"target": {"joint": "G"}}}


def worst_transmission(run_cli, spec, samples: int) -> float:
    """The worst transmission angle (degrees) `linkedit simulate spec -n samples --json` reports."""
    result = run_cli("simulate", spec, "-n", str(samples), "--json", "-o", spec.parent / f"{spec.stem}-{samples}.h5")
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)["result"][0]["worst_transmission_angle_deg"]


@pytest.fixture(scope="module")
def klann_atlas(tmp_path_factory):
    from typer.testing import CliRunner

    from linkedit.cli import app

    path = tmp_path_factory.mktemp("atlas") / "klann.h5"
    built = CliRunner().invoke(app, ["atlas", "build", "--family", "klann", "-n", "2000", "-o", str(path)])
    assert built.exit_code == 0, built.output
    return path


def test_a_synthesized_leg_keeps_the_promised_band_when_simulated_densely(run_cli, klann_atlas, tmp_path):
    """Synthesizing the foot path of a Klann leg just outside the band: the written result.yaml, simulated at 3600
    samples, keeps every transmission angle within [20°, 160°] (it came back at 19.77°, the atlas row itself)."""
    dip = tmp_path / "dip.yaml"
    dip.write_text(yaml.safe_dump(DIP))
    assert worst_transmission(run_cli, dip, 64) >= 20.0 > worst_transmission(run_cli, dip, 3600)
    assert run_cli("simulate", dip, "-n", "300", "-o", tmp_path / "dip.h5").exit_code == 0
    out = tmp_path / "out"
    result = run_cli("synthesize", f"{tmp_path / 'dip.h5'}:target", "--atlas", klann_atlas, "-o", out, "--top", "3")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["family"] == "klann" and report["error"]["after"]["rms"] <= 0.01
    assert worst_transmission(run_cli, out / "result.yaml", 3600) >= 20.0
    assert worst_transmission(run_cli, out / "result.yaml", 7200) >= 20.0


def test_the_atlas_linkages_nearest_the_margin_keep_it_between_samples(klann_atlas):
    """The stored min_ds is a lower bound of what `simulate` finds at 3600 samples, and at least the margin."""
    fam = family("klann")
    with h5py.File(klann_atlas) as f:
        params, stored = f["families/klann/params"][()], f["families/klann/min_ds"][()]
    for k in np.argsort(stored)[:4]:
        spec = fam.to_spec(params[k], phase=0.0, scale=100.0, turn=1 + 0j, shift=0j, mirrored=False, name="x",
                           units="mm", description="")
        motion = simulate(compile_plan(spec), 3600)
        found = motion.min_singularity()[0]
        assert found >= stored[k] >= BAND


def test_lowest_bounds_a_minimum_between_samples():
    """d_s = 0.5 − 0.45·cos(θ − θ₀) (its minimum 0.05 at θ₀, between samples): the sampled minimum lies above
    0.05, the bound below it and within a tenth of the sampled dip; the ends of a sweep; a lock-up is −1."""
    for t in (36, 360, CHECK_SAMPLES):
        theta = 2 * np.pi * np.arange(t) / t
        ds = 0.5 - 0.45 * np.cos(theta - np.pi / t * 0.7)
        low = float(lowest(ds))
        assert low <= 0.05 < ds.min() and ds.min() - low <= 1.1 * 0.45 * (np.pi / t) ** 2
    sweep = 0.05 + (np.linspace(0.0, 1.0, 50) - 1.0 / 98) ** 2
    assert float(lowest(sweep, cyclic=False)) <= 0.05 < sweep.min()
    assert lowest(np.array([[0.5, 0.2, np.nan, 0.3], [0.5, 0.2, TOGGLE, 0.3], [0.5, 0.4, 0.4, 0.5]])).tolist()[:2] == [-1, -1]


def test_a_four_bar_checked_densely_is_bounded_by_its_closed_form():
    """The catalog crank-rocker at CHECK_SAMPLES: Motion.lowest_singularity lies below the exact minimum of the
    four-bar family's closed form and within 1e-5 of it."""
    motion = simulate(compile_plan(catalog.crank_rocker()), CHECK_SAMPLES)
    low, joint, _ = motion.lowest_singularity()
    exact = fourbar.min_singularity(fourbar.SEEDS[:1])[0]
    assert exact - 1e-5 <= low <= exact and joint == "B"


def test_edit_calls_a_toggle_unassembled_as_simulate_does():
    """d_s at or below the toggle rounding is a lock-up for `simulate`; the edit's predicate says so too."""
    plan = compile_plan(catalog.crank_rocker())
    rest = np.array([complex(*plan.spec.joints[n]) for n in plan.joint_names])
    ds = np.ones((plan.n_ds, 4))
    dyad = int(plan.table.row[np.flatnonzero(~plan.table.rigid)[0]])
    ds[dyad, 2] = TOGGLE / 2
    why = failure(plan, rest, ds, np.array([0.0, 90.0, 180.0, 270.0]))
    assert why is not None and "cannot be assembled" in why
