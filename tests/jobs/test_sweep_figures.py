"""The figures of sweeps and regressions show the numbers they are given: means over repeated
points (failed runs left out), heat-map cells, the ensemble's ink share, and the colours of
missing and extra ink."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import PathCollection, QuadMesh

from inkarm.plots.regress import (
    EXTRA_RGB,
    MISSING_RGB,
    difference_rgb,
    ink_crop,
    plot_ink_comparison,
)
from inkarm.plots.sweep import plot_ink_overlay, plot_metric_heatmap, plot_metric_lines


def test_lines_are_the_means_over_runs_at_each_value_without_failed_runs():
    fig = plot_metric_lines([1.0, 1.0, 2.0, 2.0, 3.0], [1.0, 3.0, None, 5.0, 7.0], xlabel="k")
    line = fig.axes[0].lines[0]
    assert list(line.get_xdata()) == [1.0, 2.0, 3.0]
    assert list(line.get_ydata()) == [2.0, 5.0, 7.0]
    assert fig.axes[0].get_xlabel() == "k"


def test_lines_grouped_by_a_second_parameter_and_text_values_as_categories():
    fig = plot_metric_lines(["marker", "brush", "marker", "brush"], [1.0, 2.0, 3.0, 4.0],
                            group=[0.5, 0.5, 1.0 / 3, 1.0 / 3], group_label="f")
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["brush", "marker"]
    assert sorted(t.get_text() for t in ax.get_legend().get_texts()) == ["f = 0.3333", "f = 0.5"]
    by_label = {line.get_label(): list(line.get_ydata()) for line in ax.lines}
    assert by_label["f = 0.5"] == [2.0, 1.0]


def test_a_heat_map_holds_the_mean_of_each_cell():
    x = [1, 1, 2, 2, 1]
    y = [10, 20, 10, 20, 10]
    z = [1.0, 2.0, 3.0, 4.0, 5.0]
    fig = plot_metric_heatmap(x, y, z, zlabel="m")
    mesh = next(c for c in fig.axes[0].collections if isinstance(c, QuadMesh))
    assert np.allclose(np.asarray(mesh.get_array()).reshape(2, 2), [[3.0, 3.0], [2.0, 4.0]])


def test_points_that_do_not_fill_a_grid_are_dots():
    fig = plot_metric_heatmap([0.1, 0.7, 0.4], [3.0, 1.0, 2.0], [1.0, 2.0, None])
    dots = next(c for c in fig.axes[0].collections if isinstance(c, PathCollection))
    assert len(dots.get_offsets()) == 3


def test_the_ink_overlay_is_the_share_of_runs_with_ink():
    ink = np.zeros((2, 2), np.uint8)
    fig = plot_ink_overlay([((10, 12, 20, 22), ink), ((11, 13, 20, 22), ink)], page_rows=100,
                           px_per_mm=2.0)
    share = np.asarray(fig.axes[0].images[0].get_array())
    assert np.allclose(share, [[0.5, 0.5], [1.0, 1.0], [0.5, 0.5]])
    left, right, bottom, top = fig.axes[0].images[0].get_extent()
    assert (left, right, bottom, top) == (10.0, 11.0, (100 - 13) / 2.0, (100 - 10) / 2.0)


def test_the_difference_image_colours_missing_and_extra_ink():
    base = np.full((3, 3), 255, np.uint8)
    new = base.copy()
    base[0, 0] = new[0, 0] = 0  # both
    base[1, 1] = 0  # missing now
    new[2, 2] = 0  # extra now
    rgb = difference_rgb(base, new)
    assert tuple(rgb[0, 0]) == (0.0, 0.0, 0.0)
    assert tuple(rgb[1, 1]) == MISSING_RGB and tuple(rgb[2, 2]) == EXTRA_RGB
    assert tuple(rgb[0, 2]) == (1.0, 1.0, 1.0)
    assert ink_crop(base, new, px_per_mm=1.0, margin_mm=0.0) == (0, 3, 0, 3)
    fig = plot_ink_comparison(base, new, 1.0, title="t")
    assert [ax.get_title() for ax in fig.axes] == ["baseline", "new",
                                                  "difference: red missing, blue extra"]
