"""Minimum-jerk trajectories: closed forms, via-point timing against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.polynomial import Polynomial

from inkarm.errors import InputError
from inkarm.models import minjerk as mj

coord = st.floats(-100.0, 100.0, allow_nan=False)


def test_point_to_point_peak_speed_is_1875_amplitude_over_time_at_half_time():
    start, end, tf = np.array([10.0, -5.0]), np.array([70.0, 75.0]), 0.8
    traj = mj.point_to_point(start, end, tf, dt=0.001)
    speed = traj.speed()
    amplitude = np.linalg.norm(end - start)
    assert speed.max() == pytest.approx(1.875 * amplitude / tf, rel=1e-9)
    assert mj.peak_speed(amplitude, tf) == pytest.approx(1.875 * amplitude / tf)
    assert traj.t[np.argmax(speed)] == pytest.approx(tf / 2, abs=1e-3)


def test_point_to_point_boundary_conditions_and_exact_velocity():
    traj = mj.point_to_point([0.0, 0.0], [50.0, 20.0], 1.2, dt=0.005)
    np.testing.assert_allclose(traj.pos[0], [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(traj.pos[-1], [50.0, 20.0], atol=1e-12)
    np.testing.assert_allclose(traj.vel[[0, -1]], 0.0, atol=1e-12)
    assert traj.t[-1] == pytest.approx(1.2)
    # the stored velocity is the derivative of the stored positions
    fd = np.gradient(traj.pos, traj.t, axis=0, edge_order=2)
    np.testing.assert_allclose(traj.vel[1:-1], fd[1:-1], atol=2e-2)  # O(dt^2) error


def test_minimum_jerk_profile_is_eq_3_1_with_rest_at_both_ends():
    ends = np.array([0.0, 1.0])
    np.testing.assert_allclose(mj.minimum_jerk_profile(ends), [0.0, 1.0])
    np.testing.assert_allclose(mj.minimum_jerk_profile(ends, 1), 0.0)
    np.testing.assert_allclose(mj.minimum_jerk_profile(ends, 2), 0.0)
    # seed 002 eq. 3.1 as printed: x0 + (x0 - xf)(15 tau^4 - 6 tau^5 - 10 tau^3)
    tau = np.linspace(0, 1, 11)
    printed = 0.0 + (0.0 - 1.0) * (15 * tau**4 - 6 * tau**5 - 10 * tau**3)
    np.testing.assert_allclose(mj.minimum_jerk_profile(tau), printed, atol=1e-15)
    # the control loop's profile on n samples, bit for bit
    loop = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    np.testing.assert_array_equal(mj.minimum_jerk_profile(tau), loop)


def test_minimum_jerk_profile_derivatives_are_those_of_the_quintic():
    tau = np.linspace(0.0, 1.0, 7)
    s = Polynomial([0, 0, 0, 10, -15, 6])
    for k in range(4):
        np.testing.assert_allclose(mj.minimum_jerk_profile(tau, k), s.deriv(k)(tau), atol=1e-12)
    assert mj.minimum_jerk_profile(np.zeros((2, 3))).shape == (2, 3)


def test_minimum_jerk_profile_is_at_rest_outside_the_movement():
    outside = np.array([-0.5, 1.5])
    np.testing.assert_array_equal(mj.minimum_jerk_profile(outside), [0.0, 1.0])
    for k in (1, 2, 3):
        np.testing.assert_array_equal(mj.minimum_jerk_profile(outside, k), 0.0)


def test_minimum_jerk_profile_errors():
    with pytest.raises(InputError, match="derivative: expected 0, 1, 2 or 3, got 4") as info:
        mj.minimum_jerk_profile(0.5, 4)
    assert info.value.key == "derivative"
    with pytest.raises(InputError, match="tau: contains NaN"):
        mj.minimum_jerk_profile([0.1, np.nan])


def test_point_to_point_spline_jerk_cost_is_720_a2_over_t5():
    spline = mj.min_jerk_spline([[0.0, 0.0], [30.0, 40.0]], 0.5)
    assert spline.jerk_cost() == pytest.approx(720 * 50.0**2 / 0.5**5, rel=1e-10)


def test_via_point_trajectory_passes_through_via_with_rest_ends_and_c4_joint():
    points = np.array([[0.0, 0.0], [30.0, 50.0], [100.0, 0.0]])
    spline = mj.min_jerk_spline(points, 2.0, via_times=[0.7])
    np.testing.assert_allclose(spline.evaluate(np.array([0.0, 0.7, 2.0])), points, atol=1e-9)
    for derivative in (1, 2):
        np.testing.assert_allclose(
            spline.evaluate(np.array([0.0, 2.0]), derivative), 0.0, atol=1e-8
        )
    eps = 1e-7
    for derivative in (1, 2, 3, 4):
        left = spline.evaluate(np.array([0.7 - eps]), derivative)
        right = spline.evaluate(np.array([0.7 + eps]), derivative)
        np.testing.assert_allclose(left, right, rtol=1e-4, atol=1e-3)


def test_closed_form_via_cost_matches_piecewise_quintic_cost():
    points = np.array([[0.0, 0.0], [20.0, 35.0], [80.0, 10.0]])
    for t_via in (0.3, 0.9, 1.4):
        spline = mj.min_jerk_spline(points, 1.6, via_times=[t_via])
        closed = mj.via_jerk_cost(*points, 1.6, t_via)
        assert spline.jerk_cost() == pytest.approx(closed, rel=1e-9)


def test_symmetric_via_point_is_passed_at_half_time():
    t1 = mj.optimal_via_time([0.0, 0.0], [50.0, 30.0], [100.0, 0.0], 1.0)
    assert t1 == pytest.approx(0.5, abs=1e-9)


def test_via_time_polynomial_is_degree_nine_and_equals_the_derivative_numerator():
    start, via, end = np.array([1.0, 2.0]), np.array([30.0, 50.0]), np.array([90.0, -10.0])
    poly = mj.via_time_polynomial(start, via, end)
    assert poly.degree() == 9
    # rebuild it from J(tau) = 720|v|^2 + 20 |a|^2 / w:  tau(1-tau) d|a|^2 - 5 |a|^2 (1-2tau), / 5
    u, v = via - start, end - start
    s = Polynomial([0, 0, 0, 10, -15, 6])
    a2 = sum((Polynomial([ui]) - vi * s) ** 2 for ui, vi in zip(u, v))
    numerator = (Polynomial([0, 1, -1]) * a2.deriv() - 5 * a2 * Polynomial([1, -2])) / 5
    np.testing.assert_allclose(numerator.coef[:10], poly.coef, rtol=1e-10, atol=1e-6)
    assert np.all(np.abs(numerator.coef[10:]) < 1e-6)  # the degree-10 and 11 terms cancel


@settings(max_examples=25, deadline=None)
@given(vx=coord, vy=coord, ex=coord, ey=coord)
def test_optimal_via_time_beats_a_brute_force_scan(vx, vy, ex, ey):
    start, via, end = np.zeros(2), np.array([vx, vy]), np.array([ex, ey])
    if min(np.linalg.norm(via), np.linalg.norm(via - end)) < 1.0:
        return  # via on an end point: no interior optimum (tested separately)
    tf = 1.5
    t1 = mj.optimal_via_time(start, via, end, tf)
    best = mj.via_jerk_cost(start, via, end, tf, t1)
    scan = np.linspace(0.005, 0.995, 397) * tf
    costs = [mj.via_jerk_cost(start, via, end, tf, t) for t in scan]
    assert best <= min(costs) * (1 + 1e-9)
    # and the best scan point is next to the optimum (cost is smooth in t1)
    assert abs(scan[int(np.argmin(costs))] - t1) <= 2 * (scan[1] - scan[0])


def test_optimal_via_time_agrees_with_numerical_search_and_piecewise_cost_scan():
    points = np.array([[0.0, 0.0], [70.0, 60.0], [100.0, 0.0]])
    t_poly = mj.optimal_via_time(*points, 2.0)
    # brute force on the piecewise-quintic solution itself (independent of the closed form)
    scan = np.linspace(0.02, 1.98, 393)
    costs = [mj.min_jerk_spline(points, 2.0, [t]).jerk_cost() for t in scan]
    assert t_poly == pytest.approx(scan[int(np.argmin(costs))], abs=2 * (scan[1] - scan[0]))
    # the numerical search used for several via-points finds the same time for one
    t_num = mj._optimal_times(points, 2.0)
    assert t_num[0] == pytest.approx(t_poly, abs=1e-4)


def test_several_via_points_default_times_minimise_the_cost():
    points = np.array([[0.0, 0.0], [20.0, 40.0], [60.0, 45.0], [100.0, 0.0]])
    spline = mj.min_jerk_spline(points, 2.0)
    np.testing.assert_allclose(spline.evaluate(spline.times), points, atol=1e-8)
    best = spline.jerk_cost()
    rng = np.random.default_rng(3)
    for _ in range(30):
        times = np.sort(spline.times[1:-1] + rng.normal(0, 0.05, 2))
        if times[0] <= 0 or times[1] >= 2.0 or times[1] - times[0] <= 0:
            continue
        assert mj.min_jerk_spline(points, 2.0, times).jerk_cost() >= best * (1 - 1e-9)


def test_via_points_trajectory_samples_the_spline():
    traj = mj.via_points([[0.0, 0.0], [30.0, 50.0], [100.0, 0.0]], 2.0, via_times=[1.0], dt=0.01)
    assert traj.t[0] == 0.0 and traj.t[-1] == pytest.approx(2.0)
    np.testing.assert_allclose(traj.pos[100], [30.0, 50.0], atol=1e-9)


def test_errors_name_the_argument():
    with pytest.raises(InputError, match="duration: must be a positive number"):
        mj.point_to_point([0, 0], [1, 0], 0.0)
    with pytest.raises(InputError, match="end: has 3 coordinates, expected 2"):
        mj.point_to_point([0, 0], [1, 0, 0], 1.0)
    with pytest.raises(InputError, match="start: NaN or inf"):
        mj.point_to_point([np.nan, 0], [1, 0], 1.0)
    with pytest.raises(InputError, match="dt: must be a positive number"):
        mj.point_to_point([0, 0], [1, 0], 1.0, dt=-1)
    with pytest.raises(InputError, match="t_via: must lie strictly inside"):
        mj.via_jerk_cost([0, 0], [1, 1], [2, 0], 1.0, 1.0)
    with pytest.raises(InputError, match="via: coincides with the start or end point"):
        mj.optimal_via_time([0, 0], [2, 0], [2, 0], 1.0)
    with pytest.raises(InputError, match="via_times: expected 1 times for 1 via-points, got 2"):
        mj.min_jerk_spline([[0, 0], [1, 1], [2, 0]], 1.0, via_times=[0.2, 0.4])
    with pytest.raises(InputError, match="via_times: must increase strictly inside"):
        mj.min_jerk_spline([[0, 0], [1, 1], [2, 0], [3, 3]], 1.0, via_times=[0.6, 0.4])
    with pytest.raises(InputError, match=r"points: expected shape \(m >= 2"):
        mj.min_jerk_spline([[0, 0]], 1.0)
