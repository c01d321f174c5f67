"""Every shape svgelements knows is drawn, in the page frame [mm], against closed forms:
circle, ellipse, rect (sharp and rounded), line, polyline, polygon, <use> of paths, groups and
symbols, composed transforms, nested viewports and units."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.io.svgdraw import CURVE_POINTS
from inkarm.io.trace import read_svg

FINE = {"speed": 50.0, "rate": 1e5}  # samples every 0.5 um: lengths are the polyline's


def svg(tmp_path, body: str, attrs: str = 'width="100mm" height="100mm" viewBox="0 0 100 100"'):
    path = tmp_path / "s.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" '
                    'xmlns:xlink="http://www.w3.org/1999/xlink" '
                    f'{attrs}>{body}</svg>')
    return path


def strokes(tmp_path, body: str, **kwargs):
    return read_svg(svg(tmp_path, body, **kwargs), **FINE).strokes


def arc_tolerance(radius: float, sweep: float) -> float:
    """Length lost by flattening an arc of ``sweep`` [rad] into CURVE_POINTS chords."""
    piece = sweep / CURVE_POINTS
    return radius * (sweep - CURVE_POINTS * 2 * math.sin(piece / 2)) + 1e-4  # + resampling


def test_circle_has_length_two_pi_r_and_every_point_on_it(tmp_path):
    (ring,) = strokes(tmp_path, '<circle cx="50" cy="40" r="10" fill="none" stroke="black"/>')
    # svgelements draws a circle as four quarter arcs
    assert 2 * math.pi * 10 - ring.length == pytest.approx(0, abs=4 * arc_tolerance(10, math.pi / 2))
    assert ring.length < 2 * math.pi * 10
    radius = np.hypot(ring.pos[:, 0] - 50, ring.pos[:, 1] - 60)  # y up from y = 100
    np.testing.assert_allclose(radius, 10, atol=10 * (1 - math.cos(math.pi / 4 / CURVE_POINTS)))
    np.testing.assert_allclose(ring.pos[0], ring.pos[-1], atol=1e-9)


def test_rect_corners_and_rounded_rect_length(tmp_path):
    (box,) = strokes(tmp_path, '<rect x="10" y="20" width="30" height="15"/>')
    assert box.length == pytest.approx(90.0)
    for corner in ([10, 80], [40, 80], [40, 65], [10, 65]):
        assert np.min(np.linalg.norm(box.pos - corner, axis=1)) < 1e-9
    (round_,) = strokes(tmp_path, '<rect x="10" y="20" width="30" height="15" rx="3"/>')  # ry = rx
    exact = 2 * (30 + 15) - 8 * 3 + 2 * math.pi * 3
    assert round_.length == pytest.approx(exact, abs=4 * arc_tolerance(3, math.pi / 2))
    assert np.min(np.linalg.norm(round_.pos - [10, 80], axis=1)) == pytest.approx(
        3 * (math.sqrt(2) - 1), abs=1e-3)  # the corner is cut by the quarter circle


def test_rotated_ellipse_lies_on_its_equation_with_ramanujans_length(tmp_path):
    (oval,) = strokes(tmp_path, '<ellipse cx="50" cy="50" rx="20" ry="10" '
                                'transform="rotate(30 50 50)"/>')
    a, b = 20, 10
    rel = oval.pos - [50, 50]
    c, s = math.cos(math.radians(-30)), math.sin(math.radians(-30))  # SVG rotates y down
    u, v = c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]
    np.testing.assert_allclose((u / a) ** 2 + (v / b) ** 2, 1.0, atol=2e-3)
    ramanujan = math.pi * (3 * (a + b) - math.sqrt((3 * a + b) * (a + 3 * b)))
    assert oval.length == pytest.approx(ramanujan, abs=0.02)


def test_line_polyline_and_polygon(tmp_path):
    line, poly, gon = strokes(
        tmp_path, '<line x1="0" y1="0" x2="30" y2="40" stroke="black"/>'
        '<polyline points="0,0 10,0 10,10" fill="none" stroke="black"/>'
        '<polygon points="0,0 3,0 3,4"/>')
    np.testing.assert_allclose(line.pos[[0, -1]], [[0, 100], [30, 60]], atol=1e-9)
    assert line.length == pytest.approx(50.0)
    assert poly.length == pytest.approx(20.0)
    assert gon.length == pytest.approx(12.0)  # closed: 3 + 4 + 5


def test_use_is_translated_by_x_y_after_its_transform(tmp_path):
    body = ('<defs><path id="p" d="M1 0 L2 0" stroke="black"/></defs>'
            '<use href="#p" x="5" y="7"/>'
            '<use xlink:href="#p" x="5" transform="scale(2)"/>')
    moved, scaled = strokes(tmp_path, body)
    np.testing.assert_allclose(moved.pos[[0, -1]], [[6, 93], [7, 93]], atol=1e-9)
    np.testing.assert_allclose(scaled.pos[[0, -1]], [[12, 100], [14, 100]], atol=1e-9)


def test_use_of_a_symbol_and_of_a_group_and_of_a_use(tmp_path):
    body = ('<symbol id="s"><line x1="0" y1="0" x2="4" y2="0" stroke="black"/></symbol>'
            '<defs><g id="g"><line x1="0" y1="0" x2="0" y2="3" stroke="black"/>'
            '<use href="#s" y="1"/></g></defs>'
            '<use href="#s" x="10"/><use id="u" href="#g" x="20"/><use href="#u" y="50"/>')
    got = strokes(tmp_path, body)
    starts = [tuple(np.round(s.pos[0], 9)) for s in got]
    assert starts == [(10, 100), (20, 100), (20, 99), (20, 50), (20, 49)]
    assert [round(s.length, 9) for s in got] == [4, 3, 4, 3, 4]


def test_a_symbol_outside_defs_is_drawn_only_through_use(tmp_path):
    body = ('<symbol id="s"><circle r="2" stroke="black"/></symbol>'
            '<line x2="5" stroke="black"/>')
    (line,) = strokes(tmp_path, body)
    assert line.length == pytest.approx(5.0)


def test_nested_transforms_compose_outer_first(tmp_path):
    body = ('<g transform="translate(10 20)"><g transform="rotate(90)">'
            '<line x1="0" y1="0" x2="10" y2="0" stroke="black"/></g></g>'
            '<g transform="scale(2)"><g transform="translate(1 1)">'
            '<line x1="0" y1="0" x2="1" y2="0" stroke="black"/></g></g>')
    turned, scaled = strokes(tmp_path, body)
    np.testing.assert_allclose(turned.pos[[0, -1]], [[10, 80], [10, 70]], atol=1e-9)
    np.testing.assert_allclose(scaled.pos[[0, -1]], [[2, 98], [4, 98]], atol=1e-9)


def test_nested_svg_viewport_and_absolute_units(tmp_path):
    body = ('<svg x="96" y="0" width="96" height="96" viewBox="0 0 10 10">'
            '<line x1="0" y1="0" x2="10" y2="0" stroke="black"/></svg>'
            '<line x1="0" y1="10" x2="1in" y2="10" stroke="black"/>'
            '<circle cx="200" cy="200" r="0.5in" fill="none" stroke="black"/>')
    inner, inch, ring = strokes(tmp_path, body, attrs='width="4in" height="4in"')
    px = 25.4 / 96
    np.testing.assert_allclose(inner.pos[[0, -1]], [[96 * px, 101.6], [192 * px, 101.6]],
                               atol=1e-9)
    assert inch.length == pytest.approx(25.4)
    assert ring.length == pytest.approx(math.pi * 25.4, abs=0.01)


def test_percent_lengths_follow_the_viewport(tmp_path):
    (line,) = strokes(tmp_path, '<line x1="0" y1="50%" x2="50%" y2="50%" stroke="black"/>',
                      attrs='width="100mm" height="50mm" viewBox="0 0 200 100"')
    assert line.length == pytest.approx(50.0)  # 100 user units at 0.5 mm each
    np.testing.assert_allclose(line.pos[0], [0, 25], atol=1e-9)


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ('<circle id="c" r="5 6"/>', r"<circle> id='c': r='5 6': expected a number"),
        ('<rect width="ten" height="1"/>', r"<rect>: width='ten': expected a number"),
        ('<ellipse rx="1" ry="1e"/>', r"<ellipse>: ry='1e': expected a number"),
        ('<line x1="0" x2="3 4"/>', r"<line>: x2='3 4'"),
        ('<defs><path id="p" d="M0 0 L"/></defs><use href="#p"/>',
         r"<path> id='p': d: expected a number"),
        ('<use href="#g" x="1q"/><g id="g"/>', r"<use>: x='1q'"),
        ('<circle r="1e300" stroke="black"/>', r"<circle>: coordinates overflow"),
    ],
)
def test_bad_shape_geometry_is_refused_naming_the_element(tmp_path, body, message):
    with pytest.raises(InputError, match=message) as info:
        read_svg(svg(tmp_path, body))
    assert info.value.file == str(tmp_path / "s.svg")
