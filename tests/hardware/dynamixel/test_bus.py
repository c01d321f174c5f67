"""DynamixelBus: the SDK's sticky 'port in use', stale bytes, retries, closing."""

from __future__ import annotations

import os

import pytest

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.bus import DynamixelBus, DynamixelFault

pytestmark = pytest.mark.hardware_emulated


def test_an_interrupted_call_does_not_leave_the_port_in_use(emulator):
    with DynamixelBus(emulator.port) as bus:
        bus.port.is_using = True          # what a Ctrl-C inside the SDK leaves behind
        assert bus.read(1, "model_number") == 1020


def test_stale_bytes_are_flushed_before_a_transaction(emulator):
    with DynamixelBus(emulator.port, names={1: "waist"}) as bus:
        with emulator.lock:  # a late status of servo 1 already waiting in the input buffer
            os.write(emulator._master, p.status(1, 0, bytes([9, 9, 9, 9])))
        assert bus.read(1, "goal_position") != 0x09090909


def test_a_silent_servo_costs_the_bounded_retries_then_names_itself(emulator):
    emulator.inject("silent", 2)
    with DynamixelBus(emulator.port, retries=2, names={2: "shoulder"}) as bus:
        with pytest.raises(DynamixelFault, match=r"servo 2 \(shoulder\): no reply to read "
                                                 r"goal_position after 3 tries") as info:
            bus.read(2, "goal_position")
        assert info.value.servo_id == 2 and info.value.kind == "no reply"
        assert bus.stats["retries"] == 2
        with pytest.raises(DynamixelFault, match=r"servo 2 \(shoulder\): no reply to sync read"):
            bus.read_state([1, 2, 3])
    with pytest.raises(DynamixelFault, match="the port is closed"):
        bus.read(1, "goal_position")


def test_status_errors_raise_with_their_name(emulator):
    with DynamixelBus(emulator.port, names={1: "waist"}) as bus:
        bus.write(1, "torque_enable", 1)
        with pytest.raises(DynamixelFault, match=r"servo 1 \(waist\): access error on write "
                                                 r"operating_mode = 4"):
            bus.write(1, "operating_mode", 4)
