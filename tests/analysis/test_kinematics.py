"""Kinematic measures against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.analysis import kinematics as kin
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.minjerk import point_to_point


def _ellipse(
    a: float, b: float, omega: float, n: int = 4001, with_velocity: bool = False
) -> Trajectory:
    t = np.linspace(0.0, 2 * np.pi / omega, n)
    pos = np.column_stack([a * np.cos(omega * t), b * np.sin(omega * t)])
    vel = np.column_stack([-a * omega * np.sin(omega * t), b * omega * np.cos(omega * t)])
    return Trajectory(t=t, pos=pos, vel=vel if with_velocity else None)


@pytest.mark.parametrize("radius", [5.0, 40.0])
def test_circle_has_constant_curvature_one_over_radius_signed_by_direction(radius):
    ccw = _ellipse(radius, radius, 2.0)
    np.testing.assert_allclose(kin.curvature(ccw), 1.0 / radius, rtol=1e-5)
    cw = Trajectory(t=ccw.t, pos=ccw.pos * [1.0, -1.0])
    np.testing.assert_allclose(kin.curvature(cw), -1.0 / radius, rtol=1e-5)
    np.testing.assert_allclose(kin.speed(ccw), 2.0 * radius, rtol=1e-5)


def test_3d_curvature_is_the_magnitude_of_a_helix():
    r, c, w = 10.0, 3.0, 1.5  # helix (r cos wt, r sin wt, c t): kappa = r w^2 / (r^2 w^2 + c^2)
    t = np.linspace(0, 6, 6001)
    pos = np.column_stack([r * np.cos(w * t), r * np.sin(w * t), c * t])
    kappa = kin.curvature(Trajectory(t=t, pos=pos))
    np.testing.assert_allclose(kappa, r * w**2 / (r**2 * w**2 + c**2), rtol=1e-4)


@pytest.mark.parametrize("with_velocity", [True, False])
def test_harmonic_ellipse_obeys_the_two_thirds_power_law(with_velocity):
    # x = a cos wt, y = b sin wt: v^3 kappa = w^3 a b, so v = (w^3 a b)^(1/3) r^(1/3) exactly
    a, b, w = 40.0, 15.0, 2.0
    fit = kin.power_law_fit(_ellipse(a, b, w, with_velocity=with_velocity))
    assert fit.beta == pytest.approx(1.0 / 3.0, abs=1e-3)
    assert fit.k == pytest.approx((w**3 * a * b) ** (1 / 3), rel=1e-3)
    assert fit.r2 > 0.999


def test_power_law_fit_recovers_another_exponent_and_skips_straight_parts():
    # speed prescribed as v = 2 r^0.5 along an ellipse, then a straight segment (excluded)
    a, b = 30.0, 10.0
    theta = np.linspace(0, 2 * np.pi, 3001)
    dp = np.column_stack([-a * np.sin(theta), b * np.cos(theta)])
    radius = np.linalg.norm(dp, axis=1) ** 3 / (a * b)
    v = 2.0 * radius**0.5
    dt_dtheta = np.linalg.norm(dp, axis=1) / v
    t = np.concatenate([[0.0], np.cumsum(0.5 * (dt_dtheta[1:] + dt_dtheta[:-1]) * np.diff(theta))])
    pos = np.column_stack([a * np.cos(theta), b * np.sin(theta)])
    vel = dp / dt_dtheta[:, None]
    line_t = t[-1] + np.linspace(0.01, 1.0, 100)
    line_pos = pos[-1] + np.outer(line_t - t[-1], vel[-1])
    traj = Trajectory(
        t=np.concatenate([t, line_t]),
        pos=np.vstack([pos, line_pos]),
        vel=np.vstack([vel, np.repeat(vel[-1:], 100, axis=0)]),
    )
    fit = kin.power_law_fit(traj)
    assert fit.beta == pytest.approx(0.5, abs=5e-3)
    assert fit.k == pytest.approx(2.0, rel=2e-2)
    assert fit.n < traj.n - 50


def test_jerk_cost_of_minimum_jerk_movement_is_720_a2_over_t5():
    traj = point_to_point([0.0, 0.0], [60.0, 80.0], 0.8, dt=0.0005)
    assert kin.jerk_cost(traj) == pytest.approx(720 * 100.0**2 / 0.8**5, rel=1e-3)
    # without stored velocity, finite differences of positions still agree
    plain = Trajectory(t=traj.t, pos=traj.pos)
    assert kin.jerk_cost(plain) == pytest.approx(720 * 100.0**2 / 0.8**5, rel=1e-2)


def test_speed_peaks_counts_separated_bumps_above_the_threshold():
    t = np.linspace(0, 4, 4001)
    bumps = [(0.5, 1.0), (1.5, 0.6), (2.5, 0.05), (3.4, 0.8)]  # (centre, height)
    v = sum(h * np.exp(-0.5 * ((t - c) / 0.08) ** 2) for c, h in bumps)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    traj = Trajectory(
        t=t, pos=np.column_stack([x, np.zeros_like(x)]), vel=np.column_stack([v, 0 * v])
    )
    assert kin.speed_peaks(traj) == 3  # the 5 % bump is under 10 % of the maximum
    assert kin.speed_peaks(traj, threshold=0.01) == 4
    assert kin.speed_peaks(traj, threshold=0.7) == 2


def test_minimum_jerk_has_one_speed_peak():
    assert kin.speed_peaks(point_to_point([0, 0], [10, 0], 1.0)) == 1


def test_errors():
    line = Trajectory(t=[0.0, 1.0, 2.0, 3.0], pos=[[0, 0], [1, 0], [2, 0], [3, 0]])
    with pytest.raises(InputError, match="curved and moving enough"):
        kin.power_law_fit(line)
    with pytest.raises(InputError, match="radius of curvature is constant"):
        kin.power_law_fit(_ellipse(10.0, 10.0, 1.0, with_velocity=True))
    with pytest.raises(InputError, match=r"threshold: expected a fraction in \[0, 1\)"):
        kin.speed_peaks(line, threshold=1.5)
    with pytest.raises(InputError, match="jerk: needs at least 4 samples, the trajectory has 2"):
        kin.jerk_cost(Trajectory(t=[0.0, 1.0], pos=[[0, 0], [1, 0]]))
    with pytest.raises(InputError, match="curvature: needs a 2-D or 3-D trajectory"):
        kin.curvature(Trajectory(t=[0.0, 1.0, 2.0], pos=[[0.0], [1.0], [2.0]]))
    with pytest.raises(InputError, match="max_radius: expected a positive length"):
        kin.power_law_fit(line, max_radius=0)


def test_derivatives_that_overflow_are_refused_not_infinite():
    rng = np.random.default_rng(0)
    pos = rng.normal(size=(6, 2)) * 1e6
    for name in ("speed", "acceleration", "jerk", "curvature", "jerk_cost", "speed_peaks"):
        with pytest.raises(InputError, match=r"velocity: overflows at sample 0 .* too close"):
            getattr(kin, name)(Trajectory(t=np.arange(6) * 1e-300, pos=pos))
    close = Trajectory(t=np.arange(6) * 1e-100, pos=pos)
    with pytest.raises(InputError, match="jerk_cost: overflows"):
        kin.jerk_cost(close)
    with np.errstate(all="raise"):
        kappa = kin.curvature(close)  # |v|^3 overflows: undefined, like a pen at rest
    assert np.all(np.isnan(kappa) | np.isfinite(kappa))
