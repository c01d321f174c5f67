"""Metrics: tracking error, ink-versus-plan chamfer, gaps, force, joint margin, real-time factor."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis import metrics as M
from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk


def _ink_line(p0, p1, width_mm: float = 0.8, size_mm=(80.0, 80.0)) -> Canvas:
    canvas = Canvas(size_mm=size_mm, ink=MarkerInk(w0_mm=width_mm, k_mm=0.0))
    for k, s in enumerate(np.linspace(0.0, 1.0, 300)):
        canvas.touch(np.asarray(p0) + s * np.subtract(p1, p0), 1.0, 0.001 * k)
    canvas.lift()
    return canvas


def test_tracking_error_of_a_constant_offset_is_that_offset():
    ref = np.column_stack([np.linspace(0, 50, 100), np.zeros(100), np.full(100, 2.0)])
    tip = ref + [3.0, 4.0, -2.0]  # z is ignored
    tip[:10] += 100.0  # not drawing: ignored
    drawing = np.arange(100) >= 10
    error = M.tracking_error(ref, tip, drawing)
    assert error.rms_mm == pytest.approx(5.0) and error.max_mm == pytest.approx(5.0)


def test_tracking_error_rms_and_max_of_a_ramp():
    ref = np.zeros((5, 2))
    tip = np.column_stack([np.arange(5.0), np.zeros(5)])
    error = M.tracking_error(ref, tip, np.ones(5, bool))
    assert error.rms_mm == pytest.approx(math.sqrt(np.mean(np.arange(5.0) ** 2)))
    assert error.max_mm == 4.0


@pytest.mark.parametrize("angle_deg", [0.0, 17.0, 45.0, 90.0])
@pytest.mark.parametrize("width_mm", [0.3, 1.0, 2.5])
def test_chamfer_of_ink_drawn_on_its_plan_is_below_half_a_pixel_wide_or_not(angle_deg, width_mm):
    a = math.radians(angle_deg)
    p0 = np.array([20.0, 20.0])
    p1 = p0 + 40.0 * np.array([math.cos(a), math.sin(a)])
    canvas = _ink_line(p0, p1, width_mm)
    chamfer = M.ink_chamfer_mm(canvas.image, canvas.px_per_mm, [np.stack([p0, p1])])
    assert chamfer < 0.6 / canvas.px_per_mm


@pytest.mark.parametrize("shift_mm", [0.3, 1.0, 3.0])
@pytest.mark.parametrize("angle_deg", [0.0, 30.0])
def test_chamfer_of_a_shifted_plan_is_the_shift(shift_mm, angle_deg):
    a = math.radians(angle_deg)
    direction = np.array([math.cos(a), math.sin(a)])
    normal = np.array([-direction[1], direction[0]])
    p0 = np.array([20.0, 20.0])
    p1 = p0 + 40.0 * direction
    canvas = _ink_line(p0, p1, 1.0)
    plan = [np.stack([p0, p1]) + shift_mm * normal]
    chamfer = M.ink_chamfer_mm(canvas.image, canvas.px_per_mm, plan)
    assert chamfer == pytest.approx(shift_mm, abs=0.06)


def test_centreline_of_a_thick_line_lies_on_its_axis():
    canvas = _ink_line([10.0, 30.0], [70.0, 30.0], width_mm=3.0)
    centre = M.ink_centreline_mm(canvas.image, canvas.px_per_mm)
    assert np.all(np.abs(centre[:, 1] - 30.0) <= 0.05 + 1e-9)
    assert centre[:, 0].min() < 12.0 and centre[:, 0].max() > 68.0


def test_chamfer_of_missing_ink_is_infinite_and_of_no_plan_an_error():
    blank = np.zeros((50, 50))
    assert M.ink_chamfer_mm(blank, 10.0, [np.array([[1.0, 1.0], [4.0, 4.0]])]) == math.inf
    with pytest.raises(InputError, match=r"ink_chamfer_mm: the plan has no stroke"):
        M.ink_chamfer_mm(blank, 10.0, [])


def test_chamfer_mm_closed_form():
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    b = np.array([[0.0, 1.0]])
    # a -> b: 1 and sqrt(101); b -> a: 1
    assert M.chamfer_mm(a, b) == pytest.approx(0.5 * ((1 + math.sqrt(101)) / 2 + 1))
    assert M.chamfer_mm(a, np.empty((0, 2))) == math.inf
    with pytest.raises(InputError, match=r"chamfer_mm: both point sets are empty"):
        M.chamfer_mm(np.empty((0, 2)), np.empty((0, 2)))


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=2, max_size=6),
    st.floats(0.05, 3.0),
)
def test_resampled_polyline_keeps_vertices_and_spacing(vertices, spacing):
    points = np.array(vertices)
    dense = M.resample_polyline(points, spacing)
    assert np.all(np.linalg.norm(np.diff(dense, axis=0), axis=1) <= spacing + 1e-9)
    for vertex in points:
        assert np.min(np.linalg.norm(dense - vertex, axis=1)) < 1e-9
    assert np.allclose(dense[0], points[0]) and np.allclose(dense[-1], points[-1])


def _uniform_line(n: int = 1001, length: float = 100.0) -> np.ndarray:
    return np.column_stack([np.linspace(0.0, length, n), np.zeros(n)])  # 0.1 mm per sample


def test_gaps_on_a_synthetic_force_trace():
    ref = _uniform_line()
    x = ref[:, 0]
    force = np.full(x.size, 1.2)
    force[(x >= 20.0) & (x < 25.0)] = 0.0  # 5 mm off the paper
    force[(x >= 60.0) & (x < 62.0)] = 0.01  # 2 mm, below the contact threshold
    drawing = np.ones(x.size, bool)
    gaps = M.pen_gaps(ref, force, drawing, contact_threshold_n=0.05)
    assert gaps.count == 2
    assert gaps.longest_mm == pytest.approx(5.0, abs=1e-9)
    assert gaps.total_mm == pytest.approx(7.0, abs=1e-9)


def test_gaps_ignore_pen_up_travel_and_do_not_cross_stroke_boundaries():
    ref = _uniform_line()
    x = ref[:, 0]
    drawing = (x < 40.0) | (x >= 50.0)
    force = np.where(drawing, 1.0, 0.0)  # pen up in travel: not a gap
    assert M.pen_gaps(ref, force, drawing) == M.Gaps(0.0, 0.0, 0)
    force[(x >= 38.0) & (x < 52.0)] = 0.0  # lost contact at the end of one stroke, start of next
    gaps = M.pen_gaps(ref, force, drawing)
    assert gaps.count == 2
    # stroke ends own half a step: 2 mm minus 0.05 at the end, likewise at the next start
    assert gaps.total_mm == pytest.approx(4.0 - 0.1, abs=1e-9)


def test_contact_force_statistics_over_drawing_samples_in_contact():
    force = np.array([0.0, 1.0, 2.0, 3.0, 0.0, 10.0])
    drawing = np.array([True, True, True, True, True, False])
    mean, std = M.contact_force_stats(force, drawing)
    assert mean == pytest.approx(2.0) and std == pytest.approx(np.std([1.0, 2.0, 3.0]))
    assert all(math.isnan(v) for v in M.contact_force_stats(np.zeros(6), drawing))


def test_joint_limit_margin_is_the_closest_approach_and_negative_past_a_limit():
    q = np.array([[0.0, 0.5], [0.9, -0.2], [0.1, 0.0]])
    ranges = np.array([[-1.0, 1.0], [-0.5, 2.0]])
    assert M.joint_limit_margin_rad(q, ranges) == pytest.approx(0.1)
    assert M.joint_limit_margin_rad(q + [0.0, -0.4], ranges) == pytest.approx(-0.1)
    assert M.joint_limit_margin_rad(q, [[-np.inf, np.inf], [-0.5, 2.0]]) == pytest.approx(0.3)
    with pytest.raises(InputError, match=r"joint_range\[1\] = \[1.0, 1.0\]: expected lo < hi"):
        M.joint_limit_margin_rad(q, [[-1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(InputError, match=r"joint_range: expected shape \(2, 2\), got \(3, 2\)"):
        M.joint_limit_margin_rad(q, np.zeros((3, 2)))


def test_realtime_factor_and_its_errors():
    assert M.realtime_factor(np.linspace(2.0, 12.0, 11), 0.5) == pytest.approx(20.0)
    with pytest.raises(InputError, match=r"realtime_factor: wall_time_s must be > 0, got 0.0"):
        M.realtime_factor([0.0, 1.0], 0.0)
    with pytest.raises(InputError, match=r"realtime_factor: need at least 2 times, got 1"):
        M.realtime_factor([0.0], 1.0)


def test_compute_metrics_gives_exactly_the_documented_keys_with_consistent_values():
    n = 1001
    times = np.linspace(0.0, 10.0, n)
    ref = np.column_stack([10.0 + 0.06 * np.arange(n), np.full(n, 40.0)])
    drawing = np.ones(n, bool)
    drawing[:100] = False
    tip = ref + [0.0, 0.2]
    force = np.where(drawing, 1.5, 0.0)
    canvas = Canvas(size_mm=(80.0, 80.0))
    for k in np.flatnonzero(drawing):
        canvas.touch(tip[k], force[k], times[k])
    canvas.lift()
    q = np.column_stack([np.linspace(-0.5, 0.5, n)] * 2)
    result = M.compute_metrics(
        times_s=times,
        reference_mm=ref,
        tip_mm=tip,
        force_n=force,
        drawing=drawing,
        q=q,
        joint_range=[[-1.0, 1.0], [-2.0, 2.0]],
        wall_time_s=0.25,
        canvas=canvas,
    )
    assert tuple(result) == M.METRIC_KEYS
    assert result["tracking_rms_mm"] == pytest.approx(0.2)
    assert result["tracking_max_mm"] == pytest.approx(0.2)
    assert result["ink_chamfer_mm"] == pytest.approx(0.2, abs=0.06)
    assert result["gap_mm"] == 0.0
    assert result["contact_force_mean_n"] == pytest.approx(1.5)
    assert result["contact_force_std_n"] == pytest.approx(0.0, abs=1e-12)
    assert result["joint_limit_margin_rad"] == pytest.approx(0.5)
    assert result["realtime_factor"] == pytest.approx(40.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"tip_mm": np.zeros((9, 2))}, r"tip_mm: expected 10 samples \(rows\), got 9"),
        ({"reference_mm": np.zeros(10)}, r"reference_mm: expected a 2-D array, got shape \(10,\)"),
        ({"force_n": np.full(10, np.nan)}, r"force_n: non-finite value at index \(0,\)"),
        (
            {"drawing": np.ones(10)},
            r"drawing: expected a boolean array of shape \(10,\), got float64",
        ),
        ({"drawing": np.zeros(10, bool)}, r"tracking_error: the drawing mask selects no sample"),
        ({"q": np.zeros((10, 3))}, r"joint_range: expected shape \(3, 2\), got \(2, 2\)"),
    ],
)
def test_compute_metrics_names_the_bad_input(kwargs, message):
    args = {
        "times_s": np.linspace(0, 1, 10),
        "reference_mm": np.zeros((10, 2)),
        "tip_mm": np.zeros((10, 2)),
        "force_n": np.ones(10),
        "drawing": np.ones(10, bool),
        "q": np.zeros((10, 2)),
        "joint_range": [[-1.0, 1.0], [-1.0, 1.0]],
        "wall_time_s": 1.0,
        "canvas": Canvas(size_mm=(5, 5)),
    }
    args.update(kwargs)
    with pytest.raises(InputError, match=message):
        M.compute_metrics(**args)
