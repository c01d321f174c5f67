"""The pen phases in the page frame: order per stroke, settling rows, pressing depth, and the
minimum-jerk travel's peak speed."""

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.sequencing import (
    PenPath,
    minimum_jerk,
    pen_depth_mm,
    sequence_pen,
    stroke_points,
    ticks,
)
from inkarm.core.log import DESCEND, DRAW, LIFT, PHASES, TRAVEL
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError

DT = 0.006


def line(p0, p1, duration=0.5, n=11) -> Trajectory:
    t = np.linspace(0.0, duration, n)
    s = minimum_jerk(n)[:, None]
    return Trajectory(t, np.asarray(p0, float) + s * (np.asarray(p1, float) - p0))


def three_strokes() -> Drawing:
    return Drawing(
        [
            line([20.0, 20.0], [60.0, 30.0]),
            line([160.0, 30.0], [150.0, 90.0], duration=0.3),
            line([40.0, 200.0], [80.0, 200.0], n=3),  # too short for a spline: linear
        ]
    )


@pytest.fixture(scope="module")
def path() -> PenPath:
    return sequence_pen(three_strokes(), LoopConfig(), 1.0 / 0.3, DT)


def runs(values):
    """(value, start, stop) of each run of equal values."""
    values = np.asarray(values)
    edges = np.flatnonzero(np.diff(values)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [len(values)]])
    return [(values[a].item(), int(a), int(b)) for a, b in zip(starts, stops)]


def test_phases_come_in_order_for_each_stroke(path):
    phases = [(PHASES[p], int(path.stroke[a])) for p, a, _ in runs(path.phase)]
    assert phases == [
        ("descend", 0), ("draw", 0), ("lift", 0),
        ("travel", 1), ("descend", 1), ("draw", 1), ("lift", 1),
        ("travel", 2), ("descend", 2), ("draw", 2), ("lift", 2),
    ]  # fmt: skip
    assert "approach" not in phases and "home" not in phases  # joint moves: the arm's business
    for p, a, b in runs(path.phase):
        assert np.all(path.stroke[a:b] == path.stroke[a])
    assert len(path) == len(path.page_mm) == len(path.phase) == len(path.stroke)
    assert path.page_mm.shape[1] == 3


def test_settle_rows_are_the_ends_of_the_descents(path):
    ends = sorted(b - 1 for p, _, b in runs(path.phase) if p == DESCEND)
    assert sorted(path.settle) == ends
    for r in path.settle:
        assert path.phase[r] == DESCEND and path.phase[r + 1] == DRAW


def test_the_pen_presses_to_the_depth_while_drawing_and_hovers_between(path):
    drawing = three_strokes()
    depth = 1.0 / 0.3
    np.testing.assert_allclose(path.page_mm[path.phase == DRAW, 2], -depth)
    np.testing.assert_allclose(path.page_mm[path.phase == TRAVEL, 2], LoopConfig().hover_mm)
    for p, a, b in runs(path.phase):
        seg = path.page_mm[a:b]
        k = int(path.stroke[a])
        if p == DESCEND:  # straight down onto the stroke's first point, from hover height
            np.testing.assert_allclose(seg[:, :2], np.broadcast_to(drawing.strokes[k].pos[0],
                                                                   (b - a, 2)))
            assert seg[0, 2] == pytest.approx(LoopConfig().hover_mm)
            assert seg[-1, 2] == pytest.approx(-depth)
            assert b - a == ticks(LoopConfig().descend_s, DT)
        if p == DRAW:
            np.testing.assert_allclose(seg[[0, -1], :2], drawing.strokes[k].pos[[0, -1]],
                                       atol=1e-9)
        if p == LIFT:
            assert seg[0, 2] == pytest.approx(-depth) and seg[-1, 2] == pytest.approx(8.0)
            assert b - a == ticks(LoopConfig().lift_s, DT)
    assert np.all(path.page_mm[:, 2] >= -depth - 1e-12)


@pytest.mark.parametrize("distance, speed", [(100.0, 150.0), (37.0, 80.0), (150.0, 400.0)])
def test_travel_peaks_at_the_travel_speed(distance, speed):
    drawing = Drawing([line([20.0, 20.0], [30.0, 20.0]), line([30.0, 20.0 + distance],
                                                             [40.0, 20.0 + distance])])
    config = LoopConfig(travel_speed_mm_s=speed)
    pen = sequence_pen(drawing, config, 2.0, DT)
    travel = pen.page_mm[pen.phase == TRAVEL]
    amplitude = float(np.linalg.norm(travel[-1, :2] - travel[0, :2]))
    assert amplitude == pytest.approx(distance)
    duration = (len(travel) - 1) * DT
    # The move lasts whole periods: at least the nominal 1.875 A / v, at most one period more.
    nominal = 1.875 * amplitude / speed
    assert nominal <= duration + 1e-12 < nominal + DT + 1e-12
    peak = np.max(np.linalg.norm(np.diff(travel[:, :2], axis=0), axis=1)) / DT
    # Flash-Hogan: peak 1.875 A / T, sampled on the grid (a difference quotient, one period)
    assert peak == pytest.approx(1.875 * amplitude / duration, rel=2e-3)
    assert speed * nominal / (nominal + DT) * (1 - 2e-3) <= peak <= speed
    np.testing.assert_allclose(travel[:, 2], config.hover_mm)


def test_minimum_jerk_and_ticks():
    s = minimum_jerk(101)
    assert s[0] == 0.0 and s[-1] == pytest.approx(1.0) and s[50] == pytest.approx(0.5)
    assert np.all(np.diff(s) >= 0)
    assert len(minimum_jerk(1)) == 2
    assert ticks(0.3, 0.006) == 51
    assert ticks(0.0, 0.006) == 2
    assert ticks(0.301, 0.006) == 52


def test_stroke_points_cover_the_stroke_on_the_grid():
    stroke = line([20.0, 20.0], [60.0, 30.0], duration=0.5)
    pts = stroke_points(Drawing([stroke]), 0, DT)
    assert len(pts) == int(np.ceil(0.5 / DT)) + 1
    np.testing.assert_allclose(pts[0, :2], [20.0, 20.0])
    np.testing.assert_allclose(pts[-1, :2], [60.0, 30.0], atol=1e-9)
    np.testing.assert_allclose(pts[:, 2], 0.0)


def test_pen_depth_is_force_over_stiffness_within_the_travel():
    assert pen_depth_mm(LoopConfig(force_n=1.2), 0.3, 6.0) == pytest.approx(4.0)
    # the configured stiffness overrides the model's
    config = LoopConfig(force_n=1.0, pen_stiffness_n_per_mm=0.5)
    assert pen_depth_mm(config, 0.3, 6.0) == pytest.approx(2.0)
    with pytest.raises(InputError, match="compresses the pen by 16.7 mm") as info:
        pen_depth_mm(LoopConfig(force_n=5.0), 0.3, 6.0)
    assert info.value.key == "force_n"
    with pytest.raises(InputError) as info:
        pen_depth_mm(LoopConfig(), 0.0, 6.0)
    assert info.value.key == "pen_stiffness_n_per_mm"


def test_an_empty_drawing_is_refused():
    with pytest.raises(InputError, match="no strokes"):
        sequence_pen(Drawing([]), LoopConfig(), 1.0, DT)
