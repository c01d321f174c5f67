"""DynamixelPlant on the emulator: start-up checks, goals, limits, faults and safe stops."""

from __future__ import annotations

import time

import numpy as np
import pytest

from inkarm.core.plant import PenCommand, PositionCommand
from inkarm.errors import InputError
from inkarm.hardware.dynamixel.bus import DynamixelFault
from inkarm.hardware.dynamixel.config import with_dynamixel
from inkarm.hardware.dynamixel.emulator import FAULT_KINDS
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from tests.hardware.waiting import eventually

pytestmark = pytest.mark.hardware_emulated



def test_refuses_a_bus_that_does_not_match_naming_each_difference(wx250s, arm_emulator):
    emu = arm_emulator(wx250s)
    with emu:
        emu.servo(5).silent = True                         # the elbow's shadow is missing
        emu.servo(3).memory.set("secondary_id", 9)         # the shoulder's shadow is misset
        wrong = with_dynamixel(wx250s, models=["XM430-W350"] * 5 + ["XM540-W270"])
        with pytest.raises(InputError) as info:
            DynamixelPlant(emu.port, wrong)
    message = str(info.value)
    assert "servo 8 (wrist_rotate): a XL430-W250 answers, the profile expects a XM540-W270" \
        in message
    assert "servo 5 (elbow shadow): no reply" in message
    assert "servo 3 (shoulder shadow): Secondary ID is 9, expected 2" in message


def test_torque_on_at_the_present_position_without_a_jump(wx250s, arm_emulator):
    with arm_emulator(wx250s) as emu:
        for s in emu.bus.servos:
            s.memory.set("goal_position", 3000)            # stale goals from an earlier session
        plant = DynamixelPlant(emu.port, wx250s)
        q0 = plant.read().q
        time.sleep(0.2)
        q1 = plant.read().q
        plant.close()
    np.testing.assert_allclose(q0, wx250s.home_q, atol=2e-3)
    np.testing.assert_allclose(q1, q0, atol=3e-3)


@pytest.mark.parametrize("park_deg", [None, [0.0, -100.0, 85.0, 0.0, 45.0, 0.0]])
def test_close_parks_and_lets_go_only_at_a_rest_pose(park_deg, wx250s, arm_emulator):
    """Parked at home (a drawing pose over the sheet) the arm holds, pen up: released there
    it would fall on the sheet (the HIL twin's stray line, issue 21). At a ``park_deg`` the
    profile names (a rest pose) the torque goes off."""
    # A loaded machine's emulator thread answers late, and a host stalled past the dead-man
    # leaves the park half-way (the servos refuse goals): no dead-man here, the HIL slack.
    arm = with_dynamixel(wx250s, latency_ms=50, watchdog_ms=0)
    arm = arm if park_deg is None else with_dynamixel(arm, park_deg=park_deg)
    park = np.radians(park_deg) if park_deg is not None else wx250s.home_q
    parked = np.rint(2048 + park[:2] * 4096 / (2 * np.pi))
    torque = 1 if park_deg is None else 0
    with arm_emulator(arm) as emu:
        plant = DynamixelPlant(emu.port, arm)
        plant.read()
        plant.close()
        # the last sync writes have no replies: they land later
        assert eventually(lambda: all(s.memory.get("torque_enable") == torque
                                      for s in emu.bus.servos))
        assert eventually(lambda: abs(emu.servo(2).memory.get("goal_position") - parked[1]) <= 1)
        goals = [emu.servo(i).memory.get("goal_position") for i in (1, 2)]
    np.testing.assert_allclose(goals, parked, atol=1)


def test_goals_are_clamped_to_the_step_and_the_software_limits(wx250s, arm_emulator):
    with arm_emulator(wx250s) as emu:
        plant = DynamixelPlant(emu.port, wx250s)
        start = plant.read().q
        far = start + np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        plant.command(PositionCommand(far))
        step = round(2048 + np.radians(3.0) * 4096 / (2 * np.pi))
        assert eventually(lambda: abs(emu.servo(1).memory.get("goal_position") - step) <= 1)
        with pytest.raises(InputError, match="does not take pen commands"):
            plant.command(PenCommand(True))
        with pytest.raises(InputError, match="6 finite joint goals"):
            plant.command(PositionCommand(np.full(6, np.nan)))
        for _ in range(200):  # walk the elbow far past its range: stops at the margin
            plant.command(PositionCommand(start + np.array([0, 0, 5.0, 0, 0, 0])))
        elbow_high = np.radians(92.0 - 2.0)
        assert plant._goal_q[2] == pytest.approx(elbow_high)
        plant.close()


@pytest.mark.parametrize("kind", FAULT_KINDS)
def test_each_fault_ends_in_pen_up_and_a_safe_arm_within_50_ms(kind, wx250s, arm_emulator,
                                                                tmp_path):
    trace = tmp_path / "trace.npz"
    with arm_emulator(wx250s) as emu:
        plant = DynamixelPlant(emu.port, wx250s, trace_path=trace)
        q = plant.read().q
        for _ in range(12):
            plant.read()
            plant.command(PositionCommand(q))
            plant.step()
        emu.inject(kind, 4)                               # the elbow
        with pytest.raises(DynamixelFault) as info:
            for _ in range(40):
                plant.read()
                plant.command(PositionCommand(q))
                plant.step()
        fault = info.value
        lifted = np.degrees(plant._goal_q - q)
        plant.close()
        shoulder = round(2048 + (q[1] + np.radians(-6.0)) * 4096 / (2 * np.pi))
        lifted_on_bus = eventually(
            lambda: abs(emu.servo(2).memory.get("goal_position") - shoulder) <= 2)
        on_bus = emu.servo(2).memory.get("goal_position")
    message = str(fault)
    if kind == "disconnect":
        assert "serial port disconnected" in message and "bus watchdog" in message
    else:
        assert "servo 4 (elbow)" in message
        expected = {"silent": ("no reply",), "late": ("no reply", "late replies"),
                    "crc": ("corrupt reply",), "overload": ("hardware error: overload",),
                    "overheat": ("hardware error: overheating",),
                    "watchdog": ("bus watchdog expired",)}[kind]
        assert any(words in message for words in expected), message
        assert "pen lifted" in message and "arm holding" in message
        assert plant.safe_after_s < 0.05
        np.testing.assert_allclose(lifted, [0, -6.0, 0, 0, 0, 0], atol=0.01)
        assert lifted_on_bus, (on_bus, shoulder)
    assert trace.is_file()
    saved = np.load(trace)
    assert len(saved["time"]) >= 12 and saved["q"].shape[1] == 6


def test_current_mode_sends_torques_as_goal_currents(wx250s, arm_emulator):
    from inkarm.core.plant import TorqueCommand
    from inkarm.robots.servo import SERVO_MODELS

    arm = with_dynamixel(wx250s, operating_mode="current", models=["XM430-W350"] * 6,
                       on_fault="torque_off", on_close="torque_off")
    with arm_emulator(arm) as emu:
        plant = DynamixelPlant(emu.port, arm)
        assert plant.commands == frozenset({"torque"})
        with pytest.raises(InputError, match="does not take position commands"):
            plant.command(PositionCommand(wx250s.home_q))
        plant.read()
        plant.command(TorqueCommand(np.array([1.0, 2.0, 0, 0, 0, 99.0])))
        kt = SERVO_MODELS["XM430-W350"].torque_constant_nm_per_a
        waist, shoulder = round(1.0 / kt / 2.69e-3), round(2.0 / (2 * kt) / 2.69e-3)
        wrist = round(wx250s.torque_limits[5] / kt / 2.69e-3)           # clamped to its limit
        assert eventually(lambda: [emu.servo(i).memory.get("goal_current") for i in (1, 2, 3, 8)]
                          == [waist, shoulder, shoulder, wrist])
        assert all(s.memory.get("operating_mode") == 0 for s in emu.bus.servos)
        time.sleep(0.1)
        assert plant.read().qd[0] > 0.5          # the waist's rotor spins up under 1 N m
        plant.close()
        assert eventually(lambda: all(s.memory.get("torque_enable") == 0
                                      for s in emu.bus.servos))


def test_current_mode_needs_current_sensing_and_a_release_on_faults(wx250s):
    from inkarm.hardware.dynamixel.config import DynamixelConfig

    with pytest.raises(InputError, match="XL430-W250 do not"):
        DynamixelConfig.of(with_dynamixel(wx250s, operating_mode="current"))
    with pytest.raises(InputError, match="cannot lift the pen or hold by itself"):
        DynamixelConfig.of(with_dynamixel(wx250s, operating_mode="current",
                                        models=["XM430-W350"] * 6))
    with pytest.raises(InputError, match=r"a XL430-W250 \(models\[5\]\) has no "
                                         r"current_based_position mode"):
        DynamixelConfig.of(with_dynamixel(wx250s, operating_mode="current_based_position"))


def _at_level(emu, level):
    for s in emu.bus.servos:
        s.memory.set("status_return_level", level)


def test_servos_at_status_return_level_1_start_draw_and_stop(wx250s, arm_emulator,
                                                            monkeypatch):
    """Level 1 answers PING and reads only: the plant's writes go without waiting
    (``writeTxOnly``, never the SDK's ``writeTxRx``) and are read back."""
    from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler

    acknowledged = []
    tx_rx = Protocol2PacketHandler.writeTxRx
    monkeypatch.setattr(Protocol2PacketHandler, "writeTxRx",
                        lambda self, port, i, *a: acknowledged.append(i) or tx_rx(self, port, i,
                                                                                  *a))
    arm = with_dynamixel(wx250s, on_close="torque_off")
    with arm_emulator(arm) as emu:
        _at_level(emu, 1)
        for s in emu.bus.servos:
            s.memory.set("return_delay_time", 250)         # stale: written at start
        plant = DynamixelPlant(emu.port, arm)
        assert plant.bus.levels == {i: 1 for i in plant.config.all_ids}
        assert acknowledged == []
        assert all(s.memory.get("torque_enable") == 1 and s.memory.get("return_delay_time") == 0
                   for s in emu.bus.servos)
        q = plant.read().q
        goal = q + np.radians([2.0, 0, 0, 0, 0, 0])
        for _ in range(5):
            plant.read()
            plant.command(PositionCommand(goal))
            plant.step()
        assert eventually(lambda: abs(plant.read().q[0] - goal[0]) < np.radians(0.3))
        plant.close()
        assert eventually(lambda: all(s.memory.get("torque_enable") == 0
                                      for s in emu.bus.servos))
        assert plant.fault is None and acknowledged == []


def test_status_return_level_0_is_refused_naming_the_register_or_set_by_the_profile(
        wx250s, arm_emulator):
    fast = with_dynamixel(wx250s, latency_ms=8, on_close="torque_off")  # level 0: no reads
    with arm_emulator(wx250s) as emu:
        _at_level(emu, 0)
        with pytest.raises(DynamixelFault, match=r"servo 1 \(waist\): answers PING but not READ: "
                                                 r"its Status Return Level \(68\) is 0 \(PING "
                                                 r"only\); set it to 2 \(or 1\), e\.g\. with "
                                                 r"status_return_level = 2 in "
                                                 r"\[backends.dynamixel\]"):
            DynamixelPlant(emu.port, fast)
        for level in (2, 1):
            _at_level(emu, 0)
            arm = with_dynamixel(fast, status_return_level=level)
            plant = DynamixelPlant(emu.port, arm)
            assert [s.memory.get("status_return_level") for s in emu.bus.servos] == [level] * 8
            plant.read()
            plant.close()


def test_a_write_a_level_1_servo_refuses_is_named_from_its_read_back(emulator):
    from inkarm.hardware.dynamixel.bus import DynamixelBus

    _at_level(emulator, 1)
    with DynamixelBus(emulator.port, names={2: "wrist"}) as bus:
        bus.write(2, "led", 1)          # unanswered: the level is learnt, the write read back
        assert bus.levels == {2: 1} and bus.stats["retries"] >= 2  # the write's, unanswered
        assert emulator.servo(2).memory.get("led") == 1
        with pytest.raises(DynamixelFault, match=r"servo 2 \(wrist\): write operating_mode = 0 "
                                                 r"not applied \(reads back 3\); at Status Return "
                                                 r"Level \(68\) 1 the servo does not answer"):
            bus.write(2, "operating_mode", 0)   # an XL430 has no current mode
        bus.set_status_return_level(2, 2)
        assert bus.levels[2] == 2 and emulator.servo(2).memory.get("status_return_level") == 2
        bus.write(2, "led", 0)
    emulator.servo(3).memory.set("status_return_level", 0)
    silent_write = r"servo 3 \(elbow\): answers PING but not READ: its Status Return Level \(68\)"
    with DynamixelBus(emulator.port, names={3: "elbow"}) as bus, \
            pytest.raises(DynamixelFault, match=silent_write + r" is 0"):
        bus.write(3, "torque_enable", 0)
