"""Synthesis quality: the slider-crank family, `--timing`, the exit-1 and noted exit-0 paths, margins kept."""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest

from linkedit.planar import compile_plan, simulate
from linkedit.synthesis import atlas, fourbar, slidercrank


def write_csv(path, z: np.ndarray, times: np.ndarray | None = None) -> None:
    head = "t,x,y\n" if times is not None else "x,y\n"
    rows = [(f"{float(t)!r}," if times is not None else "") + f"{float(p.real)!r},{float(p.imag)!r}"
            for t, p in zip(times if times is not None else z, z)]
    path.write_text(head + "\n".join(rows) + "\n")


def track(path) -> np.ndarray:
    with h5py.File(path) as f:
        p = f["tracks/target/position"][()]
    return p[:, 0] + 1j * p[:, 1]


def dense_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each point of a (N,) to the densely sampled closed curve b (M,): brute force."""
    return np.abs(a[:, None] - b[None, :]).min(axis=1)


def even(z: np.ndarray, count: int) -> np.ndarray:
    """``count`` points evenly spaced along the closed polyline z (M,) complex."""
    ring = np.concatenate([z, z[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(ring)))])
    at = np.linspace(0.0, s[-1], count, endpoint=False)
    return np.interp(at, s, ring.real) + 1j * np.interp(at, s, ring.imag)


@pytest.fixture(scope="module")
def four_bars(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 3 * atlas.CHUNK, seed=1)
    return path


# --- the slider-crank family ------------------------------------------------------------------------------------


def test_slider_crank_family_matches_simulate():
    """Batched closed form against `simulate` of the written spec (placed, mirrored, motor reversed): 1e-12 of the
    size; the closed-form margin is the cycle's smallest slider d_s, 1 − (|e| + a)², reached at θ = ±90°."""
    rows = slidercrank.sample(np.random.default_rng(7), 400)
    rows = rows[slidercrank.min_singularity(rows) >= slidercrank.margin()][:5]
    assert len(rows) == 5 and set(rows[:, 4]) == {-1.0, 1.0}
    phases = np.linspace(0.0, 0.8, 5)
    batch = slidercrank.curves(rows, 360, phase=phases)
    for k, row in enumerate(rows):
        for mirrored, reversed_ in ((False, False), (True, False), (False, True)):
            spec = slidercrank.to_spec(row, phase=phases[k], scale=55.0, turn=np.exp(0.7j), shift=-4 + 9j,
                                       mirrored=mirrored, reversed=reversed_, name="x", units="mm", description="")
            motion = simulate(compile_plan(spec), 360)
            got = motion.tracks["target"].position
            want = batch[k][(-np.arange(360)) % 360] if reversed_ else batch[k]
            want = -4 + 9j + 55.0 * np.exp(0.7j) * (np.conj(want) if mirrored else want)
            assert np.abs(got[:, 0] + 1j * got[:, 1] - want).max() < 1e-12 * 55.0
            ds = motion.min_singularity()[0]
            closed_form = 1.0 - (abs(row[1]) + row[0]) ** 2
            assert slidercrank.min_singularity(row[None])[0] == pytest.approx(closed_form, abs=1e-15)
            assert closed_form - 1e-12 <= ds <= closed_form + 1e-3


def test_a_slider_that_cannot_reach_its_line_is_rejected():
    # the rod (length 1) cannot reach the line at θ = −90°: p = e + a = 1.1
    assert slidercrank.min_singularity(np.array([[0.5, 0.6, 0.5, 0.0, 1.0]]))[0] < 0
    # |e| + a = cos 25°: inside the 20° band; cos 15°: outside
    inside = np.array([[0.3, np.cos(np.radians(25.0)) - 0.3, 0.5, 0.0, 1.0]])
    outside = np.array([[0.3, -(np.cos(np.radians(15.0)) - 0.3), 0.5, 0.0, 1.0]])
    assert slidercrank.min_singularity(inside)[0] == pytest.approx(np.sin(np.radians(25.0)) ** 2)
    assert slidercrank.min_singularity(outside)[0] < slidercrank.margin() < slidercrank.min_singularity(inside)[0]


def test_a_held_out_slider_crank_is_recovered_from_its_atlas(run_cli, tmp_path):
    """`atlas build --family slider-crank`, then a slider-crank of another seed is found again within 1 %
    (checked independently against the true curve), and `simulate result.yaml` reproduces the report's curve."""
    book = tmp_path / "sc.h5"
    built = run_cli("atlas", "build", "--family", "slider-crank", "-n", "5000", "-o", book, "--seed", "3")
    assert built.exit_code == 0, built.output
    with h5py.File(book) as f:
        params = f["families/slider-crank/params"][()]
        assert params.shape == (5000, 5) and (f["families/slider-crank/min_ds"][()] >= slidercrank.margin()).all()
        assert json.loads(f["families/slider-crank/params"].attrs["columns"]) == list(slidercrank.PARAMETERS)
    row = atlas.build_chunk("slider-crank", 999, 0, 2).params[1]
    truth = 5 + 2j + 30 * np.exp(0.7j) * slidercrank.curves(row[None], 20000)[0]
    target = truth[(np.arange(250) * len(truth)) // 250]
    write_csv(tmp_path / "t.csv", target)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", book, "-o", out, "--top", "3")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["family"] == "slider-crank" and report["error"]["after"]["rms"] <= 0.01
    assert "sliders" in (out / "result.yaml").read_text()
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "again.h5")
    assert sim.exit_code == 0, sim.output
    again = track(tmp_path / "again.h5")
    np.testing.assert_allclose(np.stack([again.real, again.imag], 1), report["result"]["curve"], rtol=0, atol=1e-9)
    fine = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "4000")
    assert fine.exit_code == 0, fine.output
    drawn = track(tmp_path / "fine.h5")
    gap = np.concatenate([dense_distance(target, drawn), dense_distance(drawn[::10], truth)]) / report["target"]["size"]
    assert np.sqrt(np.mean(gap ** 2)) <= 0.01


# --- --timing ---------------------------------------------------------------------------------------------------


HELD_OUT = atlas.build_chunk("four-bar", 12345, 0, 3).params[2]


def timed_target(phases: np.ndarray) -> np.ndarray:
    """The held-out four-bar's coupler point at family phases ``phases``, moved (exact, one evaluation each)."""
    z = np.array([fourbar.curves(HELD_OUT[None], 1, p)[0, 0] for p in phases])
    return -20 + 55j + 80 * np.exp(-0.6j) * z


@pytest.mark.parametrize("direction", [1, -1])
def test_timing_reproduces_the_target_sample_by_sample(run_cli, four_bars, tmp_path, direction):
    """300 samples, 2 s per cycle, the crank either way round: with --timing the re-simulated result is at every
    target sample at its time (sample n of `simulate -n 300` is t = n/300 of the cycle) within 0.1 % of the size."""
    n = 300
    phase = np.arange(n) / n
    target = timed_target(0.3 + direction * phase)
    write_csv(tmp_path / "t.csv", target, 2.0 * phase)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bars, "-o", out, "--top", "3", "--timing")
    assert result.exit_code == 0, result.output
    assert "at the target's times" in result.output
    report = json.loads((out / "report.json").read_text())
    assert report["options"]["timing"] and report["error"]["timed"]["after"]["rms"] <= 1e-3
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "again.h5", "-n", str(n))
    assert sim.exit_code == 0, sim.output
    size = report["target"]["size"]
    gap = np.abs(track(tmp_path / "again.h5") - target) / size
    assert gap.max() <= 1e-3
    assert np.sqrt(np.mean(gap ** 2)) == pytest.approx(report["error"]["timed"]["after"]["rms"], rel=0.2, abs=2e-5)


def test_timing_reports_the_distance_at_the_target_samples_of_a_coarse_target(run_cli, four_bars, tmp_path):
    """24 samples of the held-out four-bar, one per 15° of its crank: `error.timed.after` is the distance from each
    target sample to `simulate -n 24` of result.yaml at the sample's time (not to a polygon through the samples),
    and the result meets the samples within 0.05 % of the size (a straight-line interpolation between them, 0.9 %
    of the radius off the curve mid-way, held it at 0.24 %)."""
    n = 24
    phase = np.arange(n) / n
    target = timed_target(0.3 + phase)
    write_csv(tmp_path / "t.csv", target, phase)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bars, "-o", out, "--top", "3", "--timing")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert run_cli("simulate", out / "result.yaml", "-o", tmp_path / "again.h5", "-n", str(n)).exit_code == 0
    gap = np.abs(track(tmp_path / "again.h5") - target) / report["target"]["size"]
    after = report["error"]["timed"]["after"]
    assert after["rms"] == pytest.approx(np.sqrt(np.mean(gap ** 2)), rel=1e-6)
    assert after["max"] == pytest.approx(gap.max(), rel=1e-6)
    assert after["rms"] <= 5e-4


def test_timing_from_a_result_track(run_cli, four_bars, tmp_path):
    """`result.h5:target` of a held-out four-bar whose motor turns clockwise: its /t (motor phase) are the times;
    the result re-simulated at the same samples is at the same points, sample by sample."""
    from linkedit.spec.linkage_yaml import dump_linkage

    row = atlas.build_chunk("four-bar", 4242, 0, 3).params[0]
    spec = fourbar.to_spec(row, phase=0.2, scale=50.0, turn=np.exp(1j), shift=3 + 4j, mirrored=False, reversed=True,
                           name="held-out", units="mm", description="")
    assert spec.motor.direction == "cw"
    (tmp_path / "h.yaml").write_text(dump_linkage(spec))
    assert run_cli("simulate", tmp_path / "h.yaml", "-o", tmp_path / "h.h5", "-n", "200").exit_code == 0
    out = tmp_path / "out"
    result = run_cli("synthesize", f"{tmp_path / 'h.h5'}:target", "--atlas", four_bars, "-o", out, "--top", "3",
                     "--timing")
    assert result.exit_code == 0, result.output
    assert run_cli("simulate", out / "result.yaml", "-o", tmp_path / "again.h5", "-n", "200").exit_code == 0
    size = json.loads((out / "report.json").read_text())["target"]["size"]
    assert np.abs(track(tmp_path / "again.h5") - track(tmp_path / "h.h5")).max() <= 1e-3 * size


def test_a_target_timed_unlike_its_shape_match_changes_the_result(run_cli, four_bars, tmp_path):
    """The held-out curve run through with a warped timing (phase + 0.06·sin 2πφ), which its own linkage cannot
    have: without --timing the shape is drawn (almost exactly) with the wrong timing; with --timing the result is
    nearer the samples at their times, paid for with a worse shape."""
    n = 300
    phase = np.arange(n) / n
    target = timed_target(0.3 + phase + 0.06 * np.sin(2 * np.pi * phase))
    write_csv(tmp_path / "t.csv", target, phase)
    errors = {}
    for flag in ("", "--timing"):
        out = tmp_path / f"out{flag}"
        result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bars, "-o", out, "--top", "3",
                         *([flag] if flag else []))
        assert result.exit_code == 0, result.output
        report = json.loads((out / "report.json").read_text())
        sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / f"sim{flag}.h5", "-n", str(n))
        assert sim.exit_code == 0, sim.output
        drawn = track(tmp_path / f"sim{flag}.h5")
        size = report["target"]["size"]
        # the timed error, either motor direction allowed for the shape-only result (its start is the nearest point)
        timed = min(np.sqrt(np.mean(np.abs(np.roll(drawn[::d], 1 if d < 0 else 0) - target) ** 2)) / size
                    for d in (1, -1))
        errors[flag] = (report["error"]["after"]["rms"], timed)
    (shape_only, timed_only), (shape_timed, timed_timed) = errors[""], errors["--timing"]
    assert shape_only <= 1e-3 < shape_timed
    assert timed_timed < 0.8 * timed_only


@pytest.mark.parametrize("text, flags, message", [
    ("x,y\n0,0\n1,0\n1,1\n0,1\n", [], "--timing needs the sample times"),
    ("t,x,y\n0,0,0\n1,1,0\n2,1,1\n3,2,3\n", ["--open"], "--timing needs a closed target"),
    ("t,x,y\n0,0,0\n1,1,0\n1,1,1\n2,0,1\n", [], "times must increase strictly"),
])
def test_timing_without_usable_times_is_one_line_exit_2(run_cli, four_bars, tmp_path, text, flags, message):
    (tmp_path / "t.csv").write_text(text)
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bars, "-o", tmp_path / "out", "--timing",
                     *flags)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "t.csv" in lines[0]
    assert not (tmp_path / "out").exists()


# --- exit 1 and the noted exit 0 ----------------------------------------------------------------------------------


def test_no_candidate_turns_with_the_margin_exit_1(run_cli, four_bars, tmp_path):
    """An atlas whose stored linkages cannot turn (written by hand, here: every crank longer than b + c − 1 allows)
    gives no candidate that turns within the band: one line, exit 1, no output files."""
    broken = tmp_path / "broken.h5"
    broken.write_bytes(four_bars.read_bytes())
    with h5py.File(broken, "r+") as f:
        params = f["families/four-bar/params"]
        rows = params[()]
        rows[:, 0], rows[:, 1], rows[:, 2] = 0.5, 0.6, 0.6  # 1 + a > b + c: B cannot be placed at θ = π
        params[...] = rows
    assert (fourbar.min_singularity(rows) < 0).all()
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    write_csv(tmp_path / "e.csv", 20 * np.cos(t) + 10j * np.sin(t))
    result = run_cli("synthesize", tmp_path / "e.csv", "--atlas", broken, "-o", tmp_path / "out", "--top", "2")
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and re.search(r"none of the \d+ nearest atlas linkages turns the full cycle .*\[20°, 160°\]",
                                         lines[0])
    assert not (tmp_path / "out").exists()


def test_a_target_no_family_draws_is_the_best_found_with_its_error_and_a_note(run_cli, four_bars, tmp_path):
    """A seven-pointed star: exit 0, a note, and the reported error is the re-simulated linkage's (dense, brute force,
    both ways) — the user's next step sees the figure the report gives; the linkage keeps its margin."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    star = (1 + 0.45 * np.cos(7 * t)) * np.exp(1j * t) * 10
    write_csv(tmp_path / "star.csv", star)
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "star.csv", "--atlas", four_bars, "-o", out, "--top", "2")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    error = report["error"]["after"]["rms"]
    assert error > 0.03 and "no family" in report["note"] and f"{100 * error:.1f} %" in report["note"]
    assert "note:" in result.output
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "4000")
    assert sim.exit_code == 0, sim.output
    drawn = track(tmp_path / "fine.h5")
    # the error as documented: both curves sampled evenly along their length, distances both ways
    star_even, drawn_even = even(star, 1000), even(drawn, 1000)
    gap = np.concatenate([dense_distance(star_even, even(drawn, 20000)),
                          dense_distance(drawn_even, even(star, 20000))]) / report["target"]["size"]
    assert np.sqrt(np.mean(gap ** 2)) == pytest.approx(error, rel=0.02)
    assert report["result"]["min_singularity"] >= fourbar.margin() - 1e-9


# --- --margin: the transmission band ------------------------------------------------------------------------------


def transmission_sin2(path) -> np.ndarray:
    """sin² of the angle at B between B→A and B→D at every sample of a written four-bar result (from its joints)."""
    with h5py.File(path) as f:
        names = [n.decode() for n in f["joint"][()]]
        pos = f["joints/position"][()]
    a, b, d = (pos[:, names.index(k), 0] + 1j * pos[:, names.index(k), 1] for k in "ABD")
    return np.sin(np.angle((a - b) / (d - b))) ** 2


def gerono_error(run_cli, out, tmp_path, target: np.ndarray) -> tuple[float, np.ndarray]:
    """The result re-simulated (4000 samples): normalized RMS both ways, measured here; sin² μ at every sample."""
    fine = tmp_path / f"{out.name}.h5"
    sim = run_cli("simulate", out / "result.yaml", "-o", fine, "-n", "4000")
    assert sim.exit_code == 0, sim.output
    drawn = track(fine)
    gap = np.concatenate([dense_distance(even(target, 1000), even(drawn, 20000)),
                          dense_distance(even(drawn, 1000), even(target, 20000))]) / 40.0  # size: the x extent
    return float(np.sqrt(np.mean(gap ** 2))), transmission_sin2(fine)


@pytest.mark.slow  # ≈ 7 s: a --margin sweep on the figure-eight
def test_margin_trades_transmission_for_accuracy_on_the_figure_eight(run_cli, four_bars, tmp_path):
    """Gerono's 2:1 figure-eight: a four-bar inside the default 20° band draws it only to about 4.2 % (the band's
    optimum: a global search, README), on the band's edge, and the note says so; `--margin 10` reaches ≤ 3 %,
    measured here on `linkedit simulate result.yaml`, every transmission angle within [10°, 170°] and some outside
    [20°, 160°]."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    eight = 20 * np.cos(t) + 10j * np.sin(2 * t)
    write_csv(tmp_path / "eight.csv", eight)
    found = {}
    for deg in (None, 10):
        out = tmp_path / f"out{deg}"
        result = run_cli("synthesize", tmp_path / "eight.csv", "--atlas", four_bars, "-o", out, "--top", "5",
                         *(["--margin", str(deg)] if deg else []))
        assert result.exit_code == 0, result.output
        report = json.loads((out / "report.json").read_text())
        assert report["options"]["margin_deg"] == (deg or 20)
        error, sin2 = gerono_error(run_cli, out, tmp_path, eight)
        assert error == pytest.approx(report["error"]["after"]["rms"], rel=0.02)
        found[deg] = (error, sin2.min(), report)
    (error20, ds20, report20), (error10, ds10, report10) = found[None], found[10]
    assert 0.04 <= error20 <= 0.043 and ds20 >= np.sin(np.radians(20)) ** 2 - 1e-6
    assert "--margin" in report20["note"] and "edge (20°)" in report20["note"]
    assert error10 <= 0.03 and report10["note"] == ""
    assert np.sin(np.radians(10)) ** 2 - 1e-6 <= ds10 < np.sin(np.radians(20)) ** 2
    assert report10["result"]["min_singularity"] >= np.sin(np.radians(10)) ** 2 - 1e-9


def test_a_narrower_band_than_the_atlas_keeps_it_and_a_bad_one_is_exit_2(run_cli, four_bars, tmp_path):
    """--margin 30: only atlas linkages inside [30°, 150°] are refined and the result stays there (an ellipse);
    --margin outside [1, 60] is one line, exit 2."""
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    write_csv(tmp_path / "e.csv", 20 * np.cos(t) + 10j * np.sin(t))
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "e.csv", "--atlas", four_bars, "-o", out, "--top", "3", "--margin", "30")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["result"]["min_singularity"] >= 0.25 - 1e-9
    assert all(fourbar.min_singularity(np.array([list(c["parameters_before"].values())]))[0] >= 0.25
               for c in report["candidates"])
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "again.h5")
    assert sim.exit_code == 0 and transmission_sin2(tmp_path / "again.h5").min() >= 0.25 - 1e-9
    for bad in ("0.5", "75"):
        wrong = run_cli("synthesize", tmp_path / "e.csv", "--atlas", four_bars, "-o", tmp_path / "x", "--margin", bad)
        assert wrong.exit_code == 2 and len(wrong.output.strip().splitlines()) == 1 and "--margin" in wrong.output
        assert not (tmp_path / "x").exists()


# --- the quality of classic curves (slow: a 200,000-linkage atlas) --------------------------------------------------


@pytest.mark.slow
def test_classic_curves_with_the_four_bar_family(tmp_path):
    """≤ 3 % (normalized RMS, the written result re-simulated) for the classic curves a four-bar inside the 20°
    transmission band can draw; Gerono's 2:1 figure-eight reaches the band's optimum (4.15 %: a global search,
    README), which the refinement used to stop short of (4.35 % at the first iterate on the margin), and ≤ 3 % with
    the band widened to 10° (`--margin 10`; that band's optimum is 2.85 %)."""
    from linkedit.curves.sources import make_curve
    from linkedit.synthesis.bench import classic_curves
    from linkedit.synthesis.index import Index
    from linkedit.synthesis.synthesize import synthesize

    path = tmp_path / "four-bar.h5"
    atlas.build(path, ["four-bar"], 200_000, seed=1)
    book = atlas.load(path)
    index = Index(book)
    for name, (z, closed) in classic_curves().items():
        result = synthesize(make_curve(name, np.stack([z.real, z.imag], 1), closed=closed, origin="test"), book, index)
        bound = 0.043 if "2:1)" in name else 0.03
        assert result.error[0] <= bound, (name, result.error)
        assert result.motion.min_singularity()[0] >= fourbar.margin() - 1e-9
        if "2:1)" in name:
            wide = synthesize(make_curve(name, np.stack([z.real, z.imag], 1), closed=closed, origin="test"), book,
                              index, margin_deg=10.0)
            assert wide.error[0] <= 0.03, wide.error
            assert wide.motion.min_singularity()[0] >= np.sin(np.radians(10.0)) ** 2 - 1e-9
