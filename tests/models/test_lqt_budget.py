"""The LQT's budgets and ranges: time steps and memory refused before any work (with the
estimate and the setting that raises the limit), estimates within 2x of measured peaks, and
out-of-range numbers refused naming the key, the range and the value."""

from __future__ import annotations

import time
import tracemalloc

import numpy as np
import pytest

from inkarm.core.budget import BudgetError
from inkarm.core.plan import GaussianTarget, StrokePlan
from inkarm.errors import InputError, PlanError
from inkarm.models.lqt import LQT, LQTConfig, cost, normal, oracle, problem, solve, solvers
from inkarm.models.lqt.config import time_grid
from inkarm.models.lqt.problem import sizing


def _stroke(n_steps: int, dim: int = 2, m: int = 4, dt: float = 0.01, **kwargs) -> StrokePlan:
    means = np.cumsum(np.random.default_rng(0).normal(size=(m, dim)) * 10, axis=0)
    per = n_steps // m
    return StrokePlan.from_arrays(means, 4.0, segment_time=per * dt, **kwargs)


@pytest.fixture
def quick():
    """Refusals come before any work: well within a couple of seconds."""
    start = time.perf_counter()
    yield
    assert time.perf_counter() - start < 2.0


# -- time steps ---------------------------------------------------------------------------------


def test_a_huge_step_count_is_refused_with_the_estimate_and_the_setting(quick):
    stroke = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 4.0, segment_time=3600.0)
    with pytest.raises(BudgetError, match=r"about 7\.2e\+07 time steps, more than the limit of "
                       r"1e\+06 time steps \(raise it with the environment variable "
                       r"INKARM_MAX_STEPS\)") as info:
        LQT(stroke, LQTConfig(dt=1e-4))
    assert info.value.key == "dt" and info.value.value == 1e-4
    assert info.value.estimate == 72_000_000 and info.value.variable == "INKARM_MAX_STEPS"
    assert "2 x segment_time 3600 s / dt 0.0001 s" in str(info.value)


def test_the_dense_oracle_is_refused_too(quick):
    stroke = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 4.0, segment_time=3600.0)
    with pytest.raises(BudgetError, match="INKARM_MAX_STEPS"):
        oracle.batch(stroke, LQTConfig(dt=1e-4))


def test_raising_the_step_limit_passes_the_check(monkeypatch):
    stroke = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 4.0, segment_time=3600.0)
    cfg = LQTConfig(dt=1e-4)
    with pytest.raises(BudgetError):
        time_grid(stroke, cfg)
    monkeypatch.setenv("INKARM_MAX_STEPS", "1e8")
    assert time_grid(stroke, cfg) == (36_000_000, 72_000_000)  # checked, nothing allocated
    size = sizing(stroke, cfg)  # the next check, memory, still refuses it
    with pytest.raises(BudgetError, match="INKARM_MAX_MEMORY_MB"):
        cost.require(size.solve_bytes, size.describe("memory of the LQT solve"))
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", str(size.solve_bytes / 2**20 * 1.01))
    cost.require(size.solve_bytes, "memory of the LQT solve")  # passes; not run


# -- memory -------------------------------------------------------------------------------------


def test_memory_of_the_solve_is_refused_before_building(quick):
    stroke = _stroke(900_000, dim=3, m=3, dt=1e-3)  # under the step limit
    with pytest.raises(BudgetError, match=r"memory of the LQT solve \(900000 steps x 3-D, "
                       r"order 7, augmented\): about [\d.]+ GB, more than the limit of [\d.]+ [GM]B "
                       r"\(raise it with the environment variable INKARM_MAX_MEMORY_MB\)"):
        LQT(stroke, LQTConfig(order=7, dt=1e-3, solver="augmented"))


def test_memory_of_samples_covariance_eigen_and_batch_is_refused_before_drawing(quick):
    model = LQT(_stroke(400), LQTConfig(3, 0.01, d=5.0))
    with pytest.raises(BudgetError, match=r"memory of 10000000 exact draws .*INKARM_MAX_MEMORY_MB"):
        model.sample(10_000_000)
    big = LQT(_stroke(40_000), LQTConfig(3, 0.01, d=5.0))
    with pytest.raises(BudgetError, match=r"dense LQT covariance \(40000 steps x 2-D"):
        big.covariance()
    with pytest.raises(BudgetError, match=r"1 eigen draws .*INKARM_MAX_MEMORY_MB"):
        big.sample(1, method="eigen")
    with pytest.raises(BudgetError, match=r"dense LQT oracle .*O\(N\^2\)"):
        LQT(_stroke(40_000), LQTConfig(3, 0.01, d=5.0, solver="batch"))


# -- time of the O((N D)^3) operations ----------------------------------------------------------


def test_eigen_draws_are_refused_by_their_time_pointing_to_the_exact_sampler(quick):
    model = LQT(_stroke(2000), LQTConfig())  # N D = 4000: ~0.3 ns (N D)^3 = 19 s; memory fine
    with pytest.raises(BudgetError, match=r"^method: time of 5 eigen draws of the LQT \(2000 "
                       r"steps x 2-D: 9 eigenpairs of a dense \d+ x \d+ matrix, O\(\(N D\)\^3\); "
                       r"method='exact', the default, draws in O\(N\)\): about 19\.2 s, more "
                       r"than the limit of 10 s \(raise it with the environment variable "
                       r"INKARM_MAX_COMPUTE_S\)") as info:
        model.sample(5, method="eigen")
    assert info.value.value == "eigen" and info.value.variable == "INKARM_MAX_COMPUTE_S"
    small = LQT(_stroke(800), LQTConfig())  # all components cost ~8x more: 2.5 ns (N D)^3
    with pytest.raises(BudgetError, match=r"all eigenpairs .*about 10\.24 s"):
        small.sample(5, method="eigen", components=None)
    assert cost.eigen_seconds(800, 2, 9) < 10.0  # a few components pass


def test_dense_covariance_and_oracle_are_refused_by_their_time(quick):
    model = LQT(_stroke(2300), LQTConfig())  # N D = 4600: memory fits, time does not
    with pytest.raises(BudgetError, match=r"time of the dense LQT covariance \(2300 steps x "
                       r"2-D: O\(\(N D\)\^3\) with N D = 4600\): .*INKARM_MAX_COMPUTE_S"):
        model.covariance()
    stroke = _stroke(800)  # N D = 1600: 4 ns (N D)^3 = 16 s
    with pytest.raises(BudgetError, match=r"^solver: time of the dense LQT oracle \(800 steps x "
                       r"2-D; O\(\(N D\)\^3\), use another solver\): about 16\.38 s"):
        LQT(stroke, LQTConfig(solver="batch"))
    with pytest.raises(BudgetError, match="time of the dense LQT oracle .*INKARM_MAX_COMPUTE_S"):
        oracle.batch(stroke, LQTConfig())


def test_raising_the_compute_limit_passes_the_time_checks(monkeypatch):
    seconds = cost.eigen_seconds(2000, 2, 9)
    with pytest.raises(BudgetError, match="INKARM_MAX_COMPUTE_S"):
        cost.require_time(seconds, "eigen draws")
    monkeypatch.setenv("INKARM_MAX_COMPUTE_S", "60")
    cost.require_time(seconds, "eigen draws")  # passes; the draws are not made
    cost.require_time(cost.batch_seconds(800, 2), "oracle")
    with pytest.raises(BudgetError, match=r"about 68\.75 s, more than the limit of 60 s"):
        cost.require_time(cost.covariance_seconds(2500, 2, "augmented"), "covariance")


def test_the_time_estimates_are_the_stated_constants():
    assert cost.eigen_seconds(1000, 2, 9) == pytest.approx(0.3e-9 * 2000**3)
    assert cost.eigen_seconds(1000, 2, None) == pytest.approx(2.5e-9 * 2000**3)
    assert cost.eigen_seconds(2, 2, 9) == cost.eigen_seconds(2, 2, None)  # 9 >= N D: all
    assert cost.covariance_seconds(1000, 2, "cholesky") == pytest.approx(0.15e-9 * 2000**3)
    assert cost.batch_seconds(500, 2, with_cov=True) == pytest.approx(5.5e-9 * 1000**3)


def _clear_caches() -> None:
    for f in (problem.state_stencils, problem._arange, problem._ones, normal.control_rows,
              normal._control_band, solvers._augmented_structure):
        f.cache_clear()


def _peak(fn) -> float:
    """Peak bytes allocated (tracemalloc: NumPy reports its arrays) while running fn."""
    _clear_caches()
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        fn()
        return tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize(("order", "solver", "disc"), [(4, "cholesky", "euler"),
                                                       (4, "augmented", "euler"),
                                                       (2, "auto", "zoh"),
                                                       (7, "augmented", "zoh")])
def test_memory_estimates_are_within_2x_of_the_measured_peaks(order, solver, disc):
    stroke = _stroke(2000, dim=2, m=20)
    cfg = LQTConfig(order, 0.01, d=5.0, solver=solver, discretisation=disc)
    size = sizing(stroke, cfg)
    measured = _peak(lambda: LQT(stroke, cfg).mean())
    assert 0.5 <= size.solve_bytes / measured <= 2.0
    model = LQT(stroke, cfg)
    model.mean()
    assert model.method == size.method
    k = 40
    measured = _peak(lambda: model.sample(k))
    estimate = cost.sample_bytes(k, size.n_steps, 2, size.method)
    assert 0.5 <= estimate / measured <= 2.0


@pytest.mark.parametrize("solver", ["cholesky", "augmented"])
def test_dense_estimates_are_within_2x_of_the_measured_peaks(solver):
    stroke = _stroke(240, dim=2, m=8)
    model = LQT(stroke, LQTConfig(3, 0.01, d=5.0, solver=solver))
    model.mean()
    measured = _peak(model.covariance)
    assert 0.5 <= cost.covariance_bytes(240, 2, solver) / measured <= 2.0
    measured = _peak(lambda: model.sample(5, method="eigen"))
    assert 0.5 <= cost.sample_bytes(5, 240, 2, solver, "eigen") / measured <= 2.0


def test_batch_estimate_is_within_2x_of_the_measured_peak():
    stroke = _stroke(160, dim=2)
    cfg = LQTConfig(4, 0.01, d=5.0, solver="batch")
    measured = _peak(lambda: oracle.batch(stroke, cfg))
    assert 0.5 <= cost.batch_bytes(160, 2, 4) / measured <= 2.0
    measured = _peak(lambda: oracle.batch(stroke, cfg, with_cov=True))
    assert 0.5 <= cost.batch_bytes(160, 2, 4, with_cov=True) / measured <= 2.0


# -- ranges -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "key", "match"),
    [
        ({"dt": 1e-6}, "dt", r"dt: expected a number in \[0\.0001, 1\] s, got 1e-06"),
        ({"dt": 2.0}, "dt", r"dt: expected a number in \[0\.0001, 1\] s, got 2"),
        ({"d": 1e-300}, "d", r"d: expected a number in \[1e-06, 1e\+06\] mm, got 1e-300"),
        ({"d": 1e300}, "d", r"d: expected a number in \[1e-06, 1e\+06\] mm, got 1e\+300"),
        ({"d": None, "r": 1e300}, "r", r"r: expected a number in \[1e-40, 1e\+40\]"),
        ({"d": None, "r": 1e-300}, "r", r"r: expected a number in \[1e-40, 1e\+40\]"),
    ],
)
def test_config_numbers_out_of_range(kwargs, key, match):
    with pytest.raises(InputError, match=match) as info:
        LQTConfig(**kwargs)
    assert info.value.key == key


def test_extreme_d_no_longer_divides_by_zero():
    # d = 1e-300 made (omega^n d)^2 underflow to 0: ZeroDivisionError deep in the solve
    with pytest.raises(InputError, match=r"^d: expected"):
        solve(_stroke(100), LQTConfig(d=1e-300))


@pytest.mark.parametrize(
    ("means", "cov", "key", "match"),
    [
        ([[1e300, 0.0], [0.0, 0.0]], 4.0, "targets[0].mean",
         r"expected coordinates in \[-1e\+06, 1e\+06\] mm, got 1e\+300"),
        ([[0.0, 0.0], [1e7, 0.0]], 4.0, "targets[1].mean", r"got 1e\+07"),
        ([[0.0, 0.0], [1.0, 0.0]], 1e300, "targets[0].cov",
         r"expected variances \(eigenvalues\) in \[1e-12, 1e\+12\] mm\^2 .*got 1e\+300"),
        ([[0.0, 0.0], [1.0, 0.0]], 1e-300, "targets[0].cov", r"got 1e-300"),
        ([[0.0, 0.0], [1.0, 0.0]], [[1e-6, 1e8], [1.0, 1.0]], "targets[0].cov",
         r"condition number 1e\+14 .*more than 1e\+12: nearly singular"),
    ],
)
def test_targets_out_of_range(means, cov, key, match, quick):
    stroke = StrokePlan.from_arrays(means, cov, segment_time=0.5)
    with pytest.raises(PlanError, match=match) as info:
        LQT(stroke)
    assert info.value.key == key


def test_segment_time_and_velocities_out_of_range(quick):
    stroke = StrokePlan.from_arrays([[0.0, 0.0], [1.0, 0.0]], 4.0, segment_time=1e5)
    with pytest.raises(PlanError, match=r"segment_time: expected a number in \[0\.01, 3600\] s"):
        LQT(stroke)
    targets = (GaussianTarget([0.0, 0.0], np.eye(2)), GaussianTarget([1.0, 0.0], np.eye(2)))
    fast = StrokePlan(targets, 0.5, True, velocities=[[1e300, 0.0], [0.0, 0.0]])
    with pytest.raises(PlanError, match=r"velocities: expected numbers in \[-1e\+10, 1e\+10\]"):
        LQT(fast, LQTConfig(order=3))
