"""Metrics: tracking error, ink-versus-plan chamfer, gaps, force, joint margin, real-time factor."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis import metrics as M
from inkarm.core.run import Bounds, judge
from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk, PencilInk


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


@pytest.mark.parametrize("near", [0.0, 0.05, 0.3, 2.0, math.inf])
def test_nearest_points_looked_for_nearby_first_are_the_exact_ones(near):
    """The chamfer's bounded queries, then unbounded ones for the points beyond ``near``: the
    same distances, bit for bit, as all pairs (the same arithmetic: dx^2 + dy^2, its root)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(0, 20, (300, 2)), rng.uniform(40, 60, (20, 2))])
    b = np.round(rng.uniform(0, 30, (200, 2)) * 10.0) / 10.0  # (ties on a grid)
    d = b[None, :, :] - a[:, None, :]
    brute = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2).min(axis=1)
    np.testing.assert_array_equal(M._nearest(cKDTree(b), a, near), brute)
    exact = 0.5 * (brute.mean() + np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2).min(axis=0).mean())
    assert M._chamfer(a, b, cKDTree(b), near) == M.chamfer_mm(a, b) == pytest.approx(exact)


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
    assert result["force_p1_n"] == result["force_p99_n"] == pytest.approx(1.5)
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


def test_a_run_with_no_drawing_row_has_undefined_tracking_which_never_passes():
    result = M.compute_metrics(
        times_s=np.linspace(0, 1, 10), reference_mm=np.zeros((10, 2)), tip_mm=np.ones((10, 2)),
        force_n=np.zeros(10), drawing=np.zeros(10, bool), q=np.zeros((10, 2)),
        joint_range=[[-1.0, 1.0], [-1.0, 1.0]], wall_time_s=1.0, canvas=Canvas(size_mm=(5, 5)),
        plan_strokes=[np.array([[1.0, 1.0], [4.0, 1.0]])])
    assert np.isnan(result["tracking_rms_mm"]) and np.isnan(result["tracking_max_mm"])
    shortfalls, _ = judge(result, Bounds(), force_n=1.0)
    assert any("tracking" in f.bound for f in shortfalls)


def _centreline_on_the_whole_page(darkness, px_per_mm: float, threshold: float) -> np.ndarray:
    """ink_centreline_mm as it was before it cropped to the ink: both transforms on the whole
    page (the reference the cropped computation must match exactly)."""
    from scipy import ndimage

    image = np.asarray(darkness)
    ink = image >= threshold
    depth = ndimage.distance_transform_edt(np.pad(ink, 1))[1:-1, 1:-1]
    ridge = ink & (depth >= ndimage.maximum_filter(depth, size=3) - 1e-9)
    rows, cols = np.nonzero(ridge)
    n_rows = image.shape[0]
    return np.column_stack(((cols + 0.5) / px_per_mm, (n_rows - rows - 0.5) / px_per_mm))


def _strokes(canvas: Canvas, strokes, force: float = 1.0) -> Canvas:
    t = 0.0
    for stroke in strokes:
        for p in np.asarray(stroke, float):
            canvas.touch(p, force, t)
            t += 0.001
        canvas.lift()
        t += 0.1
    return canvas


def _line(p0, p1, n: int = 200) -> np.ndarray:
    return np.asarray(p0, float) + np.linspace(0.0, 1.0, n)[:, None] * np.subtract(p1, p0)


def _canvases():
    th = np.linspace(0.0, 2.0 * np.pi, 600)
    return {
        "letter in the middle": _strokes(
            Canvas(size_mm=(80.0, 90.0), ink=MarkerInk(w0_mm=0.8, k_mm=0.0)),
            [_line([20, 20], [20, 60]), _line([20, 60], [50, 20]), _line([50, 20], [50, 60])]),
        "ink over every edge and corner": _strokes(
            Canvas(size_mm=(30.0, 20.0), ink=MarkerInk(w0_mm=2.0, k_mm=0.0)),
            [_line([-3, 10], [33, 10]), _line([15, -3], [15, 23]), _line([0, 0], [30, 20]),
             [[0.0, 20.0]], [[30.0, 0.0]]]),
        "far-apart dots and a thick circle": _strokes(
            Canvas(size_mm=(120.0, 60.0), px_per_mm=7.0, ink="brush"),
            [[[3.0, 57.0]], [[117.0, 4.0]],
             np.column_stack([60 + 12 * np.cos(th), 30 + 12 * np.sin(th)])]),
        "light pencil near the top edge": _strokes(
            Canvas(size_mm=(50.0, 50.0), px_per_mm=13.0, ink=PencilInk(width_mm=1.1)),
            [_line([5, 49.8], [45, 49.2]), _line([25, 49.9], [25, 30])], force=0.3),
    }


@pytest.mark.parametrize("name", list(_canvases()))
def test_centreline_on_the_inks_box_is_exactly_the_one_on_the_whole_page(name):
    canvas = _canvases()[name]
    image = canvas.image
    assert image.max() > 0
    for threshold in (0.5 * image.max(), 0.05, 0.5, 0.9 * image.max(), 2.0):
        cropped = M.ink_centreline_mm(image, canvas.px_per_mm, threshold)
        whole = _centreline_on_the_whole_page(image, canvas.px_per_mm, threshold)
        assert cropped.shape == whole.shape and cropped.dtype == whole.dtype
        np.testing.assert_array_equal(cropped, whole)
    plan = [np.array([[10.0, 10.0], [20.0, 30.0]])]
    expected = M.chamfer_mm(
        _centreline_on_the_whole_page(image, canvas.px_per_mm, 0.5 * image.max()),
        M.resample_polyline(plan[0], 0.5 / canvas.px_per_mm),
    )
    assert M.ink_chamfer_mm(image, canvas.px_per_mm, plan) == expected


def test_centreline_of_a_blank_page_is_empty():
    assert M.ink_centreline_mm(np.zeros((40, 30)), 10.0).shape == (0, 2)


@pytest.mark.parametrize("scan_rows", [512, 3])
def test_ink_box_bounds_the_ink_and_grows_by_the_margin_within_the_raster(monkeypatch, scan_rows):
    monkeypatch.setattr(M, "_SCAN_ROWS", scan_rows)
    image = np.zeros((30, 40), np.float32)
    image[4, 7] = 0.5
    image[20, 33] = 0.2
    assert M.ink_box(image, 0.2) == (4, 21, 7, 34)
    assert M.ink_box(image, 0.2, strict=True) == (4, 5, 7, 8)
    assert M.ink_box(image, 0.2, margin=5) == (0, 26, 2, 39)
    assert M.ink_box(image, 0.2, margin=100) == (0, 30, 0, 40)
    assert M.ink_box(image, 0.6) is None
    image[29, 0] = 1.0
    assert M.ink_box(image, 0.2) == (4, 30, 0, 34)
    with pytest.raises(InputError, match=r"ink_box: darkness must be 2-D"):
        M.ink_box(np.zeros(5), 0.5)


def test_force_percentiles_are_over_every_drawing_sample_gaps_included():
    drawing = np.ones(201, bool)
    drawing[:100] = False  # not drawing: not counted, whatever the force
    force = np.concatenate([np.full(100, 9.0), np.linspace(0.9, 1.1, 101)])
    lo, hi = M.force_percentiles(force, drawing)
    assert lo == pytest.approx(0.902) and hi == pytest.approx(1.098)  # linear interpolation
    force[150] = 0.0  # a gap pulls the low end down
    force[151] = 0.0
    assert M.force_percentiles(force, drawing)[0] < 0.9
    assert all(math.isnan(v) for v in M.force_percentiles(force, np.zeros(201, bool)))


def _masks():
    """Ink masks: sparse and dense noise, blobs grown from it, single pixels, ink on every
    edge of the page, a filled page."""
    def grown(mask, n):
        for _ in range(n):
            mask = mask.copy()
            mask[1:] |= mask[:-1].copy()
            mask[:, 1:] |= mask[:, :-1].copy()
        return mask

    shapes = st.tuples(st.integers(1, 40), st.integers(1, 40))
    noise = shapes.flatmap(lambda s: st.tuples(
        st.just(s), st.integers(0, 2**32 - 1), st.sampled_from([0.01, 0.2, 0.6, 0.95, 1.0]),
        st.integers(0, 9), st.booleans()))

    def build(args):
        (h, w), seed, density, grow, edges = args
        mask = grown(np.random.default_rng(seed).random((h, w)) < density, grow)
        if edges:
            mask[0, :: 3] = mask[-1, 1::2] = mask[:, 0] = True
        return mask

    return noise.map(build)


@settings(max_examples=150, deadline=None)
@given(_masks())
def test_depths_and_centreline_are_scipys_bit_for_bit(mask):
    from scipy import ndimage

    from inkarm.analysis.medial_axis import squared_depths

    rows, cols = np.nonzero(mask)
    expected = ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1][rows, cols]
    depth = np.sqrt(squared_depths(mask)[0].astype(np.float64))  # D at the ink's pixels
    assert depth.dtype == expected.dtype and np.array_equal(depth, expected)
    image = mask.astype(np.float32)
    whole = _centreline_on_the_whole_page(image, 7.0, 0.5)
    for within in (None, M.ink_box(image, 0.5) or (0, 0, 0, 0)):
        got = M.ink_centreline_mm(image, 7.0, 0.5, within=within)
        assert got.shape == whole.shape and got.dtype == whole.dtype
        np.testing.assert_array_equal(got, whole)


def test_the_depth_of_a_filled_disk_is_scipys_and_its_centreline_its_centre():
    rows, cols = np.mgrid[:121, :101]
    image = ((rows - 60) ** 2 + (cols - 50) ** 2 <= 45**2).astype(np.float32)
    got = M.ink_centreline_mm(image, 1.0, 0.5)
    np.testing.assert_array_equal(got, _centreline_on_the_whole_page(image, 1.0, 0.5))
    np.testing.assert_array_equal(got, [[50.5, 60.5]])


@pytest.mark.parametrize("name", list(_canvases()))
def test_the_canvas_inked_box_holds_all_its_ink_and_the_metrics_read_only_it(name):
    canvas = _canvases()[name]
    image = np.array(canvas.image)
    r0, r1, c0, c1 = canvas.inked_box
    outside = image.copy()
    outside[r0:r1, c0:c1] = 0.0
    assert image[r0:r1, c0:c1].max() > 0 and not outside.any()
    plan = [np.array([[10.0, 10.0], [20.0, 30.0], [5.0, 12.0]])]
    whole = M.ink_chamfer_mm(image, canvas.px_per_mm, plan)
    assert M.ink_chamfer_mm(image, canvas.px_per_mm, plan, within=canvas.inked_box) == whole
    image[r0:r1, c0:c1] = 0.0  # what lies outside ``within`` is not read
    assert M.ink_chamfer_mm(image + outside, canvas.px_per_mm, plan,
                            within=(r0, r1, c0, c1)) == math.inf
    blank = Canvas(size_mm=(20.0, 10.0))
    assert blank.inked_box is None
    run = {"times_s": [0.0, 1.0], "reference_mm": [[1.0, 1.0], [4.0, 1.0]],
           "tip_mm": [[1.0, 1.0], [4.0, 1.0]], "force_n": [1.0, 1.0],
           "drawing": np.ones(2, bool), "q": np.zeros((2, 1)), "joint_range": [[-1.0, 1.0]],
           "wall_time_s": 1.0}
    assert M.compute_metrics(**run, canvas=blank)["ink_chamfer_mm"] == math.inf
    assert M.compute_metrics(**run, canvas=canvas)["ink_chamfer_mm"] == M.ink_chamfer_mm(
        canvas.image, canvas.px_per_mm, M.plan_strokes_from_reference(
            np.array(run["reference_mm"]), run["drawing"]))


def test_the_plans_side_is_computed_once_per_plan_and_never_stale(monkeypatch):
    image = np.zeros((60, 80), np.float32)
    image[20:24, 10:70] = 1.0
    calls = []
    resample = M.resample_polyline
    monkeypatch.setattr(M, "resample_polyline", lambda *a: calls.append(1) or resample(*a))
    monkeypatch.setattr(M, "_PLANS", type(M._PLANS)(2))

    def fresh(strokes, px_per_mm=10.0):
        plan = np.concatenate([resample(s, 0.5 / px_per_mm)[:, :2] for s in strokes])
        return M.chamfer_mm(M.ink_centreline_mm(image, px_per_mm, 0.5), plan)

    a = [np.array([[1.0, 3.8], [7.0, 3.8]]), np.array([[2.0, 1.0, 0.0], [2.0, 5.0, 9.0]])]
    b = [np.array([[1.0, 3.0], [7.0, 3.0]])]
    assert M.ink_chamfer_mm(image, 10.0, a) == fresh(a) and len(calls) == 2
    assert M.ink_chamfer_mm(image, 10.0, [s.copy() for s in a]) == fresh(a)
    assert len(calls) == 2  # the same content: not resampled again
    assert M.ink_chamfer_mm(image, 10.0, b) == fresh(b) != fresh(a)
    assert M.ink_chamfer_mm(image, 5.0, b) == fresh(b, 5.0)
    b[0][1, 1] = 4.0  # mutated in place: a different plan
    assert M.ink_chamfer_mm(image, 10.0, b) == fresh(b)
    assert M.ink_chamfer_mm(image, 10.0, a) == fresh(a) and len(M._PLANS) == 2
    with pytest.raises(InputError, match="ink_chamfer_mm: the plan has no stroke"):
        M.ink_chamfer_mm(image, 10.0, [])
