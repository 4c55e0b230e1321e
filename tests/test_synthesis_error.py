"""The error ``synthesize`` reports (report.json ``error``): RMS and max distance between the target and the curve."""

from __future__ import annotations

import numpy as np

from linkedit.synthesis.refine import curve_error


def test_the_max_error_counts_a_target_point_on_a_sharp_tip():
    """A target on the unit circle but for a narrow tip: one point 1e-3 outside it, its neighbours 1e-5 rad either
    side (a cusp-like turnaround the motion passes slowly, as a sampled coupler curve has it). The curve is the
    circle: the max error is that point's distance, 1e-3 over the size 2. (Was 1e-6: the evenly spaced points along
    the target's length step over the tip, so report.json's max was 40 times below a user's own measure of a
    six-bar's cusp.)"""
    phase = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    target = np.exp(1j * phase)
    target = np.insert(target, 101, [np.exp(1j * (phase[100] + 0.5e-5)), 1.001 * np.exp(1j * (phase[100] + 1e-5)),
                                     np.exp(1j * (phase[100] + 1.5e-5))])
    curve = np.exp(1j * np.linspace(0.0, 2 * np.pi, 20_000, endpoint=False))
    rms, worst = curve_error(target, True, curve, 2.0)
    assert abs(worst - 0.5e-3) <= 1e-8, worst
    assert rms < 1e-5  # the tip is a negligible part of the target's length
