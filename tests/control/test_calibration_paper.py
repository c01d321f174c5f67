"""The paper's height map from touches: the fit's oracles (a plane exactly; a wave and a bump
sampled every 5 mm reproduced between the samples; a line and one touch), the believed model's
own touch, and every error."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control.calibration.paper import (
    contact_heights,
    fit_height_map,
    residual_rms_mm,
    touch_curve,
)
from inkarm.core.log import DRAW, DrawLog
from inkarm.errors import InputError


def _samples(f, spacing: float, lo=(60.0, 110.0), hi=(150.0, 190.0)) -> np.ndarray:
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 0.01, spacing),
                         np.arange(lo[1], hi[1] + 0.01, spacing))
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    return np.column_stack([xy, f(xy[:, 0], xy[:, 1])])


def _between(m, f, count: int = 3000, lo=(60.0, 110.0), hi=(150.0, 190.0)) -> np.ndarray:
    rng = np.random.default_rng(0)
    x, y = rng.uniform(lo[0], hi[0], count), rng.uniform(lo[1], hi[1], count)
    return np.abs(m.height(x, y) - f(x, y))


def _plane(x, y):
    return 0.3 + 0.01 * x - 0.02 * y


def _wave(x, y):  # 1 mm at 30 mm wavelength, across the page at 30 deg
    a = np.deg2rad(30.0)
    return np.sin(2 * np.pi * (np.cos(a) * x + np.sin(a) * y) / 30.0)


def _bump(x, y):  # 1 mm high, 8 mm full width at half height
    return np.exp(-4 * np.log(2) * ((x - 102.0) ** 2 + (y - 148.0) ** 2) / 8.0 ** 2)


@pytest.mark.parametrize("smoothing", [0.0, 1e-3])
def test_a_plane_is_reproduced_exactly_anywhere(smoothing):
    rng = np.random.default_rng(3)
    xy = rng.uniform([60, 110], [150, 190], (25, 2))
    m = fit_height_map(np.column_stack([xy, _plane(*xy.T)]), 10.0, smoothing)
    assert _between(m, _plane).max() < 1e-9
    assert m.x_mm[0] <= xy[:, 0].min() - 10.0 + 1e-9 and m.x_mm[-1] >= xy[:, 0].max() + 10.0 - 1e-9
    assert np.diff(m.x_mm).max() == pytest.approx(2.5)


def test_a_wave_sampled_every_5_mm_is_reproduced_between_the_samples():
    samples = _samples(_wave, 5.0)
    m = fit_height_map(samples, 5.0)
    err = _between(m, _wave)
    assert err.max() < 0.08 and np.sqrt(np.mean(err ** 2)) < 0.015  # of 1 mm, edges included
    assert residual_rms_mm(m, samples) < 0.01


def test_a_bump_needs_a_third_of_its_width():
    """A 1 mm bump of 8 mm full width at half height, its top between the samples: every
    2.5 mm, within 0.03 mm everywhere; every 5 mm, its top is still a quarter off."""
    around = {"lo": (80.0, 125.0), "hi": (125.0, 170.0)}
    fine = _between(fit_height_map(_samples(_bump, 2.5, **around), 2.5), _bump, **around)
    assert fine.max() < 0.03
    coarse = _between(fit_height_map(_samples(_bump, 5.0, **around), 5.0), _bump, **around)
    assert 0.1 < coarse.max() < 0.3 and np.sqrt(np.mean(coarse ** 2)) < 0.03


def test_sampled_every_10_mm_a_30_mm_wave_is_within_a_third_of_its_amplitude():
    err = _between(fit_height_map(_samples(_wave, 10.0), 10.0), _wave)
    assert err.max() < 0.35 and np.sqrt(np.mean(err ** 2)) < 0.12


def test_the_fit_refuses_what_it_cannot_fit():
    ok = _samples(_plane, 10.0)
    with pytest.raises(InputError, match=r"points_mm: expected \(k, 3\) samples"):
        fit_height_map(ok[:, :2], 10.0)
    with pytest.raises(InputError, match=r"points_mm: no samples to fit"):
        fit_height_map(ok[:0], 10.0)
    bad = ok.copy()
    bad[0, 2] = np.nan
    with pytest.raises(InputError, match=r"points_mm: expected finite samples"):
        fit_height_map(bad, 10.0)
    with pytest.raises(InputError, match=r"spacing_mm: expected a spacing > 0 mm, got 0"):
        fit_height_map(ok, 0.0)
    with pytest.raises(InputError, match=r"smoothing: expected a smoothing >= 0, got -1"):
        fit_height_map(ok, 10.0, -1.0)


def test_along_one_line_the_map_is_constant_across_it_and_one_touch_is_flat():
    t = np.linspace(0.0, 40.0, 9)
    u = np.array([0.6, 0.8])  # the line's direction
    xy = np.array([100.0, 140.0]) + t[:, None] * u
    line = np.column_stack([xy, 0.02 * t + 0.1 * np.sin(t / 10)])
    m = fit_height_map(line, 5.0)
    across = np.array([-0.8, 0.6])
    for shift in (-7.0, 0.0, 3.0):
        at = xy + shift * across
        np.testing.assert_allclose(m.height(at[:, 0], at[:, 1]), line[:, 2], atol=5e-3)
    one = fit_height_map(np.array([[10.0, 20.0, 0.7]]), 10.0)
    assert one.shape == (1, 1) and one.height(-50.0, 300.0) == 0.7


@pytest.fixture(scope="module")
def believed():
    from inkarm.sim.cell import kinematic_model

    return kinematic_model()


def _pose_over_the_page(believed) -> np.ndarray:
    from inkarm.control.ik import solve_ik
    from inkarm.control.kinematics import ArmKinematics

    target = believed.placement.to_robot([105.0, 148.5, -2.0])
    result = solve_ik(ArmKinematics.of(believed), target, believed.placement.pen_axis,
                      believed.home_q)
    assert result.converged
    return result.q


def test_the_models_own_touch_deepens_with_force(believed):
    q = _pose_over_the_page(believed)
    force, depth = touch_curve(believed, q, 1.0)
    assert np.all(np.diff(force) > 0) and np.all(np.diff(depth) < 0)
    assert force[0] < 0.8 and force[-1] > 1.8  # brackets F* = 1 N with room
    # about the pen spring in series with the underlay (0.3 and 2 N/mm): 4 to 5 mm per N
    slope = -np.polyfit(force, depth, 1)[0]
    assert 3.5 < slope < 5.0


def test_a_touch_read_back_from_a_log_of_the_models_own_touch_is_at_height_zero(believed):
    q = _pose_over_the_page(believed)
    force, depth = touch_curve(believed, q, 1.0)
    rows = 20
    log = DrawLog.empty(rows, believed.n)
    log.q[:] = q
    log.force[:] = np.interp(1.0, force, force)  # the model's settled F* ...
    log.phase[:] = DRAW
    log.stroke[:] = 0
    touches = contact_heights(log, believed, 1, force_n=1.0, settle_tol_n=0.05)
    # ... at a depth D(F*) below the model's sheet: a tip there is on a sheet at 0 + z_fk - D
    from inkarm.control.kinematics import ArmKinematics

    z_fk = believed.placement.to_page(ArmKinematics.of(believed).fk(q)[0])[2]
    assert touches.points_mm[0, 2] == pytest.approx(z_fk - np.interp(1.0, force, depth), abs=1e-9)
    assert touches.missed == () and list(touches.dots) == [0]
    log.force[:] = 0.5  # never settled at 1 +- 0.05 N
    assert contact_heights(log, believed, 1, 1.0, 0.05).missed == (0,)
    log.force[:] = np.nan
    with pytest.raises(InputError, match=r"--backend: the run senses no pen force"):
        contact_heights(log, believed, 1, 1.0, 0.05)
