"""Tests of inkarm.core.plan: targets, strokes, key-point velocities, Bezier key-points."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.plan import (
    GaussianTarget,
    MotorPlan,
    StrokePlan,
    bezier_keypoints,
    check_covariance,
)
from inkarm.errors import PlanError


def test_covariance_forms():
    np.testing.assert_array_equal(check_covariance(4.0, 2, "x"), 4.0 * np.eye(2))
    np.testing.assert_array_equal(check_covariance([1.0, 2.0], 2, "x"), np.diag([1.0, 2.0]))
    full = [[2.0, 0.5], [0.5, 1.0]]
    np.testing.assert_array_equal(check_covariance(full, 2, "x"), full)
    with pytest.raises(PlanError, match="x: diagonal covariance has 3 entries, expected 2"):
        check_covariance([1.0, 2.0, 3.0], 2, "x")
    with pytest.raises(PlanError, match=r"x: covariance has shape \(3, 3\), expected \(2, 2\)"):
        check_covariance(np.eye(3), 2, "x")


def test_stroke_arrays_are_cached_and_read_only():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [3.0, 4.0]], [1.0, [[2.0, 0.5], [0.5, 1.0]]])
    assert plan.means is plan.means and plan.covs.shape == (2, 2, 2)
    np.testing.assert_allclose(plan.precisions @ plan.covs, np.broadcast_to(np.eye(2), (2, 2, 2)))
    with pytest.raises(ValueError):
        plan.means[0, 0] = 1.0
    assert plan.dim == 2 and plan.segment_time == 0.5 and plan.velocities is None


def test_velocities():
    vel = np.array([[1.0, 0.0], [np.nan, np.nan]])
    plan = StrokePlan.from_arrays([[0.0, 0.0], [3.0, 4.0]], 1.0, keypoints=True)
    plan = StrokePlan(plan.targets, 0.4, True, velocities=vel, velocity_var=0.5)
    np.testing.assert_array_equal(plan.velocities, vel)
    with pytest.raises(PlanError, match=r"stroke velocities: expected shape \(2, 2\)"):
        StrokePlan(plan.targets, velocities=np.zeros((3, 2)))
    with pytest.raises(PlanError, match="stroke velocity 1: .* a row of NaN"):
        StrokePlan(plan.targets, velocities=[[0.0, 0.0], [np.nan, 1.0]])
    with pytest.raises(PlanError, match="velocity_var: must be a positive variance"):
        StrokePlan(plan.targets, velocities=vel, velocity_var=0.0)


def test_bezier_keypoints():
    cps = [[0, 0], [1, 2], [3, 2], [4, 0], [5, -2], [7, -2], [8, 0]]
    plan = bezier_keypoints(cps, segment_time=0.5, variance=1e-4)
    assert plan.keypoints and len(plan.targets) == 3
    np.testing.assert_array_equal(plan.means, [[0, 0], [4, 0], [8, 0]])
    np.testing.assert_allclose(plan.velocities, [[6, 12], [6, -12], [6, 12]])
    np.testing.assert_allclose(plan.covs[0], 1e-4 * np.eye(2))
    with pytest.raises(PlanError, match=r"expected \(3k \+ 1, D\) points"):
        bezier_keypoints([[0, 0], [1, 1], [2, 2]])


def test_stroke_errors():
    with pytest.raises(PlanError, match="stroke: no targets"):
        StrokePlan(())
    with pytest.raises(PlanError, match="stroke target 0: expected a GaussianTarget"):
        StrokePlan(([0.0, 0.0],))
    with pytest.raises(PlanError, match="segment_time: must be a positive number"):
        StrokePlan((GaussianTarget([0.0, 0.0], 1.0),), segment_time=0.0)
    with pytest.raises(PlanError, match=r"stroke means: expected shape \(m, D\)"):
        StrokePlan.from_arrays([0.0, 1.0], 1.0)
    with pytest.raises(PlanError, match="stroke: 2 means but 3 covariances"):
        StrokePlan.from_arrays([[0.0], [1.0]], [1.0, 1.0, 1.0])
    with pytest.raises(PlanError, match="target mean: expected 1 to 3 coordinates"):
        GaussianTarget(np.zeros(4), 1.0)
    with pytest.raises(PlanError, match=r"motor plan: strokes mix dimensions \[2, 3\]"):
        MotorPlan(
            (
                StrokePlan.from_arrays([[0.0, 0.0]], 1.0),
                StrokePlan.from_arrays([[0.0, 0.0, 0.0]], 1.0),
            )
        )
