"""A Protocol 2.0 bus on dynamixel-sdk: the driver side.

* One GroupSyncRead of Present Current, Velocity and Position (addresses 126..135, 10 bytes,
  contiguous on every X-series) per control period; the status packets' error bytes are kept
  (the SDK drops them), so a servo's hardware alert is seen in the same transaction.
* One GroupSyncWrite of the goals per period (no status packets).
* Configuration goes through acknowledged writes, read back where it matters. A servo whose
  Status Return Level (68) is 1 answers only PING and reads (e-Manual; dynamixel-sdk's
  ``write*TxRx`` would wait for a status packet that never comes): its writes are sent
  without waiting (``writeTxOnly``) and read back, a refused one named. The level is learnt
  from :meth:`status_return_level` (or, after a write goes unanswered, from a read of it).
* Every transaction is tried ``1 + retries`` times; before each try the input buffer is
  cleared (a late reply from the last try must not pass for this one) and the SDK's
  ``is_using`` flag released (an interrupted call leaves it set: "port in use" forever).
* One driver per port: the advisory lock of :mod:`inkarm.hardware.port_lock` is taken
  before the SDK opens the port and held until :meth:`close` (a second driver is refused at
  once with :class:`~inkarm.hardware.port_lock.PortBusyError` naming the holder, instead of
  both drivers' packets colliding and the second blaming the servos).
* The port is closed and the lock released on every exit path (:meth:`close` is idempotent;
  use ``with``).

Failures raise :class:`DynamixelFault`, naming the servo and the fault.
"""

from __future__ import annotations

import contextlib
import select
import struct
import termios
import time
from typing import Self

import dynamixel_sdk as sdk
import serial

from inkarm.errors import InputError, SimulationError
from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.tables import COMMON, decode, to_unsigned
from inkarm.hardware.port_lock import port_lock

STATE_ADDRESS, STATE_SIZE = 126, 10  # present current (2), velocity (4), position (4)
_REG = {r.name: r for r in COMMON}
POLL_WAIT_S = 0.0005  # longest wait for a byte before the SDK looks at its timeout [s]
RETRY_QUIET_S = 0.003  # wait before a retry so that late replies are flushed [s]


class DynamixelFault(SimulationError):
    """A fault on the bus or in a servo: ``servo_id`` (None for the bus) and ``kind`` (e.g.
    "no reply", "corrupt reply", "overload", "watchdog", "disconnected"). A
    :class:`~inkarm.errors.RunFault` (``watchdog`` "dynamixel") that the drawing loop logs,
    and a :class:`~inkarm.errors.SimulationError` so that the loop leaves the safe stop to the
    plant, which has already lifted the pen."""

    def __init__(self, message: str, servo_id: int | None = None, kind: str = ""):
        super().__init__(message, watchdog="dynamixel")
        self.servo_id, self.kind = servo_id, kind


_COMM_KIND = {sdk.COMM_RX_TIMEOUT: "no reply", sdk.COMM_RX_CORRUPT: "corrupt reply",
              sdk.COMM_TX_FAIL: "send failed", sdk.COMM_PORT_BUSY: "port busy",
              sdk.COMM_RX_FAIL: "no reply", sdk.COMM_TX_ERROR: "bad packet"}


class _PortHandler(sdk.PortHandler):
    """The SDK's port, waiting in ``select`` for the next byte instead of spinning on empty
    reads: the SDK polls its port in a loop, which on a busy machine takes the CPU from the
    very process (an emulator, a USB driver thread) that has to produce the reply."""

    latency_ms = float(sdk.port_handler.LATENCY_TIMER)

    def setPacketTimeout(self, packet_length):
        # The SDK's rule (bytes on the wire + twice the USB latency timer + 2 ms) with this
        # port's latency instead of the module-wide 16 ms.
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + 2.0 * self.latency_ms + 2.0

    def readPort(self, length):
        ser = self.ser
        if not ser.in_waiting:
            select.select([ser.fd], [], [], POLL_WAIT_S)
        return ser.read(length)


class _SyncRead(sdk.GroupSyncRead):
    """GroupSyncRead that keeps each status packet's error byte (``errors[id]``)."""

    def rxPacket(self):
        self.last_result = False
        self.errors, self.wait_s = {}, {}
        result = sdk.COMM_RX_FAIL
        for dxl_id in self.data_dict:
            t0 = time.monotonic()
            self.data_dict[dxl_id], result, error = self.ph.readRx(self.port, dxl_id,
                                                                   self.data_length)
            self.wait_s[dxl_id] = time.monotonic() - t0
            self.errors[dxl_id] = error
            self.last_failed = dxl_id
            if result != sdk.COMM_SUCCESS:
                return result
        self.last_result = result == sdk.COMM_SUCCESS
        return result


class DynamixelBus:
    """The servos on ``port`` at ``baudrate`` [bit/s] (module docstring).

    ``names`` maps servo ids to what they drive, for messages. ``latency_ms``: the USB
    adapter's latency timer [ms] in the reply timeout (``2 latency + 2 ms`` plus the bytes);
    dynamixel-sdk assumes 16 (FTDI's default; 1 after ``echo 1 > .../latency_timer``).
    """

    def __init__(self, port: str, baudrate: int = 1_000_000, retries: int = 2,
                 names: dict[int, str] | None = None, latency_ms: float | None = None):
        self.port_name, self.baudrate, self.retries = port, int(baudrate), int(retries)
        self.names = dict(names or {})
        self.port = _PortHandler(port)
        if latency_ms is not None:
            self.port.latency_ms = float(latency_ms)
        self.packet = sdk.PacketHandler(2.0)
        self.stats = {"transactions": 0, "retries": 0}
        self._open = False
        self.last_attempts = 1      # tries the last successful transaction took
        self.last_failed = None     # the servo whose reply failed the last retried sync read
        self.last_waits: dict[int, float] = {}  # per servo: wait for its reply [s], last read
        self.levels: dict[int, int] = {}  # Status Return Level per servo, where known
        self._lock = contextlib.ExitStack()
        self._lock.enter_context(port_lock(port))
        try:
            try:
                ok = self.port.openPort() and self.port.setBaudRate(self.baudrate)
            except (serial.SerialException, OSError, ValueError) as e:
                raise InputError(f"cannot open {port}: {e}", key="--port", value=port) from None
            if not ok:
                raise InputError(f"cannot open {port} at {baudrate} bit/s", key="--port",
                                 value=port)
        except BaseException:
            self._close_port()
            self._lock.close()
            raise
        self._open = True
        self._reader = _SyncRead(self.port, self.packet, STATE_ADDRESS, STATE_SIZE)
        self._last_reader = self._reader

    def close(self) -> None:
        """Close the port, then release its lock. Idempotent."""
        if self._open:
            self._open = False
            try:
                self._close_port()
            finally:
                self._lock.close()

    def _close_port(self) -> None:
        try:
            if getattr(self.port, "ser", None) is not None:
                self.port.closePort()
        except (serial.SerialException, OSError):
            pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def who(self, servo_id: int | None) -> str:
        if servo_id is None:
            return f"bus {self.port_name}"
        name = self.names.get(servo_id)
        return f"servo {servo_id}" + (f" ({name})" if name else "")

    # --- the retry frame ----------------------------------------------------------------------
    def _try(self, call, servo_id: int | None, what: str):
        """Run ``call() -> (result, error, value)`` up to 1 + retries times."""
        if not self._open:
            raise DynamixelFault(f"{self.who(None)}: the port is closed", None, "disconnected")
        result = sdk.COMM_TX_FAIL
        first_failed = None  # a late servo makes the retries fail at whoever answers first
        for attempt in range(1 + self.retries):
            self.stats["transactions"] += 1
            self.stats["retries"] += attempt > 0
            self.port.is_using = False
            try:
                if attempt:  # let the last try's stragglers arrive, then drop them
                    time.sleep(RETRY_QUIET_S)
                self.port.clearPort()
                result, error, value = call()
            except (serial.SerialException, OSError, TypeError, termios.error) as e:
                raise DynamixelFault(f"{self.who(None)}: serial port disconnected ({e})",
                                     None, "disconnected") from None
            except (IndexError, ValueError):  # the SDK's parser on garbage
                result, error, value = sdk.COMM_RX_CORRUPT, 0, None
            finally:
                self.port.is_using = False
            if result == sdk.COMM_SUCCESS:
                self.last_attempts = attempt + 1
                return error, value
            if servo_id == -1 and first_failed is None:
                first_failed = getattr(self._last_reader, "last_failed", None)
                self.last_failed = first_failed
        kind = _COMM_KIND.get(result, f"communication result {result}")
        if servo_id == -1:  # a sync read: the servo whose reply failed first
            servo_id = first_failed
        raise DynamixelFault(f"{self.who(servo_id)}: {kind} to {what} after "
                             f"{1 + self.retries} tries", servo_id, kind)

    def _checked(self, servo_id: int, error: int, what: str) -> None:
        if error & 0x7F:
            raise DynamixelFault(f"{self.who(servo_id)}: {p.error_text(error & 0x7F)} on {what}",
                                 servo_id, p.error_text(error & 0x7F))

    def _sync_read(self, reader: _SyncRead, ids, what: str) -> None:
        def call():
            result = reader.txRxPacket()
            if result == sdk.COMM_SUCCESS and any(len(reader.data_dict[i]) != reader.data_length
                                                  for i in ids):
                result = sdk.COMM_RX_CORRUPT  # a stray packet of that id: try again
            return result, 0, None

        self._last_reader = reader
        self._try(call, -1, what)

    # --- transactions --------------------------------------------------------------------------
    def ping(self, servo_id: int) -> tuple[int, int] | None:
        """(model number, firmware version), or None when nothing answers."""
        try:
            _, value = self._try(lambda: _ping(self.packet, self.port, servo_id), servo_id,
                                 "ping")
        except DynamixelFault as e:
            if e.kind == "disconnected":
                raise
            return None
        return value

    def read(self, servo_id: int, name: str) -> int:
        """An acknowledged read of register ``name``."""
        reg = _REG[name]

        def call():
            data, result, error = self.packet.readTxRx(self.port, servo_id, reg.address,
                                                       reg.size)
            value = decode(reg, int.from_bytes(bytes(data), "little")) if data else 0
            return result, error, value

        error, value = self._try(call, servo_id, f"read {name}")
        self._checked(servo_id, error, f"read {name}")
        return value

    def write(self, servo_id: int, name: str, value: int) -> None:
        """A write of register ``name``, acknowledged (or, at Status Return Level 1, read
        back); a status error, or a value that does not read back, raises."""
        reg = _REG[name]
        data = _encode(reg, value)
        what = f"write {name} = {value}"
        if self.levels.get(servo_id, 2) < 2:
            return self._write_unanswered(servo_id, name, value)

        def call():
            result, error = self.packet.writeTxRx(self.port, servo_id, reg.address, reg.size,
                                                  data)
            return result, error, None

        try:
            error, _ = self._try(call, servo_id, what)
        except DynamixelFault as fault:
            if fault.kind != "no reply" or self._learn_level(servo_id) >= 2:
                raise
            return self._write_unanswered(servo_id, name, value)
        self._checked(servo_id, error, what)
        if name == "status_return_level":
            self.levels[servo_id] = int(value)

    def status_return_level(self, servo_id: int) -> int:
        """Read (and keep) the servo's Status Return Level (68): a servo that answers PING but
        not this read is at level 0, and refused naming the register."""
        try:
            level = self.read(servo_id, "status_return_level")
        except DynamixelFault as fault:
            if fault.kind != "no reply" or self.ping(servo_id) is None:
                raise
            raise DynamixelFault(
                f"{self.who(servo_id)}: answers PING but not READ: its Status Return Level (68) "
                "is 0 (PING only); set it to 2 (or 1), e.g. with status_return_level = 2 in "
                "[backends.dynamixel], which inkarm writes at start", servo_id,
                "status return level 0") from None
        self.levels[servo_id] = level
        return level

    def set_status_return_level(self, servo_id: int, level: int) -> None:
        """Write Status Return Level (68) := ``level`` (1 or 2) whatever it is now (0 answers
        nothing but PING), then read it back."""
        current = self.levels.get(servo_id, 0)  # unknown: as 0 (let a reply pass, read back)
        if current == 2:
            return self.write(servo_id, "status_return_level", level)
        self.levels[servo_id] = current
        self._write_unanswered(servo_id, "status_return_level", level)

    def _learn_level(self, servo_id: int) -> int:
        """After a write went unanswered: the servo's Status Return Level if it answers a read
        of it (kept), else 2 (the servo is silent, not at level 1); at level 0 (it answers PING
        only) the fault says so."""
        try:
            return self.status_return_level(servo_id)
        except DynamixelFault as fault:
            if fault.kind == "status return level 0":
                raise
            return 2

    def _write_unanswered(self, servo_id: int, name: str, value: int) -> None:
        reg = _REG[name]
        data = _encode(reg, value)
        level = self.levels.get(servo_id, 2)
        what = f"write {name} = {value}"
        self._try(lambda: (self.packet.writeTxOnly(self.port, servo_id, reg.address, reg.size,
                                                   data), 0, None), servo_id, what)
        if name == "status_return_level":
            if level == 0:  # a servo at 2 answers this write after all: let it pass
                time.sleep((2.0 * self.port.latency_ms + 2.0) / 1000.0)
            self.levels[servo_id] = int(value)
        back = self.read(servo_id, name)
        if back != int(value):  # or a straggler's reply taken for this read's: read again
            time.sleep(RETRY_QUIET_S)
            back = self.read(servo_id, name)
        if back != int(value):
            raise DynamixelFault(
                f"{self.who(servo_id)}: {what} not applied (reads back {back}); at Status Return "
                f"Level (68) {level} the servo does not answer writes, so it cannot say why (2 "
                "makes it answer)", servo_id, "write not applied")

    def read_state(self, ids) -> tuple[list[int], list[int], list[int], dict[int, int]]:
        """One sync read: present positions [ticks], velocities [0.229 rpm], currents [units]
        and each servo's status error byte, in the order of ``ids``."""
        reader = self._reader
        if list(reader.data_dict) != list(ids):
            reader.clearParam()
            for i in ids:
                reader.addParam(i)
        self._sync_read(reader, ids, "sync read the state")
        positions, velocities, currents = [], [], []
        for i in ids:
            current, velocity, position = struct.unpack("<hii", bytes(reader.data_dict[i]))
            positions.append(position)
            velocities.append(velocity)
            currents.append(current)
        self.last_waits = dict(reader.wait_s)
        return positions, velocities, currents, dict(reader.errors)

    def sync_read(self, ids, name: str) -> dict[int, int]:
        """One register of every servo in ``ids``, in one transaction."""
        reg = _REG[name]
        reader = _SyncRead(self.port, self.packet, reg.address, reg.size)
        for i in ids:
            reader.addParam(i)
        self._sync_read(reader, ids, f"sync read {name}")
        return {i: decode(reg, int.from_bytes(bytes(reader.data_dict[i]), "little"))
                for i in ids}

    def sync_write(self, ids, name: str, values) -> None:
        """One register of every servo in ``ids`` (no status packets)."""
        reg = _REG[name]
        writer = sdk.GroupSyncWrite(self.port, self.packet, reg.address, reg.size)
        for i, v in zip(ids, values):
            writer.addParam(i, _encode(reg, v))
        self._try(lambda: (writer.txPacket(), 0, None), None, f"sync write {name}")

    def reboot(self, servo_id: int) -> None:
        self._try(lambda: (*self.packet.reboot(self.port, servo_id), None), servo_id, "reboot")


def _encode(reg, value) -> list[int]:
    return list(to_unsigned(value, reg.size).to_bytes(reg.size, "little"))


def _ping(packet, port, servo_id):
    model, result, error = packet.ping(port, servo_id)
    firmware = 0
    return result, error, (model, firmware)
