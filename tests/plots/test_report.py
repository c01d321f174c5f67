"""The run's report: the ink panel's geometry and pixels, the time panels, the report PNG,
input errors; the matplotlib canvas plot's geometry."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas
from inkarm.ink.png import png_pixels
from inkarm.plots import save_figure
from inkarm.plots.figure import Figure
from inkarm.plots.report import (
    BLUE,
    GREEN,
    RED,
    REPORT_PX,
    canvas_figure,
    ink_panel,
    plot_canvas,
    report_image,
    time_panels,
    write_report,
)


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


def test_canvas_figure_saves_as_an_image(tmp_path):
    from matplotlib.image import imread

    run = _run()
    path = save_figure(canvas_figure(run["canvas"]), tmp_path / "canvas.png", dpi=50)
    assert imread(path).shape[1] == 300  # 6 in at 50 dpi


def _blank(size=(800, 700)):
    return Image.new("RGB", size, (255, 255, 255))


def _rgb(image, u, v):
    return tuple(int(c) for c in np.asarray(image)[round(float(v)), round(float(u))])


def test_ink_panel_puts_ink_and_plan_at_their_page_positions_at_one_scale():
    run = _run()
    plan = [run["reference_mm"][run["drawing"]]]
    image = _blank()
    panel = ink_panel(image, (80, 20, 780, 640), run["canvas"], plan, margin_mm=5.0)
    x0, x1, y0, y1 = panel.limits  # the ink (y = 50.1 mm, 0.4 mm wide) and plan, 5 mm around
    assert x0 == pytest.approx(20.0 - 0.4 - 5.0, abs=0.2) and x1 == pytest.approx(65.4, abs=0.2)
    assert y0 == pytest.approx(45.0 - 0.4, abs=0.2) and y1 == pytest.approx(55.4, abs=0.2)
    left, top, right, bottom = panel.box
    assert (right - left) / (x1 - x0) == pytest.approx((bottom - top) / (y1 - y0), rel=0.01)
    assert right - left == 700 and top >= 20 and bottom <= 640  # as wide as the region allows
    u, v = panel.pixels(30.0, 50.1)[0]
    assert _rgb(image, u, v) == (0, 0, 0)  # ink under the tip's path ...
    assert _rgb(image, u, v - 3 * (right - left) / (x1 - x0)) == (255, 255, 255)  # not 3 mm up
    assert _rgb(image, *panel.pixels(40.0, 50.0)[0]) == RED  # the plan drawn over it


def test_ink_panel_resamples_the_ink_keeping_its_mean_darkness():
    """Enlarged by Pillow's filter, the ink keeps the mean grey level of canvas.png's pixels
    under the view (to a grey level)."""
    run = _run()
    canvas = run["canvas"]
    image = _blank()
    panel = ink_panel(image, (80, 20, 780, 640), canvas, margin_mm=5.0)
    x0, x1, y0, y1 = panel.limits
    n_rows = canvas.image.shape[0]
    crop = png_pixels(canvas.image[round(n_rows - y1 * 10) : round(n_rows - y0 * 10),
                                   round(x0 * 10) : round(x1 * 10)])
    left, top, right, bottom = panel.box
    shown = np.asarray(image)[top + 1 : bottom - 1, left + 1 : right - 1, 0]
    assert shown.mean() == pytest.approx(crop.mean(), abs=1.0)


def test_the_ink_panel_does_not_depend_on_the_page_around_the_ink():
    """The same ink on a page four times as large gives the same view and the same pixels."""
    small, large = Canvas(size_mm=(100.0, 120.0)), Canvas(size_mm=(400.0, 480.0))
    for canvas, offset in ((small, 0.0), (large, 200.0)):
        for k, x in enumerate(np.linspace(20.0, 60.0, 400)):
            canvas.touch([x + offset, 50.0 + offset + 5 * np.sin(x / 5)], 1.0, 0.001 * k)
        canvas.lift()
    a, b = _blank(), _blank()
    pa = ink_panel(a, (80, 20, 780, 640), small)
    pb = ink_panel(b, (80, 20, 780, 640), large)
    assert np.allclose(np.add(pa.limits, 200.0), pb.limits) and pa.box == pb.box
    left, top, right, bottom = pa.box
    np.testing.assert_array_equal(np.asarray(a)[top:bottom, left:right],
                                  np.asarray(b)[top:bottom, left:right])


def test_the_ink_panel_of_a_blank_page_shows_the_page():
    panel = ink_panel(_blank(), (80, 20, 780, 640), Canvas(size_mm=(30.0, 40.0)))
    assert panel.limits == (0.0, 30.0, 0.0, 40.0)


def test_time_panels_share_the_time_axis_and_draw_each_series():
    run = _run()
    times, mask = run["times_s"], run["drawing"]
    image = _blank((900, 700))
    force = np.where(mask, 1.2, 0.0)
    error = np.full(times.shape, 0.1)
    panels = time_panels(image, (100, 20, 880, 640), times, [
        ("tracking error [mm]", [(error, BLUE, 2, None)]),
        ("contact force [N]", [(force, GREEN, 2, "force")]),
    ], mask)
    assert [p.limits[:2] for p in panels] == [(0.0, times[-1])] * 2
    assert panels[0].box[3] < panels[1].box[1]  # stacked, the first above
    assert _rgb(image, *panels[1].pixels(0.5, 1.2)[0]) == GREEN  # while drawing: 1.2 N
    assert _rgb(image, *panels[1].pixels(1.5, 0.0)[0]) == GREEN  # after: 0 N
    assert _rgb(image, *panels[0].pixels(1.5, 0.1)[0]) == BLUE
    assert _rgb(image, *panels[1].pixels(0.55, 0.7)[0]) == (230, 230, 230)  # shaded: drawing
    assert _rgb(image, *panels[1].pixels(1.55, 0.7)[0]) == (255, 255, 255)  # not drawing


def test_write_report_saves_the_report_png(tmp_path):
    path = write_report(tmp_path / "report.png", metrics={"tracking_rms_mm": 0.1}, **_run())
    assert path == tmp_path / "report.png"
    with Image.open(path) as png:
        assert png.format == "PNG" and png.size == REPORT_PX == (1650, 975)
        assert np.asarray(png.convert("L")).std() > 10  # not a blank image


def test_report_image_of_a_backend_that_senses_no_force():
    """A plotter's run: force NaN throughout, metrics undefined; the force panel stays empty."""
    run = {**_run(), "force_n": np.full(1000, np.nan)}
    image = report_image(metrics={"tracking_rms_mm": 0.1, "contact_force_mean_n": np.nan},
                         title="run", **run)
    assert image.size == REPORT_PX and image.mode == "RGB"
    assert not (np.asarray(image) == GREEN).all(axis=2).any()


def test_report_image_names_the_mismatched_input(tmp_path):
    run = _run()
    run["force_n"] = run["force_n"][:-1]
    with pytest.raises(
        InputError, match=r"report_image: force_n has 999 samples, times_s has 1000"
    ):
        write_report(tmp_path / "r.png", **run)
    assert not (tmp_path / "r.png").exists()
    run = _run()
    with pytest.raises(InputError, match=r"report_image: need at least 2 samples, got 1"):
        report_image(**{k: (v[:1] if k != "canvas" else v) for k, v in run.items()})
