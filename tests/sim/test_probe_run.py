"""Probing the paper before drawing (controller.probe_paper): the probe finds a lowered, tilted
sheet, the first stroke is then drawn at its force, a sheet out of reach fails at the probe, and
the batched ensemble refuses to probe."""

from __future__ import annotations

import re

import numpy as np
import pytest

from inkarm.errors import InputError
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


def test_the_batched_ensemble_refuses_to_probe():
    scenario = load_scenario("scenarios/quick_stroke.toml").with_overrides(
        {"controller.probe_paper": True})
    with pytest.raises(InputError, match="does not probe the paper") as info:
        run_ensemble(scenario, [0, 1])
    assert "probe_paper" in str(info.value)


def test_a_plant_with_delayed_readings_draws_a_second_drawing_as_well_as_its_first():
    """The loop places each reading on the plan by the plant's clock, not by its first reading
    (which, on a plant used before, is already late)."""
    from inkarm.control.loop import run_drawing
    from inkarm.jobs.run import _substeps, placed_within_budget
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
