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
from inkarm.models.lqt import LQT, LQTConfig, Reference, normal, sample, solve, structure
from inkarm.models.lqt import model as lqt_model
from inkarm.models.lqt.normal import held_rhs, held_targets, precision_loss, rhs
from inkarm.models.lqt.problem import build_problem
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


# ---------------------------------------------------------------------------------------------
# the mean of a kept shape of held targets: A^T b from the means, the residual by a stencil


def _walk(n_steps: int, seed: int = 0) -> StrokePlan:
    """benchmarks/bench_models.py's plan: targets 50-100 mm apart, variance 100 mm^2, 0.5 s."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(n_steps // 50 - 1, 2))
    steps *= rng.uniform(50, 100, (n_steps // 50 - 1, 1)) / np.linalg.norm(steps, axis=1,
                                                                         keepdims=True)
    return StrokePlan.from_arrays(np.vstack([np.zeros(2), np.cumsum(steps, axis=0)]), 100.0,
                                  segment_time=0.5)


@pytest.mark.parametrize(("order", "end_at_rest", "keypoints"),
                         [(4, True, False), (4, False, False), (1, True, False), (3, True, True)])
def test_held_targets_give_the_assembled_right_hand_side_bit_for_bit(order, end_at_rest,
                                                                    keypoints):
    stroke = _stroke(1, keypoints)
    dt = 0.1 if keypoints else 0.01  # key-points one step apart are held targets too
    prob = build_problem(stroke, LQTConfig(order, dt, d=5.0, end_at_rest=end_at_rest))
    first = prob.blocks[0]
    assert held_targets(prob)
    weighted = structure.Structure.values(stroke, first.targets_precision)[2]
    np.testing.assert_array_equal(held_rhs(prob, weighted, first.repeat), rhs(prob))


def test_other_rows_are_not_held_targets():
    moving = StrokePlan(_stroke(1).targets, 0.1, velocities=np.full((4, 2), 50.0))
    for stroke, cfg, refs in [
        (_stroke(1), LQTConfig(4, 0.01, d=5.0, discretisation="zoh"), ()),
        (_stroke(1, keypoints=True), LQTConfig(4, 0.01, d=5.0), ()),
        (_stroke(1), LQTConfig(4, 0.01, d=5.0), (Reference(1, np.eye(2) * 1e-3),)),
        (moving, LQTConfig(4, 0.01, d=5.0), ()),
    ]:
        assert not held_targets(build_problem(stroke, cfg, refs))


def _gram_by_differences(prob, c):
    """The residual's control part before the stencil: Delta^(2n-1) by 2n - 1 differences."""
    n, n_steps = prob.n, prob.n_steps
    ext = np.zeros((n_steps + 2 * n - 1, c.shape[1]), dtype=c.dtype)
    ext[n:n_steps], ext[n_steps:] = c, c[-1]
    d = normal.differences(ext, 2 * n - 1)[: prob.n_free + 1]
    d[-1] = 0.0
    return d[1:] - d[:-1]


def _refined(factor, prob, b, gram, dtype=float):
    """c + H^-1 (b - H c) with H c = P c + (-1)^n control^2 gram(c), in ``dtype``."""
    c = factor._chol_solve(b.copy(), overwrite=False)
    for _ in range(1 if dtype is float else 4):
        x = c.astype(dtype)
        scale = dtype(prob.control) ** 2 * (1 if prob.n % 2 == 0 else -1)
        r = b - factor.obs[0].reshape(c.shape).astype(dtype) * x - scale * gram(prob, x)
        c = c + factor._chol_solve(r.astype(float))
    return c


@pytest.mark.parametrize(("n_steps", "order"), [(200, 4), (200, 3), (1000, 4)])
def test_the_stencil_residual_refines_as_well_as_repeated_differences(n_steps, order):
    """Against a refinement with extended-precision residuals (long double, four steps): the
    one step of the solver within 1e-12 of the extent, as with 2n differences (measured 2e-13
    to 6e-13 at order 4), where one solve alone is off by ~1e-7."""
    model = LQT(_walk(n_steps), LQTConfig(order, 0.01, d=5.0))
    factor, prob = model.factor, model.problem
    b = rhs(prob)
    truth = _refined(factor, prob, b, _gram_by_differences, np.longdouble)
    scale = np.max(np.abs(truth))
    assert factor.refine
    assert np.max(np.abs(factor.mean(prob) - truth)) <= 1e-12 * scale
    by_differences = _refined(factor, prob, b, _gram_by_differences)
    assert np.max(np.abs(by_differences - truth)) <= 1e-12 * scale


def test_the_mean_is_todays_to_1e_12():
    """Positions and velocities of the benchmark's N = 200 plan as the solver of the previous
    release gave them (normal equations, one refinement step with 2n differences)."""
    structure.clear()
    traj = solve(_walk(200), LQTConfig(4, 0.01, d=5.0))
    old_pos = [[0.0, 0.0], [9.643622879875227, -8.249895183326093],
               [99.16938330003511, -50.6339805346301], [82.42430303599885, -6.147868386568852],
               [74.53865870829014, 0.8295558403272089]]
    old_vel = [[0.0, 0.0], [120.08498844302355, -123.22948791794363],
               [299.48318952004058, 50.345421648898991], [-121.88042192059356, 87.35776352444455],
               [0.055545820026736692, -0.028926332068557326]]
    np.testing.assert_allclose(traj.pos[[0, 37, 100, 163, 199]], old_pos, rtol=0, atol=1e-12 * 100)
    np.testing.assert_allclose(traj.vel[[1, 37, 100, 163, 198]], old_vel, rtol=0, atol=1e-12 * 300)
    assert solve(_walk(200), LQTConfig(4, 0.01, d=5.0)) == traj  # kept: the same bits
