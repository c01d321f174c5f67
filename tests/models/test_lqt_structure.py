"""Tests of inkarm.models.lqt.structure: strokes of one shape (configuration, timing,
covariances) share the problem structure and the factorisation, give the results of a solve
from scratch bit for bit and match the dense oracle; means, budgets and the cache's bounds are
still enforced on every call."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.budget import BudgetError
from inkarm.core.plan import StrokePlan
from inkarm.errors import PlanError
from inkarm.models.lqt import LQT, LQTConfig, Reference, sample, solve, structure
from inkarm.models.lqt import model as lqt_model
from inkarm.models.lqt.normal import precision_loss
from inkarm.models.lqt.solvers import Factor

COVS = [4.0, np.diag([2.0, 0.5]), [[1.0, 0.3], [0.3, 0.4]], 9.0]


def _stroke(seed: int, keypoints: bool = False, covs=COVS) -> StrokePlan:
    means = np.random.default_rng(seed).uniform(-50.0, 50.0, (len(covs), 2))
    return StrokePlan.from_arrays(means, covs, segment_time=0.1, keypoints=keypoints)


def _cold(fn):
    """fn() with nothing kept before or after (a solve from scratch)."""
    structure.clear()
    try:
        return fn()
    finally:
        structure.clear()


def _counting(monkeypatch) -> dict:
    calls = {"build": 0, "factor": 0}
    build, factor = lqt_model.build_problem, Factor.__init__

    def counted_build(*args, **kwargs):
        calls["build"] += 1
        return build(*args, **kwargs)

    def counted_factor(self, *args, **kwargs):
        calls["factor"] += 1
        factor(self, *args, **kwargs)

    monkeypatch.setattr(lqt_model, "build_problem", counted_build)
    monkeypatch.setattr(Factor, "__init__", counted_factor)
    return calls


CASES = [
    ("auto", "euler", False),
    ("cholesky", "euler", False),
    ("augmented", "euler", False),
    ("auto", "zoh", False),
    ("auto", "euler", True),
]


@pytest.mark.parametrize(("solver", "disc", "keypoints"), CASES)
def test_a_second_stroke_of_a_shape_reuses_it_and_gives_the_same_bits(
    solver, disc, keypoints, monkeypatch
):
    cfg = LQTConfig(4, 0.01, d=5.0, discretisation=disc, solver=solver)
    first, second = _stroke(1, keypoints), _stroke(2, keypoints)
    cold_mean = _cold(lambda: solve(second, cfg))
    cold_draws = _cold(lambda: sample(second, cfg, k=5, seed=3))
    structure.clear()
    solve(first, cfg)
    calls = _counting(monkeypatch)
    mean = solve(second, cfg)
    draws = sample(second, cfg, k=5, seed=3)
    assert calls == {"build": 0, "factor": 0}
    np.testing.assert_array_equal(mean.pos, cold_mean.pos)
    np.testing.assert_array_equal(mean.vel, cold_mean.vel)
    np.testing.assert_array_equal(draws, cold_draws)


@pytest.mark.parametrize(("solver", "disc", "keypoints"), CASES)
def test_kept_shapes_match_the_dense_oracle(solver, disc, keypoints):
    """The tolerance of the solver tests (test_lqt.py): 1e-6 of the extent."""
    cfg = LQTConfig(4, 0.01, d=5.0, discretisation=disc, solver=solver)
    batch = LQTConfig(4, 0.01, d=5.0, discretisation=disc, solver="batch")
    solve(_stroke(1, keypoints), cfg)
    for seed in (2, 3):
        stroke = _stroke(seed, keypoints)
        fast, oracle = solve(stroke, cfg), solve(stroke, batch)
        scale = float(np.max(np.ptp(oracle.pos, axis=0)))
        assert np.max(np.abs(fast.pos - oracle.pos)) <= 1e-6 * scale
        assert np.max(np.abs(fast.vel - oracle.vel)) <= 1e-6 * np.max(np.abs(oracle.vel))


def test_other_covariances_or_settings_are_another_shape(monkeypatch):
    cfg = LQTConfig(4, 0.01, d=5.0)
    structure.clear()
    solve(_stroke(1), cfg)
    calls = _counting(monkeypatch)
    solve(_stroke(2, covs=[4.0, 4.0, 4.0, 4.0]), cfg)
    solve(_stroke(2), LQTConfig(4, 0.01, d=6.0))
    assert calls == {"build": 2, "factor": 2}


def test_velocities_and_references_are_not_kept():
    stroke = _stroke(1)
    moving = StrokePlan(stroke.targets, 0.1, velocities=np.full((4, 2), np.nan))
    ref = Reference(1, np.eye(2) * 1e-3)
    structure.clear()
    solve(moving, LQTConfig(4, 0.01, d=5.0))
    solve(stroke, LQTConfig(4, 0.01, d=5.0), references=[ref])
    assert len(structure._CACHE) == 0


def test_means_out_of_range_are_refused_on_a_kept_shape():
    cfg = LQTConfig(4, 0.01, d=5.0)
    solve(_stroke(1), cfg)
    far = StrokePlan.from_arrays([[0.0, 0.0], [2e6, 0.0], [1.0, 1.0], [2.0, 2.0]], COVS,
                                 segment_time=0.1)
    with pytest.raises(PlanError, match=r"targets\[1\]\.mean"):
        solve(far, cfg)


def test_budgets_are_checked_on_a_kept_shape(monkeypatch):
    cfg = LQTConfig(4, 0.01, d=5.0)
    solve(_stroke(1), cfg)
    monkeypatch.setenv("INKARM_MAX_STEPS", "10")
    with pytest.raises(BudgetError, match="INKARM_MAX_STEPS"):
        solve(_stroke(2), cfg)
    monkeypatch.delenv("INKARM_MAX_STEPS")
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "0.001")
    with pytest.raises(BudgetError, match="INKARM_MAX_MEMORY_MB"):
        solve(_stroke(2), cfg)


def test_the_cache_is_bounded(monkeypatch):
    monkeypatch.setattr(structure, "MAX_ENTRIES", 3)
    structure.clear()
    cfg = LQTConfig(4, 0.01, d=5.0)
    for i in range(6):
        solve(_stroke(i, covs=[1.0 + i] * 4), cfg)
    assert len(structure._CACHE) == 3
    big = StrokePlan.from_arrays(np.zeros((400, 2)), 1.0, segment_time=0.5)  # N = 20,000
    monkeypatch.setattr(structure, "MAX_MB", 1.0)
    solve(big, cfg)
    assert all(s.template.n_steps < 20_000 for s in structure._CACHE.values())
    structure.clear()


@pytest.mark.parametrize(("d", "refined"), [(5.0, True), (1000.0, False)])
def test_refinement_follows_the_conditioning(d, refined):
    """One step of refinement where the bound on the conditioning predicts an error above
    ~1e-10 of the solution (loss > 1e-9), none below it."""
    stroke = StrokePlan.from_arrays(_stroke(1).means, 100.0, segment_time=0.5)
    model = LQT(stroke, LQTConfig(4, 0.01, d=d))
    assert model.factor.refine == refined == (precision_loss(model.problem, model.factor.obs) > 1e-9)
