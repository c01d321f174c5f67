"""Canvas: pixel convention, capsule rasterisation, ink models, compositing, errors."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.budget import BudgetError
from inkarm.errors import InputError
from inkarm.ink import canvas as canvas_module
from inkarm.ink import capsules as capsules_module
from inkarm.ink import png as png_module
from inkarm.ink.canvas import (
    RASTER_BYTES_PER_PX,
    BrushInk,
    Canvas,
    MarkerInk,
    PencilInk,
    make_ink,
    raster_bytes,
    require_raster_memory,
)


def _draw(canvas: Canvas, points, force: float = 1.0, dt: float = 0.001, t0: float = 0.0) -> None:
    for k, p in enumerate(np.asarray(points, float)):
        canvas.touch(p, force, t0 + k * dt)
    canvas.lift()


def _line(p0, p1, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(p0, float) + s * (np.subtract(p1, p0))


def test_shape_and_pixel_centres_follow_the_page_convention():
    canvas = Canvas(size_mm=(30.0, 20.0), px_per_mm=10.0)
    assert canvas.shape == (200, 300) == canvas.image.shape
    centres = canvas.pixel_centres_mm(np.array([0, 199]), np.array([0, 299]))
    assert np.allclose(centres, [[0.05, 19.95], [29.95, 0.05]])


def test_a_dot_high_on_the_page_lands_in_the_top_rows_at_its_position():
    canvas = Canvas(size_mm=(30.0, 20.0), ink=MarkerInk(w0_mm=1.0, k_mm=0.0))
    _draw(canvas, [[7.0, 16.0]])
    rows, _ = np.nonzero(canvas.image > 0.5)
    assert rows.max() < 100  # upper half of the raster is the upper half of the page
    assert np.allclose(canvas.ink_points_mm().mean(axis=0), [7.0, 16.0], atol=0.02)


@pytest.mark.parametrize(("force", "threshold"), [(0.0, 0.0), (0.5, 0.0), (3.0, 0.0),
                                                  (0.1, 0.1), (0.5, 0.1), (3.0, 0.1)])
def test_marker_line_width_matches_the_force_law(force, threshold):
    ink = MarkerInk(w0_mm=0.4, k_mm=0.8, f0_n=1.0, threshold_n=threshold)
    canvas = Canvas(size_mm=(40.0, 20.0), ink=ink)
    _draw(canvas, _line([5.0, 10.03], [35.0, 10.03], 300), force=force)
    expected = 0.4 + 0.8 * (1.0 - math.exp(-(force - threshold)))
    # integrated darkness across the line (away from its round caps) is its width in [mm]
    width = canvas.image[:, 100:300].sum(axis=0) / canvas.px_per_mm
    assert np.allclose(width, expected, atol=0.05)


def test_fast_stroke_is_continuous_not_dotted():
    canvas = Canvas(size_mm=(60.0, 20.0), ink=MarkerInk(w0_mm=0.5, k_mm=0.0))
    _draw(canvas, _line([5.0, 10.0], [55.0, 10.0], 11), dt=0.001)  # 5 mm per step: 5 m/s
    row = canvas.image[100]  # y = 10 mm sits on the boundary of rows 99 and 100
    inside = row[int(5.0 * 10) : int(55.0 * 10)]
    assert inside.min() > 0.99


def test_short_stroke_within_one_segment_is_flushed_on_lift():
    canvas = Canvas(size_mm=(20.0, 20.0), max_segment_mm=5.0, ink=MarkerInk(w0_mm=0.5, k_mm=0.0))
    _draw(canvas, _line([5.0, 10.0], [8.0, 10.0], 30))
    xs = canvas.ink_points_mm()[:, 0]
    assert xs.min() == pytest.approx(5.0 - 0.25, abs=0.1)
    assert xs.max() == pytest.approx(8.0 + 0.25, abs=0.1)


def test_chord_between_rasterised_points_stays_on_a_circle():
    canvas = Canvas(size_mm=(40.0, 40.0), ink=MarkerInk(w0_mm=0.3, k_mm=0.0))
    th = np.linspace(0.0, 2.0 * np.pi, 4000)
    _draw(canvas, np.column_stack([20 + 10 * np.cos(th), 20 + 10 * np.sin(th)]))
    radius = np.linalg.norm(canvas.ink_points_mm() - 20.0, axis=1)
    assert np.all(np.abs(radius - 10.0) < 0.15 + 0.05)  # half width + half a pixel


def test_strokes_composite_as_transmittance_product_and_a_stroke_never_over_darkens_itself():
    ink = MarkerInk(w0_mm=1.0, k_mm=0.0, opacity=0.5)
    canvas = Canvas(size_mm=(20.0, 20.0), ink=ink)
    # one stroke that goes back and forth over itself
    _draw(canvas, np.concatenate([_line([2, 10], [18, 10], 50), _line([18, 10], [2, 10], 50)]))
    assert canvas.image.max() == pytest.approx(0.5, abs=1e-6)
    _draw(canvas, _line([10, 2], [10, 18], 50), t0=1.0)  # a second stroke crossing it
    assert canvas.image.max() == pytest.approx(1.0 - 0.5 * 0.5, abs=1e-6)
    assert canvas.n_strokes == 2


def test_pencil_darkness_grows_with_force_and_saturates():
    ink = PencilInk(width_mm=0.6, max_opacity=0.8, f0_n=1.0, texture=False)
    peaks = []
    for force in (0.2, 1.0, 10.0):
        canvas = Canvas(size_mm=(20.0, 10.0), ink=ink)
        _draw(canvas, _line([2, 5], [18, 5], 100), force=force)
        peaks.append(canvas.image.max())
    assert np.allclose(peaks, [0.8 * (1 - math.exp(-f)) for f in (0.2, 1.0, 10.0)], atol=1e-5)


def test_brush_width_is_an_inverse_power_of_speed_within_its_bounds():
    ink = BrushInk(w_ref_mm=2.0, v_ref_mm_s=50.0, gamma=1.0, w_min_mm=0.5, w_max_mm=3.0)
    assert ink.mark(1.0, 50.0)[0] == pytest.approx(2.0)
    assert ink.mark(1.0, 100.0)[0] == pytest.approx(1.0)
    assert ink.mark(1.0, 1000.0)[0] == pytest.approx(0.5)
    assert ink.mark(1.0, 0.0)[0] == pytest.approx(3.0)
    assert BrushInk(gamma=0.5).mark(0.0, 200.0)[0] == pytest.approx(1.5 * 0.5)


def test_brush_draws_a_slow_stroke_wider_than_a_fast_one():
    widths = []
    for speed in (25.0, 100.0):  # mm/s, constant along the stroke
        canvas = Canvas(size_mm=(40.0, 20.0), ink=BrushInk(opacity=1.0))
        n = int(30.0 / speed / 0.001)
        _draw(canvas, _line([5.0, 10.03], [35.0, 10.03], n + 1))
        widths.append(np.median(canvas.image[:, 150:250].sum(axis=0)) / 10.0)
    assert widths[0] == pytest.approx(3.0, abs=0.1)  # 1.5 mm * 50 / 25
    assert widths[1] == pytest.approx(0.75, abs=0.1)  # 1.5 mm * 50 / 100


def test_single_touch_leaves_a_dot_and_lift_without_touch_is_harmless():
    canvas = Canvas(size_mm=(10.0, 10.0))
    canvas.lift()
    assert canvas.image.max() == 0.0 and canvas.n_strokes == 0
    canvas.touch(np.array([5.0, 5.0]), 1.0, 0.0)
    assert canvas.in_contact
    canvas.lift()
    assert not canvas.in_contact and canvas.image.max() == pytest.approx(1.0)


def test_ink_off_the_page_is_clipped():
    canvas = Canvas(size_mm=(10.0, 10.0))
    _draw(canvas, _line([-5.0, 5.0], [15.0, 5.0], 50))
    _draw(canvas, [[50.0, 50.0], [60.0, 60.0]], t0=1.0)
    ink = canvas.ink_points_mm()
    assert ink[:, 0].min() < 0.1 and ink[:, 0].max() > 9.9
    assert canvas.image.shape == (100, 100)


def test_dirty_box_reports_the_changed_pixels_once_and_clear_blanks():
    canvas = Canvas(size_mm=(20.0, 20.0))
    assert canvas.take_dirty_box() is None
    _draw(canvas, [[5.0, 15.0], [6.0, 15.0]])
    r0, r1, c0, c1 = canvas.take_dirty_box()
    rows, cols = np.nonzero(canvas.image)
    assert r0 <= rows.min() and rows.max() < r1 and c0 <= cols.min() and cols.max() < c1
    assert canvas.take_dirty_box() is None
    revision, inked = canvas.revision, canvas.inked_box
    canvas.clear()
    assert canvas.image.max() == 0.0 and canvas.revision > revision
    assert canvas.take_dirty_box() == inked  # (clear writes the inked box only)


@pytest.mark.parametrize("ink", ["marker", "pencil", "brush"])
def test_clear_blanks_every_raster_mid_stroke_too(ink):
    """What clear leaves is a fresh page: no pixel of the image or of the stroke in progress
    (its capsules rasterised or still queued) is left, though only the inked box is written."""
    canvas = Canvas(size_mm=(30.0, 30.0), ink=ink)
    _draw(canvas, [[5.0, 25.0], [20.0, 6.0], [25.0, 25.0]])
    t = 10.0
    for x in np.linspace(3.0, 27.0, 400):  # a stroke left in progress
        canvas.touch((x, 3.0 + 0.8 * x), 1.0, t)
        t += 0.001
    assert canvas.image.any() and canvas._base is not None  # (composited mid-stroke)
    canvas.clear()
    assert not canvas._stroke.any() and not canvas._image.any() and not canvas.in_contact
    assert canvas.inked_box is None and canvas.n_strokes == 0
    _draw(canvas, [[5.0, 5.0], [9.0, 9.0]])
    fresh = Canvas(size_mm=(30.0, 30.0), ink=ink)
    _draw(fresh, [[5.0, 5.0], [9.0, 9.0]])
    assert canvas.image.tobytes() == fresh.image.tobytes()


def test_image_is_a_read_only_view():
    canvas = Canvas(size_mm=(10.0, 10.0))
    with pytest.raises(ValueError):
        canvas.image[0, 0] = 1.0


def test_to_png_writes_black_ink_on_white(tmp_path):
    from matplotlib.image import imread

    canvas = Canvas(size_mm=(20.0, 10.0))
    _draw(canvas, _line([2.0, 5.0], [18.0, 5.0], 50))
    pixels = imread(canvas.to_png(tmp_path / "page.png"))
    assert pixels.shape == (100, 200)  # 8-bit greyscale: one channel
    assert pixels[50, 100] < 0.05 and pixels[5, 5] > 0.95


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.tuples(st.floats(1.0, 19.0), st.floats(1.0, 19.0)), min_size=2, max_size=8),
    st.floats(0.0, 5.0),
    st.sampled_from(["marker", "brush", "pencil"]),
)
def test_ink_stays_in_unit_range_and_near_the_path(vertices, force, ink_name):
    canvas = Canvas(size_mm=(20.0, 20.0), px_per_mm=5.0, ink=ink_name)
    path = np.concatenate([_line(a, b, 20) for a, b in itertools.pairwise(vertices)])
    _draw(canvas, path, force=force)
    image = canvas.image
    assert image.min() >= 0.0 and image.max() <= 1.0 + 1e-6
    ink = canvas.ink_points_mm(threshold=1e-3)
    dense = np.concatenate([_line(a, b, 400) for a, b in itertools.pairwise(vertices)])
    nearest = np.min(np.linalg.norm(ink[:, None, :] - dense[None, ::4, :], axis=2), axis=1)
    widest = {"marker": 0.8, "brush": 4.0, "pencil": PencilInk().line_width_mm}[ink_name]
    blur = 1.0 if ink_name == "pencil" else 0.0  # the texture's 3x3 blur reaches a pixel out
    assert np.all(nearest <= widest / 2 + (1.5 + blur) / canvas.px_per_mm + 0.05)


def _capsule_one_at_a_time(shape, ppm, x0, y0, w0, x1, y1, w1, opacity) -> np.ndarray:
    """Reference rasteriser: the coverage of one capsule on its own (float32, as the canvas),
    from the formula of Canvas._rasterise_queue with np.arange pixel offsets."""
    n_rows, n_cols = shape
    u0, u1 = x0 * ppm - 0.5, x1 * ppm - 0.5
    v0, v1 = n_rows - y0 * ppm - 0.5, n_rows - y1 * ppm - 0.5
    rad0, rad1 = 0.5 * w0 * ppm, 0.5 * w1 * ppm
    reach = max(rad0, rad1) + 1.0
    c0, c1 = (
        max(0, math.floor(min(u0, u1) - reach)),
        min(n_cols, math.ceil(max(u0, u1) + reach) + 1),
    )
    r0, r1 = (
        max(0, math.floor(min(v0, v1) - reach)),
        min(n_rows, math.ceil(max(v0, v1) + reach) + 1),
    )
    out = np.zeros(shape, np.float32)
    if c0 >= c1 or r0 >= r1:
        return out
    pu = np.arange(c0 - u0, c1 - u0, dtype=np.float32)[None, : c1 - c0]
    pv = np.arange(r0 - v0, r1 - v0, dtype=np.float32)[: r1 - r0, None]
    du, dv = u1 - u0, v1 - v0
    length2 = du * du + dv * dv
    if length2 > 1e-12:
        s = np.clip(pu * np.float32(du / length2) + pv * np.float32(dv / length2), 0.0, 1.0)
        ex, ey = pu - s * np.float32(du), pv - s * np.float32(dv)
        cov = s * np.float32(rad1 - rad0) + np.float32(rad0 + 0.5) - np.sqrt(ex * ex + ey * ey)
    else:
        cov = np.float32(max(rad0, rad1) + 0.5) - np.sqrt(pu * pu + pv * pv)
    out[r0:r1, c0:c1] = np.clip(cov, 0.0, 1.0) * np.float32(opacity)
    return out


capsules = st.lists(
    st.tuples(
        st.floats(-1.0, 21.0),
        st.floats(-1.0, 16.0),
        st.floats(0.05, 3.0),
        st.floats(-1.0, 21.0),
        st.floats(-1.0, 16.0),
        st.floats(0.05, 3.0),
        st.floats(0.05, 1.0),
        st.booleans(),
    ),
    min_size=1,
    max_size=150,
)


@settings(max_examples=25, deadline=None)
@given(capsules)
def test_batched_capsules_give_the_pixels_of_one_at_a_time(caps):
    canvas = Canvas(size_mm=(20.0, 15.0), px_per_mm=7.0)
    expected = np.zeros(canvas.shape, np.float32)
    for x0, y0, w0, x1, y1, w1, opacity, dot in caps:
        if dot:  # a pen at rest, with a width that may have changed
            x1, y1 = x0, y0
        canvas._stamp(x0, y0, w0, x1, y1, w1, opacity)
        one = _capsule_one_at_a_time(canvas.shape, 7.0, x0, y0, w0, x1, y1, w1, opacity)
        np.maximum(expected, one, out=expected)
    blank = np.zeros(canvas.shape, np.float32)  # composited over an empty page
    np.testing.assert_array_equal(canvas.image, 1.0 - (1.0 - blank) * (1.0 - expected))


def test_queued_capsules_are_counted_by_every_reader():
    canvas = Canvas(size_mm=(20.0, 20.0), px_per_mm=10.0)
    revision = canvas.revision
    for k, x in enumerate(np.linspace(5.0, 8.0, 30)):  # fewer capsules than a batch
        canvas.touch([x, 10.0], 1.0, 0.001 * k)
    assert canvas.revision > revision
    r0, r1, c0, c1 = canvas.take_dirty_box()
    rows, cols = np.nonzero(canvas.image)
    assert len(rows) > 0 and canvas.in_contact
    assert r0 <= rows.min() and rows.max() < r1 and c0 <= cols.min() and cols.max() < c1
    canvas.clear()  # drops what is still queued
    canvas.touch([12.0, 10.0], 1.0, 1.0)
    canvas.lift()
    assert np.nonzero(canvas.image)[1].min() > 100  # nothing left of the cleared stroke


def test_make_ink_by_name_and_its_errors():
    assert make_ink("pencil", width_mm=0.2) == PencilInk(width_mm=0.2)
    with pytest.raises(
        InputError, match=r"ink model 'crayon': expected one of \['brush', 'marker', 'pencil'\]"
    ):
        make_ink("crayon")
    with pytest.raises(
        InputError, match=r"ink model 'marker': .*unexpected keyword argument 'width'"
    ):
        make_ink("marker", width=1.0)


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (
            lambda: MarkerInk(w0_mm=0.0),
            r"w0_mm: MarkerInk expects a width \[mm\] in \[0.01, 25\], got 0.0",
        ),
        (
            lambda: MarkerInk(k_mm=-1.0),
            r"k_mm: MarkerInk expects an extra width \[mm\] in \[0, 25\], got -1.0",
        ),
        (
            lambda: MarkerInk(opacity=1.5),
            r"opacity: MarkerInk expects an opacity in \(0, 1\], got 1.5",
        ),
        (
            lambda: BrushInk(w_min_mm=5.0, w_max_mm=2.0),
            r"^w_min_mm: BrushInk expects w_min_mm <= w_max_mm = 2.0, got 5.0$",
        ),
        (
            lambda: BrushInk(gamma=float("nan")),
            r"gamma: BrushInk expects an exponent of the speed in \[0.01, 10\], got nan",
        ),
        (
            lambda: PencilInk(max_opacity=0.0),
            r"max_opacity: PencilInk expects an opacity in \(0, 1\]",
        ),
        (
            lambda: Canvas(size_mm=(0.0, 10.0)),
            r"Canvas.width_mm: expected a positive finite number, got 0.0",
        ),
        (
            lambda: Canvas(px_per_mm=-1.0),
            r"Canvas.px_per_mm: expected a positive finite number, got -1.0",
        ),
        (
            lambda: Canvas(size_mm=(0.01, 0.01), px_per_mm=1.0),
            r"Canvas: size_mm \(0.01, 0.01\) at 1.0 px/mm has no pixels",
        ),
        (
            lambda: Canvas(px_per_mm=float("inf")),
            r"Canvas.px_per_mm: expected a positive finite number, got inf",
        ),
        (
            lambda: Canvas(size_mm=(1e300, 1e300)),
            r"px_per_mm: Canvas: a raster of 1e\+300 x 1e\+300 mm at 10 px/mm has 1e\+301 x",
        ),
        (lambda: Canvas(ink="ballpoint"), r"ink model 'ballpoint'"),
    ],
)
def test_bad_parameters_are_rejected_with_the_field_named(build, message):
    with pytest.raises(InputError, match=message):
        build()


def test_touch_rejects_bad_force_position_and_time_travel():
    canvas = Canvas(size_mm=(10.0, 10.0))
    with pytest.raises(
        InputError, match=r"Canvas.touch: force_n must be finite and >= 0, got -1.0"
    ):
        canvas.touch([5.0, 5.0], -1.0, 0.0)
    with pytest.raises(InputError, match=r"Canvas.touch: force_n must be finite and >= 0, got nan"):
        canvas.touch([5.0, 5.0], float("nan"), 0.0)
    with pytest.raises(InputError, match=r"Canvas.touch: non-finite p_mm \(nan, 5.0\) or t = 0.0"):
        canvas.touch([float("nan"), 5.0], 1.0, 0.0)
    canvas.touch([5.0, 5.0], 1.0, 1.0)
    with pytest.raises(
        InputError, match=r"Canvas.touch: time went backwards, t = 0.5 < previous 1.0"
    ):
        canvas.touch([5.0, 5.0], 1.0, 0.5)


def _imsave_grey(path, image) -> np.ndarray:
    """The grey levels imsave(cmap="gray_r", vmin=0, vmax=1) writes: R of an opaque RGBA image
    with R = G = B."""
    from matplotlib.image import imsave
    from PIL import Image

    imsave(path, image, cmap="gray_r", vmin=0.0, vmax=1.0)
    rgba = np.asarray(Image.open(path))
    assert rgba.shape[-1] == 4 and np.all(rgba[..., 3] == 255)
    assert np.array_equal(rgba[..., 0], rgba[..., 1]) and np.array_equal(rgba[..., 0], rgba[..., 2])
    return rgba[..., 0]


@pytest.mark.parametrize("chunk_rows", [256, 7])
def test_png_pixels_are_the_grey_levels_matplotlib_imsave_wrote(tmp_path, monkeypatch, chunk_rows):
    """to_png writes, as 8-bit greyscale, the grey levels of imsave(cmap="gray_r", vmin=0,
    vmax=1) (its R = G = B), however many rows png_pixels converts at a time."""
    from matplotlib.image import imread
    from PIL import Image

    from inkarm.ink.canvas import png_pixels

    monkeypatch.setattr(png_module, "_PNG_ROWS", chunk_rows)
    edges = np.arange(257) / 256.0  # every bin edge, and just either side of it
    values = np.concatenate(
        [np.linspace(0.0, 1.0, 4097), edges, np.nextafter(edges, 2.0), np.nextafter(edges, -1.0)]
    )
    values = np.clip(values, 0.0, 1.0)
    image = np.concatenate([values, np.zeros(-len(values) % 64)]).reshape(-1, 64)
    np.testing.assert_array_equal(png_pixels(image), _imsave_grey(tmp_path / "mpl.png", image))
    image32 = image.astype(np.float32)
    np.testing.assert_array_equal(png_pixels(image32), _imsave_grey(tmp_path / "m32.png", image32))
    outside = np.array([[-0.5, 0.0, 1.0, 1.5, np.nan]])  # clipped; NaN is blank
    np.testing.assert_array_equal(png_pixels(outside), [[255, 255, 0, 0, 255]])

    canvas = Canvas(size_mm=(20.0, 10.0), px_per_mm=5.0, ink="brush")
    _draw(canvas, _line([2.0, 2.0], [18.0, 8.0], 80), force=0.7)
    expected = _imsave_grey(tmp_path / "page_mpl.png", canvas.image)
    ours = canvas.to_png(tmp_path / "page.png")
    with Image.open(ours) as png:
        assert png.mode == "L"
        written = np.asarray(png)
    assert written.dtype == np.uint8 and written.shape == (50, 100)
    np.testing.assert_array_equal(written, expected)
    np.testing.assert_array_equal(imread(ours), imread(tmp_path / "page_mpl.png")[..., 0])
    assert len(np.unique(written)) > 10  # grey levels, not just black and white


def test_to_png_of_a_blank_a_cleared_and_an_edge_inked_page(tmp_path):
    from PIL import Image

    from inkarm.ink.canvas import png_pixels

    canvas = Canvas(size_mm=(20.0, 10.0))
    assert np.all(np.asarray(Image.open(canvas.to_png(tmp_path / "blank.png"))) == 255)
    _draw(canvas, _line([-2.0, 5.0], [22.0, 9.0], 50))
    _draw(canvas, [[0.0, 0.0]], t0=1.0)
    written = np.asarray(Image.open(canvas.to_png(tmp_path / "edges.png")))
    np.testing.assert_array_equal(written, png_pixels(canvas.image))
    assert written.min() == 0
    canvas.clear()
    _draw(canvas, [[15.0, 2.0]], t0=2.0)
    written = np.asarray(Image.open(canvas.to_png(tmp_path / "cleared.png")))
    np.testing.assert_array_equal(written, png_pixels(canvas.image))
    assert written[:, :100].min() == 255 and written.min() == 0


def test_png_pixels_wants_a_2d_image():
    from inkarm.ink.canvas import png_pixels

    with pytest.raises(InputError, match=r"png_pixels: expected a 2-D darkness image"):
        png_pixels(np.zeros((2, 3, 4)))


def test_wide_capsules_are_rasterised_in_smaller_batches_with_the_same_pixels(monkeypatch):
    """Past _QUEUE_PIXELS padded pixels a batch is split: the pixels do not change."""
    monkeypatch.setattr(canvas_module, "_QUEUE_PIXELS", 2000)
    rng = np.random.default_rng(3)
    canvas = Canvas(size_mm=(20.0, 15.0), px_per_mm=7.0)
    expected = np.zeros(canvas.shape, np.float32)
    batches = []
    original = capsules_module._max_into

    def spy(flat, n_cols, *fields):
        r0, r1, c0, c1 = fields[-4:]
        batches.append((len(r0), len(r0) * int((r1 - r0).max()) * int((c1 - c0).max())))
        original(flat, n_cols, *fields)

    monkeypatch.setattr(capsules_module, "_max_into", spy)
    for _ in range(40):
        x0, x1 = rng.uniform(0.0, 20.0, 2)
        y0, y1 = rng.uniform(0.0, 15.0, 2)
        w0, w1 = rng.uniform(0.1, 3.0, 2)
        opacity = rng.uniform(0.1, 1.0)
        canvas._stamp(x0, y0, w0, x1, y1, w1, opacity)
        one = _capsule_one_at_a_time(canvas.shape, 7.0, x0, y0, w0, x1, y1, w1, opacity)
        np.maximum(expected, one, out=expected)
    blank = np.zeros(canvas.shape, np.float32)  # composited over an empty page
    np.testing.assert_array_equal(canvas.image, 1.0 - (1.0 - blank) * (1.0 - expected))
    sizes = [n for n, _ in batches]
    assert max(sizes) < 40 and sum(sizes) == 40  # split, and every capsule drawn once
    assert all(p <= 2000 for n, p in batches if n > 1)  # (one capsule alone may be larger)


def test_raster_budget_refuses_a_huge_page_at_once_naming_estimate_and_variable(monkeypatch):
    import time

    monkeypatch.delenv("INKARM_MAX_MEMORY_MB", raising=False)
    start = time.perf_counter()
    with pytest.raises(BudgetError) as caught:
        Canvas(size_mm=(1e5, 1e5), px_per_mm=10.0)
    assert time.perf_counter() - start < 1.0  # refused before allocating anything
    error = caught.value
    assert error.key == "ink.px_per_mm" and error.value == 10.0
    assert error.variable == "INKARM_MAX_MEMORY_MB" and error.limit == 1024.0
    pixels = 1_000_000 * 1_000_000
    assert error.estimate == pytest.approx(RASTER_BYTES_PER_PX * pixels / 2**20)
    message = str(error)
    assert message.startswith(
        "ink.px_per_mm: the ink raster of a 100000 x 100000 mm page at 10 px/mm"
    )
    assert "1,000,000 x 1,000,000 pixels" in message
    assert f"about {RASTER_BYTES_PER_PX * pixels / 2**30:.3g} GB" in message
    assert "environment variable INKARM_MAX_MEMORY_MB" in message


def test_raster_budget_accepts_a_page_within_it_and_a_raised_limit(monkeypatch):
    monkeypatch.delenv("INKARM_MAX_MEMORY_MB", raising=False)
    assert raster_bytes((210.0, 297.0), 10.0) == RASTER_BYTES_PER_PX * 2970 * 2100
    require_raster_memory((210.0, 297.0), 30.0)  # A4 at 30 px/mm fits the default 1 GB
    with pytest.raises(BudgetError, match=r"INKARM_MAX_MEMORY_MB"):  # 40 px/mm: 1.3 GB
        require_raster_memory((210.0, 297.0), 40.0)
    assert Canvas(size_mm=(210.0, 297.0), px_per_mm=10.0).shape == (2970, 2100)
    big = ((1000.0, 1000.0), 15.0)  # 225 M pixels: over the default 1024 MB
    with pytest.raises(BudgetError, match=r"INKARM_MAX_MEMORY_MB"):
        require_raster_memory(*big)
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", str(raster_bytes(*big) / 2**20 + 1.0))
    require_raster_memory(*big)  # the check passes (nothing allocated here)
    # the canvas itself consults the limit in force
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "1")
    with pytest.raises(BudgetError, match=r"more than the limit of 1 MB"):
        Canvas(size_mm=(100.0, 100.0), px_per_mm=10.0)
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "100")
    assert Canvas(size_mm=(100.0, 100.0), px_per_mm=10.0).shape == (1000, 1000)


INK_RANGES = [  # model, field, accepted values, refused values, the range the message gives
    (MarkerInk, "w0_mm", (0.01, 25.0), (0.0, 0.009, 26.0, math.inf, math.nan, -1.0), "[0.01, 25]"),
    (MarkerInk, "k_mm", (0.0, 25.0), (-1e-9, 25.5, math.inf, math.nan), "[0, 25]"),
    (MarkerInk, "f0_n", (1e-3, 1e3), (0.0, 1e-4, 2e3, math.inf, math.nan), "[0.001, 1000]"),
    (MarkerInk, "opacity", (1e-6, 1.0), (0.0, 1.01, math.nan), "(0, 1]"),
    (MarkerInk, "threshold_n", (0.0, 100.0), (-1e-9, 101.0, math.inf, math.nan), "[0, 100]"),
    (BrushInk, "w_ref_mm", (0.01, 25.0), (0.0, 30.0, math.inf, math.nan), "[0.01, 25]"),
    (BrushInk, "v_ref_mm_s", (0.01, 1e4), (0.0, 0.001, 1e5, math.inf, math.nan), "[0.01, 10000]"),
    (BrushInk, "gamma", (0.01, 10.0), (0.0, -1.0, 10.5, 1e300, math.inf, math.nan), "[0.01, 10]"),
    (BrushInk, "w_min_mm", (0.01, 4.0), (0.0, -0.5, math.nan), "[0.01, 25]"),
    (BrushInk, "w_max_mm", (0.3, 25.0), (26.0, math.inf, math.nan), "[0.01, 25]"),
    (BrushInk, "opacity", (1e-6, 1.0), (0.0, 2.0, math.nan), "(0, 1]"),
    (PencilInk, "width_mm", (0.01, 25.0), (0.0, 0.005, 25.1, math.inf, math.nan), "[0.01, 25]"),
    (PencilInk, "max_opacity", (1e-6, 1.0), (0.0, 1.5, math.nan), "(0, 1]"),
    (PencilInk, "f0_n", (1e-3, 1e3), (0.0, 1e4, math.inf, math.nan), "[0.001, 1000]"),
]


@pytest.mark.parametrize(("model", "field", "accepted", "refused", "interval"), INK_RANGES,
                         ids=[f"{m.__name__}.{f}" for m, f, *_ in INK_RANGES])
def test_ink_parameters_out_of_range_are_refused_naming_the_field_and_range(
    model, field, accepted, refused, interval
):
    for value in accepted:
        assert getattr(model(**{field: value}), field) == value
    for value in refused:
        with pytest.raises(InputError) as caught:
            model(**{field: value})
        error = caught.value
        assert error.key == field
        assert error.value == value or (math.isnan(value) and math.isnan(error.value))
        assert str(error) == f"{field}: {model.__name__} expects " + error.message.split(
            " expects ", 1)[1]
        assert f" in {interval}, got {value!r}" in error.message


def test_ink_errors_name_the_scenario_key(tmp_path):
    """Through a scenario file the field's error reads ink.<field>, with the range."""
    from inkarm.jobs.scenario import load_scenario

    job = tmp_path / "job.toml"
    job.write_text("[source]\nkind = 'tag'\n[ink]\nmodel = 'brush'\ngamma = 1e300\n")
    with pytest.raises(InputError, match=r"job.toml: ink.gamma: BrushInk expects an exponent "
                       r"of the speed in \[0.01, 10\], got 1e\+300"):
        load_scenario(job)


def test_a_brush_all_but_at_rest_does_not_overflow():
    """A steep exponent at a low-passed speed that has decayed towards 0 (a brush resting on
    the paper): the width is w_max, not an OverflowError."""
    ink = BrushInk(gamma=10.0)
    assert ink.mark(1.0, 1e-200) == (4.0, 0.9)
    assert ink.mark(1.0, 5e-324) == (4.0, 0.9)
    assert ink.mark(1.0, 1e300)[0] == 0.3
