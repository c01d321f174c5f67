"""Realising plan files: mean trajectories and samples per stroke, the stacked drawing, errors
that name the stroke, independent and reproducible random streams."""

from __future__ import annotations

import re
import time
import tomllib
import tracemalloc

import numpy as np
import pytest

from inkarm.core.budget import BudgetError
from inkarm.errors import InkarmError
from inkarm.io.planfile import STREAMS, parse_plan, stroke_seeds
from inkarm.plans.realise import (
    plan_bytes,
    realise_plan,
    require_plan_time,
    stroke_seconds,
    stroke_size,
)

BASIC = """
title = "two strokes"
cov = 4.0
[model]
order = 3
d = 2.0
segment_time = 0.2
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
[[strokes]]
model = { order = 5, r = 1e-6 }
cov = [1.0, 9.0]
targets = [{ mean = [30.0, 0.0] }, { mean = [40.0, 10.0], cov = [[4.0, 1.0], [1.0, 2.0]] }]
"""


def parse(text: str, seed: int | None = None):
    return parse_plan(tomllib.loads(text), source="plan.toml", seed=seed)


def test_human_line_and_minjerk_strokes_realise():
    plan = parse("""
[human_line]
squiggle = 3.0
[[strokes]]
kind = "human_line"
points = [[0.0, 0.0], [30.0, 0.0], [30.0, 30.0]]
human_line = { duration = 1.0 }
[[strokes]]
kind = "minjerk"
points = [[0.0, 0.0], [10.0, 10.0], [20.0, 0.0]]
minjerk = { duration = 0.8, via_times = [0.3] }
""")
    result = realise_plan(plan, samples=3)
    assert result.strokes[0].mean.t[-1] == pytest.approx(2.0)
    assert result.strokes[0].samples.shape == (3, result.strokes[0].mean.n, 2)
    assert not np.allclose(result.strokes[0].samples[0], result.strokes[0].samples[1])
    np.testing.assert_allclose(result.strokes[1].mean.pos[30], [10.0, 10.0], atol=1e-9)
    np.testing.assert_array_equal(result.strokes[1].samples[2], result.strokes[1].mean.pos)


def test_realised_plan_concatenates_strokes_and_samples_in_order():
    plan = parse(BASIC)
    result = realise_plan(plan, samples=4)
    n0, n1 = (s.mean.n for s in result.strokes)
    stacked = result.stacked_samples()
    assert stacked["pos"].shape == (4, n0 + n1, 2)
    assert stacked["stroke"].tolist() == [0] * n0 + [1] * n1
    assert np.all(np.diff(stacked["t"]) > 0)
    # the second stroke starts after the first plus the pen-up pause
    assert stacked["t"][n0] == pytest.approx(stacked["t"][n0 - 1] + plan.pause)
    np.testing.assert_array_equal(stacked["pos"][:, n0:], result.strokes[1].samples)
    # the samples scatter around the mean
    mean0 = result.strokes[0].mean.pos
    assert np.max(np.abs(stacked["pos"][:, :n0] - mean0)) > 1e-3
    np.testing.assert_allclose(
        realise_plan(plan, samples=4).stacked_samples()["pos"], stacked["pos"]
    )


def test_solver_errors_name_the_stroke():
    plan = parse(
        "[model]\norder = 6\ndt = 0.1\nsegment_time = 0.1\n"
        "[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [1.0, 0.0], cov = 1.0 }]\n"
    )
    with pytest.raises(
        InkarmError,
        match=r"plan.toml: strokes\[0\]\.model\.segment_time: .*order 6 needs at least 7",
    ):
        realise_plan(plan)


SPREAD = """
seed = 7
samples = 2
[semi_tied]
h = 4.0
rho = 1.0
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [5.0, 5.0] }, { mean = [9.0, 0.0] }]
"""


def test_covariance_draws_and_samples_use_independent_streams(monkeypatch):
    from inkarm.models import lqt

    seen = {}

    def spy(name, real):
        def wrapped(*args, seed=None, **kwargs):
            seen[name] = np.random.default_rng(seed).bit_generator.state["state"]["state"]
            return real(*args, seed=seed, **kwargs)

        return wrapped

    monkeypatch.setattr(lqt, "semi_tied_covariances", spy("covariances", lqt.semi_tied_covariances))
    monkeypatch.setattr(lqt.LQT, "sample", spy("samples", lqt.LQT.sample))
    realise_plan(parse(SPREAD))
    assert set(seen) == set(STREAMS)
    assert seen["covariances"] != seen["samples"]  # the same seed gave both the same stream
    streams = stroke_seeds(7, 0)
    draws = {k: np.random.default_rng(v).standard_normal(16) for k, v in streams.items()}
    assert not np.allclose(draws["covariances"], draws["samples"])
    again = stroke_seeds(7, 0)
    for k in STREAMS:  # deterministic per seed and stroke; other strokes get other streams
        np.testing.assert_array_equal(np.random.default_rng(again[k]).standard_normal(16), draws[k])
        other = np.random.default_rng(stroke_seeds(7, 1)[k]).standard_normal(16)
        assert not np.allclose(other, draws[k])


def test_plans_and_samples_are_reproducible_per_seed():
    first = realise_plan(parse(SPREAD))
    again = realise_plan(parse(SPREAD))
    np.testing.assert_array_equal(first.strokes[0].samples, again.strokes[0].samples)
    np.testing.assert_array_equal(first.plan.strokes[0].plan.covs, again.plan.strokes[0].plan.covs)
    other = realise_plan(parse(SPREAD, seed=8))
    assert not np.allclose(other.strokes[0].samples, first.strokes[0].samples)


# -- budgets: refused before any work, naming the file, the stroke and the setting ---------------

HUGE = {
    "gaussian": "cov = 4.0\n[model]\ndt = 0.0001\nsegment_time = 3600.0\n[[strokes]]\n"
    "targets = [{ mean = [0.0, 0.0] }, { mean = [1.0, 0.0] }]\n",
    "human_line": "[model]\ndt = 0.0001\n[[strokes]]\nkind = 'human_line'\n"
    "points = [[0.0, 0.0], [10.0, 0.0]]\nhuman_line = { duration = 3600.0 }\n",
    "minjerk": "[model]\ndt = 0.0001\n[[strokes]]\nkind = 'minjerk'\n"
    "points = [[0.0, 0.0], [10.0, 0.0]]\nminjerk = { duration = 3600.0 }\n",
}


@pytest.mark.parametrize("kind", sorted(HUGE))
def test_huge_step_counts_are_refused_before_any_work(kind, monkeypatch):
    plan = parse(HUGE[kind])
    start = time.perf_counter()
    with pytest.raises(BudgetError, match=r"^plan.toml: strokes\[0\]\.model\.dt: time steps of "
                       r".*about [\d.]+e\+07 time steps, more than the limit of 1e\+06 time steps "
                       r"\(raise it with the environment variable INKARM_MAX_STEPS\)") as info:
        realise_plan(plan)
    assert time.perf_counter() - start < 2.0
    assert info.value.key == "strokes[0].model.dt" and info.value.file == "plan.toml"
    monkeypatch.setenv("INKARM_MAX_STEPS", "1e8")
    n, _ = stroke_size(plan.strokes[0], 0)  # passes the step check; the job is not run
    assert n >= 36_000_000


def test_memory_of_the_samples_is_refused_naming_the_samples():
    plan = parse("samples = 10000\ncov = 4.0\n[model]\ndt = 0.001\nsegment_time = 20.0\n"
                 "[[strokes]]\ntargets = [{ mean = [0.0, 0.0] }, { mean = [1.0, 0.0] }]\n")
    with pytest.raises(BudgetError, match=r"plan.toml: samples: memory of realising the plan "
                       r"\(1 stroke, 40000 time steps, 10000 samples each\): about [\d.]+ GB, "
                       r".*INKARM_MAX_MEMORY_MB"):
        realise_plan(plan)
    with pytest.raises(BudgetError, match=r"plan.toml: samples: samples per stroke: about "
                       r"2e\+04 samples, .*INKARM_MAX_SAMPLES"):
        realise_plan(plan, samples=20_000)


def test_memory_of_a_stroke_is_refused_naming_the_stroke():
    plan = parse("cov = 4.0\n[model]\norder = 7\ndt = 0.001\nsegment_time = 400.0\n"
                 "[[strokes]]\ntargets = [{ mean = [0.0, 0.0] }, { mean = [1.0, 0.0] }]\n")
    with pytest.raises(BudgetError, match=r"plan.toml: strokes\[0\]: memory of realising"):
        realise_plan(plan)


MIXED = """
samples = 30
cov = 4.0
[model]
dt = 0.002
segment_time = 0.5
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
[[strokes]]
kind = "human_line"
points = [[0.0, 0.0], [30.0, 0.0], [30.0, 30.0]]
[[strokes]]
kind = "minjerk"
points = [[0.0, 0.0], [10.0, 10.0], [20.0, 0.0]]
minjerk = { duration = 2.0 }
"""


def test_the_memory_estimate_of_a_plan_is_within_2x_of_the_measured_peak():
    plan = parse(MIXED)
    estimate = plan_bytes([stroke_size(s, plan.samples) for s in plan.strokes], plan.samples,
                          plan.dim)
    tracemalloc.start()
    try:
        realise_plan(plan).stacked_samples()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert 0.5 <= estimate / peak <= 2.0


def test_model_errors_name_the_key_as_the_file_spells_it():
    plan = parse("[[strokes]]\nkind = 'minjerk'\npoints = [[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]\n"
                 "minjerk = { duration = 1.0, via_times = [2.0] }\n")
    with pytest.raises(InkarmError, match=r"^plan.toml: strokes\[0\]\.minjerk\.via_times: "):
        realise_plan(plan)


# -- time ---------------------------------------------------------------------------------------


def _case(text: str, key: str, value, what: str) -> tuple:
    """A slow plan: its text, the key and value its refusal names, and a regex of its cause."""
    return text, key, value, what


SLOW = {  # each passes the step, sample and memory budgets but would run for minutes or more
    "eigen": _case(
        "samples = 10\ncov = 4.0\n[model]\nsampling = 'eigen'\nsegment_time = 5.0\n[[strokes]]\n"
        "targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 0.0] }, { mean = [10.0, 10.0] }, "
        "{ mean = [0.0, 10.0] }]\n",
        "strokes[0].model.sampling",
        "eigen",
        r"the eigen draws of strokes\[0\] \(eigenpairs of a dense 4000 x 4000 matrix, "
        r"O\(\(N D\)\^3\); sampling = \"exact\", the default, draws in O\(N\)\)\): about 19\.2 s",
    ),
    "batch": _case(
        "samples = 0\ncov = 4.0\n[model]\nsolver = 'batch'\nsegment_time = 4.0\n[[strokes]]\n"
        "targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 0.0] }]\n",
        "strokes[0].model.solver",
        "batch",
        r"the dense oracle of strokes\[0\] \(800 steps x 2-D: .*solver = \"auto\" is linear in N\)",
    ),
    "human_line": _case(
        "samples = 10000\n[model]\ndt = 0.01\n[[strokes]]\nkind = 'human_line'\npoints = ["
        + ", ".join(f"[{3.0 * i}, {3.0 * i}]" for i in range(201))
        + "]\nhuman_line = { duration = 0.05 }\n",
        "samples",
        10000,
        r"10000 sampled human polylines of strokes\[0\] \(200 lines of 0\.05 s / dt 0\.01 s\)",
    ),
    "minjerk": _case(
        "[[strokes]]\nkind = 'minjerk'\npoints = ["
        + ", ".join(f"[{float(i)}, {float(i % 7)}]" for i in range(200))
        + "]\nminjerk = { duration = 20.0 }\n",
        "strokes[0].points",
        200,
        r"the minimum-jerk path of strokes\[0\] through 200 points; give via_times to skip the "
        r"via-time search",
    ),
}


@pytest.mark.parametrize("kind", sorted(SLOW))
def test_slow_plans_are_refused_by_their_time_naming_the_input(kind, monkeypatch):
    text, key, value, what = SLOW[kind]
    plan = parse(text)
    start = time.perf_counter()
    with pytest.raises(BudgetError, match=r"^plan.toml: " + re.escape(key) + r": time of "
                       r"realising the plan \(1 stroke, \d+ samples? each; (mostly )?" + what
                       + r".*more than the limit of 10 s \(raise it with the environment "
                       r"variable INKARM_MAX_COMPUTE_S\)$") as info:
        realise_plan(plan)
    assert time.perf_counter() - start < 2.0
    assert (info.value.key, info.value.value, info.value.file) == (key, value, "plan.toml")
    assert info.value.estimate > 10.0 and info.value.variable == "INKARM_MAX_COMPUTE_S"
    monkeypatch.setenv("INKARM_MAX_COMPUTE_S", "1000")
    require_plan_time(plan, plan.samples)  # passes; the plan is not realised


def test_the_time_of_a_plan_is_the_sum_of_its_strokes():
    plan = parse(MIXED)
    parts = [part for s in plan.strokes for part in stroke_seconds(s, plan.samples)]
    assert [part[1] for part in parts] == ["strokes[1].points", "samples", "strokes[2].points"]
    start = time.perf_counter()
    realise_plan(plan)
    assert sum(part[0] for part in parts) < 1.0 and time.perf_counter() - start < 5.0
