"""Realising plan files: mean trajectories and samples per stroke, the stacked drawing, errors
that name the stroke, independent and reproducible random streams."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from inkarm.errors import InkarmError
from inkarm.io.planfile import STREAMS, parse_plan, stroke_seeds
from inkarm.plans.realise import realise_plan

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
    with pytest.raises(InkarmError, match=r"plan.toml: strokes\[0\]: .*order 6 needs at least 7"):
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
    monkeypatch.setattr(lqt, "sample", spy("samples", lqt.sample))
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
