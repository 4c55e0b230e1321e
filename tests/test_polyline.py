"""Polylines (linkedit.curves.polyline): arc-length resampling and point-to-polyline distances, planar and spatial,
one curve or a batch at once, against closed forms."""

from __future__ import annotations

import numpy as np

from linkedit.curves.polyline import arc_resample, distances_to, near_distances

SQUARE = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]])


def test_polyline_helpers_take_spatial_points():
    """On real (N, 3) points: a unit square in the plane z = 1 (closed: 8 points at its corners and midpoints;
    open: from its first corner to its last), and closed-form distances to it and to a dense circle."""
    np.testing.assert_allclose(arc_resample(SQUARE, 8, True)[1::2], (SQUARE + np.roll(SQUARE, -1, axis=0)) / 2)
    np.testing.assert_allclose(arc_resample(SQUARE, 4, False), [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
    points = np.array([[0.5, 0.5, 3.0], [2.0, 0.5, 1.0], [0.5, 2.0, 1.0]])
    np.testing.assert_allclose(distances_to(points, SQUARE, True), [np.sqrt(0.25 + 4.0), 1.0, 1.0])
    np.testing.assert_allclose(distances_to(points, SQUARE, False), [np.sqrt(0.25 + 4.0), 1.0, 1.0])
    np.testing.assert_allclose(distances_to(np.array([[-0.5, 0.5, 1.0]]), SQUARE, False), [np.sqrt(0.5)])
    phi = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    circle = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    rng = np.random.default_rng(3)
    probe = rng.normal(size=(2, 50, 3))
    exact = np.hypot(np.hypot(probe[..., 0], probe[..., 1]) - 1.0, probe[..., 2])
    near = near_distances(probe, np.broadcast_to(circle, (2, *circle.shape)))
    np.testing.assert_allclose(near, distances_to(probe, np.broadcast_to(circle, (2, *circle.shape)), True))
    np.testing.assert_allclose(near, exact, atol=2e-5)  # the chords sag 1 - cos(π/720) < 1e-5


def _square_at(u: np.ndarray) -> np.ndarray:
    """The unit square's boundary (0,0) → (1,0) → (1,1) → (0,1) at arc length u ∈ [0, 4] → (..., 2)."""
    side, f = np.minimum(np.floor(u), 3), u - np.minimum(np.floor(u), 3)
    corner = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    heading = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    k = side.astype(int)
    return corner[k] + f[..., None] * heading[k]


def test_a_batch_of_curves_is_resampled_at_once_each_by_its_own_length():
    """Squares of different sizes and places, each given with its own extra vertices (a repeated point, points
    along the sides), resampled together: each along its own length (closed: L / count apart from the first
    corner; open, the first three sides: L / (count − 1) apart, to the last corner), where the closed form puts
    them; (C, N) complex as (C, N, 2) real; one curve alone gives its row of the batch, bit for bit."""
    size = np.array([1.0, 2.5e3, 3e-4])
    place = np.array([[0.0, 0.0], [-7.0, 2.0], [1e-3, 5e-4]])
    closed_cuts = np.array([[0.0, 0.5, 1.0, 2.0, 2.0, 3.0], [0.0, 1.0, 1.25, 2.0, 3.0, 3.7],
                            [0.0, 0.1, 1.0, 2.0, 2.9, 3.0]])
    open_cuts = np.array([[0.0, 0.5, 1.0, 2.0, 2.0, 3.0], [0.0, 1.0, 1.25, 2.0, 2.5, 3.0],
                          [0.0, 0.1, 0.1, 1.0, 2.0, 3.0]])
    for closed, cuts, count, length in ((True, closed_cuts, 12, 4.0), (False, open_cuts, 10, 3.0)):
        real = place[:, None] + size[:, None, None] * _square_at(cuts)  # (3, 6, 2)
        u = np.arange(count) * (length / count if closed else length / (count - 1))
        want = place[:, None] + size[:, None, None] * _square_at(u)[None]
        got = arc_resample(real, count, closed)
        z = arc_resample(real[..., 0] + 1j * real[..., 1], count, closed)
        for c in range(3):
            np.testing.assert_allclose(got[c], want[c], rtol=0, atol=1e-12 * size[c])
            np.testing.assert_allclose(np.stack([z[c].real, z[c].imag], axis=-1), want[c], rtol=0,
                                       atol=1e-12 * size[c])
            assert np.array_equal(arc_resample(real[c], count, closed), got[c])
