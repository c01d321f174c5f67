"""The WidowX 250 draws the default letter N scaled to its reach (scenarios/wx250s_letter_N.toml)
within half a millimetre of tracking and of ink, at the force set point, without a joint above
its speed limit; a reference that would exceed a limit is slowed with a note naming the joint,
or refused naming it."""

import math
import re
from pathlib import Path

import numpy as np
import pytest

from inkarm.errors import UnreachableError
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario, source_drawing

pytestmark = [pytest.mark.sim, pytest.mark.slow]

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "wx250s_letter_N.toml"
TOO_FAST = 0.15  # time scale at which the letter's elbow would pass its 180 deg/s (~1.5 x)


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(SCENARIO)


@pytest.fixture(scope="module")
def letter(scenario):
    return run(scenario)


def test_the_scenario_is_the_default_letter_on_the_wx250s(scenario):
    assert scenario.robot.name == "wx250s"
    assert scenario.placement.height_mm == 40.0
    default = source_drawing(load_scenario(None))
    mine = source_drawing(scenario)
    assert len(mine.strokes) == len(default.strokes)
    for a, b in zip(mine.strokes, default.strokes):
        np.testing.assert_array_equal(a.t, b.t)
        np.testing.assert_array_equal(a.pos, b.pos)


def test_draws_the_letter_within_half_a_millimetre(scenario, letter):
    assert letter.ok, letter.reason
    m = letter.metrics
    assert m["tracking_rms_mm"] < 0.5, m
    if math.isfinite(m["ink_chamfer_mm"]):
        assert m["ink_chamfer_mm"] < 0.5, m
    assert abs(m["contact_force_mean_n"] - scenario.controller.force_n) < 0.1, m
    assert m["gap_mm"] == 0.0, m


def test_no_joint_exceeds_its_speed_or_torque_limit(scenario, letter):
    assert letter.notes == ()  # the planner slowed nothing
    robot = scenario.robot
    assert np.all(np.abs(letter.log.qd).max(axis=0) < robot.speed_limits)
    assert np.all(np.abs(letter.log.torque).max(axis=0) < 0.5 * robot.torque_limits)


def _named_joint(text: str, names) -> str:
    found = re.search(r"joint (\w+)", text)
    assert found and found.group(1) in names, text
    return found.group(1)


def test_a_too_fast_letter_is_slowed_with_a_note_naming_the_joint(scenario):
    fast = run(scenario.with_overrides({"placement.time_scale": TOO_FAST}))
    assert fast.finished, fast.reason  # (its force band: 0.83..1.33 N, degraded at 4 x speed)
    assert fast.notes and all(note.startswith("slowed") for note in fast.notes), fast.notes
    for note in fast.notes:
        _named_joint(note, scenario.robot.joint_names)
    slowest = float(re.match(r"slowed ([0-9.]+) x", fast.notes[-1]).group(1))
    assert slowest > 1.0
    # drawn at ~4 x the letter's speed, through the servos' own loop
    assert fast.metrics["tracking_rms_mm"] < 2.0, fast.metrics


def test_a_too_fast_letter_is_refused_naming_the_joint(scenario):
    refusing = scenario.with_overrides({"placement.time_scale": TOO_FAST,
                                        "controller.speed_limits": "refuse"})
    with pytest.raises(UnreachableError) as e:
        run(refusing)
    joint = _named_joint(str(e.value), scenario.robot.joint_names)
    assert getattr(e.value, "joint", joint) == joint
    assert "deg/s" in str(e.value)
