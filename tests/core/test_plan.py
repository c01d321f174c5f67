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


def _stroke(**kwargs) -> StrokePlan:
    plan = StrokePlan.from_arrays([[0.0, 0.0], [3.0, 4.0]], [1.0, [[2.0, 0.5], [0.5, 1.0]]])
    return StrokePlan(plan.targets, **{"segment_time": 0.4, **kwargs})


def test_plans_compare_by_value_and_hash_alike_when_equal():
    vel = [[1.0, 0.0], [np.nan, np.nan]]
    a = _stroke(keypoints=True, velocities=vel, meta={"letters": (0, 1)})
    b = _stroke(keypoints=True, velocities=np.array(vel), meta={"letters": (0, 1)})
    assert a is not b and a == b  # NaN rows (free velocities) are equal
    assert hash(a) == hash(b) and len({a, b}) == 1
    assert MotorPlan((a, _stroke())) == MotorPlan((b, _stroke()))
    assert hash(MotorPlan((a,))) == hash(MotorPlan((b,)))
    assert a != _stroke(keypoints=True, velocities=[[1.0, 0.0], [0.0, 0.0]], meta=a.meta)
    assert a != _stroke(keypoints=True, velocities=vel, meta={"letters": (0, 2)})
    assert _stroke() != _stroke(segment_time=0.5)
    assert _stroke() != StrokePlan.from_arrays([[0.0, 0.0], [3.0, 4.5]], 1.0, segment_time=0.4)
    assert _stroke() != "a stroke"
    assert GaussianTarget([0.0, -0.0], 1.0) == GaussianTarget([-0.0, 0.0], 1.0)
    assert hash(GaussianTarget([0.0, -0.0], 1.0)) == hash(GaussianTarget([-0.0, 0.0], 1.0))
    assert GaussianTarget([0.0, 0.0], 1.0) != GaussianTarget([0.0, 0.0, 0.0], 1.0)


def test_target_and_velocity_arrays_are_read_only_copies():
    mean, vel = np.array([1.0, 2.0]), np.array([[1.0, 0.0], [0.0, 1.0]])
    target = GaussianTarget(mean, np.eye(2))
    plan = StrokePlan((target, target), keypoints=True, velocities=vel)
    mean[0] = vel[0, 0] = 9.0  # the caller's arrays stay theirs
    assert target.mean[0] == 1.0 and plan.velocities[0, 0] == 1.0
    for arr in (target.mean, target.cov, plan.velocities):
        with pytest.raises(ValueError):
            arr[0] = 0.0
