"""G-code generation: profiles, travel order, resampling, the line parser's answers."""

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, ScenarioError
from inkarm.hardware.plotter.gcode import (
    PlotterStroke,
    drawing_to_gcode,
    order_strokes,
    resample_stroke,
)
from inkarm.hardware.plotter.gcode_parser import GcodeError, normalise, parse_block
from inkarm.hardware.plotter.machine import GrblMachine
from inkarm.hardware.plotter.profiles import load_profile, parse_profile, profile_names
from inkarm.hardware.plotter.timing import simulate


def stroke(points, speed=50.0) -> PlotterStroke:
    pts = np.asarray(points, dtype=float)
    return PlotterStroke(pts, np.full(len(pts), speed))


def travel(strokes, start=(0.0, 0.0)) -> float:
    here, total = np.asarray(start), 0.0
    for s in strokes:
        total += float(np.linalg.norm(s.points[0] - here))
        here = s.points[-1]
    return total


def test_builtin_profiles_load():
    assert set(profile_names()) >= {"servo", "z"}
    servo = load_profile("servo")
    assert servo.pen_lines(True) == ["M3 S1000", "G4 P0.150"]
    assert load_profile("z").pen_lines(False) == ["G0 Z5"]


@pytest.mark.parametrize("data, message", [
    ({"units": "cm"}, "units: unknown value 'cm'"),
    ({"pen_down": "M3"}, "pen_down: expected an array of G-code lines"),
    ({"pen_up": ["M5\nG0 X0"]}, "pen_up[0]: expected one G-code line"),
    ({"pen_down_dwell_s": -1}, "pen_down_dwell_s: expected a number >= 0"),
    ({"max_draw_speed_mm_s": 0}, "max_draw_speed_mm_s: expected a number > 0"),
    ({"min_draw_speed_mm_s": 200.0}, "min_draw_speed_mm_s: expected at most"),
    ({"precision": 9}, "precision: expected an integer in 0..6"),
    ({"pen_dwn": []}, "did you mean 'pen_down'"),
])
def test_profile_errors_name_the_file_and_key(data, message):
    with pytest.raises(ScenarioError) as e:
        parse_profile(data, "pen.toml", "pen")
    assert message in str(e.value) and str(e.value).startswith("pen.toml")


def test_unknown_profile_suggests_the_closest():
    with pytest.raises(InputError, match="did you mean 'servo'"):
        load_profile("serv")


def test_greedy_order_against_brute_force_on_a_small_case():
    strokes = [stroke([[50, 0], [60, 0]]), stroke([[11, 0], [20, 0]]),
               stroke([[40, 0], [30, 0]]), stroke([[0, 1], [10, 1]])]
    ordered = order_strokes(strokes, merge_mm=0.0)
    best = min(travel([s if not r else stroke(s.points[::-1]) for s, r in zip(p, rev)])
               for p in itertools.permutations(strokes)
               for rev in itertools.product([False, True], repeat=len(strokes)))
    assert travel(ordered) == pytest.approx(best)  # collinear: greedy is optimal here
    assert ordered[2].points[0].tolist() == [30.0, 0.0]  # reversed


def test_merge_joins_strokes_that_continue():
    ordered = order_strokes([stroke([[0, 0], [1, 0]]), stroke([[1, 0], [2, 1]])])
    assert len(ordered) == 1 and ordered[0].points.shape == (3, 2)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 200), st.floats(0, 200),
                          st.floats(0, 200)), min_size=1, max_size=25))
def test_order_visits_every_stroke_once_and_never_travels_more_than_given_order(segments):
    strokes = [stroke([[a, b], [c, d]]) for a, b, c, d in segments]
    ordered = order_strokes(strokes, merge_mm=-1.0)
    key = sorted(tuple(sorted(map(tuple, s.points.tolist()))) for s in strokes)
    assert sorted(tuple(sorted(map(tuple, s.points.tolist()))) for s in ordered) == key
    # never more pen-up travel than the order given (greedy alone can be worse)
    assert travel(ordered) <= travel(strokes) + 1e-6


@settings(max_examples=40, deadline=None)
@given(st.floats(5, 400), st.floats(50, 400), st.integers(30, 90))
def test_resampled_lines_never_exceed_the_line_rate(speed, rate, n):
    t = np.linspace(0, 2 * np.pi, n)
    pts = np.column_stack([40 * np.cos(t), 40 * np.sin(t)])
    out = resample_stroke(stroke(pts, speed), rate)
    step = np.linalg.norm(np.diff(out.points, axis=0), axis=1)
    h = max(speed / rate, 0.05)
    # Each line lasts at least about 1/rate at this speed (equal arcs of >= h; a chord across
    # one of the polygon's vertices, 12 deg or less here, is at most 1% shorter).
    assert np.all(step >= 0.99 * h)
    assert np.all(step < 2 * h)
    assert out.points[0] == pytest.approx(pts[0]) and out.points[-1] == pytest.approx(pts[-1])


def test_gcode_of_a_drawing_uses_the_profile_and_the_drawings_speed():
    t = np.linspace(0, 1, 101)
    d = Drawing([Trajectory(t=t, pos=np.column_stack([20 + 50 * t, 30 + 0 * t]))],
                page_size=(210, 297))
    job = drawing_to_gcode(d, load_profile("servo"))
    assert job.lines[:4] == ["G21", "G90", "G94", "M5"]
    assert "G0 X20.000 Y30.000" in job.lines and "M3 S1000" in job.lines
    feeds = {float(w[1:]) for line in job.lines for w in line.split() if w.startswith("F")}
    assert feeds == {3000.0}  # 50 mm/s, F only once
    plan = simulate(job.lines)
    assert plan.seconds > 1.0 + 0.3  # a second of drawing, two dwells
    inch = drawing_to_gcode(d, dataclasses.replace(load_profile("servo"), units="in"))
    assert inch.lines[0] == "G20" and "G0 X0.787 Y1.181" in inch.lines


def test_gcode_refuses_3d_and_empty_drawings():
    with pytest.raises(InputError, match="no strokes"):
        drawing_to_gcode(Drawing([], page_size=(210, 297)), load_profile("servo"))


@pytest.mark.parametrize("line, code", [("G1 X1 G0", 24), ("M7", 20), ("G1.5 X1", 23),
                                        ("X1 X2", 25), ("@", 1), ("GX", 2), ("T256", 38)])
def test_parser_errors(line, code):
    with pytest.raises(GcodeError) as e:
        parse_block(normalise(line))
    assert e.value.code == code


def test_normalise_drops_comments_and_spaces():
    assert normalise("g1 x1 (comment) y 2 ; tail") == "G1X1Y2"


def test_z_pen_touches_at_the_page_and_servo_pen_needs_its_settle_time():
    from inkarm.hardware.plotter.machine import PenConfig
    from inkarm.ink.canvas import Canvas

    for pen, profile in ((PenConfig(contact_z_mm=0.0), "z"), (PenConfig(), "servo")):
        canvas = Canvas((100, 100), 10)
        m = GrblMachine(pen=pen, canvas=canvas)
        lines = (["G21 G90", *load_profile(profile).header, "G0 X10 Y10",
                  *load_profile(profile).pen_lines(True), "G1 X60 Y10 F3000",
                  *load_profile(profile).pen_lines(False), "G0 X0 Y0"])
        for line in lines:
            m.take_line(line)
            while not m.accepts_line():
                m.pump()
                m.advance(0.01)
        while not m.idle:
            m.advance(0.01)
            m.pump()
        ink = canvas.ink_points_mm(0.5)
        assert ink[:, 0].min() == pytest.approx(10, abs=0.5)
        assert ink[:, 0].max() == pytest.approx(60, abs=0.5)
        assert np.all(np.abs(ink[:, 1] - 10) < 1.0)


def test_a_dwell_shorter_than_the_servo_leaves_a_gap():
    from inkarm.ink.canvas import Canvas

    canvas = Canvas((100, 100), 10)
    m = GrblMachine(canvas=canvas)  # servo settles in 0.12 s
    for line in ["G21 G90", "G0 X10 Y10", "M3 S1000", "G1 X60 Y10 F3000", "M5"]:
        m.take_line(line)
        while not m.accepts_line():
            m.pump()
            m.advance(0.005)
    while not m.idle:
        m.advance(0.005)
        m.pump()
    ink = canvas.ink_points_mm(0.5)
    # 0.12 s at (up to) 50 mm/s from rest at 1500 mm/s^2: the first ~5 mm are not inked.
    assert ink[:, 0].min() > 12.0
