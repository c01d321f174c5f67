"""Report figures: the canvas plot's geometry, the report PNG, input errors."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas
from inkarm.plots import save_figure
from inkarm.plots.figure import Figure
from inkarm.plots.report import canvas_figure, plot_canvas, report_figure, write_report


def _run():
    """A 2 s run: a 40 mm stroke at 40 mm/s with 0.1 mm tracking error, then pen-up travel."""
    times = np.arange(0.0, 2.0, 0.002)
    x = 20.0 + 40.0 * np.clip(times, 0.0, 1.0)
    reference = np.column_stack([x, np.full_like(x, 50.0)])
    tip = reference + [0.0, 0.1]
    drawing = times < 1.0
    force = np.where(drawing, 1.2, 0.0)
    canvas = Canvas(size_mm=(100.0, 120.0))
    for k in np.flatnonzero(drawing):
        canvas.touch(tip[k], force[k], times[k])
    canvas.lift()
    return {
        "canvas": canvas,
        "times_s": times,
        "reference_mm": reference,
        "tip_mm": tip,
        "force_n": force,
        "drawing": drawing,
    }


def test_plot_canvas_places_the_page_in_millimetres_and_zooms_on_ink_and_plan():
    run = _run()
    plan = [run["reference_mm"][run["drawing"]]]
    fig = plot_canvas(run["canvas"], plan_strokes=plan, margin_mm=5.0)
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 == pytest.approx(20.0 - 0.4 - 5.0, abs=0.2) and x1 == pytest.approx(65.4, abs=0.2)
    assert y0 == pytest.approx(45.0 - 0.4, abs=0.2) and y1 == pytest.approx(55.4, abs=0.2)
    assert np.allclose(ax.lines[0].get_xydata(), plan[0])
    # only the pixels under the view, two more on each side, are drawn, in page [mm]
    left, right, bottom, top = ax.images[0].get_extent()
    assert left <= x0 and right >= x1 and bottom <= y0 and top >= y1
    assert x0 - left <= 0.31 and right - x1 <= 0.31 and y0 - bottom <= 0.31 and top - y1 <= 0.31
    c0, c1, r0 = round(left * 10), round(right * 10), round(1200 - top * 10)
    r1 = round(1200 - bottom * 10)
    shown = ax.images[0].get_array()
    assert shown.shape == (r1 - r0, c1 - c0) and shown.size < 0.05 * 1000 * 1200
    np.testing.assert_array_equal(shown, run["canvas"].image[r0:r1, c0:c1])
    whole = plot_canvas(run["canvas"], zoom=False).axes[0]
    assert whole.get_xlim() == (0.0, 100.0) and whole.get_ylim() == (0.0, 120.0)
    assert whole.images[0].get_extent() == [0.0, 100.0, 0.0, 120.0]


def test_plot_canvas_block_averages_a_view_larger_than_max_image_px():
    run = _run()
    canvas = run["canvas"]
    ax = plot_canvas(canvas, zoom=False, max_image_px=300).axes[0]
    shown = ax.images[0].get_array()
    assert shown.shape == (300, 250)  # 1200 x 1000 pixels in 4 x 4 blocks
    assert ax.images[0].get_extent() == [0.0, 100.0, 0.0, 120.0]
    blocks = np.asarray(canvas.image, float).reshape(300, 4, 250, 4).mean(axis=(1, 3))
    np.testing.assert_allclose(shown, blocks, atol=1e-6)
    ax = plot_canvas(canvas, zoom=False, max_image_px=350).axes[0]  # 1200 / 350: blocks of 4
    assert ax.images[0].get_array().shape == (300, 250)
    ax = plot_canvas(canvas, zoom=False, max_image_px=700).axes[0]  # 1000 / 2 not within
    assert ax.images[0].get_array().shape == (600, 500)


def test_the_zoom_box_does_not_depend_on_the_page_around_the_ink():
    """The same ink on a page four times as large gives the same view and the same pixels."""
    small, large = Canvas(size_mm=(100.0, 120.0)), Canvas(size_mm=(400.0, 480.0))
    for canvas, offset in ((small, 0.0), (large, 200.0)):
        for k, x in enumerate(np.linspace(20.0, 60.0, 400)):
            canvas.touch([x + offset, 50.0 + offset + 5 * np.sin(x / 5)], 1.0, 0.001 * k)
        canvas.lift()
    a = plot_canvas(small).axes[0]
    b = plot_canvas(large).axes[0]
    assert np.allclose(np.add(a.get_xlim(), 200.0), b.get_xlim())
    assert np.allclose(np.add(a.get_ylim(), 200.0), b.get_ylim())
    np.testing.assert_array_equal(a.images[0].get_array(), b.images[0].get_array())


def test_plot_canvas_of_a_blank_page_shows_the_page():
    ax = plot_canvas(Canvas(size_mm=(30.0, 40.0))).axes[0]
    assert ax.get_xlim() == (0.0, 30.0) and ax.get_ylim() == (0.0, 40.0)


def test_plot_canvas_draws_on_the_given_axes():
    fig = Figure()
    left, right = fig.subplots(1, 2)
    assert plot_canvas(Canvas(size_mm=(30.0, 40.0)), right) is fig
    assert right.images and not left.images


def test_report_figure_has_the_four_panels():
    fig = report_figure(metrics={"tracking_rms_mm": 0.1}, title="run", **_run())
    assert isinstance(fig, Figure) and len(fig.axes) == 4
    assert "tracking_rms_mm = 0.1" in fig.get_suptitle()


def test_write_report_saves_the_report_png(tmp_path):
    from matplotlib.image import imread

    path = write_report(tmp_path / "report.png", metrics={"tracking_rms_mm": 0.1}, **_run())
    assert path == tmp_path / "report.png"
    pixels = imread(path)
    assert pixels.shape[:2] == (975, 1650)  # 11 x 6.5 in at 150 dpi
    assert pixels[..., :3].std() > 0.05  # not a blank image


def test_report_figure_draws_on_a_given_figure():
    fig = Figure(figsize=(8, 5))
    assert report_figure(fig=fig, **_run()) is fig and len(fig.axes) == 4


def test_canvas_figure_saves_as_an_image(tmp_path):
    from matplotlib.image import imread

    run = _run()
    path = save_figure(canvas_figure(run["canvas"]), tmp_path / "canvas.png", dpi=50)
    assert imread(path).shape[1] == 300  # 6 in at 50 dpi


def test_report_figure_names_the_mismatched_input(tmp_path):
    run = _run()
    run["force_n"] = run["force_n"][:-1]
    with pytest.raises(
        InputError, match=r"report_figure: force_n has 999 samples, times_s has 1000"
    ):
        write_report(tmp_path / "r.png", **run)
    assert not (tmp_path / "r.png").exists()
    run = _run()
    with pytest.raises(InputError, match=r"report_figure: need at least 2 samples, got 1"):
        report_figure(**{k: (v[:1] if k != "canvas" else v) for k, v in run.items()})
