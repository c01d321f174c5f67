"""X-series control tables (Protocol 2.0) as data: address, size, access, range, unit.

Facts from the ROBOTIS e-Manual control tables (firmware 45 and later), read from the
e-Manual's own sources (github.com/ROBOTIS-GIT/emanual):

* XL430-W250: https://emanual.robotis.com/docs/en/dxl/x/xl430-w250/ (docs/en/dxl/x/
  xl430-w250.md at 00a4b781): Temperature Limit 72, Voltage Limits 60..140, no Current Limit
  (38) or Goal Current (102), 126 is Present Load [0.1 %], operating modes 1, 3, 4, 16
  (_includes/en/dxl/x/operating_mode_xl.md).
* XM430-W350: https://emanual.robotis.com/docs/en/dxl/x/xm430-w350/ (docs/en/dxl/x/
  xm430-w350.md at 08551725). That page's Voltage Limit range reads "110 ~ 300" beside
  defaults 160/95 that it would refuse; the XM540 page and the X-series voltage include give
  95..160 for the 12 V servos, which is taken. The older e-Manual (and LeRobot, which copied
  it) lists an Acceleration Limit at 40 and a Velocity Limit of 350: firmware before 42; the
  current page has neither, nor has this table. Startup Configuration (60) and Backup Ready
  (147) are from firmware 45 (_includes/en/dxl/control_table_60_startup_configuration.md),
  listed on the XL430 and XM540 pages, and here for every model.
* XM540-W270: https://emanual.robotis.com/docs/en/dxl/x/xm540-w270/ (docs/en/dxl/x/
  xm540-w270.md at 028a13d2): Current Limit 2047, the External Ports (56-58, 152-156).
* Drive Mode (10) is a bit set (_includes/en/dxl/x/drive_mode.md): bit 0 reverse, bit 1
  leader/follower (X540 only), bit 2 time-based profile, bit 3 torque on by goal update; a
  value with another bit set is refused. (The XM540 page's range column reads 0 ~ 5 and the
  XM430 page's 0 ~ 1, both older than the bit list, which is taken.)
* Indirect Address n (168 + 2(n-1), 578 + 2(n-29)) names the address that Indirect Data n
  (224 + (n-1), 634 + (n-29)) reads and writes, 64..661 (RAM); each Indirect Address starts
  at its own Indirect Data (_includes/en/dxl/control_table_indirect_data.md).

A register's bounds are either fixed (``minimum``/``maximum``, or the value list ``values``:
writing outside is a Data Range Error) or set by other registers (``limit``: the names of the
registers bounding it; writing outside is a Data Limit Error), e.g. Goal Position within the
Min/Max Position Limits. Signed registers are two's complement on the wire, little-endian.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from itertools import combinations

from inkarm.errors import unknown_name
from inkarm.robots.servo import SERVO_MODELS

EEPROM, RAM = "EEPROM", "RAM"
R, RW = "R", "RW"

# Operating Mode (11)
CURRENT_MODE, VELOCITY_MODE, POSITION_MODE, EXTENDED_POSITION_MODE = 0, 1, 3, 4
CURRENT_BASED_POSITION_MODE, PWM_MODE = 5, 16
OPERATING_MODES = {"current": 0, "velocity": 1, "position": 3, "extended_position": 4,
                   "current_based_position": 5, "pwm": 16}
# Baud Rate (8) register value -> [bit/s]
BAUD_RATES = {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000,
              6: 4_000_000, 7: 4_500_000}
# Hardware Error Status (70) bits
HARDWARE_ERRORS = {0: "input voltage error", 2: "overheating", 3: "motor encoder error",
                   4: "electrical shock", 5: "overload"}
EXTENDED_RANGE = 1_048_575  # Goal Position's bound in extended position mode [ticks]
# Indirect Address/Data blocks: (first n, count, first address register, first data register)
INDIRECT_BLOCKS = ((1, 28, 168, 224), (29, 28, 578, 634))
INDIRECT_TARGETS = (64, 661)  # what an Indirect Address may name (RAM) [address]


@dataclass(frozen=True)
class Register:
    """One control-table item."""

    name: str
    address: int
    size: int
    access: str
    area: str
    default: int = 0
    minimum: int = 0
    maximum: int = 0
    unit: str = ""
    signed: bool = False
    limit: tuple[str, ...] = ()   # registers bounding it: (min, max) or (symmetric,)
    values: tuple[int, ...] = ()  # the value list, where not every value in range is taken

    def takes(self, value: int) -> bool:
        """Whether ``value`` is within the register's fixed range (and its value list)."""
        return self.minimum <= value <= self.maximum and (not self.values or
                                                          value in self.values)


def _r(name, address, size, access, area, default=0, minimum=0, maximum=None, unit="",
       signed=False, limit=(), values=()):
    if maximum is None:
        maximum = (1 << (8 * size - (1 if signed else 0))) - 1
    return Register(name, address, size, access, area, default, minimum, maximum, unit, signed,
                    tuple(limit), tuple(values))


def bit_values(*bits: int) -> tuple[int, ...]:
    """Every value whose set bits are among ``bits`` (a bit-set register's value list)."""
    return tuple(sorted(sum(1 << b for b in chosen) for k in range(len(bits) + 1)
                        for chosen in combinations(bits, k)))


def _indirect() -> tuple[Register, ...]:
    regs = []
    for first, count, address0, data0 in INDIRECT_BLOCKS:
        for k in range(count):
            regs.append(_r(f"indirect_address_{first + k}", address0 + 2 * k, 2, RW, RAM,
                           data0 + k, *INDIRECT_TARGETS))
            regs.append(_r(f"indirect_data_{first + k}", data0 + k, 1, RW, RAM))
    return tuple(regs)


COMMON: tuple[Register, ...] = (
    _r("model_number", 0, 2, R, EEPROM),
    _r("model_information", 2, 4, R, EEPROM),
    _r("firmware_version", 6, 1, R, EEPROM, 46),
    _r("id", 7, 1, RW, EEPROM, 1, 0, 252),
    _r("baud_rate", 8, 1, RW, EEPROM, 1, 0, 7),
    _r("return_delay_time", 9, 1, RW, EEPROM, 250, 0, 254, "2 us"),
    _r("drive_mode", 10, 1, RW, EEPROM, 0, 0, 13, values=bit_values(0, 2, 3)),
    _r("operating_mode", 11, 1, RW, EEPROM, 3, 0, 16, values=(0, 1, 3, 4, 5, 16)),
    _r("secondary_id", 12, 1, RW, EEPROM, 255, 0, 255),
    _r("protocol_type", 13, 1, RW, EEPROM, 2, 1, 2),
    _r("homing_offset", 20, 4, RW, EEPROM, 0, -1_044_479, 1_044_479, "tick", True),
    _r("moving_threshold", 24, 4, RW, EEPROM, 10, 0, 1023, "0.229 rpm"),
    _r("temperature_limit", 31, 1, RW, EEPROM, 80, 0, 100, "degC"),
    _r("max_voltage_limit", 32, 2, RW, EEPROM, 160, 95, 160, "0.1 V"),
    _r("min_voltage_limit", 34, 2, RW, EEPROM, 95, 95, 160, "0.1 V"),
    _r("pwm_limit", 36, 2, RW, EEPROM, 885, 0, 885, "0.113 %"),
    _r("current_limit", 38, 2, RW, EEPROM, 1193, 0, 1193, "2.69 mA"),
    _r("velocity_limit", 44, 4, RW, EEPROM, 200, 0, 1023, "0.229 rpm"),
    _r("max_position_limit", 48, 4, RW, EEPROM, 4095, 0, 4095, "tick"),
    _r("min_position_limit", 52, 4, RW, EEPROM, 0, 0, 4095, "tick"),
    _r("startup_configuration", 60, 1, RW, EEPROM, 0, 0, 3),
    _r("shutdown", 63, 1, RW, EEPROM, 52, 0, 255),
    _r("torque_enable", 64, 1, RW, RAM, 0, 0, 1),
    _r("led", 65, 1, RW, RAM, 0, 0, 1),
    _r("status_return_level", 68, 1, RW, RAM, 2, 0, 2),
    _r("registered_instruction", 69, 1, R, RAM, 0, 0, 1),
    _r("hardware_error_status", 70, 1, R, RAM),
    _r("velocity_i_gain", 76, 2, RW, RAM, 1920, 0, 16383),
    _r("velocity_p_gain", 78, 2, RW, RAM, 100, 0, 16383),
    _r("position_d_gain", 80, 2, RW, RAM, 0, 0, 16383),
    _r("position_i_gain", 82, 2, RW, RAM, 0, 0, 16383),
    _r("position_p_gain", 84, 2, RW, RAM, 800, 0, 16383),
    _r("feedforward_2nd_gain", 88, 2, RW, RAM, 0, 0, 16383),
    _r("feedforward_1st_gain", 90, 2, RW, RAM, 0, 0, 16383),
    # 1..127 [20 ms], 0 off; the servo sets -1 when it fires (the host writes 0 to clear it)
    _r("bus_watchdog", 98, 1, RW, RAM, 0, 0, 127, "20 ms", True),
    _r("goal_pwm", 100, 2, RW, RAM, 0, -885, 885, "0.113 %", True, ("pwm_limit",)),
    _r("goal_current", 102, 2, RW, RAM, 0, -1193, 1193, "2.69 mA", True, ("current_limit",)),
    _r("goal_velocity", 104, 4, RW, RAM, 0, -1023, 1023, "0.229 rpm", True,
       ("velocity_limit",)),
    _r("profile_acceleration", 108, 4, RW, RAM, 0, 0, 32767, "214.577 rev/min^2"),
    _r("profile_velocity", 112, 4, RW, RAM, 0, 0, 32767, "0.229 rpm"),
    _r("goal_position", 116, 4, RW, RAM, 0, -EXTENDED_RANGE, EXTENDED_RANGE, "tick", True,
       ("min_position_limit", "max_position_limit")),
    _r("realtime_tick", 120, 2, R, RAM, 0, 0, 32767, "ms"),
    _r("moving", 122, 1, R, RAM, 0, 0, 1),
    _r("moving_status", 123, 1, R, RAM),
    _r("present_pwm", 124, 2, R, RAM, 0, -885, 885, "0.113 %", True),
    _r("present_current", 126, 2, R, RAM, 0, -1193, 1193, "2.69 mA", True),
    _r("present_velocity", 128, 4, R, RAM, 0, unit="0.229 rpm", signed=True,
       minimum=-(1 << 31)),
    _r("present_position", 132, 4, R, RAM, 0, unit="tick", signed=True, minimum=-(1 << 31)),
    _r("velocity_trajectory", 136, 4, R, RAM, 0, unit="0.229 rpm", signed=True,
       minimum=-(1 << 31)),
    _r("position_trajectory", 140, 4, R, RAM, 0, unit="tick", signed=True, minimum=-(1 << 31)),
    _r("present_input_voltage", 144, 2, R, RAM, 120, unit="0.1 V"),
    _r("present_temperature", 146, 1, R, RAM, 30, unit="degC"),
    _r("backup_ready", 147, 1, R, RAM, 0, 0, 1),
    *_indirect(),
)
# The XM540's External Ports: mode 0 analog in, 1 push-pull out, 2 pull-up in, 3 pull-down in
EXTERNAL_PORTS = (
    *(_r(f"external_port_mode_{k}", 55 + k, 1, RW, EEPROM, 3, 0, 3) for k in (1, 2, 3)),
    *(_r(f"external_port_data_{k}", 150 + 2 * k, 2, RW, RAM) for k in (1, 2, 3)),
)


@dataclass(frozen=True)
class ControlTable:
    """A model's control table: registers by name and by address."""

    model: str
    model_number: int
    registers: tuple[Register, ...]

    def __post_init__(self):
        object.__setattr__(self, "_by_name", {r.name: r for r in self.registers})
        owner: list[Register | None] = [None] * self.size
        for reg in self.registers:
            owner[reg.address:reg.address + reg.size] = [reg] * reg.size
        object.__setattr__(self, "_by_address", tuple(owner))

    @property
    def by_name(self) -> Mapping[str, Register]:
        return self._by_name  # type: ignore[attr-defined]

    @property
    def by_address(self) -> tuple[Register | None, ...]:
        """The register each byte of memory belongs to (None: reserved)."""
        return self._by_address  # type: ignore[attr-defined]

    def __getitem__(self, name: str) -> Register:
        if name not in self.by_name:
            raise unknown_name(f"{self.model} register", name, self.by_name)
        return self.by_name[name]

    def __contains__(self, name: str) -> bool:
        return name in self.by_name

    @property
    def size(self) -> int:
        """Bytes of memory the table spans."""
        last = max(self.registers, key=lambda r: r.address)
        return last.address + last.size


def _table(model: str, defaults: dict[str, int], drop: tuple[str, ...] = (),
           changes: dict[str, dict] | None = None,
           extra: tuple[Register, ...] = ()) -> ControlTable:
    number = SERVO_MODELS[model].model_number
    regs = []
    for reg in COMMON:
        if reg.name in drop:
            continue
        reg = replace(reg, **(changes or {}).get(reg.name, {}))
        if reg.name == "model_number":
            reg = replace(reg, default=number)
        if reg.name in defaults:
            reg = replace(reg, default=defaults[reg.name])
        regs.append(reg)
    regs = sorted((*regs, *extra), key=lambda r: r.address)
    return ControlTable(model, number, tuple(regs))


TABLES: dict[str, ControlTable] = {
    "XM430-W350": _table("XM430-W350", {"velocity_limit": 200, "position_p_gain": 800}),
    "XL430-W250": _table(
        "XL430-W250",
        {"velocity_limit": 265, "position_p_gain": 640, "position_d_gain": 4000,
         "velocity_i_gain": 1000, "temperature_limit": 72, "max_voltage_limit": 140,
         "min_voltage_limit": 60},
        drop=("current_limit", "goal_current"),
        changes={"present_current": {"name": "present_load", "unit": "0.1 %", "minimum": -1000,
                                     "maximum": 1000},
                 "max_voltage_limit": {"minimum": 60, "maximum": 140},
                 "min_voltage_limit": {"minimum": 60, "maximum": 140},
                 "operating_mode": {"values": (1, 3, 4, 16)}}),
    "XM540-W270": _table(
        "XM540-W270", {"velocity_limit": 128, "current_limit": 2047},
        changes={"current_limit": {"maximum": 2047},
                 "goal_current": {"minimum": -2047, "maximum": 2047},
                 "drive_mode": {"maximum": 15, "values": bit_values(0, 1, 2, 3)}},
        extra=EXTERNAL_PORTS),
}
MODEL_NAMES = {t.model_number: t.model for t in TABLES.values()}


def table(model: str) -> ControlTable:
    """The control table of ``model`` (an :class:`InputError` naming the closest otherwise)."""
    if model not in TABLES:
        raise unknown_name("Dynamixel model", model, TABLES)
    return TABLES[model]


def to_unsigned(value: int, size: int) -> int:
    """A register value as its ``size``-byte two's complement."""
    return int(value) & ((1 << (8 * size)) - 1)


def to_signed(raw: int, size: int) -> int:
    """Two's complement ``size``-byte ``raw`` as a signed integer."""
    bits = 8 * size
    raw = int(raw) & ((1 << bits) - 1)
    return raw - (1 << bits) if raw >> (bits - 1) else raw


def decode(register: Register, raw: int) -> int:
    """The register's value from its raw little-endian integer."""
    return to_signed(raw, register.size) if register.signed else int(raw)
