"""AxiDraw motion planning (inkarm.hardware.axidraw.motion), the profiles and the travel check:
steps that sum exactly to the path, no move above the speed or acceleration limits, every
move within the firmware's limits, the servo figures of the AxiDraw software, and points
beyond the travel refused naming the point and the travel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.errors import InkarmError, InputError
from inkarm.hardware.axidraw import ebb
from inkarm.hardware.axidraw.geometry import carriage_mm
from inkarm.hardware.axidraw.motion import (
    Limits,
    StepCursor,
    junction_speed,
    path_moves,
    plan_path,
    profile_limits,
)
from inkarm.hardware.axidraw.placement import SheetPlacement
from inkarm.hardware.axidraw.profiles import load_profile, profile_names

PROFILE = load_profile("v3")
K = PROFILE.steps_per_mm


def speeds_of(moves):
    """Per move, the carriage speed [mm/s] it steps at."""
    out = []
    for m in moves:
        dx, dy = carriage_mm(m.steps1, m.steps2, K)
        out.append(math.hypot(float(dx), float(dy)) * 1000.0 / m.duration_ms)
    return np.array(out)


def check_moves(moves, lim: Limits, start, end, cursor_end):
    # every move is one the firmware takes (formatting raises otherwise)
    for m in moves:
        ebb.sm(m.duration_ms, m.steps1, m.steps2)
    s1 = sum(m.steps1 for m in moves)
    s2 = sum(m.steps2 for m in moves)
    # the steps sum exactly to the rounded end: no drift
    assert (start[0] + s1, start[1] + s2) == cursor_end
    assert cursor_end == (round(K * (end[0] + end[1])), round(K * (end[0] - end[1])))
    v = speeds_of(moves)
    d = np.array([m.duration_ms for m in moves]) / 1000.0
    quantum = math.sqrt(2.0) / K / d  # the rounding to whole steps
    assert np.all(v <= lim.speed_mm_s * 1.0001 + quantum)
    # speed changes between neighbours within the acceleration (plus their rounding)
    dv = np.abs(np.diff(v))
    allowed = lim.accel_mm_s2 * 0.5 * (d[1:] + d[:-1]) + quantum[1:] + quantum[:-1]
    assert np.all(dv <= allowed * 1.001)
    # from rest and to rest: the first and last moves are slow
    assert v[0] <= lim.accel_mm_s2 * d[0] + quantum[0] + 1e-9
    assert v[-1] <= lim.accel_mm_s2 * d[-1] + quantum[-1] + 1e-9
    assert np.all(d <= lim.slice_s + 0.0015)


@pytest.mark.parametrize("end", [(100.0, 50.0), (0.3, 0.0), (-20.0, 80.0), (150.0, 150.0),
                                 (0.01, 0.02), (250.0, -3.0)])
def test_a_travel_is_acceleration_limited_and_sums_to_its_end(end):
    lim = profile_limits(PROFILE, pen_down=False)
    start = np.array([20.0, 5.0])
    cursor = StepCursor(K, StepCursor(K).target(start))
    s0 = cursor.steps
    target = start + np.array(end)
    moves, _ = path_moves(cursor, [start, target], [lim.speed_mm_s], lim)
    if cursor.target(target) == s0:
        assert moves == []
        return
    check_moves(moves, lim, s0, target, cursor.steps)


def test_a_long_travel_cruises_at_the_pen_up_speed_and_takes_the_trapezoids_time():
    lim = profile_limits(PROFILE, pen_down=False)
    moves, _ = path_moves(StepCursor(K), [[0, 0], [200, 0]], [1e9], lim)
    v, a = lim.speed_mm_s, lim.accel_mm_s2
    expected = 200.0 / v + v / a  # accelerate and decelerate: v/a lost in all
    assert sum(m.duration_ms for m in moves) / 1000.0 == pytest.approx(expected, abs=0.003)
    assert speeds_of(moves).max() == pytest.approx(v, rel=0.01)


def test_a_drawn_curve_follows_the_asked_speed_within_the_limits():
    lim = profile_limits(PROFILE, pen_down=True)
    th = np.linspace(0.0, 1.5 * np.pi, 300)
    pts = np.c_[60 + 15 * np.cos(th), 60 + 15 * np.sin(th)]
    caps = np.full(len(pts) - 1, 30.0)
    cursor = StepCursor(K, StepCursor(K).target(pts[0]))
    s0 = cursor.steps
    moves, reached = path_moves(cursor, pts, caps, lim)
    check_moves(moves, lim, s0, pts[-1], cursor.steps)
    assert np.median(speeds_of(moves)) == pytest.approx(30.0, rel=0.03)
    # every vertex is reached by a move, in order
    assert reached[0] == -1 and np.all(np.diff(reached) >= 0) and reached[-1] == len(moves) - 1
    # the moves stay on the curve: their ends within 0.02 mm of the circle
    ends = np.cumsum([[m.steps1, m.steps2] for m in moves], axis=0) + np.array(s0)
    xy = np.column_stack(carriage_mm(ends[:, 0], ends[:, 1], K))
    r = np.hypot(xy[:, 0] - 60, xy[:, 1] - 60)
    assert np.abs(r - 15).max() < 0.02


def test_a_sharp_corner_is_taken_slowly_and_kept_as_a_move_boundary():
    lim = profile_limits(PROFILE, pen_down=True)
    assert junction_speed(np.array([1.0, 0]), np.array([1.0, 0]), lim) == math.inf
    assert junction_speed(np.array([1.0, 0]), np.array([-1.0, 0]), lim) == 0.0
    right_angle = junction_speed(np.array([1.0, 0]), np.array([0, 1.0]), lim)
    # GRBL's junction deviation: v^2 = a d sin(t/2) / (1 - sin(t/2)), t = 90 degrees
    s = math.sin(math.pi / 4)
    assert right_angle == pytest.approx(math.sqrt(762.0 * 0.0508 * s / (1 - s)))
    timed = plan_path([[0, 0], [10, 0], [10, 10]], [50.0, 50.0], lim)
    corner = timed.vertex_sample[1]
    assert np.allclose(timed.xy[corner], [10, 0], atol=0.01)  # (samples at whole ms)
    step = np.hypot(*(timed.xy[corner + 1] - timed.xy[corner - 1]))
    assert step / (timed.t[corner + 1] - timed.t[corner - 1]) < 1.5 * right_angle


def test_rounding_never_drifts_over_many_short_strokes():
    lim = profile_limits(PROFILE, pen_down=True)
    rng = np.random.default_rng(3)
    cursor = StepCursor(K)
    here = np.zeros(2)
    total = np.zeros(2, dtype=int)
    for _ in range(200):
        pts = here + np.cumsum(rng.normal(0, 0.37, size=(6, 2)), axis=0)
        pts = np.vstack([here, pts])
        moves, _ = path_moves(cursor, pts, np.full(len(pts) - 1, 40.0), lim)
        total += [sum(m.steps1 for m in moves), sum(m.steps2 for m in moves)]
        here = pts[-1]
    assert tuple(total) == cursor.target(here) == cursor.steps


def test_a_move_too_fast_for_the_steppers_is_lengthened_not_sent():
    lim = Limits(speed_mm_s=1000.0, accel_mm_s2=1e6, junction_mm=0.05)
    moves, _ = path_moves(StepCursor(K), [[0, 0], [50, 50]], [1000.0], lim)
    for m in moves:
        assert max(abs(m.steps1), abs(m.steps2)) * 1000.0 / m.duration_ms <= ebb.MAX_STEP_RATE
        ebb.sm(m.duration_ms, m.steps1, m.steps2)
    assert sum(m.steps1 for m in moves) == round(K * 100)


# -- profiles ----------------------------------------------------------------------------------

def test_the_servo_figures_are_the_axidraw_softwares():
    # pen_handling.py: 9855 + 179.76 x 60 % and x 30 %; rate 17976 x 0.24 / 200 x 75 % and 50 %;
    # wait ((2.69 x 30 + 45)^4 + (200 x 30 / rate)^4)^(1/4): 130 ms up, 146 ms down
    assert PROFILE.servo_position(60) == 20641 and PROFILE.servo_position(30) == 15248
    assert PROFILE.servo_rate(75) == 1618 and PROFILE.servo_rate(50) == 1079
    assert PROFILE.pen_move_ms(True) == 130 and PROFILE.pen_move_ms(False) == 146
    # axidraw.py: speed 25 % / 75 % of 8.6979 in/s / 1.1; accel 40 and 60 in/s^2 x 75 %
    assert PROFILE.speed_pendown_mm_s == pytest.approx(25 * 8.6979 / 110 * 25.4, abs=0.01)
    assert PROFILE.speed_penup_mm_s == pytest.approx(75 * 8.6979 / 110 * 25.4, abs=0.01)
    assert PROFILE.accel_pendown_mm_s2 == pytest.approx(40 * 0.75 * 25.4)
    assert PROFILE.max_speed_mm_s() == pytest.approx(8.6979 * 25.4, rel=1e-3)  # hr limit
    a3 = load_profile("v3_a3")
    assert a3.travel_mm == pytest.approx((16.93 * 25.4, 11.69 * 25.4), abs=1e-3)
    assert PROFILE.travel_mm == pytest.approx((11.81 * 25.4, 8.58 * 25.4), abs=1e-3)
    assert set(profile_names()) >= {"v3", "v3_a3"}


@pytest.mark.parametrize("text, key, what", [
    ("travel = [1, 2]\n", "travel", "did you mean 'travel_mm'"),
    ("speed_penup_mm_s = 300.0\n", "speed_penup_mm_s", "at most 221 mm/s"),
    ("pen_pos_up = 120\n", "pen_pos_up", "<= 100"),
    ("travel_mm = [300.0]\n", "travel_mm", "expected [x, y]"),
    ("servo_min = 30000\n", "servo_min", "less than servo_max"),
    ("min_move_ms = 50\n", "min_move_ms", "at most time_slice_ms"),
    ("time_slice_ms = 2.5\n", "time_slice_ms", "an integer"),
])
def test_profile_errors_name_the_file_and_the_key(tmp_path, text, key, what):
    path = tmp_path / "mine.toml"
    path.write_text(text)
    with pytest.raises(InkarmError) as caught:
        load_profile(str(path))
    message = str(caught.value)
    assert str(path) in message and key in message and what in message


def test_an_unknown_profile_name_suggests_one():
    with pytest.raises(InputError, match=r"--profile.*did you mean 'v3_a3'"):
        load_profile("v3a3")


# -- the sheet on the machine -----------------------------------------------------------------

def test_the_sheet_hangs_from_home_and_points_beyond_the_travel_are_named():
    sheet = SheetPlacement((210.0, 297.0), (0.0, 0.0), PROFILE.travel_mm, "V3")
    assert np.allclose(sheet.to_machine([[0.0, 297.0], [210.0, 100.0]]), [[0, 0], [210, 197]])
    assert np.allclose(sheet.to_page(sheet.to_machine([[12.5, 40.0]])), [[12.5, 40.0]])
    sheet.check_strokes([np.array([[10.0, 290.0], [200.0, 80.0]])])
    with pytest.raises(InputError) as caught:
        sheet.check_strokes([np.array([[10.0, 290.0]]),
                             np.array([[20.0, 100.0], [30.0, 60.0]])])
    text = str(caught.value)
    assert "stroke 2 point 2 at page (30.00, 60.00) mm" in text
    assert "machine (30.00, 237.00) mm" in text and "y 0 to 217.932 mm" in text
    with pytest.raises(InputError, match="machine \\(-1.00, 5.00\\) mm is beyond"):
        sheet.check_machine(np.array([-1.0, 5.0]))


@pytest.mark.parametrize("seed", range(12))
def test_random_strokes_keep_every_limit_and_end_exactly(seed):
    rng = np.random.default_rng(seed)
    lim = profile_limits(PROFILE, pen_down=bool(seed % 2))
    n = int(rng.integers(2, 80))
    pts = np.cumsum(rng.normal(0, rng.uniform(0.05, 5.0), size=(n, 2)), axis=0) + 100.0
    caps = rng.uniform(1.0, 2 * lim.speed_mm_s, size=n - 1)
    cursor = StepCursor(K, StepCursor(K).target(pts[0]))
    s0 = cursor.steps
    moves, reached = path_moves(cursor, pts, caps, lim)
    if not moves:
        assert cursor.steps == s0 == cursor.target(pts[-1])
        return
    check_moves(moves, lim, s0, pts[-1], cursor.steps)
    assert np.all(np.diff(reached) >= 0) and reached[-1] == len(moves) - 1
