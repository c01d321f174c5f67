"""Timing "pulses": key-points at a recording's speed minima, at its times and speeds."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.analysis.kinematics import lowpass, speed_peaks
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.plans.handstyles import Handstyle
from inkarm.plans.pulses import FREE_VARIANCE, control_weight, pulse_breakpoints, pulse_plan
from inkarm.plans.restyle import RestyleConfig, restyle

RATE = 200.0


def zigzag(durations=(0.3, 0.4, 0.25), legs=((30.0, 0.0), (0.0, 20.0), (-25.0, 5.0))):
    """Minimum-jerk legs one after the other (speed 0 where one ends and the next starts):
    (trace, the sample indices of the leg boundaries)."""
    t_all, p_all, bounds, t0, p0 = [], [], [0], 0.0, np.zeros(2)
    for duration, leg in zip(durations, legs):
        s = np.arange(1, round(duration * RATE) + 1) / (duration * RATE)
        shape = 10 * s**3 - 15 * s**4 + 6 * s**5
        t_all.append(t0 + s * duration)
        p_all.append(p0 + shape[:, None] * np.asarray(leg))
        t0, p0 = t0 + duration, p0 + np.asarray(leg)
        bounds.append(bounds[-1] + len(s))
    t = np.concatenate([[0.0], *t_all])
    pos = np.vstack([np.zeros((1, 2)), *p_all])
    return Trajectory(t, pos), np.array(bounds)


def test_breakpoints_are_the_ends_the_speed_minima_and_the_peaks():
    trace, bounds = zigzag()
    peaks = (bounds[:-1] + bounds[1:]) // 2  # a minimum-jerk leg peaks half way
    expected = np.sort(np.concatenate([bounds, peaks]))
    found = pulse_breakpoints(trace)
    assert len(found) == len(expected)
    assert np.all(np.abs(found - expected) <= 3)  # 15 ms at 200 Hz (the low-pass smears a stop)


def test_the_restyle_passes_each_minimum_at_its_time_and_keeps_the_pulses():
    trace, _ = zigzag()
    # order 3: minimum jerk between the minima, one bell a leg (a higher order may dip inside a
    # long leg)
    hand = Handstyle("h", h=0.01, d=1.0, order=3, timing="pulses")
    cfg = RestyleConfig.from_handstyle(hand, dt=0.01)
    out = restyle(Drawing([trace]), cfg)
    stroke = out.drawing.strokes[0]
    assert stroke.duration == pytest.approx(trace.duration, abs=0.011)
    for b in out.targets[0].breakpoints:
        at = np.argmin(np.abs(stroke.t - trace.t[b]))
        assert np.linalg.norm(stroke.pos[at] - trace.pos[b]) < 0.5
    assert speed_peaks(lowpass(stroke, 10.0)) == speed_peaks(lowpass(trace, 10.0)) == 3


def test_plan_has_key_points_at_the_minima_and_is_free_between():
    trace, _ = zigzag()
    cuts = np.array([0, 60, 61, trace.n - 1])  # two minima one sample (5 ms) apart
    covs = np.repeat(0.04 * np.eye(2)[None], len(cuts), axis=0)
    plan = pulse_plan(trace, cuts, covs, dt=0.01)
    steps = np.array(plan.meta["pulse_steps"])
    assert np.all(np.diff(steps) >= 1)  # closer than a step: moved one step on
    assert steps[0] == 0 and steps[-1] == round(trace.duration / 0.01)
    variances = np.array([tg.cov[0, 0] for tg in plan.targets])
    assert np.all(variances[steps] == 0.04)
    assert np.all(variances[np.setdiff1d(np.arange(len(variances)), steps)] == FREE_VARIANCE)
    velocities = np.asarray(plan.velocities)
    assert np.isfinite(velocities[steps]).all()
    assert np.isnan(np.delete(velocities, steps, axis=0)).all()
    assert plan.keypoints


def test_control_weight_is_the_isochronous_one():
    # m targets over T: omega = 2 pi m / T (seed 000 eq. 9-10)
    assert control_weight(4, 2.0, 3.0, 6) == pytest.approx(1.0 / ((2 * np.pi * 2.0) ** 4 * 2.0) ** 2)


def test_timing_names_are_checked():
    with pytest.raises(InputError, match=r"timing.*expected one of \('isochronous', 'pulses'\)"):
        RestyleConfig(timing="human")
    with pytest.raises(Exception, match="timing must be one of isochronous, pulses, got 'x'"):
        Handstyle("h", timing="x")


def test_a_human_style_restyles_at_its_own_step_unless_told():
    hand = Handstyle("h", h=0.01, d=1.0, order=3, timing="pulses")
    assert RestyleConfig.from_handstyle(hand).dt == 0.005
    assert RestyleConfig.from_handstyle(hand, dt=0.01).dt == 0.01


def test_a_step_too_coarse_for_the_key_points_is_refused():
    trace, _ = zigzag()
    with pytest.raises(InputError, match=r"dt: a step of 0.5 s is too coarse for the "
                                         r"recording's key-points"):
        restyle(Drawing([trace]), RestyleConfig(timing="pulses", dt=0.5))


def test_pulses_need_an_order_that_has_velocities():
    with pytest.raises(InputError, match="order: timing 'pulses' constrains velocities at its "
                                         "key-points: expected an order of 2 or more, got 1"):
        RestyleConfig(timing="pulses", order=1)
