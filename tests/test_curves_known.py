"""Known values of the curve descriptors and distances."""

from __future__ import annotations

import numpy as np
import pytest

from linkedit.curves.descriptors import describe, describe_ragged
from linkedit.curves.distance import align, aligned_rms, term_distances, weighted
from linkedit.curves.efd import efd_coefficients, efd_distance, normalize_efd
from linkedit.curves.features import self_intersections, turning_angles
from linkedit.curves.learn import learn_weights
from linkedit.curves.normalize import normalize


def ellipse(a: float, b: float, m: int) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, m, endpoint=False)
    return np.stack([a * np.cos(t), b * np.sin(t)], axis=1)


def feature(desc, name: str) -> np.ndarray:
    return desc.features[:, desc.names.index(name)]


def test_circle_has_ellipticity_one():
    m = 360
    d = describe(ellipse(3.0, 3.0, m)[None], True)
    # a regular m-gon: every extent lies between 2r cos(π/m) and 2r
    assert np.cos(np.pi / m) <= feature(d, "ellipticity")[0] <= 1 / np.cos(np.pi / m)
    assert feature(d, "area")[0] == pytest.approx(np.pi / 4, rel=1e-4)  # π r² / (2r)²
    # the length is that of the resampled 64-gon (inscribed in the 360-gon): 64 sin(π/64) / (2r) · 2r
    assert feature(d, "length")[0] == pytest.approx(64 * np.sin(np.pi / 64), rel=1e-4)


@pytest.mark.parametrize("a,b", [(5.0, 2.0), (3.0, 2.9), (10.0, 0.5)])
def test_ellipse_ellipticity_is_b_over_a(a, b):
    d = describe(ellipse(a, b, 400)[None], True)  # vertices at the ends of both axes
    assert feature(d, "ellipticity")[0] == pytest.approx(b / a, abs=1e-12)
    assert feature(d, "self_intersections")[0] == 0


def test_figure_eight_crosses_itself_once():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    eight = np.stack([np.cos(t), np.sin(t) * np.cos(t)], axis=1)  # lemniscate of Gerono
    d = describe(eight[None], True)
    assert feature(d, "self_intersections")[0] == 1
    assert feature(d, "area")[0] == pytest.approx(0.0, abs=1e-12)  # the two lobes cancel


def test_crossing_through_a_sample_point_counts_once():
    # a figure eight whose crossing is exactly a vertex of both strands
    pts = np.array([[0, 0], [1, 1], [2, 0], [1, -1], [0, 0], [-1, 1], [-2, 0], [-1, -1]], dtype=float)
    assert self_intersections(pts[None], np.array([True]))[0] == 1
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    assert self_intersections(square[None], np.array([True]))[0] == 0


def test_crossings_of_a_looped_curve_match_brute_force():
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    curve = np.stack([np.cos(t) + 0.6 * np.cos(3 * t), np.sin(t) - 0.6 * np.sin(3 * t)], axis=1)
    count = self_intersections(curve[None], np.array([True]))[0]

    def cross(o, p, q):
        return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])

    nxt = np.roll(curve, -1, axis=0)
    brute = sum(cross(curve[i], nxt[i], curve[j]) * cross(curve[i], nxt[i], nxt[j]) < 0
                and cross(curve[j], nxt[j], curve[i]) * cross(curve[j], nxt[j], nxt[i]) < 0
                for i in range(64) for j in range(i + 2, 64) if not (i == 0 and j == 63))
    assert count == brute >= 2


def test_line_segment_has_zero_area_and_ellipticity():
    seg = np.stack([np.linspace(0, 4, 9), np.linspace(1, 3, 9)], axis=1)
    d = describe(seg[None], False)
    assert feature(d, "area")[0] == 0.0
    assert feature(d, "ellipticity")[0] == 0.0
    assert feature(d, "length")[0] == pytest.approx(1.0)
    assert feature(d, "self_intersections")[0] == 0
    np.testing.assert_allclose(d.turning, 0.0, atol=1e-12)


def test_3d_features_of_a_tilted_ellipse():
    flat = np.concatenate([ellipse(4.0, 1.0, 400), np.zeros((400, 1))], axis=1)
    c, s = np.cos(0.4), np.sin(0.4)
    tilted = flat @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + [1, 2, 3]
    d = describe(tilted[None], True)
    assert feature(d, "ellipticity_xy")[0] == pytest.approx(0.25, abs=1e-12)
    assert feature(d, "ellipticity_yz")[0] == 0.0 and feature(d, "ellipticity_xz")[0] == 0.0
    assert feature(d, "area_xy")[0] == pytest.approx(np.pi * 4 / 64, rel=1e-4)
    assert feature(d, "area_yz")[0] == pytest.approx(0.0, abs=1e-12)


def test_wire_moments_of_an_l_shape():
    # legs of length 2 (along x) and 1 (along y): wire centroid ((2·1 + 1·0)/3, (2·0 + 1·0.5)/3)
    pts = np.array([[2.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    n = normalize(pts[None], False, 16)
    np.testing.assert_allclose(n.centroid[0], [2 / 3, 1 / 6], atol=1e-15)
    assert n.length[0] * n.scale[0] == pytest.approx(3.0)
    assert np.linalg.det(n.frame[0]) == pytest.approx(1.0)


def test_resampling_is_equal_arc_length():
    pts = np.array([[0, 0], [3, 0], [3, 1], [0, 1]], dtype=float)  # perimeter 8
    n = normalize(pts[None], True, 16)
    steps = np.linalg.norm(np.diff(n.points[0], axis=0), axis=1) * n.scale[0]
    corner_free = steps[np.abs(steps - 0.5) < 1e-9]
    assert len(corner_free) >= 10  # straight stretches: exactly L / N apart
    assert np.all(steps <= 0.5 + 1e-12)


@pytest.mark.parametrize("m", [60, 200])
def test_start_is_the_farthest_point_between_vertices(m):
    """An ellipse with no vertex at the ends of its major axis: the start lies much closer to an
    end than the nearest vertex (half an input step away)."""
    t = np.linspace(0, 2 * np.pi, m, endpoint=False) + np.pi / m
    e = np.stack([3 * np.cos(t), np.sin(t)], axis=1)
    n = normalize(e[None], True, 64)
    start = n.points[0, 0] * n.scale[0]
    half_step = np.sin(np.pi / m)  # the vertices' distance from the axis
    assert abs(start[1]) < 0.05 * half_step and abs(start[0]) > 2.99


def test_a_reversal_at_the_farthest_vertex_stays_the_start():
    """A path traced there and back (a rocker's): the start is the reversal vertex itself."""
    t = np.linspace(0, 1, 41)
    there = np.stack([3 * t, t**2], axis=1)
    n = normalize(np.concatenate([there, there[-2:0:-1]])[None], True, 64)
    start = n.points[0, 0] @ n.frame[0].T * n.scale[0] + n.centroid[0]
    assert np.linalg.norm(start - there[-1]) < 1e-12 or np.linalg.norm(start - there[0]) < 1e-12


@pytest.mark.parametrize("size", [1e-300, 1e-170, 1e-12, 1e12, 1e170, 1e300])
def test_tiny_and_huge_coordinates_give_the_same_features(size):
    """Squares of steps would under/overflow: the curve is scaled into its bounding box first."""
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    egg = ellipse(3.0, 1.0, 90) + [2.0, 5.0] + 0.3 * ellipse(1.0, 0.0, 90) ** 2
    curves, anchors = [square, egg], [np.array([2.0, 0.0])] * 2
    unit = describe_ragged(curves, [True, True], anchors=anchors)
    scaled = describe_ragged([c * size for c in curves], [True, True], anchors=[a * size for a in anchors])
    assert np.isfinite(scaled.features).all() and np.isfinite(scaled.efd).all()
    np.testing.assert_allclose(scaled.features, unit.features, atol=1e-12, rtol=0)
    np.testing.assert_allclose(scaled.points, unit.points, atol=1e-12, rtol=0)
    np.testing.assert_allclose(scaled.normalized.scale, unit.normalized.scale * size, rtol=1e-12)
    # a square is isotropic: its major axis runs to the farthest vertex (a corner), extent √2
    assert feature(scaled, "length")[0] == pytest.approx(4.0 / np.sqrt(2.0), abs=1e-12)
    assert feature(scaled, "area")[0] == pytest.approx(0.5, abs=1e-12)


def test_anchor_angle_of_a_centrally_symmetric_curve_is_rotation_invariant():
    """A 3:1 ellipse has no third moments: rounding used to pick the axis signs (angle ± π)."""
    base, anchor = ellipse(3.0, 1.0, 120), np.array([1.0, 0.5])
    rows = []
    for angle in np.linspace(0.0, 3.0, 7):
        c, s = np.cos(angle), np.sin(angle)
        rot = np.array([[c, -s], [s, c]])
        rows.append(describe((base @ rot.T + [4.0, -2.0])[None], True, anchors=(anchor @ rot.T + [4.0, -2.0])[None]))
    angles = np.array([feature(d, "anchor_angle")[0] for d in rows])
    np.testing.assert_allclose(angles, np.arctan2(0.5, 1.0), atol=1e-9)  # anchor on the + side of the major axis
    np.testing.assert_allclose([feature(d, "anchor_distance")[0] for d in rows], np.hypot(1.0, 0.5) / 6, atol=1e-12)


def test_anchor_angle_of_a_symmetric_3d_curve_is_rotation_invariant():
    t = np.linspace(0, 2 * np.pi, 150, endpoint=False)
    curve = np.stack([3 * np.cos(t), np.sin(t), 0.4 * np.sin(3 * t)], axis=1)  # x(t + π) = -x(t)
    anchor = np.array([0.7, -0.4, 0.3])
    rng = np.random.default_rng(5)
    angles = []
    for _ in range(6):
        q, r = np.linalg.qr(rng.normal(size=(3, 3)))
        q = q * np.sign(np.diag(r))
        q *= np.linalg.det(q)
        d = describe((curve @ q.T + 1.0)[None], True, anchors=(anchor @ q.T + 1.0)[None])
        angles.append(feature(d, "anchor_angle")[0])
    np.testing.assert_allclose(angles, angles[0], atol=1e-9)
    assert abs(angles[0]) < np.pi / 2  # the anchor signs the major axis: it lies on its + side


def test_frame_is_proper_and_deterministic():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(5, 50, 3)).cumsum(axis=1)
    n = normalize(pts, True)
    np.testing.assert_allclose(np.linalg.det(n.frame), 1.0)
    np.testing.assert_allclose(n.extents[:, 0], 1.0)


def test_turning_angles_of_a_convex_curve_sum_to_one_turn():
    t = turning_angles(normalize(ellipse(3, 1, 100)[None], True).points, np.array([True]))
    assert t.sum() == pytest.approx(2 * np.pi)
    assert np.all(t > 0)  # counter-clockwise


def _procrustes_rms(a: np.ndarray, b: np.ndarray) -> float:
    """RMS of a (N, 2) and b turned by the best angle about the origin (closed form)."""
    za, zb = a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]
    return float(np.sqrt(max(np.sum(abs(za) ** 2) + np.sum(abs(zb) ** 2) - 2 * abs(np.vdot(za, zb)), 0) / len(a)))


def test_aligned_rms_matches_brute_force():
    """Whole-sample shifts, both directions, the best rotation: the brute force is an upper
    bound that the sub-sample refinement may only improve, and is met exactly by open pairs."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 16, 2))
    b = rng.normal(size=(4, 16, 2))
    closed_a, closed_b = np.array([True, True, False]), np.array([True, False, True, True])
    got = aligned_rms(a, b, closed_a, closed_b)
    for i in range(3):
        for j in range(4):
            cyclic = closed_a[i] and closed_b[j]
            options = [_procrustes_rms(a[i], np.roll(rev, -s, axis=0))
                       for rev in (b[j], b[j][::-1])  # reversal of an open curve: end to start
                       for s in (range(16) if cyclic else [0])]
            if cyclic:
                assert min(options) - 0.2 < got[i, j] <= min(options) + 1e-12
            else:
                assert got[i, j] == pytest.approx(min(options), abs=1e-12)
    aligned = align(a[0], True, b, closed_b)
    for j in range(4):
        rms = np.sqrt(np.mean(np.sum((a[0] - aligned[j]) ** 2, 1)))
        if closed_b[j]:
            assert got[0, j] <= rms + 1e-12
        else:
            assert rms == pytest.approx(got[0, j], abs=1e-12)


def test_3d_aligned_rms_matches_brute_force_over_proper_sign_patterns():
    rng = np.random.default_rng(8)
    a, b = rng.normal(size=(2, 12, 3)), rng.normal(size=(3, 12, 3))
    closed = np.array([False, False, False])
    got = aligned_rms(a, b, closed[:2], closed)
    mirrored = aligned_rms(a, b, closed[:2], closed, mirror=True)
    patterns = [p for p in np.array(np.meshgrid([1, -1], [1, -1], [1, -1])).T.reshape(-1, 3)]
    for i in range(2):
        for j in range(3):
            def best(proper_only: bool) -> float:
                return min(np.sqrt(np.mean(np.sum((a[i] - rev * p) ** 2, 1))) for rev in (b[j], b[j][::-1])
                           for p in patterns if not proper_only or np.prod(p) > 0)
            assert got[i, j] == pytest.approx(best(True), abs=1e-12)
            assert mirrored[i, j] == pytest.approx(best(False), abs=1e-12)


def test_symmetric_matrix_equals_full_computation():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(7, 32, 3))
    closed = np.array([True] * 5 + [False] * 2)
    np.testing.assert_allclose(aligned_rms(a, None, closed), aligned_rms(a, a.copy(), closed, closed), atol=1e-12)


def test_efd_of_an_ellipse():
    coeffs = efd_coefficients(ellipse(3.0, 1.0, 2000)[None], 5)[0]
    np.testing.assert_allclose(coeffs[0], [3.0, 0.0, 0.0, 1.0], atol=1e-5)
    np.testing.assert_allclose(coeffs[1:], 0.0, atol=1e-5)
    rotated = ellipse(3.0, 1.0, 2000) @ np.array([[0.6, -0.8], [0.8, 0.6]]).T
    norm = normalize_efd(efd_coefficients(np.roll(rotated, 300, axis=0)[None], 5))[0]
    np.testing.assert_allclose(np.abs(norm[0]), [1.0, 0.0, 0.0, 1 / 3], atol=1e-5)


def test_efd_distance_takes_the_best_variant():
    rng = np.random.default_rng(2)
    e = rng.normal(size=(1, 6, 4))
    n = np.arange(1, 7)[:, None]
    half = e * (-1.0) ** (n + 1)
    reverse = e * np.array([1, -1, 1, -1])
    assert efd_distance(e, np.concatenate([half, reverse, half * np.array([1, -1, 1, -1])])) == pytest.approx(0.0)
    assert efd_distance(e, -e)[0, 0] > 0.1  # not a variant


def test_weighted_distance_combines_terms():
    terms = {"a": np.array([[0.0, 3.0]]), "b": np.array([[0.0, 4.0]])}
    np.testing.assert_allclose(weighted(terms, {"a": 1.0, "b": 1.0}), [[0.0, 5.0]])
    np.testing.assert_allclose(weighted(terms, {"a": 4.0, "b": 0.0}), [[0.0, 6.0]])


def test_nearest_neighbour_is_known_by_construction():
    """A query matches its own shape, moved and resampled, before any other shape."""
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    shapes = [np.stack([np.cos(t) + a * np.cos(2 * t), 0.5 * np.sin(t) + b * np.sin(3 * t)], 1)
              for a, b in [(0.0, 0.0), (0.3, 0.0), (0.0, 0.2), (0.3, 0.2), (0.6, 0.1)]]
    wobble = np.stack([np.cos(2 * t + 1), np.sin(3 * t)], 1)
    library = [s + 0.01 * wobble for s in shapes]  # every library curve a little off its shape
    query = np.roll(shapes[3], 77, axis=0)[::-1] @ np.array([[0, -1], [1, 0]]).T * 7 + 5
    desc = describe(np.stack([query] + library), True)
    terms = term_distances(desc.take([0]), desc.take(range(1, 6)))
    dist = weighted(terms, dict.fromkeys(terms, 1.0))[0]
    assert np.argmin(dist) == 3
    # the same shape with growing distortion ranks in order of the distortion
    distorted = [shapes[2] + eps * wobble for eps in (0.2, 0.01, 0.1, 0.05)]
    desc = describe(np.stack([shapes[2]] + distorted), True)
    terms = term_distances(desc.take([0]), desc.take(range(1, 5)))
    assert list(np.argsort(weighted(terms, dict.fromkeys(terms, 1.0))[0])) == [1, 3, 2, 0]


def test_learned_weights_separate_the_labelled_pairs():
    rng = np.random.default_rng(4)
    # term 0 is noise (large on every pair), term 1 tells the classes apart
    similar = np.stack([rng.uniform(0, 3, 12), rng.uniform(0, 0.1, 12), rng.uniform(0, 1, 12)], 1)
    dissimilar = np.stack([rng.uniform(0, 3, 9), rng.uniform(0.5, 1.0, 9), rng.uniform(0, 1, 9)], 1)
    fit = learn_weights(["noise", "signal", "other"], similar, dissimilar, regularization=1e-3)
    assert fit.separated and fit.dissimilar.min() >= 1 - 1e-9
    assert fit.weights["signal"] > 0 and fit.weights["noise"] == pytest.approx(0.0, abs=1e-9)
    # equal weights do not separate this set
    plain = np.sqrt((similar**2).sum(1)).max() < np.sqrt((dissimilar**2).sum(1)).min()
    assert not plain


def test_weights_format_knows_every_term():
    from linkedit.curves.distance import term_names
    from linkedit.spec.curveset import TERMS

    for dim in (2, 3):
        curve = np.concatenate([ellipse(3, 1, 50), np.zeros((50, dim - 2))], axis=1)
        d = describe(curve[None], True, anchors=np.zeros((1, dim)))
        assert set(term_names(d)) <= set(TERMS)
