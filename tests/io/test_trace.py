"""Trace input: CSV through Drawing.from_csv, SVG paths flattened and sampled in arc length."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.io.trace import load_trace, parse_path_data, read_svg, resample_arc_length


def write_svg(
    tmp_path,
    body: str,
    attrs: str = 'width="100mm" height="100mm" viewBox="0 0 100 100"',
    name="t.svg",
):
    path = tmp_path / name
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {attrs}>{body}</svg>')
    return path


def polyline(d: str) -> np.ndarray:
    (poly,) = parse_path_data(d)
    return poly


def test_csv_is_read_as_a_drawing(tmp_path):
    t = np.linspace(0, 1, 11)
    drawing = Drawing(
        [Trajectory(t, np.column_stack([t, t**2])), Trajectory(t, np.column_stack([t, -t]))]
    )
    drawing.to_csv(tmp_path / "a.csv")
    back = load_trace(tmp_path / "a.csv")
    assert len(back.strokes) == 2
    np.testing.assert_allclose(back.strokes[1].pos, drawing.strokes[1].pos)


def test_svg_written_by_drawing_reads_back_in_the_page_frame(tmp_path):
    t = np.linspace(0, 1, 400)
    pos = np.column_stack([50 + 30 * np.cos(2 * np.pi * t), 80 + 20 * np.sin(2 * np.pi * t)])
    Drawing([Trajectory(t, pos)]).to_svg(tmp_path / "a.svg")
    back = load_trace(tmp_path / "a.svg")
    assert back.page_size == pytest.approx((210.0, 297.0))
    (stroke,) = back.strokes
    np.testing.assert_allclose(stroke.pos[0], pos[0], atol=1e-3)
    np.testing.assert_allclose(stroke.pos[-1], pos[-1], atol=1e-3)
    radius = np.hypot((stroke.pos[:, 0] - 50) / 30, (stroke.pos[:, 1] - 80) / 20)
    np.testing.assert_allclose(radius, 1.0, atol=1e-3)


def test_samples_are_uniform_in_arc_length_at_the_given_speed(tmp_path):
    path = write_svg(tmp_path, '<path d="M 0 0 L 10 0 L 10 7.3"/>', attrs="")
    (stroke,) = read_svg(path, speed=20.0, rate=100.0).strokes
    steps = np.linalg.norm(np.diff(stroke.pos, axis=0), axis=1)
    assert steps.max() <= 20.0 / 100.0 + 1e-12
    assert (
        np.sum(np.abs(steps - steps[0]) > 1e-9) == 1
    )  # only the step across the corner is shorter
    np.testing.assert_allclose(np.diff(stroke.t), steps / 20.0)
    assert stroke.t[0] == 0.0


def test_resample_keeps_both_ends_and_refuses_nothing_to_draw():
    pts = np.array([[0.0, 0.0], [0.0, 0.0], [3.0, 4.0]])
    out = resample_arc_length(pts, 1.0)
    assert len(out) == 6
    np.testing.assert_allclose(out[[0, -1]], pts[[0, -1]])
    assert resample_arc_length(np.zeros((3, 2)), 1.0) is None


def test_absolute_relative_and_shorthand_lines_agree():
    a = polyline("M10 10 L20 10 L20 20 L10 20 Z")
    b = polyline("m10,10 l10,0 l0,10 l-10,0 z")
    c = polyline("M10 10H20V20H10z")
    d = polyline("M10 10 20 10 20 20 10 20z")  # implicit linetos after M
    e = polyline("m10 10 h10 v10 h-10 z")
    for other in (b, c, d, e):
        np.testing.assert_allclose(other, a)
    np.testing.assert_allclose(a[-1], [10, 10])


def test_cubic_passes_through_its_midpoint_and_smooth_cubic_reflects():
    p = np.array([[0, 0], [0, 10], [10, 10], [10, 0]], float)
    curve = polyline("M0 0 C0 10 10 10 10 0")
    mid = (p[0] + 3 * p[1] + 3 * p[2] + p[3]) / 8
    assert np.min(np.linalg.norm(curve - mid, axis=1)) < 1e-12
    np.testing.assert_allclose(
        polyline("M0 0 C0 10 10 10 10 0 S20 -10 20 0"),
        polyline("M0 0 C0 10 10 10 10 0 C10 -10 20 -10 20 0"),
    )
    np.testing.assert_allclose(
        polyline("m0 0 c0 10 10 10 10 0 s10 -10 10 0"),
        polyline("M0 0 C0 10 10 10 10 0 S20 -10 20 0"),
    )


def test_quadratic_and_smooth_quadratic():
    curve = polyline("M0 0 Q5 10 10 0")
    assert np.min(np.linalg.norm(curve - [5, 5], axis=1)) < 1e-12  # B(1/2) = (P0 + 2 P1 + P2) / 4
    np.testing.assert_allclose(
        polyline("M0 0 Q5 10 10 0 T20 0"), polyline("M0 0 Q5 10 10 0 Q15 -10 20 0")
    )
    np.testing.assert_allclose(polyline("M0 0 q5 10 10 0 t10 0"), polyline("M0 0 Q5 10 10 0 T20 0"))


def test_arcs_lie_on_their_ellipse():
    half = polyline("M0 0 A10 10 0 0 1 20 0")
    np.testing.assert_allclose(np.linalg.norm(half - [10, 0], axis=1), 10.0, atol=1e-9)
    assert half[:, 1].min() < -9.99  # sweep 1 runs through negative y (y down in SVG)
    other = polyline("M0 0 A10 10 0 0 0 20 0")
    assert other[:, 1].max() > 9.99
    small = polyline("M0 0 a1 1 0 0 1 20 0")  # radii too small are scaled up to reach the end
    np.testing.assert_allclose(np.linalg.norm(small - [10, 0], axis=1), 10.0, atol=1e-9)
    np.testing.assert_allclose(small[-1], [20, 0])
    rotated = polyline("M0 0 A20 10 90 0 1 0 40")  # x radius along y: centre (0, 20)
    np.testing.assert_allclose(
        np.hypot(rotated[:, 0] / 10, (rotated[:, 1] - 20) / 20), 1.0, atol=1e-9
    )
    compact = polyline("M0 0 A10 10 0 0120 0")  # flags written without separators
    np.testing.assert_allclose(compact, half)


def test_subpaths_polylines_polygons_and_transforms(tmp_path):
    body = (
        '<g transform="translate(10 5) scale(2)">'
        '<path d="M0 0 L5 0 M0 10 L0 15"/></g>'
        '<polyline points="0,0 10,0"/><polygon points="0 0 4 0 4 3"/>'
        '<defs><path d="M0 0 L50 50"/></defs>'
    )
    drawing = read_svg(write_svg(tmp_path, body), speed=10.0, rate=100.0)
    assert len(drawing.strokes) == 4
    first, second, line, triangle = drawing.strokes
    # translate(10 5) scale(2): (0,0) -> (10,5); the page's y axis points up from y = 100.
    np.testing.assert_allclose(first.pos[[0, -1]], [[10, 95], [20, 95]])
    assert second.length == pytest.approx(10.0)
    assert line.length == pytest.approx(10.0)
    assert triangle.length == pytest.approx(12.0, abs=0.05)  # closed: 4 + 3 + 5
    np.testing.assert_allclose(triangle.pos[0], triangle.pos[-1])


def test_units_and_view_box_fix_the_scale(tmp_path):
    body = '<path d="M0 0 L100 0"/>'
    half = read_svg(write_svg(tmp_path, body, 'width="100mm" height="50mm" viewBox="0 0 200 100"'))
    assert half.strokes[0].length == pytest.approx(50.0)
    assert half.page_size == pytest.approx((100.0, 50.0))
    inches = read_svg(write_svg(tmp_path, body, 'width="2in" height="1in" viewBox="0 0 100 50"'))
    assert inches.strokes[0].length == pytest.approx(50.8)
    pixels = read_svg(write_svg(tmp_path, body, 'width="96" height="96"'))
    assert pixels.strokes[0].length == pytest.approx(100 * 25.4 / 96)
    rotated = read_svg(write_svg(tmp_path, '<path transform="rotate(90)" d="M0 0 L10 0"/>', ""))
    np.testing.assert_allclose(
        rotated.strokes[0].pos[-1] - rotated.strokes[0].pos[0], [0, -10], atol=1e-9
    )
    assert math.isclose(rotated.strokes[0].length, 10.0)


def test_svg_without_paths_names_the_file(tmp_path):
    path = write_svg(
        tmp_path, '<rect x="0" y="0" width="10" height="10" display="none"/><path d="M5 5"/>',
        name="empty.svg",
    )
    with pytest.raises(
        InputError, match=r"empty\.svg: no drawable shape \(visible, of non-zero length\) found; "
        r"skipped 2 elements: 1 hidden, 1 of zero length"
    ):
        load_trace(path)


def test_missing_and_unknown_files_are_refused(tmp_path):
    with pytest.raises(InputError, match=r"nope\.svg: no such file"):
        load_trace(tmp_path / "nope.svg")
    with pytest.raises(InputError, match=r"nope\.csv: no such file"):
        load_trace(tmp_path / "nope.csv")
    (tmp_path / "a.txt").write_text("t,x,y\n")
    with pytest.raises(
        InputError, match=r"a\.txt: unknown trace format '\.txt'; expected \.csv or \.svg"
    ):
        load_trace(tmp_path / "a.txt")


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            '<path id="p1" d="M0 0 L10"/>',
            r"<path> id='p1': d: expected a number at character 8, got 'end of data'",
        ),
        ('<path d="L0 0 L10 10"/>', r"d: path data must start with M or m, got 'L'"),
        (
            '<path d="M0 0 X 5 5"/>',
            r"d: expected a number or a path command at character 5, got 'X 5 5'",
        ),
        ('<path d="M0 0 A5 5 0 2 1 10 0"/>', r"expected an arc flag 0 or 1"),
        ('<path transform="spin(3)" d="M0 0 L1 1"/>', r"transform spin\(3.0\) not understood"),
        (
            '<polyline points="0 0 1"/>',
            r"points='0 0 1': expected an even count of at least 4 numbers",
        ),
        ('<polygon points="0 0 1 1 x"/>', r"points: unexpected 'x'"),
    ],
)
def test_bad_svg_content_is_refused_with_its_place(tmp_path, body, message):
    with pytest.raises(InputError, match=message):
        read_svg(write_svg(tmp_path, body))


def test_bad_svg_documents_are_refused(tmp_path):
    (tmp_path / "broken.svg").write_text("<svg><path d='M0 0'></svg>")
    with pytest.raises(InputError, match=r"broken\.svg: not well-formed XML"):
        read_svg(tmp_path / "broken.svg")
    (tmp_path / "html.svg").write_text("<html/>")
    with pytest.raises(InputError, match=r"root element is <html>, expected <svg>"):
        read_svg(tmp_path / "html.svg")
    with pytest.raises(InputError, match=r"<svg width='-3mm'>: expected a positive length"):
        read_svg(write_svg(tmp_path, "", 'width="-3mm"'))
    with pytest.raises(InputError, match=r"viewBox='0 0 1'>: expected four numbers"):
        read_svg(write_svg(tmp_path, "", 'viewBox="0 0 1"'))
    with pytest.raises(InputError, match=r"speed: SVG trace speed must lie in \[0.001, 100000\]"):
        read_svg(write_svg(tmp_path, '<path d="M0 0 L1 1"/>'), speed=0.0)
    with pytest.raises(InputError, match=r"rate: SVG trace rate must lie in .* got 1e\+09"):
        read_svg(write_svg(tmp_path, '<path d="M0 0 L1 1"/>'), rate=1e9)


# -- svgelements: what it is handed and what it may raise ------------------------------------


def test_viewbox_is_fitted_into_the_page_uniformly_and_centred(tmp_path):
    wide = write_svg(
        tmp_path, '<path d="M0 0 L100 0"/>', 'width="100mm" height="50mm" viewBox="0 0 100 100"'
    )
    (stroke,) = read_svg(wide).strokes  # preserveAspectRatio xMidYMid meet: scale 0.5
    np.testing.assert_allclose(stroke.pos[[0, -1]], [[25, 50], [75, 50]], atol=1e-9)
    boxed = read_svg(write_svg(tmp_path, '<path d="M0 0 L10 0"/>', 'viewBox="0 0 40 30"'))
    assert boxed.page_size == pytest.approx((40.0, 30.0))  # no width/height: 1 unit = 1 mm
    assert boxed.strokes[0].length == pytest.approx(10.0)


def test_elements_that_are_not_drawn_are_ignored_even_when_broken(tmp_path):
    body = (
        '<mask><path d="M0 0 L3 3"/></mask><symbol id="s"><path d="M0 0 L1 1"/></symbol>'
        '<defs><path d="garbage"/></defs><text>hi</text><!-- a comment -->'
        '<g id="a"><use href="#a"/><use href="#s"/></g>'  # a self-referencing <use>: no loop
        '<path d="M0 0 L10 0"/>'
    )
    drawing = read_svg(write_svg(tmp_path, body))
    symbol, line = drawing.strokes  # the <use> of the symbol draws its path
    assert symbol.length == pytest.approx(math.sqrt(2))
    assert line.length == pytest.approx(10.0)
    assert drawing.meta["svg_skipped"] == {"circular <use>": 1, "text": 1}


def test_display_none_is_not_drawn(tmp_path):
    body = '<g display="none"><path d="M0 0 L3 3"/></g><path d="M0 0 L10 0"/>'
    assert len(read_svg(write_svg(tmp_path, body)).strokes) == 1


def test_deep_nesting_up_to_the_limit_is_read_and_beyond_it_is_refused(tmp_path):
    from inkarm.io.trace import MAX_DEPTH

    def nested(depth):
        inner = '<path d="M0 0 L1 0"/>'
        return '<g transform="translate(0.5)">' * depth + inner + "</g>" * depth

    (stroke,) = read_svg(write_svg(tmp_path, nested(MAX_DEPTH - 1))).strokes
    assert stroke.pos[0, 0] == pytest.approx(0.5 * (MAX_DEPTH - 1))
    with pytest.raises(InputError, match=rf"deep\.svg: elements are nested more than {MAX_DEPTH}"):
        read_svg(write_svg(tmp_path, nested(20_000), name="deep.svg"))


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("this is not XML", r"hostile\.svg: not well-formed XML"),
        (b"\x89PNG\r\n\x1a\n\x00", r"hostile\.svg: not well-formed XML"),
        ("", r"hostile\.svg: not well-formed XML"),
        (
            '<!DOCTYPE s [<!ENTITY a "aaaaaaaaaa">'
            + "".join(
                f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(8)
            )
            + ']><svg><path id="&i;" d="M0 0 L1 1"/></svg>',
            r"hostile\.svg: not well-formed XML \(limit on input amplification",
        ),
        (
            (
                '<!DOCTYPE s [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
                '<svg><path id="&x;" d="M0 0 L1 1"/></svg>'
            ),
            r"hostile\.svg: not well-formed XML \(reference to external entity",
        ),
        ("<svg><rect width='5' height='5' fill='none'/></svg>",
         r"hostile\.svg: no drawable shape .*: 1 with no stroke or fill"),
        (
            "<svg><path id='g' d='M0 0 L 5 5 @@@'/></svg>",
            r"hostile\.svg: <path> id='g': d: expected a number or a path command at character 11",
        ),
        ("<svg><path d='M0 0 Z 5'/></svg>", r"hostile\.svg: <path>: d: expected a path command"),
        ("<svg><path d='#'/></svg>", r"hostile\.svg: <path>: d: expected a path command \(M, L"),
        ("<svg><path d='M0 0 L1e999 0'/></svg>", r"hostile\.svg: <path>: coordinates overflow"),
        ("<svg><path d='M0 0 L1e12 0'/></svg>", r"hostile\.svg: <path>: .* 1e\+12 mm in the page"),
        ("<svg><path d='M0 0 L1e6 0'/></svg>",
         r"hostile\.svg: rate: 1e\+06 mm of paths at 50 mm/s.*about 4e\+06 time steps.*STEPS"),
        ("<svg><path transform='rotate(1e400)' d='M0 0 L1 0'/></svg>",
         r"hostile\.svg: <path>: transform 'rotate\(1e400\)': arguments must be numbers"),
        ("<svg width='1e300mm'><path d='M0 0 L1 0'/></svg>",
         r"hostile\.svg: <svg width='1e300mm'>: expected a positive length up to 1e\+06 mm"),
        ("<svg viewBox='0 0 1e300 1'><path d='M0 0 L1 0'/></svg>",
         r"hostile\.svg: page of 1e\+300 x 1 mm"),
        ("<svg><path d='M0 0 L1e-300 0'/></svg>", r"hostile\.svg: no drawable"),
        ("<svg viewBox='0 0 nan 1'/>", r"hostile\.svg: <svg viewBox='0 0 nan 1'>: expected four"),
    ],
)
def test_bad_or_hostile_svg_gives_an_input_error_naming_the_file(tmp_path, content, message):
    path = tmp_path / "hostile.svg"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(InputError, match=message) as info:
        load_trace(path)
    assert info.value.file == str(path)


def test_whatever_svgelements_raises_becomes_an_input_error(tmp_path, monkeypatch):
    import svgelements

    def broken(*args, **kwargs):
        raise IndexError("list index out of range")

    monkeypatch.setattr(svgelements.SVG, "parse", staticmethod(broken))
    with pytest.raises(
        InputError, match=r"t\.svg: <svg>: svgelements cannot read it \(IndexError: list index"
    ):
        read_svg(write_svg(tmp_path, '<path d="M0 0 L1 1"/>'))


def test_zero_radius_arc_is_a_straight_line():
    np.testing.assert_allclose(polyline("M0 0 A0 5 0 0 1 10 0"), [[0, 0], [10, 0]])
