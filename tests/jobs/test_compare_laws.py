"""The comparison of control laws (:mod:`inkarm.jobs.compare_laws`): its measures on paths whose
answers are known, and one comparison drawn."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.control.laws.sensorimotor import Targets
from inkarm.errors import InputError
from inkarm.jobs.compare_laws import (
    curvature_bins,
    overshoots,
    path_curvature,
    path_error,
    speed_profile,
)


def test_the_curvature_of_a_circle_is_one_over_its_radius():
    for radius in (2.0, 10.0, 50.0):
        angle = np.linspace(0.0, np.pi, 2000)
        circle = radius * np.column_stack([np.cos(angle), np.sin(angle)])
        kappa = path_curvature(circle, np.array([1000]), arc_mm=1.0)
        assert kappa[0] == pytest.approx(1.0 / radius, rel=5e-3)
    line = np.column_stack([np.linspace(0.0, 10.0, 50), np.zeros(50)])
    assert path_curvature(line, np.array([25]))[0] == pytest.approx(0.0, abs=1e-12)
    # a corner of 90 degrees turns pi/2 within the arc
    corner = np.vstack([np.column_stack([np.zeros(51), np.linspace(-5, 0, 51)]),
                        np.column_stack([np.linspace(0, 5, 51)[1:], np.zeros(50)])])
    assert path_curvature(corner, np.array([50]), arc_mm=1.5)[0] == pytest.approx(
        math.pi / 2 / 1.5, rel=1e-6)


def test_curvature_bins_cover_every_value_once():
    kappa = np.array([0.0, 0.01, 0.06, 0.3, 0.7, 5.0])
    bins = curvature_bins(kappa)
    assert [list(b) for b in bins] == [[0, 1], [2], [3], [4, 5]]


def test_path_error_is_the_distance_to_the_curve_whatever_the_timing():
    reference = np.column_stack([np.linspace(0.0, 10.0, 6), np.zeros(6)])  # 2 mm apart
    tip = np.array([[1.0, 0.5], [7.3, -0.2], [10.0, 0.0]])
    np.testing.assert_allclose(path_error(tip, reference), [0.5, 0.2, 0.0], atol=0.011)


def _corner(carry_mm: float):
    """A path up 10 mm then right 10 mm, one row per 0.5 mm, targets at the ends and the
    corner; the pen follows it but carries on ``carry_mm`` past the corner before turning."""
    up = np.column_stack([np.zeros(21), np.linspace(0.0, 10.0, 21)])
    right = np.column_stack([np.linspace(0.0, 10.0, 21)[1:], np.full(20, 10.0)])
    reference = np.vstack([up, right])
    rows = np.arange(len(reference))
    tip = reference.copy()
    bump = np.clip(carry_mm - 0.5 * np.abs(rows - 22), 0.0, None)  # up past the corner
    tip[:, 1] += bump
    targets = Targets(row=np.array([0, 20, 40]), xy=reference[[0, 20, 40]],
                      stroke=np.zeros(3, dtype=np.intp), active=np.zeros(len(rows), np.intp))
    return tip, rows, reference, targets


def test_the_overshoot_is_how_far_the_pen_carries_on_past_a_corner():
    for carry in (0.0, 0.8, 2.0):
        tip, rows, reference, targets = _corner(carry)
        out = overshoots(tip, rows, reference, rows, targets, np.array([1]))
        assert out[0] == pytest.approx(carry, abs=1e-9)


def test_a_pen_ahead_on_a_straight_stretch_does_not_overshoot():
    reference = np.column_stack([np.linspace(0.0, 30.0, 61), np.zeros(61)])
    rows = np.arange(61)
    tip = np.column_stack([np.minimum(reference[:, 0] + 1.5, 30.0), np.zeros(61)])  # leads
    targets = Targets(row=np.array([0, 20, 40, 60]), xy=reference[[0, 20, 40, 60]],
                      stroke=np.zeros(4, dtype=np.intp), active=np.zeros(61, np.intp))
    out = overshoots(tip, rows, reference, rows, targets, np.array([1, 2]))
    np.testing.assert_array_equal(out, [0.0, 0.0])


def test_speed_peaks_per_second_and_the_peak_speed():
    t = np.linspace(0.0, 2.0, 2001)
    speed = 100.0 + 50.0 * np.sin(2 * np.pi * 3.0 * t)  # three peaks a second
    speed[1000] += 2.0  # a ripple well under 10 % of the top speed is not a peak
    peaks, top = speed_profile((speed,), (t,))
    assert peaks == pytest.approx(3.0) and top == pytest.approx(150.0, abs=0.1)
    assert speed_profile((np.ones(2),), (np.array([0.0, 1.0]),)) == (0.0, 0.0)


@pytest.mark.sim
@pytest.mark.slow
def test_a_comparison_of_two_laws_on_the_default_letter():
    from matplotlib.figure import Figure

    from inkarm.jobs.compare_laws import compare_laws, comparison_figure
    from inkarm.jobs.scenario import load_scenario

    comparison = compare_laws(load_scenario(), laws=(
        ("position", "LQT reference"), ("sensorimotor", "sensorimotor")))
    reference, sensorimotor = comparison.results
    assert comparison.compression == 0.85 and len(comparison.targets) == 30
    # the targets are the plan's drawing rows, and the reference path goes through them
    assert set(comparison.plan.phase[comparison.targets.row]) == {2}
    # the default law follows the plan; the sensorimotor law's path emerges from its loop
    assert reference.status == "ok" and reference.path_rms_mm < 0.1
    assert reference.ink_vs_reference_mm == 0.0
    assert 0.3 < sensorimotor.path_rms_mm < 1.5
    assert sensorimotor.ink_vs_reference_mm < 1.5
    assert reference.overshoot_mm.max() < 0.2 < sensorimotor.overshoot_mm.max()
    assert 200 < sensorimotor.peak_speed_mm_s < 450
    assert comparison.result("sensorimotor") is sensorimotor
    with pytest.raises(InputError, match="no law 'impedance'"):
        comparison.result("impedance")
    table = comparison.table().splitlines()
    assert len(table) == 5 and "| sensorimotor | degraded |" in table[-1]
    assert comparison.overshoot_table().count("\n") == 5
    fig = comparison_figure(comparison, window_s=(0.0, 1.0))
    assert isinstance(fig, Figure) and len(fig.axes) == 3  # paths, speed, overshoot
    assert len(fig.axes[0].child_axes) == 1  # the inset on a corner
    fig.canvas.draw()
