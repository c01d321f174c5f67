"""Servo arms drawing through their own position firmware (inkarm.jobs.run with position
commands on the wx250s: inkarm.robots.servo inside the plant, goals shaped by ServoGoals)."""

from __future__ import annotations

import pytest

from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.robots.servo import JointServos

pytestmark = pytest.mark.sim

# The "Servo arms" row, bounds in [mm].
ROW = {"tracking_rms_mm": 1.0, "ink_chamfer_mm": 1.0}
# Position commands on the realistic arm (as the scenario ships): the host leads its goals by
# the 4 ms bus delay it knows of and keeps the model's friction, as position commands on servos
# need.
REALISTIC_POSITION = {"controller.law": "position", "controller.lookahead_s": 0.004}


class FirmwareCalls:
    """Counts the firmware's periods and keeps the firmware, through JointServos.torque."""

    def __init__(self, monkeypatch):
        self.calls, self.servos = 0, None
        torque = JointServos.torque

        def counted(servos, goal_q, q, qd):
            self.calls += 1
            self.servos = servos
            return torque(servos, goal_q, q, qd)

        monkeypatch.setattr(JointServos, "torque", counted)

    def simulated_s(self) -> float:
        """The time the firmware believes passed [s]."""
        return self.calls * self.servos.firmware.period_s


def drawn_time_s(result) -> float:
    return float(result.log.time[-1] - result.log.time[0])


def test_the_letter_through_the_servo_firmware_meets_the_servo_row(monkeypatch):
    firmware = FirmwareCalls(monkeypatch)
    result = run(load_scenario("scenarios/wx250s_letter_N.toml").with_overrides(
        {"controller.law": "position"}))
    assert result.ok, result.reason
    m = result.metrics
    assert m["tracking_rms_mm"] <= ROW["tracking_rms_mm"], m
    assert m["ink_chamfer_mm"] <= ROW["ink_chamfer_mm"], m
    assert m["gap_mm"] == 0.0
    # The servos' own loop held every goal (not the profile's joint drives), one period a step.
    assert firmware.calls > 0
    assert firmware.simulated_s() == pytest.approx(drawn_time_s(result), abs=0.01)


@pytest.fixture(scope="module")
def realistic_position():
    with pytest.MonkeyPatch.context() as monkeypatch:
        firmware = FirmwareCalls(monkeypatch)
        result = run(load_scenario("scenarios/realistic_servo_arm.toml").with_overrides(
            REALISTIC_POSITION))
    return result, firmware


def test_the_firmware_keeps_time_with_a_plant_that_refines_its_step(realistic_position):
    """The backlash's gear train splits the physics step (2 ms -> 1/3 ms); the firmware's
    periods must still add up to the simulated time (its I and D are per second)."""
    result, firmware = realistic_position
    assert result.finished, result.reason
    assert firmware.servos.firmware.period_s < 0.002
    assert firmware.simulated_s() == pytest.approx(drawn_time_s(result), abs=0.01)


def test_the_realistic_servo_arm_meets_the_row_through_its_firmware(realistic_position):
    result, _ = realistic_position
    m = result.metrics
    assert result.ok, result.reason
    assert m["tracking_rms_mm"] <= ROW["tracking_rms_mm"], m
    assert m["ink_chamfer_mm"] <= ROW["ink_chamfer_mm"], m
    assert m["gap_mm"] == 0.0
