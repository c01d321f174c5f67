"""Tests of inkarm.core.plan: targets, strokes, key-point velocities, Bezier key-points."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from inkarm.core.plan import (
    GaussianTarget,
    MotorPlan,
    StrokePlan,
    TargetArray,
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


# -- bulk checks: the same results and errors as one target at a time ------------------------


def _reference_check_covariance(cov, dim, where):
    """check_covariance as it was: NumPy and LAPACK on every matrix."""
    c = np.asarray(cov, dtype=float)
    if c.ndim == 0:
        c = np.eye(dim) * c
    elif c.ndim == 1:
        if c.shape[0] != dim:
            raise PlanError(
                f"{where}: diagonal covariance has {c.shape[0]} entries, expected {dim}"
            )
        c = np.diag(c)
    if c.shape != (dim, dim):
        raise PlanError(f"{where}: covariance has shape {c.shape}, expected ({dim}, {dim})")
    if not np.all(np.isfinite(c)):
        raise PlanError(f"{where}: covariance contains NaN or inf")
    scale = max(float(np.max(np.abs(c))), np.finfo(float).tiny)
    if np.max(np.abs(c - c.T)) > 1e-9 * scale:
        raise PlanError(f"{where}: covariance is not symmetric: {c.tolist()}")
    c = 0.5 * (c + c.T)
    try:
        np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(c)
        raise PlanError(
            f"{where}: covariance is not positive definite (eigenvalues {eig.tolist()})"
        ) from None
    return c


def _outcome(f, *args):
    try:
        return "ok", f(*args)
    except PlanError as e:
        return "error", str(e)


def _covariance_cases(seed: int = 0, n: int = 300):
    """Covariances of every form, good and bad: well and badly conditioned, near singular,
    slightly asymmetric, tiny and huge scales, NaN, inf, negative."""
    rng = np.random.default_rng(seed)
    cases = [
        (np.zeros((2, 2)), 2),
        (np.array([[1.0, 1.0], [1.0, 1.0]]), 2),
        (np.array([[1.0, 1.0 + 1e-16], [1.0, 1.0]]), 2),
        (np.array([[1e-310, 0.0], [0.0, 1e-310]]), 2),
        (np.array([[1e200, 0.0], [0.0, 1e200]]), 2),
        (5e-324, 2),
        (-1.0, 3),
        ([1.0, 2.0, 3.0], 2),
        (np.eye(3), 2),
    ]
    for _ in range(n):
        dim = int(rng.integers(1, 4))
        a = rng.normal(size=(dim, dim))
        kind = int(rng.integers(0, 7))
        if kind == 0:
            c = a @ a.T
        elif kind == 1:
            c = a @ a.T
            c[0, -1] += 1e-12 * rng.normal()
        elif kind == 2:
            v = rng.normal(size=dim)
            c = np.outer(v, v) + 10.0 ** rng.uniform(-20, 0) * np.eye(dim)
        elif kind == 3:
            c = a
        elif kind == 4:
            c = float(rng.normal())
        elif kind == 5:
            c = rng.normal(size=dim)
        else:
            c = a @ a.T
            c.flat[rng.integers(0, dim * dim)] = rng.choice([np.nan, np.inf, 0.0, -0.0])
        cases.append((c, dim))
    return cases


def test_check_covariance_gives_the_reference_result_or_error():
    for cov, dim in _covariance_cases():
        want = _outcome(_reference_check_covariance, cov, dim, "w")
        got = _outcome(check_covariance, cov, dim, "w")
        assert got[0] == want[0], (cov, want, got)
        if want[0] == "ok":
            assert got[1].dtype == want[1].dtype
            np.testing.assert_array_equal(got[1], want[1])
        else:
            assert got[1] == want[1]


def test_the_quick_positive_definite_test_only_accepts_what_lapack_accepts():
    from inkarm.core.plan import _clearly_positive_definite

    rng = np.random.default_rng(1)
    for _ in range(3000):
        dim = int(rng.integers(1, 4))
        v = rng.normal(size=(dim, dim))
        c = v @ v.T + 10.0 ** rng.uniform(-12, 1) * np.eye(dim) - 10.0 ** rng.uniform(-12, 0)
        c = 0.5 * (c + c.T)
        if _clearly_positive_definite(c.tolist()):
            np.linalg.cholesky(c)  # never raises


def test_check_covariances_checks_a_batch_at_once_and_names_the_first_bad():
    from inkarm.core.plan import check_covariances

    rng = np.random.default_rng(2)
    v = rng.normal(size=(20, 2, 2))
    covs = v @ np.swapaxes(v, 1, 2) + 0.1 * np.eye(2)
    np.testing.assert_array_equal(
        check_covariances(covs, 2, lambda i: f"c{i}"),
        [check_covariance(c, 2, "c") for c in covs],
    )
    covs[7] = [[1.0, 0.0], [0.0, -1.0]]
    covs[12, 0, 1] = np.nan
    with pytest.raises(PlanError, match=r"^c7: covariance is not positive definite"):
        check_covariances(covs, 2, lambda i: f"c{i}")


def _reference_from_arrays(means, covs, segment_time=0.5):
    means = np.asarray(means, dtype=float)
    if isinstance(covs, (int, float)):
        covs = [covs] * len(means)
    targets = []
    for i, (m, c) in enumerate(zip(means, covs)):
        try:
            targets.append(GaussianTarget(m, c))
        except PlanError as e:
            raise PlanError(
                f"stroke target {i}: {str(e).removeprefix('target: ').removeprefix('target ')}"
            ) from None
    return StrokePlan(tuple(targets), segment_time)


def test_from_arrays_checks_in_bulk_and_builds_the_same_plan_and_errors(monkeypatch):
    import inkarm.core.plan as plan_module

    rng = np.random.default_rng(3)
    cases = _covariance_cases(4, 200)
    for trial in range(400):
        dim = int(rng.integers(1, 4))
        m = int(rng.integers(0, 6))
        means = 10 * rng.normal(size=(m, dim))
        if m and rng.random() < 0.1:
            means.flat[rng.integers(0, means.size)] = np.inf
        form = trial % 5
        if form == 0:
            covs = float(rng.uniform(0.1, 3.0))
        elif form == 1:
            covs = list(rng.uniform(-0.5, 3.0, m))
        elif form == 2:
            covs = rng.uniform(0.01, 3.0, (m, dim))
        elif form == 3:
            v = rng.normal(size=(m, dim, dim))
            covs = v @ np.swapaxes(v, 1, 2)
        else:  # mixed forms and bad matrices
            picks = [c for c, d in cases if d == dim]
            covs = [picks[int(j)] for j in rng.integers(0, len(picks), m)]
        segment_time = [0.5, 0.1, 0.0][trial % 3]
        want = _outcome(_reference_from_arrays, means, covs, segment_time)
        got = _outcome(StrokePlan.from_arrays, means, covs, segment_time)
        assert got[0] == want[0] and (got[0] == "ok" or got[1] == want[1]), (want, got)
        if want[0] == "ok":
            a, b = want[1], got[1]
            assert a == b and hash(a) == hash(b)
            np.testing.assert_array_equal(a.means, b.means)
            np.testing.assert_array_equal(a.covs, b.covs)
            np.testing.assert_array_equal(a.precisions, b.precisions)
            assert not b.means.flags.writeable and not b.targets[0].cov.flags.writeable

    # the bulk path: no check of a covariance at a time, and the caller's arrays stay theirs
    calls = []
    monkeypatch.setattr(plan_module, "check_covariance", lambda *a: calls.append(a))
    means = np.zeros((50, 2))
    plan = StrokePlan.from_arrays(means, np.full((50, 2), 2.0), meta={"k": 1})
    assert calls == [] and len(plan.targets) == 50 and plan.meta == {"k": 1}
    means[0, 0] = 9.0
    assert plan.means[0, 0] == 0.0 and plan.targets[0].mean[0] == 0.0


def test_targets_from_arrays_are_held_as_arrays_and_equal_the_tuple_of_targets():
    """A stroke built from arrays keeps them (a page of text is a hundred thousand targets):
    its targets equal, hash, index, slice and pickle as the tuple of GaussianTargets."""
    means = np.random.default_rng(1).normal(size=(5, 2))
    plan = StrokePlan.from_arrays(means, 0.5, meta={"letters": (0, 0, 1, 1, 2)})
    tup = tuple(GaussianTarget(m, 0.5) for m in means)
    targets = plan.targets
    assert isinstance(targets, TargetArray) and len(targets) == 5
    assert targets == tup and tup == targets and hash(targets) == hash(tup)
    assert targets[-1] == tup[-1] and targets[1:3] == tup[1:3] and list(targets) == list(tup)
    assert targets != tup[:4] and targets != list(tup)
    with pytest.raises(IndexError):
        targets[5]
    assert plan == StrokePlan(tup, meta=plan.meta) and hash(plan) == hash(StrokePlan(tup))
    assert pickle.loads(pickle.dumps(plan)) == plan
    timed = StrokePlan(targets, 0.4, True, velocities=np.zeros((5, 2)))
    assert timed.targets is targets and timed.means is plan.means and timed.dim == 2
    with pytest.raises(PlanError, match=r"expected shape \(5, 2\)"):
        StrokePlan(targets, velocities=np.zeros((4, 2)))
    with pytest.raises(PlanError, match="no targets"):
        StrokePlan(TargetArray(np.zeros((0, 2)), np.zeros((0, 2, 2))))


def test_target_arrays_made_by_hand_are_checked_and_read_only():
    with pytest.raises(PlanError, match="targets: expected finite means and symmetric positive"):
        TargetArray([[np.nan, 0.0]], [np.eye(2)])
    with pytest.raises(PlanError, match="targets: expected finite means and symmetric positive"):
        TargetArray([[0.0, 0.0]], -np.ones((1, 2, 2)))
    with pytest.raises(PlanError, match=r"expected means \(m, D\) and covariances \(m, D, D\)"):
        TargetArray([[0.0, 0.0]], np.eye(2))
    means = np.zeros((1, 2))
    targets = TargetArray(means, [np.eye(2)])
    means[0, 0] = 5.0  # the caller's array is copied
    assert targets[0].mean[0] == 0.0 and not targets.means.flags.writeable
