"""Speed pulses, their asymmetry, the normalised jerk and the low-pass of
inkarm.analysis.kinematics (issue 25), against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.analysis.kinematics import (
    lowpass,
    normalised_jerk,
    path_length,
    speed_peak_indices,
    speed_pulses,
)
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.minjerk import point_to_point


def lognormal_line(t: np.ndarray, d: float, t0: float, mu: float, sigma: float) -> Trajectory:
    """A straight stroke along x whose speed is one lognormal pulse."""
    from scipy.special import erf

    x = np.clip(t - t0, 1e-300, None)
    s = d * 0.5 * (1 + erf((np.log(x) - mu) / (sigma * math.sqrt(2))))
    return Trajectory(t=t, pos=np.column_stack([s, np.zeros_like(s)]))


def minimum_jerk_line(length: float, duration: float, n: int = 4001) -> Trajectory:
    t = np.linspace(0.0, duration, n)
    tau = t / duration
    s = length * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    return Trajectory(t=t, pos=np.column_stack([s, 0.5 * s]))


def test_minimum_jerk_point_to_point_has_normalised_jerk_sqrt_360():
    # cost 720 A^2 / T^5 (Flash and Hogan) -> sqrt(0.5 * 720) whatever the size and duration
    for length, duration in ((10.0, 0.5), (80.0, 2.0)):
        assert normalised_jerk(minimum_jerk_line(length, duration)) == pytest.approx(
            math.sqrt(360.0), rel=2e-3)


def test_normalised_jerk_refuses_a_still_pen():
    still = Trajectory(t=np.linspace(0, 1, 20), pos=np.ones((20, 2)))
    with pytest.raises(InputError, match="does not move"):
        normalised_jerk(still)


def test_a_lognormal_pulse_peaks_at_its_mode_and_rises_faster_than_it_falls():
    t0, mu, sigma = -0.05, math.log(0.25), 0.25
    t = np.arange(0.0, 1.2, 0.001)
    traj = lognormal_line(t, 40.0, t0, mu, sigma)
    (pulse,) = speed_pulses(traj)
    mode = t0 + math.exp(mu - sigma**2)
    assert t[pulse.peak] == pytest.approx(mode, abs=1e-3)
    assert (pulse.start, pulse.end) == (0, t.size - 1)
    assert pulse.asymmetry(t) == pytest.approx((mode - t[0]) / (t[-1] - t[0]), abs=1e-3)
    assert pulse.asymmetry(t) < 0.5


def test_minimum_jerk_pulses_are_symmetric_and_split_at_the_speed_minimum():
    one = minimum_jerk_line(10.0, 1.0, 1001)
    two = Trajectory(t=np.concatenate([one.t, one.t[1:] + 1.0]),
                     pos=np.vstack([one.pos, one.pos[1:] + one.pos[-1]]))
    pulses = speed_pulses(two)
    assert len(pulses) == 2
    assert pulses[0].end == pulses[1].start
    assert two.t[pulses[0].end] == pytest.approx(1.0, abs=2e-3)
    for p in pulses:
        assert p.asymmetry(two.t) == pytest.approx(0.5, abs=2e-3)
    # n stop-and-go minimum-jerk movements: sqrt(360) n^2 (cost n 720 A^2 / tau^5, T = n tau,
    # L = n A)
    assert normalised_jerk(two) == pytest.approx(math.sqrt(360.0) * 4, rel=5e-3)


def test_peak_indices_agree_with_the_count_and_refuse_a_bad_threshold():
    traj = minimum_jerk_line(10.0, 1.0, 501)
    assert list(speed_peak_indices(traj)) == [250]
    assert speed_pulses(Trajectory(t=np.linspace(0, 1, 9), pos=np.zeros((9, 2)))) == []
    with pytest.raises(InputError, match=r"expected a fraction in \[0, 1\), got 1.5") as e:
        speed_peak_indices(traj, 1.5)
    assert e.value.key == "threshold"


def test_lowpass_removes_fast_tremor_and_keeps_the_slow_movement():
    t = np.arange(0.0, 2.0, 0.002)
    slow = np.column_stack([20 * np.sin(2 * math.pi * t), 10 * np.cos(2 * math.pi * t)])
    tremor = 0.2 * np.sin(2 * math.pi * 60 * t)[:, None]
    smooth = lowpass(Trajectory(t=t, pos=slow + tremor), 10.0)
    inner = slice(100, -100)  # away from the filter's edges
    assert np.max(np.abs(smooth.pos[inner] - slow[inner])) < 0.02
    assert smooth.vel is None


def test_lowpass_leaves_what_it_cannot_filter_and_refuses_bad_settings():
    coarse = minimum_jerk_line(10.0, 1.0, 11)  # 10 Hz sampling: Nyquist 5 Hz below the cutoff
    assert lowpass(coarse, 10.0) is coarse
    short = Trajectory(t=np.arange(5) * 0.001, pos=np.zeros((5, 2)))
    assert lowpass(short, 10.0) is short
    with pytest.raises(InputError, match="expected a positive frequency in Hz, got -1"):
        lowpass(coarse, -1.0)
    with pytest.raises(InputError, match="lowpass order: expected 1 to 8, got 0"):
        lowpass(coarse, 10.0, order=0)


def test_path_length_of_a_polyline():
    traj = Trajectory(t=np.arange(3.0), pos=np.array([[0, 0], [3, 4], [3, 10]], dtype=float))
    assert path_length(traj) == pytest.approx(11.0)


def test_the_model_of_minjerk_has_the_same_normalised_jerk():
    # the library's own minimum-jerk model gives the same closed-form value
    traj = point_to_point([0.0, 0.0], [30.0, 40.0], 1.0, dt=0.0005)
    assert normalised_jerk(traj) == pytest.approx(math.sqrt(360.0), rel=5e-3)


def test_a_prominence_keeps_only_the_peaks_that_stand_out():
    # a bell with a 1 % ripple: 1 peak at 2 % prominence, many without
    t = np.linspace(0.0, 1.0, 2001)
    bell = 30 * np.sin(math.pi * t) ** 2 * (1 + 0.01 * np.sin(2 * math.pi * 20 * t))
    pos = np.column_stack([np.concatenate([[0.0], np.cumsum(bell[1:] * np.diff(t))]),
                           np.zeros_like(t)])
    traj = Trajectory(t=t, pos=pos)
    assert speed_peak_indices(traj).size == 3  # the ripple makes maxima near the top
    assert speed_peak_indices(traj, prominence=0.02).size == 1
    assert len(speed_pulses(traj, prominence=0.02)) == 1
    with pytest.raises(InputError, match=r"prominence: expected a fraction in \[0, 1\), got 2"):
        speed_peak_indices(traj, prominence=2.0)
