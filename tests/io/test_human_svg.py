"""SVG pen recordings with the time of every point (inkarm.io.svgtiming), and their refusal where
times are missing (analyse --human, fit-style)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.commands import load_recordings
from inkarm.errors import InputError
from inkarm.io.human import read_tablet_csv
from inkarm.io.svgtiming import UNTIMED, read_timed_svg, svg_has_times

DATA = Path(__file__).parents[1] / "data" / "human"
TIMED = DATA / "tablet_timed.svg"
TABLET = DATA / "tablet_ms_units.csv"


def _svg(tmp_path: Path, body: str, root: str = "", name: str = "rec.svg") -> Path:
    path = tmp_path / name
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100" '
                    f'{root}>{body}</svg>')
    return path


def _options(**given) -> argparse.Namespace:
    base = {"time_unit": "s", "scale": 1.0, "speed": 50.0, "rate": 200.0}
    return argparse.Namespace(**{**base, **given})


# -- reading -------------------------------------------------------------------------------------


def test_the_timed_svg_reads_as_the_same_recording_in_csv():
    """The two files hold the same samples (tests/data/human/README.md): the polyline's
    pressure-0 samples end its stroke, the path's group translation is applied, the page's
    y axis is flipped, times are in ms by the root's data-time-unit."""
    svg, csv = read_timed_svg(TIMED), read_tablet_csv(TABLET, time_unit="ms", scale_mm=0.01)
    assert len(svg.strokes) == len(csv.strokes) == 2
    for a, b in zip(svg.strokes, csv.strokes):
        assert np.array_equal(a.t, b.t)
        assert np.allclose(a.pos, b.pos, atol=1e-9)
    assert svg.strokes[0].t[-1] == pytest.approx(0.8)  # the pen lifts at 805 ms
    assert np.allclose(svg.strokes[0].pressure, 0.6)
    assert svg.strokes[1].pressure is None
    assert svg.page_size == (90.0, 50.0)
    assert svg.meta["svg_skipped"] == {UNTIMED: 1}  # the untimed border
    assert svg_has_times(TIMED)


def test_analyse_human_measures_the_timed_svg_with_its_closed_forms(capsys):
    assert main(["analyse", str(TIMED), "--human", "--no-lognormal"]) == 0
    said = capsys.readouterr()
    # the ellipse at constant angular velocity: beta 1/3, two turns, 4 speed peaks in 2 s
    assert "stroke 1: 2.00 s" in said.out and "beta 0.33" in said.out
    assert "4 speed peaks (2.00/s)" in said.out
    assert f"skipped 1 element: 1 {UNTIMED}" in said.err


def test_units_a_path_of_subpaths_and_the_option_where_the_file_names_none(tmp_path):
    path = _svg(tmp_path, '<path d="M10,10 L20,10 30,10 M40,50 H50 V60" '
                          'data-timestamps="0, 100, 200, 300 400 500"/>')
    one, two = read_timed_svg(path, time_unit="ms").strokes
    assert np.allclose(one.t, [0.0, 0.1, 0.2]) and np.allclose(two.t, [0.3, 0.4, 0.5])
    assert np.allclose(two.pos, [[40, 50], [50, 50], [50, 40]])  # y up from the page's foot
    assert np.allclose(read_timed_svg(path).strokes[0].t, [0, 100, 200])  # default s
    declared = _svg(tmp_path, '<g data-time-unit="s"><polyline points="0,0 1,1" '
                    'data-t="1 2"/></g>', root='data-time-unit="ms"', name="d.svg")
    assert np.allclose(read_timed_svg(declared, time_unit="ms").strokes[0].t, [1, 2])


def test_a_lone_timed_point_is_skipped_and_counted(tmp_path):
    path = _svg(tmp_path, '<polyline points="0,0 1,0 2,0 3,0" data-t="0 1 2 3" '
                          'data-pressure="0.5 0 0.5 0.5"/>')
    [stroke] = read_timed_svg(path).strokes
    assert np.allclose(stroke.t, [2, 3])
    assert read_timed_svg(path).meta["svg_skipped"] == {"a single timed point": 1}


# -- refused -------------------------------------------------------------------------------------


UNTIMED_SVG = '<polyline points="10,10 20,20 30,10" fill="none" stroke="black"/>'


def test_analyse_human_and_fit_style_refuse_an_svg_without_times(tmp_path, capsys):
    path = _svg(tmp_path, UNTIMED_SVG)
    assert main(["analyse", str(path), "--human"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: no time stamps: a recording needs the time of every point" in err
    assert 'data-t="t0 t1 ..."' in err
    assert main(["fit-style", str(path), "--out", str(tmp_path / "s.toml")]) == 2
    assert f"{path}: no time stamps" in capsys.readouterr().err
    assert not (tmp_path / "s.toml").exists()


def test_plain_analyse_still_reads_an_untimed_svg_at_the_speed_option(tmp_path):
    path = _svg(tmp_path, UNTIMED_SVG)
    [drawing] = load_recordings(path, _options(human=False))
    assert drawing.strokes[0].duration == pytest.approx(2 * np.hypot(10, 10) / 50.0, rel=1e-6)
    with pytest.raises(InputError, match="no time stamps"):
        load_recordings(path, _options())  # (no `human` option: fit-style)


def test_smil_timing_is_named_as_timing_whole_strokes(tmp_path):
    path = _svg(tmp_path, '<path d="M0,0 L10,10" stroke="black"><animate '
                          'attributeName="stroke-dashoffset" begin="0s" dur="1s"/></path>')
    with pytest.raises(InputError, match=r"1 SMIL animation element \(<animate> \.\.\.\) time "
                                         r"whole strokes, not their points"):
        read_timed_svg(path)


@pytest.mark.parametrize(("body", "message"), [
    ('<polyline id="a" points="0,0 1,1 2,2" data-t="0 1"/>',
     "data-t: <polyline> id='a': 2 values for 3 points; expected one per vertex"),
    ('<polyline points="0,0 1,1 2,2" data-t="0 1 1"/>',
     "time 2 (1 s) does not come after time 1 (1 s); times must increase"),
    ('<polyline points="0,0 1,1" data-t="0 x"/>', "data-t: <polyline>: not a number: 'x'"),
    ('<polyline points="0,0 1,1" data-t="0 inf"/>', "data-t: <polyline>: not a finite number: inf"),
    ('<polyline points="0,0 1,1" data-t="0 1" data-time-unit="min"/>',
     "data-time-unit: <polyline>: got 'min', expected one of s, ms"),
    ('<path d="M0,0 C1,1 2,2 3,0" data-t="0 1"/>',
     "segment 1 is a cubicbezier; times are read on straight segments (M, L, H, V) only"),
    ('<path d="M0,0 L1,1 Z" data-t="0 1"/>',
     "segment 2 is Z, which has no time for the closing point"),
    ('<polygon points="0,0 1,1 2,0" data-t="0 1 2"/>',
     "a <polygon> closes back to its first point, which has no time"),
    ('<rect width="5" height="5" data-t="0 1 2 3"/>',
     "times are read on <polyline> and <path> elements only"),
    ('<polyline points="0,0 1,1" data-t="0 1" data-time="0 1"/>',
     "times given twice (data-t, data-time); keep one"),
    ('<polyline points="0,0 1,1" data-t="0 1" data-pressure="0.5 1.5"/>',
     "pressure 1.5 outside [0, 1]"),
    ('<g data-t="0 1"><polyline points="0,0 1,1"/></g>',
     ("no stroke of two or more timed points with the pen down; 1 shape without times of "
      "their own")),
])
def test_every_problem_of_a_timed_svg_names_the_file_and_element(tmp_path, body, message):
    path = _svg(tmp_path, body)
    with pytest.raises(InputError) as raised:
        read_timed_svg(path)
    assert message in str(raised.value)
    assert str(raised.value).startswith(str(path))


def test_files_and_options_that_are_not_a_timed_recording(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_timed_svg(tmp_path / "none.svg")
    broken = tmp_path / "broken.svg"
    broken.write_text("<svg data-t='1'")
    assert not svg_has_times(broken)
    with pytest.raises(InputError, match="no time stamps"):
        read_timed_svg(broken)
    with pytest.raises(InputError, match="expected a time unit of s, ms, got 'min'"):
        read_timed_svg(TIMED, time_unit="min")
    with pytest.raises(InputError, match="--scale: only for a tablet CSV"):
        load_recordings(TIMED, _options(scale=0.5))
    with pytest.raises(InputError, match="--time-unit: only for a tablet CSV or a timed SVG"):
        load_recordings(_svg(tmp_path, UNTIMED_SVG), _options(human=False, time_unit="ms"))


def test_every_command_reading_recordings_takes_the_recorded_times(tmp_path):
    for options in (_options(), _options(human=True), _options(human=False)):
        [drawing] = load_recordings(TIMED, options)  # fit-style, analyse --human, analyse
        assert [s.duration for s in drawing.strokes] == pytest.approx([0.8, 2.0])
    seconds = _svg(tmp_path, '<polyline points="0,0 3,4" data-t="0 250"/>')
    [drawing] = load_recordings(seconds, _options(time_unit="ms"))  # the file names no unit
    assert drawing.strokes[0].duration == pytest.approx(0.25)
