"""One emulated servo's control-table memory, with the firmware's access rules.

* A write must cover whole registers (else Data Length Error), only writable ones (Access
  Error), never the EEPROM area while Torque Enable is 1 (Access Error); each value within the
  register's fixed range (Data Range Error) and within the bounds other registers set (Goal
  Position within the Min/Max Position Limits in position mode, Goal Current within the
  Current Limit, ...: Data Limit Error). A write is all or nothing.
* Once the bus watchdog has fired (Bus Watchdog reads -1) goal writes are refused with a Data
  Range Error until the host writes 0 to it.
* A hardware error in the Shutdown mask turns the torque off; Torque Enable cannot be set
  again (Result Fail) until a REBOOT clears the error.
* Indirect Data n stands for the byte at the address Indirect Address n holds (one level: an
  Indirect Address that names an Indirect Data, as each does at first, is plain storage); a
  read or write through it behaves as one of those bytes would, with the same rules. An
  Indirect Address outside 64..661 is a Data Range Error.
* EEPROM survives REBOOT; RAM returns to its defaults.
"""

from __future__ import annotations

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.tables import (
    EEPROM,
    EXTENDED_RANGE,
    INDIRECT_BLOCKS,
    POSITION_MODE,
    RW,
    ControlTable,
    Register,
    decode,
    to_unsigned,
)

GOALS = ("goal_pwm", "goal_current", "goal_velocity", "goal_position")


class ServoMemory:
    """The control table of one servo (``table``), as bytes."""

    def __init__(self, table: ControlTable, servo_id: int):
        self.table = table
        self.data = bytearray(table.size)
        self._owner = table.by_address
        # Indirect Data address -> its Indirect Address register's address
        self._pointer = {data0 + k: address0 + 2 * k
                         for _, count, address0, data0 in INDIRECT_BLOCKS
                         for k in range(count) if data0 + k < table.size}
        self._indirect = [(data0, data0 + count) for _, count, _, data0 in INDIRECT_BLOCKS]
        self.factory_reset(0xFF)
        self.set("id", servo_id)

    # --- raw access --------------------------------------------------------------------------
    def get(self, name: str) -> int:
        reg = self.table.by_name[name]
        raw = int.from_bytes(self.data[reg.address:reg.address + reg.size], "little")
        return decode(reg, raw)

    def set(self, name: str, value: int) -> None:
        """Set a register regardless of the access rules (the firmware's own updates)."""
        reg = self.table.by_name[name]
        self.data[reg.address:reg.address + reg.size] = to_unsigned(value, reg.size).to_bytes(
            reg.size, "little")

    def has(self, name: str) -> bool:
        return name in self.table.by_name

    # --- the host's access -------------------------------------------------------------------
    def read(self, address: int, length: int) -> tuple[int, bytes]:
        """(error, data) for a READ of ``length`` bytes at ``address``."""
        if length < 1 or address < 0 or address + length > len(self.data):
            return p.ACCESS_ERROR, b""
        if not self._touches_indirect(address, address + length):
            return 0, bytes(self.data[address:address + length])
        return 0, bytes(self.data[self._target(a)] for a in range(address, address + length))

    def _touches_indirect(self, start: int, end: int) -> bool:
        return any(start < high and low < end for low, high in self._indirect)

    def _target(self, address: int) -> int:
        """The byte ``address`` stands for: itself, or what its Indirect Address names."""
        pointer = self._pointer.get(address)
        if pointer is None:
            return address
        target = int.from_bytes(self.data[pointer:pointer + 2], "little")
        return target if 0 <= target < len(self.data) and target not in self._pointer \
            else address

    def check_write(self, address: int, data: bytes) -> tuple[int, list[tuple[Register, int]]]:
        """(error, [(register, value), ...]) of writing ``data`` at ``address``; nothing is
        changed."""
        end = address + len(data)
        if not data or address < 0 or end > len(self.data):
            return p.ACCESS_ERROR, []
        if self._touches_indirect(address, end):
            error, writes = self._indirect_writes(address, data)
        else:
            error, writes = self._direct_writes(address, data)
        if error:
            return error, []
        torque_on = self.get("torque_enable") == 1
        for reg, value in writes:
            if reg.access != RW or (reg.area == EEPROM and torque_on):
                return p.ACCESS_ERROR, []
        for reg, value in writes:
            error = self._check_value(reg, value, {r.name: v for r, v in writes})
            if error:
                return error, []
        return 0, writes

    def _direct_writes(self, address: int, data: bytes) -> tuple[int, list[tuple[Register, int]]]:
        end = address + len(data)
        first, last = self._owner[address], self._owner[end - 1]
        if first is None or last is None or first.address != address or \
                last.address + last.size != end:
            return p.DATA_LENGTH_ERROR, []
        writes = []
        a = address
        while a < end:
            reg = self._owner[a]
            if reg is None:
                a += 1
                continue
            raw = int.from_bytes(data[a - address:a - address + reg.size], "little")
            writes.append((reg, decode(reg, raw)))
            a += reg.size
        return 0, writes

    def _indirect_writes(self, address: int, data: bytes) -> tuple[int, list[tuple[Register,
                                                                                  int]]]:
        """A write through Indirect Data: each byte to the address it stands for; every
        register so touched must get all its bytes (else Data Length Error)."""
        target: dict[int, int] = {}
        for k, byte in enumerate(data):
            target[self._target(address + k)] = byte
        writes, seen = [], set()
        for a in sorted(target):
            reg = self._owner[a]
            if reg is None:
                return p.ACCESS_ERROR, []
            if reg.name in seen:
                continue
            span = range(reg.address, reg.address + reg.size)
            if any(b not in target for b in span):
                return p.DATA_LENGTH_ERROR, []
            seen.add(reg.name)
            raw = int.from_bytes(bytes(target[b] for b in span), "little")
            writes.append((reg, decode(reg, raw)))
        return 0, writes

    def _check_value(self, reg: Register, value: int, pending: dict[str, int]) -> int:
        if not reg.takes(value):
            return p.DATA_RANGE_ERROR
        if reg.name in GOALS and self.get("bus_watchdog") == -1:
            return p.DATA_RANGE_ERROR
        if reg.name == "goal_position":
            if self.get("operating_mode") == POSITION_MODE:
                low = pending.get("min_position_limit", self.get("min_position_limit"))
                high = pending.get("max_position_limit", self.get("max_position_limit"))
            else:
                low, high = -EXTENDED_RANGE, EXTENDED_RANGE
            return 0 if low <= value <= high else p.DATA_LIMIT_ERROR
        if reg.limit and all(self.has(n) for n in reg.limit):
            bound = pending.get(reg.limit[0], self.get(reg.limit[0]))
            return 0 if -bound <= value <= bound else p.DATA_LIMIT_ERROR
        if reg.name == "torque_enable" and value == 1 and self.get("hardware_error_status"):
            return p.RESULT_FAIL
        return 0

    def write(self, address: int, data: bytes) -> tuple[int, list[str]]:
        """Apply a host write (all or nothing); returns the error number (0: done) and the
        names of the registers written."""
        error, writes = self.check_write(address, data)
        if error:
            return error, []
        for reg, value in writes:
            self.set(reg.name, value)
        return 0, [reg.name for reg, _ in writes]

    # --- resets ------------------------------------------------------------------------------
    def reboot(self) -> None:
        """RAM back to its defaults (EEPROM kept), hardware errors cleared, torque off."""
        for reg in self.table.registers:
            if reg.area != EEPROM:
                self.set(reg.name, reg.default)

    def factory_reset(self, option: int) -> None:
        """0xFF: everything; 0x01: all but the ID; 0x02: all but the ID and the baud rate."""
        keep = {0x01: ("id",), 0x02: ("id", "baud_rate")}.get(option, ())
        kept = {name: self.get(name) for name in keep}
        for reg in self.table.registers:
            self.set(reg.name, reg.default)
        for name, value in kept.items():
            self.set(name, value)
