"""The sigma-lognormal fit of a speed profile (inkarm.analysis.lognormal), on profiles made of
known lognormals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.analysis.kinematics import speed
from inkarm.analysis.lognormal import (
    Lognormal,
    LognormalFit,
    fit_sigma_lognormal,
    initial_guess,
    snr_db,
)
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError


def stroke_of(pulses: list[Lognormal], t: np.ndarray, turn: float = 0.0) -> Trajectory:
    """A stroke whose speed is the sum of ``pulses``, each along its own direction (pulse i
    at angle i * turn), positions integrated exactly enough (cumulative trapezoid, fine t)."""
    vel = np.zeros((t.size, 2))
    for i, p in enumerate(pulses):
        vel += np.outer(p.speed(t), [math.cos(i * turn), math.sin(i * turn)])
    steps = 0.5 * (vel[1:] + vel[:-1]) * np.diff(t)[:, None]
    pos = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    return Trajectory(t=t, pos=pos, vel=vel)


def test_one_lognormal_is_recovered_with_its_parameters():
    truth = Lognormal(d=40.0, t0=-0.05, mu=math.log(0.25), sigma=0.25)
    t = np.arange(0.0, 1.0, 0.002)
    fit = fit_sigma_lognormal(stroke_of([truth], t))
    (p,) = fit.pulses
    assert p.d == pytest.approx(40.0, rel=1e-3)
    assert p.mu == pytest.approx(truth.mu, abs=1e-3)
    assert p.sigma == pytest.approx(0.25, abs=1e-3)
    assert p.t0 == pytest.approx(-0.05, abs=1e-3)
    assert fit.snr_db > 60


def test_two_overlapping_pulses_reconstruct_the_speed():
    truth = [Lognormal(20.0, 0.0, math.log(0.2), 0.3), Lognormal(30.0, 0.25, math.log(0.25), 0.25)]
    t = np.arange(0.002, 1.2, 0.002)
    traj = stroke_of(truth, t)  # collinear: the speeds add exactly
    fit = fit_sigma_lognormal(traj)
    assert len(fit.pulses) == 2
    assert fit.snr_db > 40
    assert sorted(p.d for p in fit.pulses) == pytest.approx([20.0, 30.0], rel=0.02)
    peaks = sorted(p.peak_time for p in fit.pulses)
    assert peaks == pytest.approx(sorted(p.peak_time for p in truth), abs=5e-3)


def test_a_minimum_jerk_pulse_is_fitted_less_well_than_a_lognormal():
    t = np.linspace(0.0, 1.0, 501)
    s = 10 * t**3 - 15 * t**4 + 6 * t**5
    mj = Trajectory(t=t, pos=np.column_stack([30 * s, np.zeros_like(s)]))
    fit = fit_sigma_lognormal(mj)
    assert 15 < fit.snr_db < 60  # a bell, but symmetric: a lognormal fits it only roughly


def test_initial_guess_peaks_on_the_pulse_and_carries_its_area():
    truth = Lognormal(40.0, -0.05, math.log(0.25), 0.25)
    t = np.arange(0.0, 1.0, 0.002)
    (guess,) = initial_guess(stroke_of([truth], t))
    assert guess.peak_time == pytest.approx(truth.peak_time, abs=3e-3)
    assert guess.d == pytest.approx(40.0, rel=0.01)


def test_snr_closed_form_and_exact():
    t = np.linspace(0.0, 1.0, 101)
    v = np.ones_like(t)
    assert snr_db(v, 0.9 * v, t) == pytest.approx(20.0)  # noise 1 % of the energy
    assert snr_db(v, v, t) == math.inf
    with pytest.raises(InputError, match="the speed is zero throughout"):
        snr_db(np.zeros_like(t), v, t)


def test_the_fit_speed_sums_its_pulses():
    a, b = Lognormal(1.0, 0.0, -1.0, 0.3), Lognormal(2.0, 0.1, -1.2, 0.4)
    t = np.linspace(-0.1, 1.0, 50)
    assert LognormalFit((a, b), 0.0).speed(t) == pytest.approx(a.speed(t) + b.speed(t))
    assert np.all(a.speed(t[t <= 0.0]) == 0.0)


def test_a_constant_speed_stroke_has_no_pulse_to_fit():
    t = np.linspace(0.0, 1.0, 50)
    line = Trajectory(t=t, pos=np.column_stack([10 * t, 0 * t]))
    assert np.ptp(speed(line)) < 1e-9
    with pytest.raises(InputError, match="the speed has no peak to fit"):
        fit_sigma_lognormal(line)
