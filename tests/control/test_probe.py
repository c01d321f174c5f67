"""Where the paper is probed: three points of the drawing's own path, spread to see both
slopes of the sheet (brute force over the path as the oracle), fewer on a straight line."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.control.probe import DWELL_S, probe_drawing, probe_points
from inkarm.core.trajectory import Drawing, Trajectory


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
