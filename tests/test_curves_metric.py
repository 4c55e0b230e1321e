"""The curve-metric defects of issue 12, each reproduced on the code before the fix."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import report_of

from linkedit.curves import describe, term_distances, weighted
from linkedit.curves.compare import describe_curves, placements
from linkedit.curves.smooth import smooth
from linkedit.curves.sources import make_curve
from linkedit.planar import catalog, compile_plan, simulate


def rounded_triangle(m: int = 300, turn: float = 0.0, lobe: tuple[float, float, float] = (0, 0, 0)) -> np.ndarray:
    """r(t) = 1 + 0.15 cos 3t (+ a bump on each lobe), turned by ``turn`` rad: (m, 2)."""
    t = np.linspace(0, 2 * np.pi, m, endpoint=False)
    r = 1 + 0.15 * np.cos(3 * t) + sum(h * np.exp(-((t - 2 * np.pi * k / 3 + np.pi) % (2 * np.pi) - np.pi) ** 2 / 0.1)
                                      for k, h in enumerate(lobe))
    return np.stack([r * np.cos(t + turn), r * np.sin(t + turn)], axis=1)


def all_terms(curves: list[np.ndarray], **kw) -> dict[str, float]:
    desc = describe(np.stack(curves), True)
    return {k: float(v[0, 1]) for k, v in term_distances(desc, **kw).items()}


@pytest.mark.parametrize("turn_deg", [13.0, 60.0, 100.0])
def test_a_turned_rounded_triangle_is_the_same_curve(turn_deg):
    """Nearly isotropic: the principal axes are arbitrary; every term must still be ~0."""
    terms = all_terms([rounded_triangle(), rounded_triangle(turn=np.radians(turn_deg))])
    assert max(terms.values()) < 1e-6, terms


def test_3d_efd_does_not_flip_on_a_tiny_out_of_plane_bump():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    flat = np.stack([2 * np.cos(t) + 0.3 * np.cos(2 * t) + 0.1 * np.sin(3 * t),
                     np.sin(t) + 0.2 * np.sin(2 * t) + 0.02 * np.cos(2 * t), 0 * t], axis=1)
    for sign in (1.0, -1.0):
        bumped = flat.copy()
        bumped[40:60, 2] = sign * 1e-6
        terms = all_terms([flat, bumped])
        assert terms["efd"] < 1e-5 and terms["points"] < 1e-5, terms


def test_sub_sample_shift():
    """Two lobes almost equally far: a 1e-3 bump moves the canonical start to the other lobe,
    a fractional number of samples away. The point term must stay at the bump's size."""
    a = rounded_triangle(600, lobe=(2e-3, 0, 0))
    b = rounded_triangle(600, lobe=(0, 2e-3, 0))  # the same shape turned by 120°
    c = rounded_triangle(600, lobe=(2e-3, 1e-3, 0))  # start stays, a 1e-3 change
    ab, ac = all_terms([a, b]), all_terms([a, c])
    assert ab["points"] < 1e-4
    assert ac["points"] < 1e-3


def family_curves(per: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Tracked curves of the catalog mechanisms with every moving joint perturbed by 1 % of the size."""
    rng = np.random.default_rng(seed)
    families = {"jansen": (catalog.jansen_leg, "foot"), "klann": (catalog.klann_leg, "foot"),
                "crank-rocker": (catalog.crank_rocker, "coupler_point"), "hoekens": (catalog.hoekens, "tracer"),
                "watt": (catalog.watt_six_bar, None)}
    curves, labels = [], []
    for name, (build, track) in families.items():
        spec = build()
        track = track or next(iter(spec.tracks))
        size = np.ptp(np.array(list(spec.joints.values())), axis=0).max()
        while labels.count(name) < per:
            joints = {k: tuple(np.array(v) + rng.normal(scale=0.01 * size, size=2)) if k not in spec.ground else v
                      for k, v in spec.joints.items()}
            try:
                motion = simulate(compile_plan(spec.model_copy(update={"joints": joints})), 360)
            except Exception:  # a perturbation that locks up: draw another
                continue
            curves.append(motion.tracks[track].position)
            labels.append(name)
    return np.array(curves), np.array(labels)


def test_noisy_queries_find_their_family():
    """1 % noise (of the curve's size) on every point, smoothed: precision@1 ≥ 0.95."""
    curves, labels = family_curves(20, seed=0)
    size = np.ptp(curves, axis=1).max(axis=1)
    noisy = curves + np.random.default_rng(1).normal(size=curves.shape) * 0.01 * size[:, None, None]
    library = describe(curves, True)
    query = describe_curves([make_curve(str(i), c, closed=True, origin="q") for i, c in enumerate(noisy)], smooth=0.01)
    terms = term_distances(query, library)
    dist = weighted(terms, dict.fromkeys(terms, 1.0))
    np.fill_diagonal(dist, np.inf)  # the query's own clean curve does not count
    precision = np.mean(labels[np.argmin(dist, axis=1)] == labels)
    assert precision >= 0.95


def test_noise_does_not_inflate_the_length():
    foot = simulate(compile_plan(catalog.jansen_leg()), 360).tracks["foot"].position
    size = np.ptp(foot, axis=0).max()
    noisy = foot + np.random.default_rng(3).normal(size=foot.shape) * 0.003 * size
    lengths = describe(np.stack([foot, noisy]), True).features[:, 0]
    assert abs(lengths[1] / lengths[0] - 1) < 0.02


def test_smoothing_keeps_the_ends_of_an_open_curve_and_straight_runs():
    line = np.stack([np.linspace(0, 1, 50), 2 * np.linspace(0, 1, 50)], axis=1)
    np.testing.assert_allclose(smooth(line, False, 0.05), line, atol=1e-12)
    circle = rounded_triangle(200, lobe=(0, 0, 0))
    assert np.abs(smooth(circle, True, 0.01) - circle).max() < 0.01


def test_mirror_option():
    a = rounded_triangle(300, lobe=(0.1, 0.3, 0))
    b = a * np.array([1.0, -1.0])
    assert all_terms([a, b])["points"] > 0.01
    assert max(all_terms([a, b], mirror=True).values()) < 1e-6


def test_placement_maps_the_library_curve_onto_the_query():
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    lib = np.stack([2 * np.cos(t) + 0.3 * np.cos(2 * t), np.sin(t) + 0.2 * np.sin(3 * t)], axis=1)
    turn = np.radians(40.0)
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    query = np.roll(lib, 123, axis=0) @ rot.T * 3.0 + [5.0, -2.0]
    desc = describe(np.stack([query, lib]), True)
    (place,) = placements(desc.take([0]), desc.take([1]))
    assert place["scale"] == pytest.approx(3.0, rel=1e-9)
    assert place["rotation_deg"] == pytest.approx(40.0, abs=1e-6)
    moved = np.asarray(place["translation"]) + place["scale"] * lib @ np.asarray(place["matrix"]).T
    np.testing.assert_allclose(np.roll(moved, 123, axis=0), query, atol=1e-9)
    assert not place["reversed"] and not place["mirrored"]


def test_ranking_reports_the_placement_and_mirror_option(run_cli, tmp_path):
    import json

    a = rounded_triangle(300, lobe=(0.1, 0.3, 0))
    turn = np.radians(30.0)
    mirror = (a * [1.0, -1.0]) @ np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]]).T * 2 + 7
    for name, pts in (("query", a), ("lib/mirror", mirror)):
        path = tmp_path / f"{name}.csv"
        path.parent.mkdir(exist_ok=True)
        path.write_text("x,y\n" + "\n".join(f"{float(x)!r},{float(y)!r}" for x, y in pts))
    plain = run_cli("compare-curves", "--query", tmp_path / "query.csv", "--library", tmp_path / "lib", "--json")
    assert plain.exit_code == 0, plain.output
    mirrored = run_cli("compare-curves", "--query", tmp_path / "query.csv", "--library", tmp_path / "lib", "--json",
                       "--mirror", "--smooth", "0")
    first = report_of(mirrored)["queries"][0]["ranking"][0]
    assert first["distance"] < 1e-6 < report_of(plain)["queries"][0]["ranking"][0]["distance"]
    assert first["placement"]["mirrored"] and first["placement"]["scale"] == pytest.approx(0.5, rel=1e-9)


def test_one_mislabelled_pair_does_not_swing_the_learned_weights():
    """Hard margins let one wrong label dictate the weights (and separate held-out pairs worse than
    the point term alone); the cross-validated soft margin does not."""
    from linkedit.curves.learn import _fit, cross_validate, learn_weights

    curves, labels = family_curves(6, seed=4)
    terms = term_distances(describe(curves, True))
    names = list(terms)
    table = np.stack([terms[n] for n in names], axis=-1)
    i, j = np.triu_indices(len(labels), 1)
    same = labels[i] == labels[j]
    rng = np.random.default_rng(0)
    si = rng.choice(np.flatnonzero(same), 40, replace=False)
    di = rng.choice(np.flatnonzero(~same), 40, replace=False)
    sim, dis = table[i[si], j[si]], table[i[di], j[di]]
    clean = learn_weights(names, sim, dis)
    k = int(np.argmin(sim[:, names.index("points")]))  # the most similar pair, labelled dissimilar
    sim_bad, dis_bad = np.delete(sim, k, axis=0), np.vstack([dis, sim[k:k + 1]])
    hard = _fit(sim_bad ** 2, dis_bad ** 2, 1e-3, None)
    hard_auc = cross_validate(sim_bad ** 2, dis_bad ** 2, 1e-3, costs=(None,))[None]
    soft = learn_weights(names, sim_bad, dis_bad)
    # the defect, reproduced: the hard fit's weights explode and separate worse than points alone
    assert hard.max() > 100 * max(clean.weights.values()) and hard_auc < soft.term_auc["points"]
    # the soft fit: the same weights as without the wrong label, and better than points alone
    w_clean, w_soft = np.array(list(clean.weights.values())), np.array(list(soft.weights.values()))
    assert np.linalg.norm(w_soft - w_clean) <= 0.05 * np.linalg.norm(w_clean)
    assert soft.held_out_auc > soft.term_auc["points"]


@pytest.mark.parametrize("start", [0, 120, 250])
def test_half_a_foot_path_matches_its_own_leg(run_cli, tmp_path, start):
    """Half of Jansen's foot path (open) against the full Jansen, Klann and crank-rocker cycles."""
    import json

    jansen = simulate(compile_plan(catalog.jansen_leg()), 360).tracks["foot"].position
    half = np.roll(jansen, -start, axis=0)[:180] * 3.0 + [10.0, -4.0]
    (tmp_path / "half.csv").write_text("x,y\n" + "\n".join(f"{float(x)!r},{float(y)!r}" for x, y in half))
    for name, build, track in (("jansen", catalog.jansen_leg, "foot"), ("klann", catalog.klann_leg, "foot"),
                               ("crank-rocker", catalog.crank_rocker, "coupler_point")):
        curve = simulate(compile_plan(build()), 360).tracks[track].position
        (tmp_path / "lib").mkdir(exist_ok=True)
        (tmp_path / "lib" / f"{name}.csv").write_text(
            "x,y\n" + "\n".join(f"{float(x)!r},{float(y)!r}" for x, y in curve))
    r = run_cli("compare-curves", "--query", tmp_path / "half.csv", "--library", tmp_path / "lib", "--partial",
                "--json")  # the half path's ends are far apart: it is open, the cycles are closed
    assert r.exit_code == 0, r.output
    ranking = report_of(r)["queries"][0]["ranking"]
    assert ranking[0]["curve"] == "jansen" and ranking[0]["distance"] < ranking[1]["distance"]


def test_part_of_a_3d_cycle_matches_its_own_cycle(run_cli, tmp_path):
    """--partial with 3D curves (it was ignored there: the part was compared as a whole curve and its own cycle
    ranked last of six): 45 % of a spherical four-bar's cycle, turned, scaled and moved, against that cycle and
    five other spatial linkages' cycles."""
    from scipy.spatial.transform import Rotation

    from linkedit.synthesis import atlas, rssr, spherical

    (tmp_path / "lib").mkdir()
    for name, fam in (("spherical-four-bar", spherical), ("rssr", rssr)):
        params = atlas.build_chunk(name, 5, 0, 3).params
        for j in range(3):
            np.savetxt(tmp_path / "lib" / f"{name}{j}.csv", fam.curves(params[j:j + 1], 300)[0], delimiter=",",
                       header="x,y,z", comments="")
    part = spherical.curves(atlas.build_chunk("spherical-four-bar", 5, 0, 3).params[1:2], 300, 0.2)[0][:135]
    np.savetxt(tmp_path / "part.csv", 5.0 + 2.0 * part @ Rotation.random(random_state=1).as_matrix().T,
               delimiter=",", header="x,y,z", comments="")
    r = run_cli("compare-curves", "--query", tmp_path / "part.csv", "--library", tmp_path / "lib", "--partial",
                "--json")
    assert r.exit_code == 0, r.output
    ranking = report_of(r)["queries"][0]["ranking"]
    assert ranking[0]["curve"] == "spherical-four-bar1" and ranking[0]["distance"] < ranking[1]["distance"]


@pytest.mark.parametrize("dim", [2, 3])
def test_partial_ranking_places_the_library_curve_on_the_open_query(run_cli, tmp_path, dim):
    """--partial: the ranking's transform (scale, matrix, translation) carries the library curve onto the open
    query (it was the whole-curve alignment's: an ellipse's arc turned 90°, scaled 5 and moved was listed at scale
    4.38, turn −172°, 4 % of the arc's size off its ellipse). Measured independently: every query point's
    distance to the transformed library polyline."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    closed = np.stack([3 * np.cos(t), np.sin(t)] + ([0.4 * np.sin(2 * t)] if dim == 3 else []), axis=1)
    turn = np.array([[0.0, -1.0], [1.0, 0.0]]) if dim == 2 else np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0],
                                                                            [0.0, 1.0, 0.0]])
    part = closed[40:180] @ turn.T * 5.0 + np.arange(10.0, 10.0 + dim)
    header = "x,y,z" if dim == 3 else "x,y"
    (tmp_path / "lib").mkdir()
    np.savetxt(tmp_path / "lib" / "ellipse.csv", closed, delimiter=",", header=header, comments="")
    np.savetxt(tmp_path / "part.csv", part, delimiter=",", header=header, comments="")
    r = run_cli("compare-curves", "--query", tmp_path / "part.csv", "--library", tmp_path / "lib", "--partial",
                "--json")
    assert r.exit_code == 0, r.output
    p = report_of(r)["queries"][0]["ranking"][0]["placement"]
    placed = p["translation"] + p["scale"] * closed @ np.array(p["matrix"]).T
    dense = placed[np.arange(len(placed) * 20) // 20] + np.repeat(np.roll(placed, -1, 0) - placed, 20, 0) * (
        np.arange(len(placed) * 20) % 20 / 20)[:, None]
    gap = np.min(np.linalg.norm(part[:, None] - dense[None], axis=2), axis=1)
    size = np.ptp(part, axis=0).max()
    assert p["scale"] == pytest.approx(5.0, rel=0.02)
    assert gap.max() < 0.01 * size


def _four_bar_coupler(theta: np.ndarray, px: float, py: float) -> np.ndarray:
    """Closed form: the coupler point (px, py in the A→B frame) of the crank-rocker O=(0,0), D=(4,0), crank 1,
    coupler 3.5, rocker 3 at crank angles ``theta`` (N,) → (N, 2)."""
    a = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    v = np.array([4.0, 0.0]) - a
    gap = np.linalg.norm(v, axis=1)
    along = (3.5 ** 2 - 3.0 ** 2 + gap ** 2) / (2 * gap)
    u = v / gap[:, None]
    b = a + along[:, None] * u + np.sqrt(3.5 ** 2 - along ** 2)[:, None] * np.stack([-u[:, 1], u[:, 0]], axis=1)
    e = (b - a) / 3.5
    return a + px * e + py * np.stack([-e[:, 1], e[:, 0]], axis=1)


def _spherical_coupler(theta: np.ndarray, beta_deg: float, gamma_deg: float) -> np.ndarray:
    """Closed form: the coupler point of a unit-sphere four-bar (crank axis z, rocker axis 60° from it in the xz
    plane; arcs: crank 20°, coupler 55°, rocker 45°), at arc ``beta`` from the coupler joint A and angle ``gamma``
    from the great circle A→B, at crank angles ``theta`` (N,) → (N, 3)."""
    from scipy.spatial.transform import Rotation

    u1 = np.array([np.sin(np.radians(60)), 0.0, np.cos(np.radians(60))])
    a = Rotation.from_rotvec(np.outer(theta, [0, 0, 1])).apply([np.sin(np.radians(20)), 0, np.cos(np.radians(20))])
    n = np.cross(u1, a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    # B: on the sphere, B·u1 = cos 45°, B·A = cos 55°, on the side of n
    dot = a @ u1
    c1 = (np.cos(np.radians(45)) - dot * np.cos(np.radians(55))) / (1 - dot ** 2)
    c2 = (np.cos(np.radians(55)) - dot * np.cos(np.radians(45))) / (1 - dot ** 2)
    b0 = c1[:, None] * u1 + c2[:, None] * a
    b = b0 + np.sqrt(1 - np.sum(b0 ** 2, axis=1))[:, None] * n
    e2 = b - np.sum(b * a, axis=1)[:, None] * a
    e2 /= np.linalg.norm(e2, axis=1)[:, None]
    beta, gamma = np.radians(beta_deg), np.radians(gamma_deg)
    return np.cos(beta) * a + np.sin(beta) * (np.cos(gamma) * e2 + np.sin(gamma) * np.cross(a, e2))


@pytest.mark.parametrize("dim", [2, 3])
def test_an_exact_stretch_of_a_cycle_scores_near_zero_and_ranks_first(run_cli, tmp_path, dim):
    """--partial: an open curve that is exactly 30 % of a closed one (turned, scaled, moved; 3D also reversed)
    is at the distance of that stretch — the chords of the 256-point resampled cycle, ~1e-4 —, not the grid's
    (its stretch lengths step by 10 %: the exact stretch scored 0.6 % and 0.9 % of the size, and the 2D one ranked
    behind another coupler curve of a four-bar while its own placement put it 4e-5 from the query). Curves in
    closed form: a planar crank-rocker's and a spherical four-bar's coupler points."""
    from scipy.spatial.transform import Rotation

    cycle = np.linspace(0, 2 * np.pi, 240, endpoint=False)
    arc = np.linspace(1.0, 1.0 + 0.3 * 2 * np.pi, 60)
    if dim == 2:
        own, other = _four_bar_coupler(cycle, -1.0, 2.0), _four_bar_coupler(cycle, 1.5, 1.0)
        turn = Rotation.from_euler("z", 0.8).as_matrix()[:2, :2]
        part = _four_bar_coupler(arc, -1.0, 2.0) @ turn.T * 3.0 + [5.0, 7.0]
    else:
        own, other = _spherical_coupler(cycle, 50.0, -30.0), _spherical_coupler(cycle, 30.0, 40.0)
        part = _spherical_coupler(arc, 50.0, -30.0)[::-1] @ Rotation.from_rotvec([0, 1.4, 1.4]).as_matrix().T * 0.2 - 4
    header = "x,y,z" if dim == 3 else "x,y"
    (tmp_path / "lib").mkdir()
    for name, curve in (("own", own), ("other", other)):
        np.savetxt(tmp_path / "lib" / f"{name}.csv", curve, delimiter=",", header=header, comments="")
    np.savetxt(tmp_path / "part.csv", part, delimiter=",", header=header, comments="")
    r = run_cli("compare-curves", "--query", tmp_path / "part.csv", "--library", tmp_path / "lib", "--partial",
                "-n", "256", "--json")
    assert r.exit_code == 0, r.output
    ranking = report_of(r)["queries"][0]["ranking"]
    assert [row["curve"] for row in ranking] == ["own", "other"]
    assert ranking[0]["distance"] < 5e-4 < ranking[1]["distance"]


def test_the_distance_is_symmetric_and_zero_for_the_same_shape_to_rounding(run_cli, tmp_path):
    """A shape moved, turned, scaled, started elsewhere and reversed: d(a, b) = d(b, a) and ≈ 0 to rounding
    (not the ~1e-8 of ‖a‖² + ‖b‖² - 2 a·b under a square root), in the ranking (both ways) as in the matrix."""
    import json

    import yaml

    base = rounded_triangle(150, lobe=(0.2, 0.05, 0))
    t = np.linspace(0, 2 * np.pi, 150, endpoint=False)
    other = np.stack([np.cos(t) + 0.3 * np.cos(2 * t), 0.6 * np.sin(t) + 0.1 * np.sin(3 * t)], axis=1)
    turn = np.radians(37.0)
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    moved = np.roll(2.5 * base @ rot.T + [40.0, -7.0], 41, axis=0)[::-1]
    curves = {"a": base, "a-moved": moved, "b": other, "b-turned": np.roll(other @ rot.T, 17, axis=0)}
    path = tmp_path / "set.yaml"
    path.write_text(yaml.safe_dump({"curves": [{"name": k, "points": v.tolist()} for k, v in curves.items()]}))
    names = list(curves)
    assert run_cli("compare-curves", path, "-o", tmp_path / "m.json").exit_code == 0
    matrix = np.array(json.loads((tmp_path / "m.json").read_text())["values"])
    queries = sum((["--query", f"{path}:{n}"] for n in names), [])
    assert run_cli("compare-curves", *queries, "--library", path, "-o", tmp_path / "r.json").exit_code == 0
    ranked = json.loads((tmp_path / "r.json").read_text())
    assert ranked["curves"] == names
    both = np.array(ranked["values"])  # rows library, columns queries
    assert np.abs(both - both.T).max() < 1e-13
    assert np.abs(both - matrix).max() < 1e-13
    assert both[0, 1] < 1e-12 and both[2, 3] < 1e-12 and np.abs(np.diag(both)).max() < 1e-12
