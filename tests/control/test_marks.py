"""Dot marks found on an ink raster and on a photographed sheet: planted dots recovered."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control.calibration.marks import (
    Marks,
    apply_homography,
    canvas_marks,
    common_shift,
    find_blobs,
    homography,
    image_marks,
    match_marks,
    raster_marks,
    read_darkness,
    rendered_mark,
    sheet_homography,
)
from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas

PAGE = (120.0, 90.0)


def planted(k: int = 12, seed: int = 0) -> np.ndarray:
    """k dot centres [mm] on a jittered grid of PAGE, at arbitrary sub-pixel places."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.linspace(15, PAGE[0] - 15, 4), np.linspace(15, PAGE[1] - 15, 3))
    grid = np.column_stack([xs.ravel(), ys.ravel()])[:k]
    return grid + rng.uniform(-3.0, 3.0, grid.shape)


def discs(x_mm: np.ndarray, y_mm: np.ndarray, dots: np.ndarray, radius_mm: float,
          edge_mm: float) -> np.ndarray:
    """Darkness of anti-aliased discs (a linear ramp ``edge_mm`` wide) at page points."""
    out = np.zeros_like(x_mm)
    for cx, cy in dots:
        d = np.hypot(x_mm - cx, y_mm - cy)
        out = np.maximum(out, np.clip((radius_mm - d) / edge_mm + 0.5, 0.0, 1.0))
    return out


def test_canvas_dots_found_where_the_pen_touched():
    canvas = Canvas(size_mm=PAGE, px_per_mm=10.0)
    dots = planted()
    for p in dots:
        canvas.touch(p, 1.0, 0.0)
        canvas.touch(p + [1e-4, 0.0], 1.0, 0.01)  # the pen resting on its dot
        canvas.lift()
    marks = canvas_marks(canvas)
    assert isinstance(marks, Marks) and len(marks) == len(dots)
    found = match_marks(dots, marks, radius_mm=3.0)
    assert np.abs(found - dots).max() < 0.01  # a tenth of a pixel
    assert np.all(marks.area_px > 20) and np.all(marks.ink > 10)


def test_raster_centroids_subpixel_and_sorted():
    px = 8.0
    rows, cols = round(PAGE[1] * px), round(PAGE[0] * px)
    i, j = np.mgrid[0:rows, 0:cols]
    x, y = (j + 0.5) / px, (rows - i - 0.5) / px
    dots = planted(seed=3)
    marks = raster_marks(discs(x, y, dots, 0.9, 1.0 / px), px)
    order = np.lexsort((dots[:, 0], dots[:, 1]))
    assert np.abs(marks.page_mm - dots[order]).max() < 0.01
    assert np.all(np.diff(marks.page_mm[:, 1]) >= 0)


def test_dust_and_a_background_are_ignored():
    image = np.full((40, 60), 0.1)  # a grey sheet
    image[10:16, 10:16] = 0.9  # a dot of 36 px
    image[30, 50] = 0.9  # dust, 1 px
    centres, area, ink = find_blobs(image, threshold=0.25, min_area_px=4)
    assert np.allclose(centres, [[12.5, 12.5]]) and area.tolist() == [36]
    assert ink[0] == pytest.approx(36 * 0.8)
    assert len(find_blobs(np.zeros((5, 5)))[0]) == 0


def test_homography_recovers_a_planted_one():
    rng = np.random.default_rng(1)
    truth = np.array([[0.9, 0.1, 30.0], [-0.05, 1.1, 20.0], [2e-4, -1e-4, 1.0]])
    src = rng.uniform(0, 500, (8, 2))
    dst = apply_homography(truth, src)
    assert np.allclose(homography(src, dst), truth, rtol=1e-9, atol=1e-12)
    # four points map exactly
    assert np.allclose(apply_homography(homography(src[:4], dst[:4]), src[:4]), dst[:4],
                       atol=1e-9)


def photographed(dots: np.ndarray, corners: np.ndarray, shape=(700, 900)) -> np.ndarray:
    """A photo of the sheet: white paper inside ``corners``, dots in perspective, a grey desk."""
    h_img_to_page = sheet_homography(corners, PAGE)
    v, u = np.mgrid[0:shape[0], 0:shape[1]]
    page = apply_homography(h_img_to_page, np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5]))
    x, y = page[:, 0].reshape(shape), page[:, 1].reshape(shape)
    scale = np.sqrt(abs(np.linalg.det(h_img_to_page[:2, :2])))  # about mm per px
    ink = discs(x, y, dots, 1.0, scale)
    on = (x >= 0) & (x <= PAGE[0]) & (y >= 0) & (y <= PAGE[1])
    return np.where(on, 0.03 + 0.9 * ink, 0.35)


def test_photographed_sheet_in_perspective():
    dots = planted(seed=2)
    # lower-left, lower-right, upper-right, upper-left, in (u right, v down) pixels
    corners = np.array([[80.0, 640.0], [860.0, 600.0], [790.0, 90.0], [130.0, 40.0]])
    marks = image_marks(photographed(dots, corners), corners, PAGE)
    assert len(marks) == len(dots)
    found = match_marks(dots, marks, radius_mm=3.0)
    assert np.abs(found - dots).max() < 0.05


def test_image_file_read_with_pillow(tmp_path):
    from PIL import Image

    dots = planted(k=4, seed=5)
    corners = np.array([[10.0, 690.0], [890.0, 690.0], [890.0, 10.0], [10.0, 10.0]])
    grey = np.round(255 * (1 - photographed(dots, corners))).astype(np.uint8)
    path = tmp_path / "sheet.png"
    Image.fromarray(grey, mode="L").convert("RGB").save(path)
    assert read_darkness(path).shape == grey.shape
    found = match_marks(dots, image_marks(path, corners, PAGE), radius_mm=3.0)
    assert np.abs(found - dots).max() < 0.05


def test_match_errors_name_the_dot():
    marks = np.array([[10.0, 10.0], [30.0, 10.0], [31.0, 10.5]])
    assert match_marks([[10.2, 9.9]], marks, 2.0).tolist() == [[10.0, 10.0]]
    with pytest.raises(InputError, match=r"planned dot 1 at \(50.00, 50.00\) mm: no mark within "
                                         r"2 mm \(the nearest is 43.83 mm away\)"):
        match_marks([[10.0, 10.0], [50.0, 50.0]], marks, 2.0)
    with pytest.raises(InputError, match=r"planned dot 0 .*: 2 marks within 2 mm"):
        match_marks([[30.5, 10.0]], marks, 2.0)
    with pytest.raises(InputError, match="no marks at all"):
        match_marks([[1.0, 1.0]], np.zeros((0, 2)), 2.0)
    with pytest.raises(InputError, match="radius_mm > 0"):
        match_marks([[1.0, 1.0]], marks, 0.0)


def test_input_errors(tmp_path):
    with pytest.raises(InputError, match="2-D darkness raster"):
        find_blobs(np.zeros(5))
    with pytest.raises(InputError, match="NaN"):
        find_blobs(np.full((3, 3), np.nan))
    with pytest.raises(InputError, match=r"threshold in \(0, 1\), got 1.5"):
        find_blobs(np.zeros((3, 3)), threshold=1.5)
    with pytest.raises(InputError, match="px_per_mm > 0"):
        raster_marks(np.zeros((3, 3)), 0.0)
    with pytest.raises(InputError, match="4 corners .* lower-left, lower-right"):
        sheet_homography([[0, 0], [1, 0], [1, 1]], PAGE)
    with pytest.raises(InputError, match="lie on a line"):
        sheet_homography([[0, 0], [5, 0], [10, 0], [0, 10]], PAGE)
    with pytest.raises(InputError, match="positive page size"):
        sheet_homography([[0, 0], [1, 0], [1, 1], [0, 1]], (0.0, 10.0))
    with pytest.raises(InputError, match="k >= 4"):
        homography(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(InputError, match="finite"):
        homography(np.full((4, 2), np.inf), np.zeros((4, 2)))
    with pytest.raises(InputError, match="no such image file"):
        read_darkness(tmp_path / "missing.png")
    bad = tmp_path / "not_an_image.png"
    bad.write_text("hello")
    with pytest.raises(InputError, match="cannot read .* as an image"):
        read_darkness(bad)


def test_rendered_mark_of_a_pen_that_slid():
    """A pen resting at a point: its mark is there; one that slid along a line at an even
    force: half way (the capsule's centroid)."""
    from inkarm.ink.inks import make_ink

    t = np.arange(10) * 0.006
    rest = rendered_mark(np.tile([50.3, 20.7], (10, 1)), np.ones(10), t, make_ink("marker"),
                         10.0)
    assert np.allclose(rest, [50.3, 20.7], atol=0.01)
    line = np.column_stack([np.linspace(10.0, 10.6, 10), np.full(10, 5.0)])
    slid = rendered_mark(line, np.ones(10), t, make_ink("marker"), 10.0)
    assert np.allclose(slid, [10.3, 5.0], atol=0.01)
    with pytest.raises(InputError, match="lays no ink"):
        rendered_mark(line, np.zeros(10), t, make_ink("marker"), 10.0)
    with pytest.raises(InputError, match="r forces and times"):
        rendered_mark(line, np.ones(9), t, make_ink("marker"), 10.0)


def pen_grid(spacing: float = 12.0) -> np.ndarray:
    """The pen pattern's 13 dots: a 4 x 4 serpentine grid around (105, 148.5) mm, cut to 13."""
    xs, ys = np.meshgrid(spacing * (np.arange(4) - 1.5), spacing * (np.arange(4) - 1.5))
    return (np.c_[xs.ravel(), ys.ravel()] + [105.0, 148.5])[:13]


@pytest.mark.parametrize("shift", [(5.6, -3.1), (-7.5, 6.0), (0.3, 9.2)])
def test_marks_all_shifted_by_an_uncalibrated_arm_are_matched_to_their_own_dots(shift):
    """Planted: every mark a few mm off (more than the radius, some nearer a neighbour dot
    than their own) plus +-1 mm of its own (a tip offset turned with the pen's spin): each is
    matched to the dot that made it, and the common shift recovered."""
    dots = pen_grid()
    own = np.random.default_rng(1).uniform(-1.0, 1.0, dots.shape)
    marks = (dots + shift + own)[::-1]  # (in another order than the dots)
    with pytest.raises(InputError, match="no mark within 5.4 mm"):
        match_marks(dots, marks, 5.4)  # (the old matching: the dot itself)
    found = match_marks(dots, marks, 5.4, max_shift_mm=10.0)
    np.testing.assert_allclose(found, dots + shift + own, atol=1e-12)
    np.testing.assert_allclose(common_shift(dots, marks, 5.4, 10.0), shift, atol=1.0)


def test_one_sheet_of_several_runs_is_not_matched_to_the_neighbours_marks():
    """The kinematics' runs share a sheet, each grid 14 mm beside the next: a run's dots, all
    3 mm off, take their own marks, not those 11 mm the other way (the smaller shift wins a
    tie); a shift beyond ``max_shift_mm`` is not searched (0: the dots themselves)."""
    grid = np.array([(x, y) for y in (20.0, 62.5, 105.0) for x in (20.0, 62.5, 105.0)])
    runs = [grid + (dx, 0.0) for dx in (-14.0, 0.0, 14.0)]
    sheet = np.vstack([r + (3.0, 0.0) for r in runs])
    for run in runs:
        np.testing.assert_allclose(match_marks(run, sheet, 6.0, max_shift_mm=6.0), run + (3, 0))
        np.testing.assert_allclose(common_shift(run, sheet, 6.0, 6.0), (3.0, 0.0))
    assert common_shift(grid, sheet, 6.0, 0.0).tolist() == [0.0, 0.0]
    assert common_shift(grid, sheet + 50.0, 1.0, 5.0).tolist() == [0.0, 0.0]  # (none near)
    assert common_shift(grid, np.zeros((0, 2)), 1.0, 5.0).tolist() == [0.0, 0.0]


def test_a_shifted_match_s_errors_name_the_shift():
    dots = pen_grid()
    marks = np.delete(dots + (4.0, 0.0), 5, axis=0)
    with pytest.raises(InputError, match=r"planned dot 5 at \(99.00, 142.50\) mm: no mark "
                       r"within 5.4 mm of it moved by the marks' common shift \(\+4.00, "
                       r"\+0.00\) mm \(the nearest is 12.00 mm away\)") as e:
        match_marks(dots, marks, 5.4, max_shift_mm=10.0)
    assert e.value.key == "marks" and e.value.value == 5
    with pytest.raises(InputError, match="max_shift_mm >= 0") as e:
        match_marks(dots, marks, 5.4, max_shift_mm=-1.0)
    assert e.value.key == "max_shift_mm"
