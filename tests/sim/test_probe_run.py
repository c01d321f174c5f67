"""Probing the paper before drawing (controller.probe_paper): the probe finds a lowered, tilted
sheet, the first stroke is then drawn at its force, a sheet out of reach fails at the probe, and
a batched ensemble probes as each member does."""

from __future__ import annotations

import re

import numpy as np
import pytest

from inkarm.core.log import HOME, TRAVEL
from inkarm.jobs.ensemble import run_ensemble
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario

pytestmark = pytest.mark.sim

SHEET = {"plant.paper_height_mm": -3.0, "plant.paper_tilt_deg": 2.0,
         "plant.paper_tilt_axis_deg": 30.0}


def first_stroke_force_error(result) -> float:
    log = result.log
    rows = np.flatnonzero(log.drawing & (log.stroke == 0))[:60]  # the first 0.36 s of ink
    return float(np.abs(log.force[rows] - 1.0).max())


@pytest.fixture(scope="module")
def letter():
    return load_scenario()


def test_the_probe_finds_the_sheet_and_the_first_stroke_starts_on_it(letter):
    probed = run(letter.with_overrides({**SHEET, "controller.probe_paper": True}))
    believed = run(letter.with_overrides(SHEET))
    assert probed.ok and believed.ok
    (note,) = [n for n in probed.notes if n.startswith("probed the paper")]
    found = re.search(r"at 3 points .* pressed ([+-][0-9.]+) mm .* tilted ([0-9.]+) deg", note)
    depth, tilt = float(found.group(1)), float(found.group(2))
    assert 2.0 < depth < 4.0 and 1.4 < tilt < 2.2  # 3 mm lower (less the nib's sink), 2 deg
    assert first_stroke_force_error(probed) < first_stroke_force_error(believed)
    assert probed.metrics["tracking_rms_mm"] <= 0.1 and probed.metrics["gap_mm"] == 0.0


def test_a_sheet_beyond_the_search_fails_at_the_probe(letter):
    result = run(letter.with_overrides({"plant.paper_height_mm": -30.0,
                                        "controller.probe_paper": True}))
    assert result.status == "failed" and result.reason.startswith("paper_not_found: ")
    assert len(result.log) > 0 and result.log.force[-1] == 0.0  # the probe's log, pen up
    assert "metrics" not in result.reason


def test_a_batched_ensemble_probes_as_each_member_alone_does():
    """The probe's dots lead the one plan, so the batch probes too: same status, log and note
    as each member run alone, on sheets of their own height and tilt."""
    scenario = load_scenario("scenarios/quick_stroke.toml").with_overrides(
        {"controller.probe_paper": True,
         "plant.random": {"paper_height_mm": [-4.0, 2.0], "paper_tilt_deg": [0.0, 2.0]}})
    seeds = [0, 5]
    batched = run_ensemble(scenario, seeds, processes=1)
    for seed, member in zip(seeds, batched):
        alone = run(scenario.with_overrides({"plant.seed": seed}))
        assert member.status == alone.status == "ok", (member.reason, alone.reason)
        assert np.array_equal(member.log.q, alone.log.q)
        assert np.array_equal(member.log.stroke, alone.log.stroke)
        assert member.notes == alone.notes and alone.notes[0].startswith("probed the paper")
        assert member.metrics["tracking_rms_mm"] == pytest.approx(
            alone.metrics["tracking_rms_mm"], rel=1e-9)


def test_the_log_starts_where_the_pen_leaves_the_last_probe_dot(letter):
    probed = run(letter.with_overrides({**SHEET, "controller.probe_paper": True})).log
    assert probed.phase[0] == TRAVEL and probed.stroke[0] == 0  # towards the first stroke
    assert probed.stroke.max() == 0  # the letter's one stroke, numbered from 0 again
    assert probed.phase[probed.stroke == -1][0] == HOME


def test_a_plant_with_delayed_readings_draws_a_second_drawing_as_well_as_its_first():
    """The loop places each reading on the plan by the plant's clock, not by its first reading
    (which, on a plant used before, is already late)."""
    from inkarm.control.executor import run_drawing
    from inkarm.jobs.preflight import placed_within_budget
    from inkarm.jobs.preflight import substeps as _substeps
    from inkarm.sim.cell import Cell, kinematic_model
    from inkarm.sim.perturb import plant_model
    from inkarm.sim.plant import MujocoPlant

    scenario = load_scenario("scenarios/quick_stroke.toml").with_overrides(
        {"plant.sensing_delay_ms": 2.0, "plant.actuation_delay_ms": 2.0,
         "controller.lookahead_s": 0.002})
    cell = Cell(scenario.cell, scenario.robot)
    truth = scenario.plant.realised()
    plant = MujocoPlant(plant_model(cell, truth), cell=cell, truth=truth,
                        substeps=_substeps(scenario.robot.control_period_s,
                                           scenario.cell.timestep))
    drawing, model = placed_within_budget(scenario, cell), kinematic_model(cell)
    logs = [run_drawing(drawing, plant, model, scenario.robot.gains, scenario.controller)
            for _ in range(2)]
    rms = [float(np.sqrt(np.mean(log.tracking_error() ** 2))) for log in logs]
    assert logs[1].time[0] > logs[0].time[-1]
    assert rms[1] < 1.5 * rms[0] + 0.01, rms
