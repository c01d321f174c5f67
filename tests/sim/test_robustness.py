"""The controller against plants that are not its model (issue 9's robustness rows), and runs
beyond its reach ending as failed, with the right watchdog, the pen up, the log kept.

Each row is a full run of the default letter with a ``[plant]`` table; the controller keeps the
nominal model. ``benchmarks/bench_robustness.py`` prints the same rows as a table, with the
64-member ensemble.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from inkarm.jobs.robustness import (
    ALL_AT_ONCE,
    BEYOND_REACH,
    BOUNDS,
    ELASTIC,
    ONE_AT_A_TIME,
    SAFE_WITHIN_S,
    overrides,
)
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario

QUICK = {"paper -5 mm", "hard paper (rigid, solref 2 ms), nib friction 0.3"}
ROWS = {name: plant for name, plant in ONE_AT_A_TIME.items() if "elasticity" not in name}


def draw(plant: dict, scenario=None, knows_latency: bool = True, careful: bool = False):
    return run((scenario or load_scenario()).with_overrides(
        overrides(plant, knows_latency, careful)))


def assert_within_bounds(result, rms=BOUNDS["tracking_rms_mm"], chamfer=BOUNDS["ink_chamfer_mm"],
                         band=BOUNDS["force_band_n"]):
    assert result.ok, result.reason
    m = result.metrics
    assert m["tracking_rms_mm"] <= rms and m["ink_chamfer_mm"] <= chamfer, m
    assert m["gap_mm"] == 0.0
    f = result.log.force[result.log.drawing]
    lo, hi = np.percentile(f, [1, 99])
    assert 1.0 - band <= lo and hi <= 1.0 + band, (lo, hi)


@pytest.mark.sim
@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n in QUICK else pytest.mark.slow)
                                  for n in ROWS])
def test_one_imperfection_at_a_time_is_drawn_within_the_bounds(name):
    assert_within_bounds(draw(ROWS[name]))


@pytest.mark.sim
@pytest.mark.slow
def test_the_exact_twin_keeps_its_tracking():
    result = draw({})
    assert_within_bounds(result, rms=0.1, chamfer=0.1, band=0.05)


@pytest.mark.sim
@pytest.mark.slow
def test_series_elasticity_within_the_bounds():
    assert_within_bounds(draw({"elasticity_nm_per_rad": ELASTIC}))


@pytest.mark.sim
@pytest.mark.slow
def test_every_imperfection_at_once_tracks_within_the_bounds():
    # degraded by the README's band (0.87..1.14 N: its table says so); within 0.15 N
    scenario = load_scenario().with_overrides({"judge.force_band_n": 0.15})
    assert_within_bounds(draw(ALL_AT_ONCE, scenario), band=0.15)


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.parametrize("mass_scale", [0.8, 1.2])
def test_every_imperfection_at_once_within_the_bounds_with_the_careful_controller(mass_scale):
    """The paper probed first and a slower force loop (CAREFUL_CONTROLLER): the whole mix, with
    the links 20 % lighter or heavier than the model, within every bound (the default
    controller leaves it at 0.87..1.14 N, and degrades with heavier links)."""
    plant = {**ALL_AT_ONCE, "mass_scale": mass_scale}
    assert_within_bounds(run(load_scenario().with_overrides(overrides(plant, careful=True))))


@pytest.mark.sim
@pytest.mark.slow
def test_an_ensemble_around_the_mix_draws_with_the_careful_controller():
    """Members of AROUND_ALL_AT_ONCE (the bench draws 64: 64 within every bound)."""
    for seed in (0, 1, 2, 3):
        scenario = load_scenario().with_overrides(overrides(ALL_AT_ONCE, careful=True,
                                                            seed=seed))
        assert_within_bounds(run(scenario))


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.parametrize("name", list(ONE_AT_A_TIME))
def test_the_careful_controller_keeps_every_row(name):
    assert_within_bounds(draw(ONE_AT_A_TIME[name], careful=True))


@pytest.mark.sim
@pytest.mark.slow
def test_an_ensemble_around_the_realistic_scenario_draws():
    scenario = load_scenario("scenarios/realistic_iiwa.toml")
    results = [run(scenario.with_overrides({"plant.seed": seed})) for seed in range(6)]
    assert [r.status for r in results] == ["ok"] * 6
    assert max(r.metrics["tracking_rms_mm"] for r in results) <= 0.3
    assert max(r.metrics["ink_chamfer_mm"] for r in results) <= 0.3


@pytest.mark.sim
@pytest.mark.parametrize("name", [
    pytest.param(n, marks=() if n == "paper 30 mm lower" else pytest.mark.slow) for n in BEYOND_REACH])
def test_beyond_reach_the_run_fails_safe_within_100_ms(name):
    plant, watchdog = BEYOND_REACH[name]
    result = draw(plant, knows_latency=False)
    assert result.status == "failed" and result.reason.startswith(f"{watchdog}: "), result.reason
    fault = float(re.search(r"at t = ([0-9.]+) s", result.reason).group(1))
    log = result.log
    assert len(log) > 0 and log.time[-1] - fault <= SAFE_WITHIN_S  # the log up to the safe stop
    assert log.force[-1] == 0.0  # the pen is off the paper


@pytest.mark.sim
@pytest.mark.slow
def test_the_servo_arm_draws_through_its_encoders_backlash_and_bus_delay():
    """4096 ticks a turn, velocity in the servo's units, 0.2 deg backlash, 4 ms bus delay."""
    result = run(load_scenario("scenarios/realistic_servo_arm.toml"))
    assert result.ok, result.reason
    m = result.metrics
    assert m["tracking_rms_mm"] <= 1.0 and m["ink_chamfer_mm"] <= 1.0 and m["gap_mm"] == 0.0
