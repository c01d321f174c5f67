"""A second Dynamixel client on the emulator: rustypot (Pollen Robotics' Rust driver, from the
package index), its standard flow through its own XL430/XM430/XM540 controller (scan, ping,
reads, writes, sync read/write, torque on and off), every register it knows, and the
indirect address block it exposes."""

from __future__ import annotations

import pytest

from inkarm.hardware.dynamixel import protocol as p
from tests.hardware.waiting import eventually

rustypot = pytest.importorskip("rustypot", reason="rustypot is not installed "
                               "(pip install rustypot: the test extras carry it)")
pytestmark = pytest.mark.hardware_emulated

MODELS = {1: 1020, 2: 1060, 3: 1120}  # the conftest emulator: XM430-W350, XL430-W250, XM540-W270



@pytest.fixture
def controller(emulator):
    c = rustypot.Xl430PyController(emulator.port, 1_000_000, 0.1)
    yield c
    c.close()


def test_rustypot_finds_each_servo_by_scan_and_ping(controller):
    assert controller.broadcast_scan() == MODELS
    assert controller.scan([1, 2, 3, 9]) == MODELS
    assert controller.ping(1) and controller.ping(3) and not controller.ping(9)
    assert [controller.read_model_number(i)[0] for i in MODELS] == list(MODELS.values())
    assert controller.read_firmware_version(2) == [46]


def test_rustypot_standard_flow_moves_a_servo_and_lets_it_go(controller, emulator):
    c = controller
    assert c.read_present_position(1) == [2048]            # the joint at 0 rad
    c.write_torque_enable(1, 1)
    assert c.read_torque_enable(1) == [1]
    c.write_goal_position(1, 2148)
    assert c.read_goal_position(1) == [2148]
    assert eventually(lambda: abs(c.read_present_position(1)[0] - 2148) <= 3)
    c.sync_write_torque_enable([2, 3], [1, 1])
    c.sync_write_goal_position([1, 2, 3], [2048, 1948, 2300])
    assert c.sync_read_goal_position([1, 2, 3]) == [2048, 1948, 2300]
    assert eventually(lambda: all(abs(a - b) <= 3 for a, b in zip(
        c.sync_read_present_position([1, 2, 3]), [2048, 1948, 2300])))
    c.sync_write_torque_enable([1, 2, 3], [0, 0, 0])
    assert c.sync_read_torque_enable([1, 2, 3]) == [0, 0, 0]
    assert [emulator.servo(i).memory.get("torque_enable") for i in MODELS] == [0, 0, 0]


def test_rustypot_reads_every_register_it_knows_on_every_model(controller):
    """Backup Ready (147) and the Indirect Address/Data blocks included (rustypot's table
    names them; a servo without them would fail these reads)."""
    names = [r.name for r in rustypot.Xl430PyController.registers()]
    assert {"backup_ready", "startup_configuration", "indirect_address_1",
            "indirect_data_6"} <= set(names)
    for servo_id in MODELS:
        for name in names:
            _value, error = controller.read_register_with_error(servo_id, name)
            assert error == 0, (servo_id, name)
    assert controller.read_indirect_address_6(2) == [229]    # each starts at its own data
    assert controller.read_backup_ready(3) == [0]


def test_rustypot_maps_registers_through_the_indirect_block(controller, emulator):
    c = controller
    for k, address in enumerate((132, 133, 134, 135), start=1):  # Present Position's bytes
        getattr(c, f"write_indirect_address_{k}")(1, address)
    c.write_indirect_address_5(1, 65)                           # LED
    c.write_indirect_data_5(1, 1)
    assert c.read_led(1) == [1] and emulator.servo(1).memory.get("led") == 1
    assert c.read_raw_data(1, 224, 4) == list((2048).to_bytes(4, "little"))
    # a range and a value-list refusal come back as rustypot reads them: refused
    assert c.write_register_with_error(1, "indirect_address_6", 20) == p.DATA_RANGE_ERROR
    status = c.write_register_with_error(2, "operating_mode", 5)   # no current mode on XL430
    assert status == p.DATA_RANGE_ERROR and c.definition().refuses(status)
    assert c.read_operating_mode(2) == [3]


def test_rustypot_bus_api_sync_reads_models_of_one_port(emulator):
    definition = rustypot.Xl430PyController.definition()
    with rustypot.Bus(emulator.port, 1_000_000, 0.1, {i: definition for i in MODELS}) as bus:
        assert bus.sync_read_register([1, 2, 3], "present_position") == [2048] * 3
        bus.write_register(2, "led", 1)
        assert bus.read_register(2, "led") == 1
