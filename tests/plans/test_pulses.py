"""Timing "pulses": key-points at a recording's speed minima and peaks, with its times and
kinematic states."""

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
        at = np.argmin(np.abs(stroke.t - trace.t[b]))  # (the step the key-point lands on)
        there = [np.interp(stroke.t[at], trace.t, trace.pos[:, k]) for k in range(2)]
        assert np.linalg.norm(stroke.pos[at] - there) < 0.1  # (the hand's place at that time)
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


# -- the key-points' states (issue 25: a restyle keeps the recording's speed peaks) -----------

CENTRES = (0.13, 0.33, 0.45, 0.63, 0.81, 0.95)
WIDTHS = (0.23, 0.23, 0.19, 0.24, 0.21, 0.21)
HEIGHTS = (20.0, 20.0, 35.0, 26.0, 21.0, 30.0)


def pulse_train(noise_mm: float = 0.0, rate: float = 300.0) -> Trajectory:
    """Six overlapping minimum-jerk speed pulses (CENTRES, WIDTHS [s], HEIGHTS [mm/s] times
    30/16 at the top) along a path turning by 1 rad every 11 mm, rest to rest, sampled at
    ``rate`` [Hz] as LASA is (about 3 ms), positions with white noise of ``noise_mm``: its
    10 Hz speed has six peaks (two of them where the pulses overlap, 35-75 % of the top)."""
    t = np.arange(CENTRES[0] - WIDTHS[0] / 2, CENTRES[-1] + WIDTHS[-1] / 2, 1 / rate)
    speed = np.zeros_like(t)
    for centre, width, height in zip(CENTRES, WIDTHS, HEIGHTS):
        s = np.clip((t - centre) / width + 0.5, 0.0, 1.0)
        speed += height * 30 * s**2 * (1 - s) ** 2
    heading = np.cumsum(speed) / rate / 11.0
    pos = np.cumsum(speed[:, None] * np.column_stack([np.cos(heading), np.sin(heading)]),
                    axis=0) / rate
    pos += noise_mm * np.random.default_rng(0).standard_normal(pos.shape)
    return Trajectory(t - t[0], pos)


def test_the_key_points_are_the_peaks_and_minima_the_measure_counts():
    from inkarm.analysis.humanlike import stroke_stats
    from inkarm.analysis.kinematics import speed_pulses

    trace = pulse_train(noise_mm=0.01)  # (noise: the raw speed has many more maxima)
    pulses = speed_pulses(lowpass(trace, 10.0))
    assert stroke_stats(trace, lognormal=False).peaks == len(pulses) == 6
    assert speed_peaks(trace) > 6
    inner_minima = [p.end for p in pulses[:-1]]
    expected = sorted({0, trace.n - 1, *inner_minima, *(p.peak for p in pulses)})
    assert pulse_breakpoints(trace).tolist() == expected


def test_key_points_take_the_recordings_state_at_their_steps_before_the_measures_low_pass():
    from inkarm.analysis.kinematics import acceleration
    from inkarm.plans.pulses import ACCELERATION_VARIANCE, KEYPOINT_HZ, pulse_references

    trace = pulse_train(noise_mm=0.01)
    cuts = pulse_breakpoints(trace)
    plan = pulse_plan(trace, cuts, np.repeat(0.01 * np.eye(2)[None], len(cuts), axis=0), 0.005)
    steps = np.array(plan.meta["pulse_steps"])
    assert np.max(np.abs(steps * 0.005 - trace.t[cuts])) > 0.001  # (the samples lie between steps)
    smooth = lowpass(trace, KEYPOINT_HZ)

    def at_steps(values):  # the oracle: each coordinate interpolated at the steps' times
        return np.column_stack([np.interp(steps * 0.005, trace.t, values[:, k])
                                for k in range(2)])

    np.testing.assert_allclose(np.asarray(plan.velocities)[steps], at_steps(smooth.velocity()))
    np.testing.assert_allclose(plan.targets.means[steps], at_steps(smooth.pos))
    accelerations = np.array(plan.meta["pulse_accelerations"])
    np.testing.assert_allclose(accelerations, at_steps(acceleration(smooth)))
    (ref,) = pulse_references(plan, order=3)
    assert ref.derivative == 2 and ref.steps.tolist() == steps.tolist()
    np.testing.assert_allclose(ref.value, accelerations)
    np.testing.assert_allclose(ref.precision, np.eye(2) / ACCELERATION_VARIANCE)
    assert pulse_references(plan, order=2) == ()  # (an order-2 state has no acceleration)


def test_a_restyle_measured_as_its_recording_has_its_six_peaks_where_they_are():
    from inkarm.analysis.humanlike import stroke_stats
    from inkarm.analysis.kinematics import speed_peak_indices
    from inkarm.plans.handstyles import FITTED

    trace = pulse_train()
    cfg = RestyleConfig.from_handstyle(FITTED["human"])
    stroke = restyle(Drawing([trace]), cfg).drawing.strokes[0]
    recorded = trace.t[speed_peak_indices(lowpass(trace, 10.0))]
    smooth = lowpass(stroke, 10.0)
    restyled = smooth.t[speed_peak_indices(smooth)]
    assert stroke_stats(stroke, lognormal=False).peaks == stroke_stats(trace, lognormal=False).peaks
    assert len(restyled) == len(recorded) == 6
    assert np.max(np.abs(restyled - recorded)) <= 0.01  # [s]: two steps of the restyle
