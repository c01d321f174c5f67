"""Charts drawn into pixels: the data-to-pixel map, round-number ticks and their labels,
limits around data, lines broken at NaN."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from inkarm.plots.raster import Panel, data_limits, nice_step, polyline, tick_label, ticks


def test_a_panel_maps_its_limits_to_its_box_corners_y_up():
    panel = Panel((10, 20, 110, 70), (0.0, 5.0, -1.0, 1.0))
    np.testing.assert_allclose(panel.pixels([0.0, 5.0, 2.5], [-1.0, 1.0, 0.0]),
                               [[10, 70], [110, 20], [60, 45]])


@pytest.mark.parametrize(("span", "count", "step"), [
    (4.97, 5, 1.0), (0.24, 5, 0.05), (1.1, 5, 0.25), (280.0, 5, 100.0), (50.0, 5, 10.0),
    (1e-3, 4, 2.5e-4),
])
def test_the_tick_step_is_the_smallest_round_step_giving_at_most_count_intervals(span, count,
                                                                                  step):
    assert nice_step(span, count) == pytest.approx(step)
    assert span / nice_step(span, count) <= count + 1e-9


def test_ticks_are_the_multiples_of_the_step_within_the_range():
    values, step = ticks(-0.012, 0.231)
    assert step == pytest.approx(0.05)
    np.testing.assert_allclose(values, [0.0, 0.05, 0.10, 0.15, 0.20])
    assert [tick_label(v, step) for v in values] == ["0.00", "0.05", "0.10", "0.15", "0.20"]
    assert [tick_label(v, 0.25) for v in (0.0, 0.75)] == ["0.00", "0.75"]
    assert [tick_label(v, 100.0) for v in (0.0, 200.0)] == ["0", "200"]
    assert tick_label(-1e-17, 0.5) == "0.0"  # never "-0.0"


def test_data_limits_pad_the_finite_range_and_survive_constants_and_nothing():
    assert data_limits([0.0, np.nan, 10.0]) == pytest.approx((-0.5, 10.5))
    assert data_limits([2.0, 2.0]) == (1.0, 3.0)
    assert data_limits([np.nan], [np.inf]) == (0.0, 1.0)


def test_a_polyline_breaks_where_a_value_is_nan():
    image = Image.new("RGB", (100, 40), (255, 255, 255))
    panel = Panel((0, 0, 99, 39), (0.0, 99.0, 0.0, 39.0))
    x = np.arange(100.0)
    y = np.where((x > 40) & (x < 60), np.nan, 20.0)
    polyline(image, panel, x, y, (0, 0, 255))
    row = np.asarray(image)[19]
    assert (row[:40] == (0, 0, 255)).all() and (row[62:] == (0, 0, 255)).all()
    assert (row[42:59] == 255).all()  # the gap
