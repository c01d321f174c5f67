"""The page layout (inkarm.plans.page): vpype's page sizes, fit, align, scale, rotation, and the
restyled drawing kept inside the page (refit, clip), each against a hand-worked oracle and,
where vpype is installed, against vpype's own ``layout``."""

from __future__ import annotations

import re

import numpy as np
import pytest

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.plans.page import (
    PAGE_SIZES_MM,
    Layout,
    clip,
    keep_inside,
    lay_out,
    oriented,
    outside,
    parse_length,
    parse_page_size,
    refit,
)


def drawing(*strokes, layers=None, **meta) -> Drawing:
    """Strokes of [[x, y], ...] [mm], timed 1 s a sample."""
    trajs = [Trajectory(np.arange(len(p), dtype=float), np.asarray(p, dtype=float))
             for p in strokes]
    if layers is not None:
        meta["layers"] = np.asarray(layers, dtype=np.int64)
    return Drawing(trajs, meta=meta)


RECT = drawing([[0, 0], [100, 0], [100, 50]], [[0, 50], [0, 0]], layers=[1, 2], title="r")


def bounds(d: Drawing):
    lo, hi = d.bounds()
    return np.round(np.concatenate([lo, hi]), 9).tolist()


# -- page sizes -----------------------------------------------------------------------------

def test_page_sizes_as_vpype_names_them():
    assert parse_page_size("a4") == (210.0, 297.0)
    assert parse_page_size("A3") == (297.0, 420.0)
    assert parse_page_size("letter") == (215.9, 279.4)
    assert parse_page_size("tabloid") == (279.4, 431.8)
    assert parse_page_size("210x297mm") == (210.0, 297.0)
    assert parse_page_size("8.5x11in") == pytest.approx((215.9, 279.4))
    assert parse_page_size("21cmx297mm") == pytest.approx((210.0, 297.0))  # a unit each side
    assert parse_page_size("21x29.7cm") == pytest.approx((210.0, 297.0))  # one unit for both
    assert parse_page_size("100x150") == (100.0, 150.0)  # a number alone is mm
    assert parse_page_size("96x192px") == pytest.approx((25.4, 50.8))
    assert parse_length("10mm", "m") == 10.0 and parse_length("1cm", "m") == 10.0
    assert parse_length("0.5in", "m") == 12.7 and parse_length(3, "m") == 3.0


def test_page_sizes_are_vpypes_table():
    vp = pytest.importorskip("vpype")
    for name, size in PAGE_SIZES_MM.items():
        assert np.allclose(np.asarray(vp.PAGE_SIZES[name]) * 25.4 / 96.0, size), name
    assert set(vp.PAGE_SIZES) - set(PAGE_SIZES_MM) == {"tight"}


def test_orientation_is_enforced_as_vpype_does():
    assert oriented((210, 297), landscape=True) == (297.0, 210.0)
    assert oriented((297, 210), landscape=False) == (210.0, 297.0)  # portrait unless asked
    assert oriented((297, 210), landscape=True) == (297.0, 210.0)
    out = lay_out(RECT, Layout(page_size=parse_page_size("a4"), landscape=True))
    assert out.page_size == (297.0, 210.0)


# -- layout ---------------------------------------------------------------------------------

def test_fit_to_margins_puts_the_box_exactly_inside_them_aspect_kept_and_centred():
    out = lay_out(RECT, Layout(page_size=(210.0, 297.0), fit_to_margins_mm=10.0))
    # 100 x 50 into 190 x 277: x limits, k = 1.9 -> 190 x 95, centred in y
    assert bounds(out) == pytest.approx([10.0, 101.0, 200.0, 196.0])
    assert out.page_size == (210.0, 297.0)
    # times, layers and meta unchanged
    assert all(np.array_equal(a.t, b.t) for a, b in zip(out.strokes, RECT.strokes, strict=True))
    assert out.meta["title"] == "r" and out.meta["layers"].tolist() == [1, 2]
    assert out.strokes[0].pos[1] == pytest.approx([200.0, 101.0])


@pytest.mark.parametrize("align, valign, box", [
    ("left", "top", [10.0, 192.0, 200.0, 287.0]),
    ("right", "bottom", [10.0, 10.0, 200.0, 105.0]),
    ("center", "center", [10.0, 101.0, 200.0, 196.0]),
])
def test_align_and_valign_put_the_box_against_the_margins(align, valign, box):
    out = lay_out(RECT, Layout(page_size=(210.0, 297.0), fit_to_margins_mm=10.0, align=align,
                               valign=valign))
    assert bounds(out) == pytest.approx(box)


def test_without_a_fit_the_drawing_keeps_its_size_and_is_placed():
    out = lay_out(RECT, Layout(page_size=(210.0, 297.0), align="right", valign="top"))
    assert bounds(out) == pytest.approx([110.0, 247.0, 210.0, 297.0])
    centred = lay_out(RECT, Layout(page_size=(210.0, 297.0)))
    assert bounds(centred) == pytest.approx([55.0, 123.5, 155.0, 173.5])


def test_rotation_by_90_degrees_maps_a_known_point_and_the_velocities():
    d = Drawing([Trajectory([0.0, 1.0], [[0.0, 0.0], [10.0, 0.0]], vel=[[10.0, 0], [10.0, 0]])])
    out = lay_out(d, Layout(rotation_deg=90.0))  # counter-clockwise about the centre (5, 0)
    assert out.strokes[0].pos == pytest.approx(np.array([[5.0, -5.0], [5.0, 5.0]]))
    assert out.strokes[0].vel == pytest.approx(np.array([[0.0, 10.0], [0.0, 10.0]]))


def test_scale_acts_about_the_centre_and_is_not_a_fit():
    out = lay_out(RECT, Layout(scale=2.0))
    assert bounds(out) == pytest.approx([-50.0, -25.0, 150.0, 75.0])
    assert out.page_size == RECT.page_size  # not placed: no page
    placed = lay_out(RECT, Layout(scale=0.5, page_size=(100.0, 100.0), align="left"))
    assert bounds(placed) == pytest.approx([0.0, 37.5, 50.0, 62.5])


def test_layout_is_vpypes_layout():
    """vpype draws y down: its top is the page's top edge, as inkarm's y-up top."""
    execute = pytest.importorskip("vpype_cli").execute
    for options, kw in ((["-m", "15mm", "-h", "left", "-v", "top"],
                         {"fit_to_margins_mm": 15.0, "align": "left", "valign": "top"}),
                        (["-l", "-h", "right", "-v", "bottom"],
                         {"landscape": True, "align": "right", "valign": "bottom"}),
                        (["-m", "1cm"], {"fit_to_margins_mm": 10.0})):
        doc = execute(f"rect 0 0 100mm 50mm layout {' '.join(options)} a4")
        w, h = np.asarray(doc.page_size) * 25.4 / 96.0
        x0, y0, x1, y1 = np.asarray(doc.bounds()) * 25.4 / 96.0
        rect = drawing([[0, 0], [100, 0], [100, 50], [0, 50], [0, 0]])
        out = lay_out(rect, Layout(page_size=(210.0, 297.0), **kw))
        assert out.page_size == pytest.approx((w, h))
        assert bounds(out) == pytest.approx([x0, h - y1, x1, h - y0], abs=1e-6), options


# -- errors ---------------------------------------------------------------------------------

@pytest.mark.parametrize("make, key, message", [
    (lambda: parse_page_size("a44", "--page-size"), "--page-size",
     "unknown page size 'a44' (did you mean 'a4'?); expected one of a6, a5, a4"),
    (lambda: parse_page_size("leter"), "page_size", "did you mean 'letter'?"),
    (lambda: parse_page_size("10x", "p"), "p", "or WxH with a unit (mm, cm, in, inch, px, pt)"),
    (lambda: parse_page_size("0x5"), "page_size", "expected each side in (0, 10000] mm"),
    (lambda: parse_page_size("20000x5mm"), "page_size", "expected each side in (0, 10000]"),
    (lambda: parse_length("10furlongs", "--fit-to-margins"), "--fit-to-margins",
     "expected a length such as 10mm, 1cm or 0.5in"),
    (lambda: parse_length("-3mm", "m"), "m", "expected a length such as"),
    (lambda: Layout(page_size=(0.0, 5.0)), "page_size", "expected a page of (0, 10000] mm"),
    (lambda: Layout(fit_to_margins_mm=-1.0), "fit_to_margins", "expected a margin in [0, 5000]"),
    (lambda: Layout(scale=0.0), "scale", "expected a scale factor in (0, 1000]"),
    (lambda: Layout(scale=2.0, fit_to_margins_mm=5.0), "scale",
     "give a scale or fit to margins, not both"),
    (lambda: Layout(align="centre"), "align", ("unknown value 'centre' (did you mean 'center'?)"
     "; expected one of left, center, right")),
    (lambda: Layout(valign="middle"), "valign", "expected one of top, center, bottom"),
    (lambda: Layout(rotation_deg=float("nan")), "rotation_deg", "expected an angle in"),
    (lambda: lay_out(RECT, Layout(page_size=(100.0, 100.0), fit_to_margins_mm=50.0)),
     "fit_to_margins", "a margin of 50 mm leaves nothing of the 100 x 100 mm page"),
    (lambda: lay_out(drawing([[3, 3]]), Layout(fit_to_margins_mm=5.0)), "fit_to_margins",
     "the drawing is a single point: there is nothing to fit"),
    (lambda: keep_inside(RECT, (0, 0), (1, 1), "clp"), "overshoot",
     "unknown value 'clp' (did you mean 'clip'?); expected one of refit, clip"),
    (lambda: clip(RECT, (200, 200), (300, 300)), "overshoot",
     "nothing of the drawing lies inside (200, 200) to (300, 300) mm"),
])
def test_every_error_names_its_key_and_what_was_expected(make, key, message):
    with pytest.raises(InputError) as caught:
        make()
    assert caught.value.key == key and message in caught.value.message


# -- kept inside the page ---------------------------------------------------------------------

def test_refit_scales_down_just_enough_and_moves_inside():
    over = drawing([[-1.9, 0.0], [100.0, 0.0], [100.0, 50.0]], layers=[3])
    kept, k = refit(over, (0.0, 0.0), (100.0, 100.0))
    assert k == pytest.approx(100.0 / 101.9)
    assert bounds(kept) == pytest.approx([0.0, 25 - 25 * k, 100.0, 25 + 25 * k])
    assert kept.meta["layers"].tolist() == [3]
    inside, k = refit(RECT, (0.0, 0.0), (100.0, 50.0))
    assert inside is RECT and k == 1.0
    moved, k = refit(drawing([[-5.0, 0.0], [5.0, 0.0]]), (0.0, -1.0), (20.0, 1.0))
    assert k == 1.0 and bounds(moved) == pytest.approx([0.0, 0.0, 10.0, 0.0])
    said = keep_inside(over, (0, 0), (100, 100), "refit")[1]
    assert re.search(r"scaled by 0\.98135\d to stay within", said), said


def test_clip_cuts_at_the_edges_interpolating_time_and_splits_a_stroke_that_comes_back():
    u = drawing([[0, 0], [100, 0], [100, 50], [0, 50]], [[10, 10], [20, 10]], layers=[4, 5])
    kept, cut = clip(u, (-1.0, -1.0), (90.0, 60.0))
    assert cut == 1 and len(kept.strokes) == 3
    first, second, whole = kept.strokes
    assert first.pos.tolist() == [[0.0, 0.0], [90.0, 0.0]] and first.t.tolist() == [0.0, 0.9]
    assert second.pos.tolist() == [[90.0, 50.0], [0.0, 50.0]]
    assert second.t == pytest.approx([2.1, 3.0])
    assert whole is u.strokes[1]
    assert kept.meta["layers"].tolist() == [4, 4, 5]
    assert outside(kept, (-1.0, -1.0), (90.0, 60.0)) is None
    assert outside(u, (-1.0, -1.0), (90.0, 60.0)) == (0, 1)
    assert "overshoot clip: 1 strokes cut" in keep_inside(u, (-1, -1), (90, 60), "clip")[1]
    assert "no overshoot" in keep_inside(u, (-1, -1), (200, 60), "clip")[1]
