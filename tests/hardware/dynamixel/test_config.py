"""[backends.dynamixel] checked, every error naming its key; control tables as data."""

from __future__ import annotations

import itertools

import pytest

from inkarm.errors import InputError
from inkarm.hardware.dynamixel.config import DynamixelConfig
from inkarm.hardware.dynamixel.tables import TABLES, table
from inkarm.robots.servo import SERVO_MODELS

NAMES = ("waist", "shoulder", "elbow", "forearm_roll", "wrist_angle", "wrist_rotate")
BASE = {"ids": [1, 2, 4, 6, 7, 8], "models": ["XM430-W350"] * 5 + ["XL430-W250"]}


def test_the_wx250s_table_reads(wx250s):
    cfg = DynamixelConfig.of(wx250s)
    assert cfg.all_ids == (1, 2, 4, 6, 7, 8, 3, 5) and cfg.shadows == {1: 3, 2: 5}
    assert cfg.gains["position_p"][0] == 4000 and cfg.mode_number == 4


@pytest.mark.parametrize("change, message", [
    ({"ids": [1, 2, 3]}, "backends.dynamixel.ids: expected 6 values"),
    ({"ids": [1, 2, 4, 6, 7, 300]}, r"backends.dynamixel.ids\[5\]: expected an integer in 0..252"),
    ({"models": ["XM430-W350"] * 5 + ["XM430-W250"]},
     r"models\[5\]: unknown Dynamixel model 'XM430-W250' \(did you mean"),
    ({"shadows": {"elbw": 5}}, "backends.dynamixel.shadows.elbw: unknown joint"),
    ({"shadows": {"elbow": 4}}, "servo ids must differ"),
    ({"baudrate": 12345}, "backends.dynamixel.baudrate: expected one of"),
    ({"position_p": [1, 2]}, "backends.dynamixel.position_p: expected 6 values"),
    ({"position_p": 20000}, r"position_p\[0\]: expected an integer in 0..16383"),
    ({"on_fault": "drop"}, "backends.dynamixel.on_fault: unknown value 'drop'"),
    ({"operating_mode": "pwm"}, "backends.dynamixel.operating_mode: unknown value"),
    ({"max_step_deg": 0}, "backends.dynamixel.max_step_deg: expected a number > 0"),
    ({"status_return_level": 0}, r"status_return_level: expected an integer in 1..2"),
    ({"idz": [1]}, r"backends.dynamixel.idz: unknown key \(did you mean 'ids'"),
])
def test_bad_values_name_the_key(change, message):
    with pytest.raises(InputError, match=message):
        DynamixelConfig.from_table({**BASE, **change}, 6, NAMES, "arm.toml")


def test_a_profile_without_the_table_is_refused(wx250s):
    import dataclasses

    bare = dataclasses.replace(wx250s, backends={})
    with pytest.raises(InputError, match=r"no \[backends.dynamixel\] table"):
        DynamixelConfig.of(bare)


def test_control_tables_agree_with_the_sdk_addresses_and_the_servo_models():
    for model, t in TABLES.items():
        assert t.model_number == SERVO_MODELS[model].model_number
        assert (t["goal_position"].address, t["present_position"].address) == (116, 132)
        assert t["bus_watchdog"].address == 98 and t["bus_watchdog"].signed
        registers = sorted(t.registers, key=lambda r: r.address)
        for a, b in itertools.pairwise(registers):
            assert a.address + a.size <= b.address, (model, a.name, b.name)
    assert "current_limit" not in table("XL430-W250") and "present_load" in table("XL430-W250")
    assert table("XM540-W270")["current_limit"].maximum == 2047
    with pytest.raises(InputError, match="unknown Dynamixel model"):
        table("AX-12A")
