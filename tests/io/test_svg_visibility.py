"""Nothing invisible is drawn, and what is skipped is counted (``meta["svg_skipped"]``) and said
in one line (:func:`skipped_summary`, printed by the commands that read traces)."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from inkarm.commands import load_trace_for
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.io.trace import read_svg, skipped_summary

VISIBLE = '<line id="seen" x1="0" y1="0" x2="10" y2="0" stroke="black"/>'


def read(tmp_path, body: str, name: str = "v.svg"):
    path = tmp_path / name
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" '
                    f'viewBox="0 0 100 100"><style>.ghost {{ display: none }}</style>{body}'
                    f"{VISIBLE}</svg>")
    return read_svg(path)


@pytest.mark.parametrize(
    ("element", "reason"),
    [
        ('<circle r="5" stroke="black" display="none"/>', "hidden"),
        ('<circle r="5" stroke="black" style="display:none"/>', "hidden"),
        ('<circle r="5" stroke="black" class="ghost"/>', "hidden"),
        ('<g display="none"><circle r="5" display="inline"/></g>', "hidden"),  # cannot undo
        ('<circle r="5" stroke="black" visibility="hidden"/>', "hidden"),
        ('<g style="visibility:collapse"><circle r="5"/></g>', "hidden"),
        ('<circle r="5" opacity="0"/>', "hidden"),
        ('<circle r="5" style="opacity:0%"/>', "hidden"),
        ('<g opacity="0"><g opacity="1"><circle r="5" opacity="1"/></g></g>', "hidden"),
        ('<g display="none"><text>hi</text></g>', "hidden"),
        ('<circle r="5" fill="none"/>', "no stroke or fill"),
        ('<circle r="5" fill="none" stroke="none"/>', "no stroke or fill"),
        ('<circle r="5" fill="none" stroke="black" stroke-width="0"/>', "no stroke or fill"),
        ('<circle r="5" fill="none" stroke="black" stroke-opacity="0"/>', "no stroke or fill"),
        ('<g stroke-opacity="0"><circle r="5" fill="none" stroke="red"/></g>',
         "no stroke or fill"),
        ('<circle r="5" fill="black" fill-opacity="0"/>', "no stroke or fill"),
        ('<circle r="5" fill="transparent"/>', "no stroke or fill"),
        ('<circle r="5" fill="rgba(0,0,0,0)"/>', "no stroke or fill"),
        ('<rect width="100" height="100" style="fill:#ffffff"/>', "white on white"),
        ('<circle r="5" fill="white" stroke="#fafafa"/>', "white on white"),
        ('<circle r="5" fill="none" stroke="rgb(255,255,255)"/>', "white on white"),
        ('<circle r="5" fill="#fff" stroke="black" stroke-width="0"/>', "white on white"),
        ('<path d="M5 5 L5 5" stroke="black"/>', "zero length"),
        ('<path stroke="black"/>', "zero length"),  # no d at all
        ('<text x="1" y="1">hi</text>', "text"),
        ('<image width="1" height="1" href="x.png"/>', "image"),
        ('<foreignObject width="1" height="1"><p>hi</p></foreignObject>', "foreignObject"),
        ('<use href="#nowhere"/>', "unresolved <use>"),
        ('<use href="other.svg#p"/>', "unresolved <use>"),
    ],
)
def test_an_invisible_element_is_skipped_and_counted(tmp_path, element, reason):
    drawing = read(tmp_path, element)
    (stroke,) = drawing.strokes  # only the visible line
    assert stroke.length == pytest.approx(10.0)
    assert drawing.meta["svg_skipped"] == {reason: 1}


@pytest.mark.parametrize(
    "element",
    [
        '<circle r="5"/>',  # SVG's default fill is black: a filled glyph is drawn
        '<circle r="5" stroke="none" style="fill:#262626"/>',  # matplotlib's glyphs
        '<g visibility="hidden"><circle r="5" visibility="visible"/></g>',  # may be undone
        '<g opacity="0.5"><circle r="5" opacity="0.5"/></g>',
        '<circle r="5" fill="#f9f9f9"/>',  # below WHITE_LEVEL in one channel: not white
        '<circle r="5" fill="white" stroke="black"/>',
        '<circle r="5" fill="none" stroke="black" stroke-opacity="0.1"/>',
        '<circle r="5" fill="url(#gradient)"/>',  # a paint server is drawn
        '<g fill="none"><circle r="5" stroke="blue"/></g>',
    ],
)
def test_a_seen_element_is_drawn(tmp_path, element):
    drawing = read(tmp_path, element)
    assert len(drawing.strokes) == 2
    assert drawing.meta["svg_skipped"] == {}
    assert skipped_summary(drawing) is None


def test_a_style_sheet_inside_defs_applies(tmp_path):
    drawing = read(tmp_path, '<defs><style>circle.off { visibility: hidden }</style></defs>'
                             '<circle class="off" r="5"/>')
    assert drawing.meta["svg_skipped"] == {"hidden": 1}


def test_a_fill_only_shape_draws_its_outline_one_stroke_per_subpath(tmp_path):
    ring = '<path d="M0 0 H10 V10 H0 Z M3 3 H7 V7 H3 Z" fill="black" stroke="none"/>'
    outer, inner, _ = read(tmp_path, ring).strokes
    assert (outer.length, inner.length) == pytest.approx((40.0, 16.0))


def test_the_summary_says_every_reason_most_frequent_first(tmp_path):
    body = ('<g display="none"><circle r="1"/><circle r="2"/></g>'
            '<text>a</text><rect width="100" height="100" fill="#fff"/>')
    drawing = read(tmp_path, body)
    assert drawing.meta["svg_skipped"] == {"hidden": 2, "text": 1, "white on white": 1}
    assert skipped_summary(drawing) == (
        "skipped 4 elements: 2 hidden, 1 <text> (convert text to paths), "
        "1 white on white paper")
    assert skipped_summary(Drawing([Trajectory([0, 1], [[0, 0], [1, 0]])])) is None


def test_commands_say_what_was_skipped_on_stderr_in_one_line(tmp_path, capsys):
    read(tmp_path, '<g display="none"><circle r="1"/></g><text>a</text>', name="drawing.svg")
    args = argparse.Namespace(trace=tmp_path / "drawing.svg", speed=50.0, rate=200.0)
    drawing = load_trace_for(args)
    assert len(drawing.strokes) == 1
    err = capsys.readouterr().err
    assert err == (f"note: {tmp_path / 'drawing.svg'}: skipped 2 elements: 1 hidden, "
                   "1 <text> (convert text to paths)\n")


def test_nothing_to_draw_is_refused_saying_what_was_skipped(tmp_path):
    path = tmp_path / "blank.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg"><rect width="9" height="9" '
                    'fill="white"/><text>a</text></svg>')
    with pytest.raises(Exception, match=r"blank\.svg: no drawable shape \(visible, of non-zero "
                       r"length\) found; skipped 2 elements: 1 <text> .*, 1 white on white"):
        read_svg(path)


def test_matplotlib_text_as_paths_draws_the_glyphs_and_not_the_background(tmp_path):
    """matplotlib's SVG (svg.fonttype='path'): a white unstroked figure rectangle, glyph
    outlines in <defs> placed with <use>, filled, not stroked."""
    body = ('<defs><path id="DejaVuSans-6f" d="M 0 0 L 10 0 L 10 10 Z" '
            'transform="scale(0.015625)"/></defs>'
            '<g id="figure_1"><g id="patch_1"><path d="M 0 100 L 100 100 L 100 0 L 0 0 z" '
            'style="fill: #ffffff"/></g>'
            '<g id="text_1"><g style="fill: #262626" transform="translate(20 30) scale(0.5 -0.5)">'
            '<use xlink:href="#DejaVuSans-6f" x="0"/><use xlink:href="#DejaVuSans-6f" '
            'x="20"/></g></g></g>')
    path = tmp_path / "mpl.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" '
                    'xmlns:xlink="http://www.w3.org/1999/xlink" width="100mm" height="100mm" '
                    f'viewBox="0 0 100 100">{body}</svg>')
    drawing = read_svg(path)
    assert drawing.meta["svg_skipped"] == {"white on white": 1}
    first, second = drawing.strokes
    np.testing.assert_allclose(first.pos[0], [20, 70], atol=1e-9)
    np.testing.assert_allclose(second.pos[0], [30, 70], atol=1e-9)  # x=20 at scale 0.5
