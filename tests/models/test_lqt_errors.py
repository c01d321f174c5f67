"""Tests of inkarm.models.lqt's errors: each names the field, the value and what was expected."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.plan import GaussianTarget, StrokePlan
from inkarm.errors import InputError, PlanError, SolverError
from inkarm.models.lqt import (
    LQT,
    LQTConfig,
    Reference,
    sample,
    solve,
    velocity_direction_reference,
)
from inkarm.models.lqt.problem import build_problem
from inkarm.models.lqt.solvers import Factor


@pytest.mark.parametrize(
    "kwargs, key, match",
    [
        ({"order": 0}, "order", "order: expected 1..7, got 0"),
        ({"order": 8}, "order", "order: expected 1..7, got 8"),
        ({"order": 2.5}, "order", "order: expected an integer"),
        ({"dt": 0.0}, "dt", "dt: must be a positive number"),
        ({"dt": float("nan")}, "dt", "dt: must be a positive number"),
        ({"d": None}, "d", "exactly one of d .* and r"),
        ({"d": 5.0, "r": 1e-6}, "d", "exactly one of d .* and r"),
        ({"d": -1.0}, "d", "d: must be a positive number of mm, got -1.0"),
        ({"d": None, "r": float("inf")}, "r", "r: must be a positive number"),
        ({"discretisation": "rk4"}, "discretisation", "discretisation: expected 'euler' or 'zoh'"),
        ({"solver": "magic"}, "solver", "solver: expected one of"),
    ],
)
def test_config_errors(kwargs, key, match):
    with pytest.raises(InputError, match=match) as info:
        LQTConfig(**kwargs)
    assert info.value.key == key


def test_segment_time_must_be_a_whole_number_of_steps():
    stroke = StrokePlan.from_arrays([[0, 0], [10, 0]], 1.0, segment_time=0.025)
    with pytest.raises(PlanError, match=r"segment_time: 0.025 s is not a whole number of dt = "
                       r"0.01 s steps \(2.5\)") as info:
        solve(stroke, LQTConfig(dt=0.01))
    assert info.value.key == "segment_time" and info.value.value == 0.025
    assert solve(stroke, LQTConfig(dt=0.005)).n == 10


def test_plan_errors_name_the_target():
    with pytest.raises(PlanError, match="stroke target 1: covariance is not symmetric"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [1.0, [[1.0, 0.5], [0.0, 1.0]]])
    with pytest.raises(PlanError, match="stroke target 0: covariance is not positive definite"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [[[1.0, 2.0], [2.0, 1.0]], 1.0])
    with pytest.raises(PlanError, match="NaN or inf"):
        StrokePlan.from_arrays([[0, np.nan], [1, 1]], 1.0)
    with pytest.raises(PlanError, match="stroke target 1: covariance contains NaN"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [1.0, [[np.inf, 0], [0, 1]]])
    with pytest.raises(PlanError, match="no targets"):
        StrokePlan(())
    with pytest.raises(PlanError, match="stroke target 1: has 3 dimensions but target 0 has 2"):
        StrokePlan((GaussianTarget(np.zeros(2), 1.0), GaussianTarget(np.zeros(3), 1.0)))


def test_solve_errors():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.02)
    with pytest.raises(PlanError, match="order 4 needs at least 5"):
        solve(plan, LQTConfig(4, 0.01))
    with pytest.raises(PlanError, match="shorter than dt"):
        solve(plan, LQTConfig(1, 0.05))
    single = StrokePlan.from_arrays([[0.0, 0.0]], 1.0, keypoints=True)
    with pytest.raises(PlanError, match="at least 2 key-points"):
        solve(single, LQTConfig(2, 0.01))
    with pytest.raises(InputError, match="expected a StrokePlan"):
        solve([[0, 0]], LQTConfig())
    ok = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.2)
    with pytest.raises(SolverError, match="not positive definite"):
        Factor(build_problem(ok, LQTConfig(7, 0.001, d=100.0, solver="cholesky")), "cholesky")


@pytest.mark.parametrize(
    "ref, key, match",
    [
        (Reference(3, np.eye(2)), "references[0].derivative", r"expected an integer 0..2 \(order - 1\), got 3"),
        (Reference(1, [[1.0, 1.0], [0.0, 1.0]]), "references[0].precision", "not symmetric"),
        (Reference(1, -np.eye(2)), "references[0].precision", "not positive semi-definite"),
        (Reference(1, np.eye(3)), "references[0].precision", r"expected shape \(2, 2\) or \(40, 2, 2\), got \(3, 3\)"),
        (Reference(1, np.eye(2), value=[np.nan, 0.0]), "references[0].value", "contains NaN or inf"),
        (Reference(1, np.eye(2), steps=np.array([40])), "references[0].steps", "must lie in 0..39, got 40..40"),
        (Reference(1, np.eye(2), steps=np.array([0.5])), "references[0].steps", "non-empty 1-D array of integers"),
        ("velocity", "references[0]", "expected a Reference, got str"),
    ],
)
def test_reference_errors_name_the_field(ref, key, match):
    ok = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.2)
    with pytest.raises(InputError, match=match) as info:
        solve(ok, LQTConfig(3, 0.01), references=[ref])
    assert info.value.key == key
    assert str(info.value).startswith(key + ": ")


def test_sample_errors():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.2)
    with pytest.raises(InputError, match="k: expected a positive integer number of draws, got 0"):
        sample(plan, LQTConfig(), k=0)
    with pytest.raises(InputError, match="components: expected a positive integer or None"):
        sample(plan, LQTConfig(), method="eigen", components=0)
    with pytest.raises(InputError, match="method: expected 'exact' or 'eigen', got 'gibbs'") as info:
        LQT(plan).sample(3, method="gibbs")
    assert info.value.key == "method" and info.value.value == "gibbs"
    with pytest.raises(InputError, match="v: expected a finite non-zero direction vector"):
        velocity_direction_reference([0.0, 0.0])
    with pytest.raises(InputError, match="weight: must be a positive number, got -1"):
        velocity_direction_reference([0.0, 1.0], weight=-1)
    with pytest.raises(PlanError, match="velocities: need order >= 2"):
        solve(StrokePlan(plan.targets, velocities=np.zeros((2, 2))), LQTConfig(1, 0.01))
