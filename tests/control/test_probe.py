"""Where the paper is probed: three points of the drawing's own path, spread to see both
slopes of the sheet (brute force over the path as the oracle), fewer on a straight line; for a
height map, dots every spacing along the path or on a grid over the drawing, and the errors of
both patterns."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.control.probe import (
    DWELL_S,
    MAX_PROBES,
    PATTERNS,
    grid_points,
    path_points,
    probe_drawing,
    probe_points,
)
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError


def drawing_of(*paths) -> Drawing:
    return Drawing([Trajectory(t=np.linspace(0.0, 1.0, len(p)), pos=np.asarray(p, float))
                    for p in paths], page_size=(210.0, 297.0))


def on_path(points, drawing) -> bool:
    path = np.vstack([s.pos[:, :2] for s in drawing.strokes])
    return all(np.min(np.linalg.norm(path - p, axis=1)) == 0.0 for p in points)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 280)), min_size=4, max_size=12,
                unique=True))
def test_the_points_lie_on_the_path_and_span_a_large_triangle(xy):
    drawing = drawing_of(xy[: len(xy) // 2 + 1], xy[len(xy) // 2 + 1:] or xy[:2])
    points = probe_points(drawing)
    assert 1 <= len(points) <= 3 and on_path(points, drawing)
    path = np.vstack([s.pos[:, :2] for s in drawing.strokes])
    if len(points) == 3:
        def area(a, b, c):
            return abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2
        best = max(area(*t) for t in itertools.combinations(path, 3))
        # a greedy choice from the first point: at least a quarter of the best triangle
        assert area(*points) >= best / 4 - 1e-9


def test_a_straight_line_is_probed_at_its_two_ends():
    line = drawing_of([[10.0, 10.0], [20.0, 20.0], [40.0, 40.0]])
    assert np.array_equal(probe_points(line), [[10.0, 10.0], [40.0, 40.0]])


def test_the_probe_drawing_holds_a_dot_at_each_point():
    drawing = drawing_of([[0.0, 0.0], [50.0, 0.0], [50.0, 30.0]])
    probe = probe_drawing(drawing)
    assert len(probe.strokes) == 3 and probe.page_size == drawing.page_size
    for stroke, p in zip(probe.strokes, probe_points(drawing)):
        assert np.array_equal(stroke.pos, [p, p]) and stroke.t[-1] == pytest.approx(DWELL_S)


def polyline_distance(p, path) -> float:
    """Distance [mm] from point p to the polyline ``path`` (brute force over its segments)."""
    best = np.inf
    for a, b in itertools.pairwise(path):
        ab = b - a
        length2 = float(np.dot(ab, ab))
        u = 0.0 if length2 == 0.0 else np.clip(np.dot(p - a, ab) / length2, 0.0, 1.0)
        best = min(best, float(np.linalg.norm(p - (a + u * ab))))
    return best


def test_the_path_pattern_steps_along_each_stroke_by_the_spacing():
    line = drawing_of([[10.0, 20.0], [40.0, 20.0], [40.0, 45.0]])  # 55 mm with a corner
    points = path_points(line, 10.0)
    expected = [[10, 20], [20, 20], [30, 20], [40, 20], [40, 30], [40, 40], [40, 45]]
    np.testing.assert_allclose(points, expected, atol=1e-12)
    assert len(probe_drawing(line, spacing_mm=10.0).strokes) == 7


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 280)), min_size=2, max_size=10),
       st.floats(2.0, 40.0))
def test_path_points_lie_on_the_path_cover_it_and_never_crowd(xy, spacing):
    drawing = drawing_of(xy)
    path = np.asarray(xy, float)
    points = path_points(drawing, spacing)
    assert all(polyline_distance(p, path) < 1e-9 for p in points)
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2) + np.eye(len(points)) * 1e9
    assert gaps.min() >= spacing / 2 - 1e-9
    # every point of the path is within a spacing of a probe (the sheet is seen all along)
    samples = np.vstack([a + u * (b - a) for a, b in itertools.pairwise(path)
                         for u in np.linspace(0.0, 1.0, 7)])
    nearest = np.linalg.norm(samples[:, None] - points[None], axis=2).min(axis=1)
    assert nearest.max() <= spacing + 1e-9


def test_a_retraced_stroke_adds_no_probe():
    there = [[0.0, 0.0], [30.0, 0.0]]
    once = path_points(drawing_of(there), 5.0)
    twice = path_points(drawing_of(there, there[::-1]), 5.0)
    np.testing.assert_array_equal(once, twice)


def test_the_grid_pattern_spans_the_bounding_box_in_a_serpentine():
    drawing = drawing_of([[10.0, 20.0], [35.0, 20.0]], [[20.0, 5.0], [20.0, 41.0]])
    points = grid_points(drawing, 10.0)
    xs, ys = np.unique(points[:, 0]), np.unique(points[:, 1])
    np.testing.assert_allclose(xs, np.linspace(10.0, 35.0, 4))  # ceil(25 / 10) + 1 columns
    np.testing.assert_allclose(ys, np.linspace(5.0, 41.0, 5))  # ceil(36 / 10) + 1 rows
    assert len(points) == 20 and np.diff(xs).max() <= 10.0 and np.diff(ys).max() <= 10.0
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert steps.max() <= 9.0 + 1e-9  # neighbours only: along a row, or up at its end
    dots = probe_drawing(drawing, spacing_mm=10.0, pattern="grid")
    np.testing.assert_array_equal([s.pos[0] for s in dots.strokes], points)


@pytest.mark.parametrize("spacing", [0.0, -1.0, float("nan"), float("inf"), True, "5"])
def test_a_spacing_that_is_not_a_positive_length_is_refused(spacing):
    with pytest.raises(InputError, match=r"spacing_mm: expected a probe spacing > 0 mm, got ") \
            as info:
        probe_drawing(drawing_of([[0.0, 0.0], [10.0, 0.0]]), spacing_mm=spacing)
    assert info.value.key == "spacing_mm"


def test_too_many_probes_and_an_unknown_pattern_are_refused_by_name():
    page = drawing_of([[0.0, 0.0], [200.0, 280.0]])
    with pytest.raises(InputError, match=rf"more than {MAX_PROBES} probe points 0.5 mm apart; "
                                         r"expected a larger spacing"):
        probe_drawing(page, spacing_mm=0.5, pattern="grid")
    with pytest.raises(InputError, match=r"pattern: expected one of path, grid, got 'gird' "
                                         r"\(did you mean 'grid'\?\)") as info:
        probe_drawing(page, spacing_mm=5.0, pattern="gird")
    assert info.value.choices == PATTERNS
