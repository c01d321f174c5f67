"""The planner model against GRBL's closed forms: junction speeds, trapezoids, look-ahead."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.hardware.plotter.machine import DEFAULT_SETTINGS, GrblMachine
from inkarm.hardware.plotter.planner import (
    BLOCK_BUFFER,
    Planner,
    junction_speed_sqr,
    limit_by_axes,
    profile_step,
    profile_time,
)
from inkarm.hardware.plotter.timing import simulate

ACCEL = np.array([1500.0, 1500.0, 500.0])


def closed_form(a: float, delta: float, theta: float) -> float:
    """GRBL's junction speed v = sqrt(a delta sin(theta/2) / (1 - sin(theta/2)))."""
    s = math.sin(theta / 2)
    return math.sqrt(a * delta * s / (1 - s))


@pytest.mark.parametrize("theta_deg", [30.0, 45.0, 60.0, 90.0, 120.0, 150.0, 170.0])
def test_junction_speed_is_grbls_closed_form(theta_deg):
    # Incoming along +x; the outgoing line makes the interior angle theta with the reversed
    # incoming direction (theta = 180 deg: straight on).
    theta = math.radians(theta_deg)
    prev = np.array([1.0, 0.0, 0.0])
    out = np.array([-math.cos(theta), math.sin(theta), 0.0])
    # Equal X and Y accelerations: the junction vector's limit is a / max|component|.
    junction = (out - prev) / np.linalg.norm(out - prev)
    a_j = 1500.0 / np.max(np.abs(junction[:2]))
    v = math.sqrt(junction_speed_sqr(prev, out, ACCEL, 0.01))
    assert v == pytest.approx(closed_form(a_j, 0.01, theta), rel=1e-12)


def test_junction_limits_straight_and_reversal():
    x = np.array([1.0, 0.0, 0.0])
    assert junction_speed_sqr(x, x, ACCEL, 0.01) == math.inf
    assert junction_speed_sqr(x, -x, ACCEL, 0.01) == 0.0


def test_acceleration_and_speed_are_limited_per_axis():
    diagonal = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    assert limit_by_axes(ACCEL, diagonal) == pytest.approx(1500.0 * math.sqrt(2))
    assert limit_by_axes(ACCEL, np.array([0.0, 0.0, 1.0])) == 500.0


@pytest.mark.parametrize("theta_deg", [45.0, 90.0, 135.0])
def test_emulated_machine_turns_corners_at_the_junction_speed(theta_deg):
    """Two long lines: the machine's speed at the corner is the closed form's (the lines are
    long enough for the look-ahead not to matter and the nominal speed is higher)."""
    theta = math.radians(theta_deg)
    corner = np.array([100.0, 100.0])
    end = corner + 80 * np.array([-math.cos(theta), math.sin(theta)])
    lines = ["G21 G90", "G0 X20 Y100", f"G1 X{corner[0]} Y{corner[1]} F12000",
             f"G1 X{end[0]:.6f} Y{end[1]:.6f}"]
    plan = simulate(lines, samples=True)
    t, xy = plan.samples[:, 0], plan.samples[:, 1:3]
    keep = np.concatenate(([True], np.diff(t) > 1e-9))
    t, xy = t[keep], xy[keep]
    speed = np.linalg.norm(np.diff(xy, axis=0), axis=1) / np.diff(t)
    mid = 0.5 * (xy[1:] + xy[:-1])
    near = np.linalg.norm(mid - corner, axis=1) < 0.5
    out = np.array([-math.cos(theta), math.sin(theta), 0.0])
    prev = np.array([1.0, 0.0, 0.0])
    junction = (out - prev) / np.linalg.norm(out - prev)
    expected = closed_form(1500.0 / np.max(np.abs(junction[:2])), 0.01, theta)
    # Samples 4 ms apart straddle the corner: the slowest chord is within a(4 ms) of it.
    assert speed[near].min() == pytest.approx(expected, abs=1500.0 * 0.004)


@settings(max_examples=60, deadline=None)
@given(v0=st.floats(0, 150), d=st.floats(0.01, 50), vn=st.floats(1, 200),
       ve=st.floats(0, 150), a=st.floats(50, 5000))
def test_profile_steps_add_up_to_the_profile(v0, d, vn, ve, a):
    ve = min(ve, math.sqrt(v0 * v0 + 2 * a * d), vn)
    v0 = min(v0, vn)
    total = profile_time(v0, d, vn, ve, a)
    moved, t, v = 0.0, 0.0, v0
    for _ in range(100000):
        ds, v, tau, done = profile_step(v, d - moved, vn, ve, a, 0.003)
        moved += ds
        t += tau
        if done:
            break
    assert moved == pytest.approx(d, rel=1e-6, abs=1e-9)
    assert t == pytest.approx(total, rel=1e-3, abs=1e-6)


def test_lookahead_plans_a_stop_at_the_last_block_and_respects_acceleration():
    planner = Planner(ACCEL, [200.0, 200.0, 50.0], 0.01)
    start = np.zeros(3)
    for k in range(BLOCK_BUFFER):
        target = np.array([10.0 * (k + 1), 5.0 * (k % 2), 0.0])
        planner.add(start, target, 150.0)
        start = target
    assert planner.full
    blocks = list(planner.blocks)
    for b, nxt in itertools.pairwise(blocks):
        assert nxt.entry_sqr <= b.entry_sqr + 2 * b.accel * b.length + 1e-9
        assert b.entry_sqr <= nxt.entry_sqr + 2 * b.accel * b.length + 1e-9
        assert nxt.entry_sqr <= nxt.max_entry_sqr + 1e-9
    assert blocks[-1].entry_sqr <= 2 * blocks[-1].accel * blocks[-1].length + 1e-9


def test_machine_accepts_no_line_while_a_dwell_runs_and_reports_state():
    m = GrblMachine()
    m.take_line("G4 P0.5")
    m.pump()
    # GRBL 1.1h mc_dwell: the planner is empty, so the state is Idle while it waits.
    assert not m.accepts_line() and m.state == "Idle" and m.outbox[-1] != "ok"
    m.advance(0.6)
    m.pump()
    assert m.accepts_line() and m.state == "Idle" and m.outbox[-1] == "ok"


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(st.floats(1, 250), st.floats(1, 250)), min_size=2, max_size=10),
       st.floats(1200, 12000).map(lambda f: round(f, 1)))
def test_executed_motion_respects_speed_and_acceleration_limits(points, feed_mm_min):
    """The machine's motion, sampled every few ms: its speed never above the feed (nor the
    rapid rate), its speed never changing faster than the largest block acceleration."""
    lines = ["G21 G90"] + [f"G1 X{x:.3f} Y{y:.3f} F{feed_mm_min:.1f}" for x, y in points]
    plan = simulate(lines, samples=True)
    t, xy = plan.samples[:, 0], plan.samples[:, 1:3]
    dt = np.diff(t)
    keep = dt > 1e-6
    speed = np.linalg.norm(np.diff(xy, axis=0), axis=1)[keep] / dt[keep]
    assert np.all(speed <= feed_mm_min / 60.0 * (1 + 1e-6) + 1e-6)
    mid_t = 0.5 * (t[1:] + t[:-1])[keep]
    accel = np.abs(np.diff(speed)) / np.maximum(np.diff(mid_t), 1e-9)
    assert np.all(accel <= 1500.0 * math.sqrt(2) * (1 + 1e-3) + 1e-3)
    # GRBL plans whole steps (plan_buffer_line: lround of target x steps/mm): the motion ends
    # on the step nearest the target as the G-code gives it (3 decimals)
    spm = np.array([DEFAULT_SETTINGS[100], DEFAULT_SETTINGS[101]])
    target = np.array([float(f"{v:.3f}") for v in points[-1]])
    assert xy[-1] == pytest.approx(np.floor(target * spm + 0.5) / spm, abs=1e-9)
