"""Minimum-jerk trajectories (inkarm.models.minjerk, minjerk_spline, minjerk_timing): closed
forms, via-point timing against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.polynomial import Polynomial

from inkarm.errors import InputError
from inkarm.models import minjerk as mj
from inkarm.models import minjerk_spline as mjs
from inkarm.models import minjerk_timing as mjt

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
    spline = mjs.min_jerk_spline([[0.0, 0.0], [30.0, 40.0]], 0.5)
    assert spline.jerk_cost() == pytest.approx(720 * 50.0**2 / 0.5**5, rel=1e-10)


def test_via_point_trajectory_passes_through_via_with_rest_ends_and_c4_joint():
    points = np.array([[0.0, 0.0], [30.0, 50.0], [100.0, 0.0]])
    spline = mjs.min_jerk_spline(points, 2.0, via_times=[0.7])
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
        spline = mjs.min_jerk_spline(points, 1.6, via_times=[t_via])
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
    costs = [mjs.min_jerk_spline(points, 2.0, [t]).jerk_cost() for t in scan]
    assert t_poly == pytest.approx(scan[int(np.argmin(costs))], abs=2 * (scan[1] - scan[0]))
    # the numerical search used for several via-points finds the same time for one
    t_num = mjt.optimal_times(points, 2.0)
    assert t_num[0] == pytest.approx(t_poly, abs=1e-4)


def test_several_via_points_default_times_minimise_the_cost():
    points = np.array([[0.0, 0.0], [20.0, 40.0], [60.0, 45.0], [100.0, 0.0]])
    spline = mjs.min_jerk_spline(points, 2.0)
    np.testing.assert_allclose(spline.evaluate(spline.times), points, atol=1e-8)
    best = spline.jerk_cost()
    rng = np.random.default_rng(3)
    for _ in range(30):
        times = np.sort(spline.times[1:-1] + rng.normal(0, 0.05, 2))
        if times[0] <= 0 or times[1] >= 2.0 or times[1] - times[0] <= 0:
            continue
        assert mjs.min_jerk_spline(points, 2.0, times).jerk_cost() >= best * (1 - 1e-9)


def test_via_points_trajectory_samples_the_spline():
    traj = mjs.via_points([[0.0, 0.0], [30.0, 50.0], [100.0, 0.0]], 2.0, via_times=[1.0], dt=0.01)
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
        mjs.min_jerk_spline([[0, 0], [1, 1], [2, 0]], 1.0, via_times=[0.2, 0.4])
    with pytest.raises(InputError, match="via_times: must increase strictly inside"):
        mjs.min_jerk_spline([[0, 0], [1, 1], [2, 0], [3, 3]], 1.0, via_times=[0.6, 0.4])
    with pytest.raises(InputError, match=r"points: expected shape \(m >= 2"):
        mjs.min_jerk_spline([[0, 0]], 1.0)


# -- several via-points: the timing search, independent of the input's digits -----------------

# Six via-points on which the former Nelder-Mead search (absolute tolerances xatol 1e-8,
# fatol 1e-12 on a cost of ~3e9 mm^2/s^5, below one ulp of it) never stopped: its simplex
# collapsed onto one point while the round-off of the cost kept its vertices ~36 ulp apart,
# so it ran to maxiter = 4000 (29,018 cost evaluations, 140 s) with these coordinates rounded
# to 0, 2, 6 or 9 decimals, and stopped after ~950 evaluations with 1 or 3.
SLOW_POINTS = np.array(
    [
        [57.419388311, -61.676748196],
        [60.472832227, -61.735214789],
        [-83.689476527, 71.045394857],
        [72.256699236, 75.307419283],
        [-5.618056128, -45.190322277],
        [-98.581634279, 29.144179115],
        [43.981876702, 67.1138433],
        [-43.624434527, -56.956366567],
    ]
)
# Nelder-Mead's via times for SLOW_POINTS rounded to 0 decimals, duration 2 s.
SLOW_OLD_TIMES = [
    0.10278895381646021,
    0.48963723031616413,
    0.8062690494399841,
    1.0646110476976904,
    1.3035188007713374,
    1.6163697373049137,
]


def _counting(monkeypatch) -> list[int]:
    """Count the evaluations of the jerk cost the timing search makes."""
    count = [0]
    real = mjt._jerk_cost_and_gradient

    def counted(points, times):
        count[0] += 1
        return real(points, times)

    monkeypatch.setattr(mjt, "_jerk_cost_and_gradient", counted)
    return count


def test_fast_cost_and_gradient_match_the_piecewise_quintic():
    rng = np.random.default_rng(7)
    for m, dim in ((2, 2), (3, 1), (5, 2), (8, 3)):
        points = rng.uniform(-50, 50, (m, dim))
        times = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 1.7, m - 2)), [1.7]])
        cost, gradient = mjt._jerk_cost_and_gradient(points, times)
        assert cost == pytest.approx(mjs._spline_through(points, times).jerk_cost(), rel=1e-10)
        for k in range(m - 1):  # dJ/dh_k: lengthen interval k, the later knots move with it
            eps = 1e-6 * (times[k + 1] - times[k])
            up, down = times.copy(), times.copy()
            up[k + 1 :] += eps
            down[k + 1 :] -= eps
            numeric = (mjt._jerk_cost_and_gradient(points, up)[0]
                       - mjt._jerk_cost_and_gradient(points, down)[0]) / (2 * eps)
            assert gradient[k] == pytest.approx(numeric, rel=1e-5, abs=1e-6 * cost)


@pytest.mark.parametrize("decimals", [0, 1, 2, 3, 6, 9])
def test_via_time_search_work_does_not_depend_on_the_digits(monkeypatch, decimals):
    count = _counting(monkeypatch)
    spline = mjs.min_jerk_spline(np.round(SLOW_POINTS, decimals), 2.0)
    assert count[0] <= 150  # ~110 here; Nelder-Mead took 29,018 with 0, 2, 6 or 9 decimals
    assert np.all(np.diff(spline.times) > 0) and spline.times[-1] == 2.0


def test_via_time_search_finds_the_former_optimum_or_better():
    points = np.round(SLOW_POINTS, 0)
    spline = mjs.min_jerk_spline(points, 2.0)
    old = mjs._spline_through(points, np.concatenate([[0.0], SLOW_OLD_TIMES, [2.0]]))
    assert spline.jerk_cost() <= old.jerk_cost() * (1 + 1e-12)
    np.testing.assert_allclose(spline.times[1:-1], SLOW_OLD_TIMES, atol=1e-7)
    # a stationary point: the gradient over the intervals (at a fixed total) vanishes
    _, gradient = mjt._jerk_cost_and_gradient(points, spline.times)
    assert np.max(np.abs(gradient - gradient.mean())) <= 1e-9 * spline.jerk_cost()


def test_via_time_search_beats_dense_scans_of_each_via_time():
    points = np.round(SLOW_POINTS, 3)
    times = mjs.min_jerk_spline(points, 2.0).times
    best = mjt._jerk_cost_and_gradient(points, times)[0]
    for k in range(1, len(times) - 1):  # move one via time across the whole gap it may use
        for t in np.linspace(times[k - 1], times[k + 1], 402)[1:-1]:
            trial = times.copy()
            trial[k] = t
            assert mjt._jerk_cost_and_gradient(points, trial)[0] >= best * (1 - 1e-12)


def test_two_via_times_match_a_brute_force_grid():
    points = np.array([[0.0, 0.0], [12.5, 31.25], [47.0, 29.0], [60.0, -4.0]])
    tf = 1.3
    times = mjs.min_jerk_spline(points, tf).times
    best = mjt._jerk_cost_and_gradient(points, times)[0]
    grid = np.linspace(0.0, tf, 161)[1:-1]
    costs = np.full((grid.size, grid.size), np.inf)
    for i, t1 in enumerate(grid):
        for j in range(i + 1, grid.size):
            costs[i, j] = mjt._jerk_cost_and_gradient(points, np.array([0, t1, grid[j], tf]))[0]
    i, j = np.unravel_index(np.argmin(costs), costs.shape)
    assert costs[i, j] >= best * (1 - 1e-12)
    step = grid[1] - grid[0]
    assert abs(grid[i] - times[1]) <= step and abs(grid[j] - times[2]) <= step


def test_via_times_do_not_change_with_the_scale_or_place_of_the_points():
    points = np.round(SLOW_POINTS, 2)
    ref = mjs.min_jerk_spline(points, 1.0).times
    for scale, offset in ((1e-3, 0.0), (1e6, 0.0), (1.0, 1e4), (1e200, 0.0), (1e-200, 0.0)):
        times = mjs.min_jerk_spline(points * scale + offset, 3.0).times / 3.0
        np.testing.assert_allclose(times, ref, atol=1e-7)


def test_via_time_search_stops_at_its_evaluation_budget(monkeypatch):
    monkeypatch.setattr(mjt, "TIME_SEARCH_MAX_EVALUATIONS", 12)
    count = _counting(monkeypatch)
    spline = mjs.min_jerk_spline(np.round(SLOW_POINTS, 2), 2.0)
    assert count[0] == 12
    assert np.all(np.diff(spline.times) > 0)  # the best times seen: ordered, if not optimal


def test_consecutive_coincident_points_need_given_via_times():
    points = [[0.0, 0.0], [10.0, 0.0], [10.0, 0.0], [20.0, 5.0]]
    with pytest.raises(InputError, match="points: points 1 and 2 coincide") as info:
        mjs.min_jerk_spline(points, 1.0)
    assert info.value.key == "points"
    spline = mjs.min_jerk_spline(points, 1.0, via_times=[0.4, 0.5])
    np.testing.assert_allclose(spline.evaluate(spline.times), points, atol=1e-9)
    # coincident but not consecutive is fine: back to the start
    loop = mjs.min_jerk_spline([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 0.0]], 1.0)
    assert np.all(np.diff(loop.times) > 0)


def test_single_via_time_is_scale_free_even_near_overflow():
    start, via, end = np.array([0.0, 0.0]), np.array([30.0, 50.0]), np.array([100.0, 0.0])
    ref = mj.optimal_via_time(start, via, end, 1.0)
    for scale in (1e-200, 1e-3, 1e6, 1e200):
        t = mj.optimal_via_time(start * scale, via * scale, end * scale, 1.0)
        assert t == pytest.approx(ref, abs=1e-12)


# -- budgets ------------------------------------------------------------------------------------


def test_many_points_are_refused_by_the_time_of_their_dense_systems(monkeypatch):
    import time

    from inkarm.core.budget import BudgetError

    points = np.cumsum(np.ones((200, 2)), axis=0) * [1.0, 0.5]
    start = time.perf_counter()
    with pytest.raises(BudgetError, match=r"^points: time of the minimum-jerk path through 200 "
                       r"points, choosing the via times \(up to 400 dense solves of 396 unknowns; "
                       r"give via_times to skip it\): about 48\.36 s, more than the limit of 10 s "
                       r"\(raise it with the environment variable INKARM_MAX_COMPUTE_S\)") as info:
        mjs.via_points(points, 10.0)
    assert info.value.value == 200 and info.value.variable == "INKARM_MAX_COMPUTE_S"
    many = np.cumsum(np.ones((3000, 2)), axis=0)
    with pytest.raises(BudgetError, match=r"through 3000 points, given via times \(a dense "
                       r"system of 17994 unknowns\): about 193\.5 s"):
        mjs.min_jerk_spline(many, 300.0, np.linspace(0.0, 300.0, 3000)[1:-1])
    assert time.perf_counter() - start < 2.0
    # given via times, the same 200 points are cheap (~0.3 s)
    assert mjs.spline_seconds(200, search=False) < 1.0
    traj = mjs.via_points(points, 10.0, np.linspace(0.0, 10.0, 200)[1:-1], dt=0.1)
    np.testing.assert_allclose(traj.pos[0], points[0])
    monkeypatch.setenv("INKARM_MAX_COMPUTE_S", "300")
    mjs._require_time(200, search=True)  # passes; the search is not run
    mjs._require_time(3000, search=False)


def test_via_points_checks_its_time_steps_first():
    from inkarm.core.budget import BudgetError

    with pytest.raises(BudgetError, match=r"^dt: time steps of the minimum-jerk path \(duration "
                       r"3600 s / dt 1e-06 s\): about 3\.6e\+09 time steps, .*INKARM_MAX_STEPS"):
        mjs.via_points([[0.0, 0.0], [1.0, 1.0]], 3600.0, dt=1e-6)
