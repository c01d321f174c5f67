"""DPPLA (seed 001, sec. 3) against brute force, the banded DP against the exact one."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis.dppla import (
    compression_rate,
    dppla,
    dppla_tolerance,
    reconstruct,
    segments_for_compression,
    trajectory_channels,
)
from inkarm.analysis.dppla_budget import banded_cost, check_budget, exact_cost
from inkarm.analysis.dppla_segments import SegmentCost
from inkarm.core.budget import BudgetError
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError


def direct_cost(x, i, j, error, tau=None):
    """d(i, j) summed sample by sample, straight from the definitions."""
    tau = np.arange(len(x), dtype=float) if tau is None else tau
    seg, a, b = x[i : j + 1], x[i], x[j]
    if error == "interpolation":
        s = (tau[i : j + 1] - tau[i]) / (tau[j] - tau[i])
        return float(np.sum((seg - a - s[:, None] * (b - a)) ** 2))
    r = seg - a
    n = np.linalg.norm(b - a)
    if n == 0:
        return float(np.sum(r**2))
    return float(np.sum(r**2) - np.sum((r @ ((b - a) / n)) ** 2))


def path_cost(x, breakpoints, error, tau=None):
    return sum(direct_cost(x, i, j, error, tau) for i, j in itertools.pairwise(breakpoints))


def brute_force(x, k, error):
    """Minimum over every set of k-1 interior break points."""
    w = len(x)
    return min(
        path_cost(x, (0, *inner, w - 1), error)
        for inner in itertools.combinations(range(1, w - 1), k - 1)
    )


def in_band(breakpoints, w, k, band, window=True):
    short = np.all(np.diff(breakpoints) <= band)
    centre = np.arange(k + 1) * (w - 1) / k
    return bool(short and (not window or np.all(np.abs(breakpoints - centre) <= band)))


# Coordinates on a 1e-3 grid: two samples either coincide or lie at least 1e-3 apart, so a
# chord's direction is never decided by rounding.
coords = st.integers(-50_000, 50_000).map(lambda v: v / 1000)


@st.composite
def trajectories(draw, max_w=12, max_k=4):
    w = draw(st.integers(2, max_w))
    p = draw(st.integers(1, 3))
    x = np.array(draw(st.lists(coords, min_size=w * p, max_size=w * p))).reshape(w, p)
    k = draw(st.integers(1, min(max_k, w - 1)))
    return x, k


@settings(max_examples=150, deadline=None)
@given(trajectories(), st.sampled_from(["interpolation", "perpendicular"]))
def test_exact_equals_brute_force(case, error):
    x, k = case
    result = dppla(x, k, error=error)
    best = brute_force(x, k, error)
    bp = result.breakpoints
    assert bp[0] == 0 and bp[-1] == len(x) - 1 and np.all(np.diff(bp) > 0) and result.k == k
    assert result.cost == pytest.approx(best, rel=1e-7, abs=1e-7)
    assert path_cost(x, bp, error) == pytest.approx(result.cost, rel=1e-7, abs=1e-7)
    assert result.rms == pytest.approx(math.sqrt(result.cost / len(x)))


@settings(max_examples=80, deadline=None)
@given(
    st.integers(8, 40).flatmap(lambda w: st.tuples(st.just(w), st.integers(2, min(8, w - 1)))),
    st.integers(0, 2**31 - 1),
    st.sampled_from([None, 0.5, 1.0]),
    st.booleans(),
)
def test_banded_equals_exact_when_the_optimum_is_in_band(wk, seed, band_factor, window):
    w, k = wk
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(size=(w, 2)), axis=0)
    exact = dppla(x, k)
    band = None
    if band_factor is not None:
        band = max(math.ceil(band_factor * w / k), math.ceil((w - 1) / k))
    banded = dppla(x, k, banded=True, band=band, window=window, verify=True)
    assert banded.cost >= exact.cost - 1e-9
    assert path_cost(x, banded.breakpoints, "interpolation") == pytest.approx(
        banded.cost, rel=1e-7, abs=1e-9
    )
    assert in_band(banded.breakpoints, w, k, banded.band, window)
    if in_band(exact.breakpoints, w, k, banded.band, window):
        assert banded.cost == pytest.approx(exact.cost, rel=1e-9, abs=1e-9)
    assert banded.optimal_in_band == (banded.cost <= exact.cost + 1e-9 * max(exact.cost, 1.0))


def test_band_that_excludes_the_optimum_is_reported():
    # A long straight run then a tight zig-zag: the optimum puts every break point in the
    # zig-zag, far from the uniform segmentation.
    line = np.column_stack([np.linspace(0, 100, 80), np.zeros(80)])
    zigzag = np.column_stack([100 + np.arange(1, 21), 5.0 * (np.arange(1, 21) % 2)])
    x = np.vstack([line, zigzag])
    exact = dppla(x, 20)
    banded = dppla(x, 20, banded=True, verify=True)
    assert banded.optimal_in_band is False
    assert banded.cost > exact.cost * 1.5
    assert dppla(x, 20, banded=True, verify=False).optimal_in_band is None
    # Bounding only the segment length (the paper's literal lb) still excludes it here.
    assert dppla(x, 20, banded=True, window=False, verify=True).optimal_in_band is False
    assert exact.optimal_in_band is True


def test_banded_verification_runs_by_default_only_when_cheap():
    t = np.linspace(0, 2 * np.pi, 400)
    x = np.column_stack([np.cos(t), np.sin(2 * t)])
    assert dppla(x, 10, banded=True).optimal_in_band is not None  # k w^2 / 2 = 8e5
    big = np.column_stack([np.linspace(0, 1, 2000), np.zeros(2000)])
    assert dppla(big, 20, banded=True).optimal_in_band is None  # k w^2 / 2 = 4e7


def test_segment_cost_vectorised_matches_direct_sums():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(30, 3)) * 10 + 500.0  # far from the origin: conditioning
    tau = np.cumsum(rng.uniform(0.5, 2.0, size=30))
    for error in ("interpolation", "perpendicular"):
        cost = SegmentCost(x, tau, error)
        i, j = np.triu_indices(30, k=1)
        expected = [direct_cost(x, a, b, error, tau) for a, b in zip(i, j)]
        np.testing.assert_allclose(cost(i, j), expected, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(
            cost.row(3, 17),
            [direct_cost(x, a, 17, error, tau) for a in range(3, 17)],
            rtol=1e-8,
            atol=1e-8,
        )


def test_straight_line_at_constant_speed_costs_nothing():
    x = np.column_stack([np.linspace(0, 10, 50), np.linspace(5, -5, 50)])
    for error in ("interpolation", "perpendicular"):
        assert dppla(x, 1, error=error).cost == pytest.approx(0.0, abs=1e-9)


def test_interpolation_error_counts_timing_and_perpendicular_does_not():
    s = np.linspace(0, 1, 40) ** 2  # accelerating along a straight line
    x = np.column_stack([10 * s, 0 * s])
    assert dppla(x, 1, error="perpendicular").cost == pytest.approx(0.0, abs=1e-9)
    assert dppla(x, 1).cost > 1.0
    # With the true times as chord parameter the line is traversed uniformly in tau.
    assert dppla(x, 1, tau=s + np.arange(40) * 1e-12).cost == pytest.approx(0.0, abs=1e-6)


def test_reconstruct_gives_the_cost():
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.normal(size=(60, 2)), axis=0)
    result = dppla(x, 7)
    model = reconstruct(x, result.breakpoints)
    assert np.sum((model - x) ** 2) == pytest.approx(result.cost)
    np.testing.assert_allclose(model[result.breakpoints], x[result.breakpoints])


def test_channel_weights_scale_the_error():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=(40, 3)), axis=0)
    dropped = dppla(x[:, :2], 5)
    zero = dppla(x, 5, weights=[1.0, 1.0, 0.0])
    assert zero.cost == pytest.approx(dropped.cost)
    np.testing.assert_array_equal(zero.breakpoints, dropped.breakpoints)
    assert dppla(x, 5, weights=[4.0, 4.0, 4.0]).cost == pytest.approx(4 * dppla(x, 5).cost)


def test_time_and_pressure_channels_join_the_error():
    t = np.linspace(0.0, 1.0, 30)
    traj = Trajectory(t, np.column_stack([t, 2 * t]), pressure=np.where(t < 0.5, 0.2, 0.9))
    x = trajectory_channels(traj, time=True, pressure=True)
    np.testing.assert_allclose(x, np.column_stack([t, 2 * t, t, traj.pressure]))
    # Positions and time are linear: only the pressure step needs a break point.
    geometric = dppla(x, 2, weights=[1.0, 1.0, 1.0, 0.0])
    with_pressure = dppla(x, 3, weights=[1.0, 1.0, 1.0, 100.0])
    assert geometric.cost == pytest.approx(0.0, abs=1e-9)
    assert set(with_pressure.breakpoints[1:-1]) == {14, 15}
    with pytest.raises(InputError, match="pressure requested but the trajectory has none"):
        trajectory_channels(Trajectory(t, np.column_stack([t, t])), pressure=True)


def test_compression_rate_follows_the_paper():
    # rho = 1 - |{n_i}| / w * (p + 1) / p: 330 samples in 3-D at 85 % keep 37 targets.
    assert segments_for_compression(0.85, 330, 3) == 36
    assert segments_for_compression(0.75, 2000, 2) == 332
    assert compression_rate(36, 330, 3) == pytest.approx(1 - 37 / 330 * 4 / 3)
    assert segments_for_compression(0.999, 10, 2) == 1  # at least two targets


def test_tolerance_picks_the_fewest_segments():
    t = np.linspace(0, 2 * np.pi, 150)
    x = np.column_stack([30 * np.cos(t), 10 * np.sin(t)])
    result = dppla_tolerance(x, 0.2)
    assert result.rms <= 0.2
    assert dppla(x, result.k - 1).rms > 0.2
    assert dppla(x, result.k).cost == pytest.approx(result.cost)
    assert dppla_tolerance(x, 0.0).cost == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("rho", [0.0, 1.0, -0.1, 1.5, float("nan")])
def test_compression_outside_unit_interval_is_refused(rho):
    with pytest.raises(InputError, match=r"compression rate: must lie in \(0, 1\)"):
        segments_for_compression(rho, 100, 2)


@pytest.mark.parametrize("k", [0, 10, 11])
def test_k_not_below_the_number_of_samples_is_refused(k):
    x = np.zeros((10, 2))
    with pytest.raises(
        InputError,
        match=rf"dppla k: {k} segments need {k + 1} distinct samples but the trajectory has 10",
    ):
        dppla(x, k)


def test_bad_inputs_are_refused():
    x = np.column_stack([np.arange(20.0), np.zeros(20)])
    with pytest.raises(InputError, match="dppla k: expected an integer"):
        dppla(x, 2.5)
    with pytest.raises(InputError, match="band: 2 samples is too narrow"):
        dppla(x, 3, banded=True, band=2)
    with pytest.raises(InputError, match="dppla band: expected a positive integer"):
        dppla(x, 3, banded=True, band=0)
    bad = x.copy()
    bad[4, 1] = np.nan
    with pytest.raises(InputError, match=r"NaN or inf at index \(4, 1\)"):
        dppla(bad, 3)
    with pytest.raises(InputError, match="need at least 2 samples"):
        dppla(x[:1], 1)
    with pytest.raises(InputError, match="dppla weights: expected 2 non-negative"):
        dppla(x, 3, weights=[1.0, -1.0])
    with pytest.raises(InputError, match="dppla tau: expected 20 strictly increasing"):
        dppla(x, 3, tau=np.zeros(20))
    with pytest.raises(InputError, match="dppla error: expected one of"):
        dppla(x, 3, error="hausdorff")
    with pytest.raises(InputError, match="dppla tolerance: expected a non-negative RMS"):
        dppla_tolerance(x, -1.0)


# -- memory and time budgets ---------------------------------------------------------------


def smooth(w: int) -> np.ndarray:
    t = np.linspace(0.0, 6 * np.pi, w)
    return np.column_stack([60 * np.cos(t), 20 * np.sin(2 * t) + t])


def peak_bytes(fn) -> tuple[object, int]:
    """fn()'s result and the peak of the memory it allocated (tracemalloc)."""
    import tracemalloc

    tracemalloc.start()
    try:
        result = fn()
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_banded_dp_allocates_only_the_band():
    # 40,000 samples in 6,666 segments (band 13): the (k+1, w) tables of delta and parents
    # alone were 4.3 GB; the band needs a few MB (the samples and prefix sums included).
    w, k = 40_000, 6_666
    x = smooth(w)
    result, peak = peak_bytes(lambda: dppla(x, k, banded=True, verify=False))
    assert peak < 40 * 2**20
    assert peak <= banded_cost(k, w, result.band)[1]
    assert result.k == k and result.breakpoints[-1] == w - 1 and np.all(np.diff(result.breakpoints) > 0)
    np.testing.assert_allclose(reconstruct(x, result.breakpoints), x, atol=1.0)


@pytest.mark.parametrize(("w", "k", "band_factor", "window"),
                         [(2000, 100, 2, True), (2000, 100, 2, False), (5000, 10, 2, True),
                          (3000, 1000, 2, False), (4000, 40, 0.5, True)])
def test_banded_estimate_bounds_its_allocations(w, k, band_factor, window):
    x = smooth(w)
    band = max(math.ceil(band_factor * w / k), math.ceil((w - 1) / k))
    _, peak = peak_bytes(lambda: dppla(x, k, banded=True, band=band, window=window, verify=False))
    steps, n_bytes = banded_cost(k, w, band, window)
    assert peak <= n_bytes <= 4 * peak + 2**20
    assert steps >= k * band  # every layer tries at least one row of band candidates


def test_exact_estimate_bounds_its_allocations_and_counts_its_steps():
    w, k = 1500, 200
    x = smooth(w)
    _, peak = peak_bytes(lambda: dppla(x, k))
    steps, n_bytes = exact_cost(k, w)
    assert peak <= n_bytes <= 4 * peak
    assert k * (w - k) ** 2 / 2 <= steps <= k * w * w / 2 + 5000 * w


def test_banded_results_do_not_depend_on_the_chunking(monkeypatch):
    import inkarm.analysis.dppla_dp as module

    x = np.cumsum(np.random.default_rng(3).normal(size=(700, 2)), axis=0)
    reference = dppla(x, 60, banded=True, verify=False)
    for chunk in (1, 7, 100):
        monkeypatch.setattr(module, "CHUNK", chunk)
        again = dppla(x, 60, banded=True, verify=False)
        assert again.cost == reference.cost
        np.testing.assert_array_equal(again.breakpoints, reference.breakpoints)


def test_exact_dp_over_the_memory_budget_is_refused_before_allocating():
    # 100,000 samples in 16,666 segments once asked for 12.4 GiB and failed.
    x = smooth(100_000)
    (error, peak) = peak_bytes(lambda: pytest.raises(BudgetError, dppla, x, 16_666).value)
    assert peak < 10 * 2**20
    assert error.variable == "INKARM_MAX_MEMORY_MB" and error.estimate > 2048
    assert "exact DPPLA of 100000 samples in 16666 segments" in str(error)
    assert dppla(x, 16_666, banded=True, verify=False).k == 16_666


def test_exact_dp_over_the_step_budget_is_refused(monkeypatch):
    x = smooth(300)
    monkeypatch.setenv("INKARM_MAX_DPPLA_STEPS", "1e6")
    with pytest.raises(BudgetError, match="INKARM_MAX_DPPLA_STEPS") as info:
        dppla(x, 50)
    assert info.value.estimate == exact_cost(50, 300)[0]
    with pytest.raises(BudgetError, match="INKARM_MAX_DPPLA_STEPS"):
        dppla_tolerance(x, 0.0)
    with pytest.raises(BudgetError, match="INKARM_MAX_DPPLA_STEPS"):
        dppla(x, 50, banded=True, verify=True)  # the certificate is the exact DP
    assert dppla(x, 50, banded=True, verify=False).banded
    monkeypatch.setenv("INKARM_MAX_DPPLA_STEPS", "1")
    with pytest.raises(BudgetError, match="banded DPPLA of 300 samples in 50 segments, band 12"):
        check_budget(50, 300, banded=True)


@pytest.mark.parametrize("w, k", [(101, 4), (60, 7), (500, 3)])
def test_on_a_straight_run_the_exact_dp_spreads_its_targets_evenly(w, k):
    # every split of a uniformly traversed line fits exactly: the tie-break takes the evenest
    # (without it the arg-min piled the break points at the start)
    x = np.column_stack([np.linspace(0.0, 50.0, w), np.linspace(0.0, 20.0, w)])
    result = dppla(x, k, banded=False)
    lengths = np.diff(result.breakpoints)
    assert lengths.max() - lengths.min() <= 1
    assert result.cost == pytest.approx(0.0, abs=1e-9)
