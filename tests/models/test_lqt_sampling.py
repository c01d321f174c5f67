"""Tests of inkarm.models.lqt sampling and covariance (seed 000 eq. 14-17), and of the
:class:`LQT` object: one problem build and one factorisation behind the mean, the draws and
the covariance, bit-for-bit equal to the functional API."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.plan import StrokePlan
from inkarm.models.lqt import LQT, LQTConfig, covariance, oracle, sample, solve, structure
from inkarm.models.lqt import model as lqt_model
from inkarm.models.lqt.solvers import Factor

COVS = [1.0, np.diag([2.0, 0.5]), [[1.0, 0.3], [0.3, 0.4]]]


def _held_targets() -> StrokePlan:
    return StrokePlan.from_arrays([[0.0, 0.0], [8.0, 5.0], [15.0, 2.0]], COVS, segment_time=0.1)


def _moving_keypoints() -> StrokePlan:
    """Key-points (sparse observations) with velocities: a moving start, a free velocity."""
    plan = StrokePlan.from_arrays(
        [[0.0, 0.0], [8.0, 5.0], [15.0, 2.0]], COVS, segment_time=0.1, keypoints=True
    )
    vel = [[50.0, 0.0], [np.nan, np.nan], [0.0, -20.0]]
    return StrokePlan(plan.targets, 0.1, True, velocities=vel, velocity_var=100.0)


def _oracle_covariance(plan, cfg) -> np.ndarray:
    n = oracle.batch(plan, cfg)[0].shape[0]
    return oracle.batch(plan, cfg, with_cov=True)[1].reshape(n, plan.dim, n, plan.dim)


# ---------------------------------------------------------------------------------------------
# covariance and sampling


@pytest.mark.parametrize("solver", ["cholesky", "augmented"])
@pytest.mark.parametrize("disc", ["euler", "zoh"])
@pytest.mark.parametrize("end_at_rest", [True, False])
def test_covariance_from_the_factorisation_matches_the_dense_oracle(solver, disc, end_at_rest):
    """M H^-1 M^T from the banded factor equals eq. 15's S_u Sigma_u S_u^T."""
    for plan in (_held_targets(), _moving_keypoints()):
        if solver == "cholesky" and plan.keypoints:
            continue  # sparse observations: too ill-conditioned for the normal equations
        cfg = LQTConfig(3, 0.01, d=None, r=1e-7, discretisation=disc, end_at_rest=end_at_rest,
                        solver=solver)
        truth = _oracle_covariance(plan, cfg)
        cov = LQT(plan, cfg).covariance()
        assert cov.shape == truth.shape
        assert np.max(np.abs(cov - truth)) <= 1e-7 * np.max(np.abs(truth))


def test_exact_samples_match_analytic_covariance():
    plan = _held_targets()
    steps = np.arange(8, 18)  # 10 time steps
    for solver in ("cholesky", "augmented"):
        cfg = LQTConfig(3, 0.01, d=5.0, solver=solver)
        cov = _oracle_covariance(plan, cfg)[steps][:, :, steps].reshape(20, 20)  # eq. 15
        draws = sample(plan, cfg, k=20000, seed=7)
        assert draws.shape == (20000, 30, 2)
        emp = np.cov(draws[:, steps].reshape(20000, -1).T)
        assert np.linalg.norm(emp - cov) / np.linalg.norm(cov) <= 0.03
        mean = solve(plan, cfg).pos
        assert np.max(np.abs(draws.mean(axis=0) - mean)) <= 0.05


@pytest.mark.parametrize("disc", ["euler", "zoh"])
def test_perturbation_samples_of_keypoints_with_velocities(disc):
    """Key-points, a moving start and ZOH go through the augmented solver's perturbation
    sampler; its covariance is the oracle's within 3 standard errors."""
    plan = _moving_keypoints()
    cfg = LQTConfig(3, 0.01, d=None, r=1e-7, discretisation=disc)
    cov = _oracle_covariance(plan, cfg).reshape(42, 42)
    draws = sample(plan, cfg, k=20000, seed=2).reshape(20000, -1)
    stderr = np.sqrt((np.linalg.norm(cov) ** 2 + np.trace(cov) ** 2) / 20000)
    assert np.linalg.norm(np.cov(draws.T) - cov) <= 3 * stderr
    assert np.max(np.abs(draws.mean(axis=0) - solve(plan, cfg).pos.reshape(-1))) <= 0.01


def test_samples_are_seeded_and_start_on_the_first_mean():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [40.0, 30.0]], 50.0, segment_time=0.3)
    cfg = LQTConfig(4, 0.01, d=5.0)
    a = sample(plan, cfg, k=5, seed=3)
    np.testing.assert_array_equal(a, sample(plan, cfg, k=5, seed=3))
    assert not np.allclose(a, sample(plan, cfg, k=5, seed=4))
    np.testing.assert_allclose(a[:, :4], 0.0, atol=1e-9)  # xi_1 = (mu_1, 0, 0, 0) is not random
    assert np.all(np.std(a[:, -1], axis=0) > 0.1)


def test_eigen_sampler_with_all_components_matches_covariance():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 4.0]], [2.0, 1.0], segment_time=0.1)
    cfg = LQTConfig(2, 0.01, d=5.0)
    cov = covariance(plan, cfg).reshape(40, 40)
    full = sample(plan, cfg, k=20000, seed=1, method="eigen", components=None)
    emp = np.cov(full.reshape(20000, -1).T)
    # standard error of a sample covariance in Frobenius norm: sqrt((|C|^2 + tr(C)^2) / K)
    stderr = np.sqrt((np.linalg.norm(cov) ** 2 + np.trace(cov) ** 2) / 20000)
    assert np.linalg.norm(emp - cov) <= 3 * stderr
    few = sample(plan, cfg, k=4000, seed=1, method="eigen", components=3)
    assert np.trace(np.cov(few.reshape(4000, -1).T)) < np.trace(cov)  # truncation drops variance


# ---------------------------------------------------------------------------------------------
# the LQT object


@pytest.mark.parametrize("solver", ["auto", "cholesky", "augmented", "batch"])
def test_lqt_object_equals_the_functional_api_bit_for_bit(solver):
    plans = [_held_targets()] if solver == "cholesky" else [_held_targets(), _moving_keypoints()]
    for plan in plans:
        cfg = LQTConfig(3, 0.01, d=None, r=1e-7, solver=solver)
        model = LQT(plan, cfg)
        mean, ref = model.mean(), solve(plan, cfg)
        np.testing.assert_array_equal(mean.t, ref.t)
        np.testing.assert_array_equal(mean.pos, ref.pos)
        np.testing.assert_array_equal(mean.vel, ref.vel)
        for method in ("exact", "eigen"):
            np.testing.assert_array_equal(
                model.sample(7, seed=5, method=method),
                sample(plan, cfg, k=7, seed=5, method=method),
            )
        np.testing.assert_array_equal(model.covariance(), covariance(plan, cfg))
        np.testing.assert_array_equal(model.mean().pos, ref.pos)  # unchanged by the draws


@pytest.mark.parametrize("solver", ["cholesky", "augmented"])
def test_lqt_builds_and_factorises_once(solver, monkeypatch):
    calls = {"build": 0, "factor": 0}
    build = lqt_model.build_problem

    def counted_build(*args, **kwargs):
        calls["build"] += 1
        return build(*args, **kwargs)

    def counted(method):
        def wrapper(self):
            calls["factor"] += 1
            return method(self)

        return wrapper

    structure.clear()  # a stroke of a kept shape is neither built nor factorised again
    monkeypatch.setattr(lqt_model, "build_problem", counted_build)
    monkeypatch.setattr(Factor, "_factor_cholesky", counted(Factor._factor_cholesky))
    monkeypatch.setattr(Factor, "_factor_augmented", counted(Factor._factor_augmented))
    model = LQT(_held_targets(), LQTConfig(3, 0.01, d=5.0, solver=solver))
    model.mean()
    model.mean()
    model.sample(4, seed=1)
    model.sample(4, seed=2, method="eigen")
    model.covariance()
    assert calls == {"build": 1, "factor": 1}
    assert model.factor.method == solver
