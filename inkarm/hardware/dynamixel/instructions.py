"""The instructions of Protocol 2.0, as the servos on one bus answer them (the emulator's core).

:class:`EmulatedBus` takes a framed :class:`~inkarm.hardware.dynamixel.protocol.Packet` and
returns the status packets the servos send back, in bus order, each with the servo that sends
it (whose Return Delay Time the port waits before its reply). Rules (e-Manual, Protocol 2.0):

* Broadcast (ID 254) is answered only by PING, SYNC_READ, FAST_SYNC_READ and BULK_READ, each
  addressed servo in turn; unicast packets to absent IDs get no answer.
* Status Return Level 0 answers only PING, 1 also the reads, 2 everything.
* A wrong CRC gets a CRC Error from the addressed servo; an unknown instruction, ACTION with
  nothing registered or a malformed CLEAR an Instruction Error; a wrong parameter count a
  Data Length Error; memory errors as :mod:`inkarm.hardware.dynamixel.memory` says.
* A servo with a hardware error sets the alert bit (0x80) in every status packet.
* Writes addressed to a Secondary (Shadow) ID are applied by the servos that carry it, which
  never answer for it.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.memory import ServoMemory
from inkarm.hardware.dynamixel.tables import ControlTable

READS = (p.READ, p.SYNC_READ, p.FAST_SYNC_READ, p.BULK_READ)
CLEAR_MULTI_TURN = bytes([0x01, 0x44, 0x58, 0x4C, 0x22])


@dataclass
class EmulatedServo:
    """One servo on the emulated bus: its memory and the faults it is showing."""

    table: ControlTable
    servo_id: int
    silent: bool = False          # answers nothing (a broken wire)
    corrupt_crc: bool = False     # its replies carry a wrong CRC
    late_s: float = 0.0           # extra delay before its replies [s]
    registered: tuple[int, bytes] | None = None
    last_packet_s: float = 0.0    # when a packet last addressed it (bus watchdog)
    pending_reboot: bool = False
    memory: ServoMemory = field(init=False)

    def __post_init__(self):
        self.memory = ServoMemory(self.table, self.servo_id)

    @property
    def id(self) -> int:
        return self.memory.get("id")

    @property
    def alert(self) -> int:
        return p.ALERT if self.memory.get("hardware_error_status") else 0

    def status(self, error: int = 0, params: bytes = b"") -> bytes:
        packet = p.status(self.id, error | self.alert, params)
        if self.corrupt_crc:
            packet = packet[:-2] + bytes([packet[-2] ^ 0x5A, packet[-1]])
        return packet


Reply = tuple[EmulatedServo, bytes]


class EmulatedBus:
    """Servos on one Protocol 2.0 bus (module docstring)."""

    def __init__(self, servos: list[EmulatedServo]):
        self.servos = servos
        self.on_write = None  # callback(servo, register names) after a memory write
        self.now = 0.0

    def by_id(self, servo_id: int) -> EmulatedServo | None:
        for s in self.servos:
            if s.id == servo_id and not s.silent:
                return s
        return None

    def _shadows(self, servo_id: int) -> list[EmulatedServo]:
        return [s for s in self.servos
                if s.memory.get("secondary_id") == servo_id and not s.silent]

    def handle(self, packet: p.Packet) -> list[Reply]:
        """The replies to ``packet``, in the order the servos send them."""
        target = self.by_id(packet.servo_id) if packet.servo_id != p.BROADCAST_ID else None
        for s in self.servos:
            if packet.servo_id in (p.BROADCAST_ID, s.id, s.memory.get("secondary_id")):
                s.last_packet_s = self.now
        if not packet.crc_ok:
            return self._reply(target, packet.instruction, p.CRC_ERROR)
        handler = _HANDLERS.get(packet.instruction)
        if handler is None:
            return self._reply(target, packet.instruction, p.INSTRUCTION_ERROR)
        return handler(self, packet, target)

    # --- helpers -------------------------------------------------------------------------------
    @staticmethod
    def _reply(servo: EmulatedServo | None, instruction: int, error: int = 0,
               params: bytes = b"", level: int | None = None) -> list[Reply]:
        """The status packet of ``servo``, if its Status Return Level (``level``: as it was
        before this packet's write) answers ``instruction``."""
        if servo is None:
            return []
        if level is None:
            level = servo.memory.get("status_return_level")
        if instruction != p.PING and (level == 0 or (level == 1 and instruction not in READS)):
            return []
        return [(servo, servo.status(error, params))]

    def _addressed(self, packet: p.Packet, target: EmulatedServo | None) -> list[EmulatedServo]:
        """Every servo that hears a broadcast, else the target (if it answers)."""
        if packet.servo_id == p.BROADCAST_ID:
            return [s for s in self.servos if not s.silent]
        return [target] if target else []

    def _write(self, servo: EmulatedServo, address: int, data: bytes) -> int:
        error, names = servo.memory.write(address, data)
        if not error and self.on_write is not None:
            self.on_write(servo, names)
        return error

    def _write_with_shadows(self, servo_id: int, address: int, data: bytes,
                            primary: EmulatedServo | None) -> int:
        error = self._write(primary, address, data) if primary is not None else 0
        for shadow in self._shadows(servo_id):
            self._write(shadow, address, data)
        return error

    # --- instructions --------------------------------------------------------------------------
    def ping(self, packet, target):
        def params(s):
            return struct.pack("<HB", s.memory.get("model_number"),
                               s.memory.get("firmware_version"))
        if packet.servo_id == p.BROADCAST_ID:
            return [(s, s.status(0, params(s))) for s in sorted(self.servos, key=lambda s: s.id)
                    if not s.silent]
        return self._reply(target, p.PING, 0, params(target) if target else b"")

    def read(self, packet, target):
        if target is None:
            return []
        if len(packet.params) != 4:
            return self._reply(target, p.READ, p.DATA_LENGTH_ERROR)
        address, length = struct.unpack("<HH", packet.params)
        error, data = target.memory.read(address, length)
        return self._reply(target, p.READ, error, data)

    def write(self, packet, target):
        if len(packet.params) < 3:
            return self._reply(target, p.WRITE, p.DATA_LENGTH_ERROR)
        address = packet.params[0] | packet.params[1] << 8
        data = packet.params[2:]
        if packet.servo_id == p.BROADCAST_ID:
            for s in self._addressed(packet, target):
                self._write(s, address, data)
            return []
        level = target.memory.get("status_return_level") if target is not None else None
        error = self._write_with_shadows(packet.servo_id, address, data, target)
        return self._reply(target, p.WRITE, error, level=level)

    def reg_write(self, packet, target):
        if len(packet.params) < 3:
            return self._reply(target, p.REG_WRITE, p.DATA_LENGTH_ERROR)
        address = packet.params[0] | packet.params[1] << 8
        servos = self._addressed(packet, target)
        error = 0
        for s in servos:
            error, _ = s.memory.check_write(address, packet.params[2:])
            if not error:
                s.registered = (address, bytes(packet.params[2:]))
                s.memory.set("registered_instruction", 1)
        return self._reply(target, p.REG_WRITE, error)

    def action(self, packet, target):
        servos = self._addressed(packet, target)
        if target is not None and target.registered is None:
            return self._reply(target, p.ACTION, p.INSTRUCTION_ERROR)
        for s in servos:
            if s.registered is not None:
                self._write(s, *s.registered)
                s.registered = None
                s.memory.set("registered_instruction", 0)
        return self._reply(target, p.ACTION)

    def factory_reset(self, packet, target):
        if target is None:
            return []  # a real servo refuses a broadcast factory reset
        if len(packet.params) != 1 or packet.params[0] not in (0x01, 0x02, 0xFF):
            return self._reply(target, p.FACTORY_RESET, p.DATA_RANGE_ERROR)
        if target.memory.get("torque_enable"):
            return self._reply(target, p.FACTORY_RESET, p.ACCESS_ERROR)
        replies = self._reply(target, p.FACTORY_RESET)
        target.memory.factory_reset(packet.params[0])
        if packet.params[0] == 0xFF:
            target.memory.set("id", 1)
        target.registered = None
        return replies

    def reboot(self, packet, target):
        for s in self._addressed(packet, target):
            s.pending_reboot = True
        return self._reply(target, p.REBOOT)

    def clear(self, packet, target):
        if target is None:
            return []
        if packet.params != CLEAR_MULTI_TURN:
            return self._reply(target, p.CLEAR, p.INSTRUCTION_ERROR)
        if target.memory.get("torque_enable"):
            return self._reply(target, p.CLEAR, p.RESULT_FAIL)
        position = target.memory.get("present_position")
        target.memory.set("present_position", position % 4096)
        target.pending_reboot = False
        return self._reply(target, p.CLEAR)

    def sync_read(self, packet, target, fast: bool = False):
        if packet.servo_id != p.BROADCAST_ID or len(packet.params) < 5:
            return self._reply(target, packet.instruction, p.DATA_LENGTH_ERROR)
        address, length = struct.unpack("<HH", packet.params[:4])
        replies = []
        for servo_id in packet.params[4:]:
            s = self.by_id(servo_id)
            if s is None:
                continue
            error, data = s.memory.read(address, length)
            replies += self._reply(s, packet.instruction, error, data)
        return _fast_packet(replies, packet.instruction) if fast else replies

    def fast_sync_read(self, packet, target):
        return self.sync_read(packet, target, fast=True)

    def sync_write(self, packet, target):
        if packet.servo_id != p.BROADCAST_ID or len(packet.params) < 5:
            return []
        address, length = struct.unpack("<HH", packet.params[:4])
        body = packet.params[4:]
        if length < 1 or len(body) % (length + 1):
            return []
        for k in range(0, len(body), length + 1):
            servo_id = body[k]
            self._write_with_shadows(servo_id, address, body[k + 1:k + 1 + length],
                                     self.by_id(servo_id))
        return []

    def bulk_read(self, packet, target):
        if packet.servo_id != p.BROADCAST_ID or not packet.params or len(packet.params) % 5:
            return []
        replies = []
        for k in range(0, len(packet.params), 5):
            servo_id, address, length = struct.unpack("<BHH", packet.params[k:k + 5])
            s = self.by_id(servo_id)
            if s is not None:
                error, data = s.memory.read(address, length)
                replies += self._reply(s, p.BULK_READ, error, data)
        return replies

    def bulk_write(self, packet, target):
        if packet.servo_id != p.BROADCAST_ID:
            return []
        body, k = packet.params, 0
        while k + 5 <= len(body):
            servo_id, address, length = struct.unpack("<BHH", body[k:k + 5])
            data = body[k + 5:k + 5 + length]
            if len(data) != length or length < 1:
                return []
            self._write_with_shadows(servo_id, address, data, self.by_id(servo_id))
            k += 5 + length
        return []


def _fast_packet(replies: list[Reply], instruction: int) -> list[Reply]:
    """FAST_SYNC_READ: the servos' answers as one status packet from ID 254 in which each
    servo's part is ``error, id, data, CRC`` (that CRC over the packet so far)."""
    if not replies:
        return []
    parts = []
    for servo, status in replies:
        body = p.unstuff(status[7:-2])  # 0x55, error, data
        parts.append((servo, body[1], status[4], body[2:]))
    n_body = sum(4 + len(d) for *_, d in parts)
    length = 1 + n_body  # the last part's CRC is the packet's
    packet = bytearray(p.HEADER + bytes([p.BROADCAST_ID, length & 0xFF, length >> 8, p.STATUS]))
    for _servo, error, servo_id, data in parts:  # the last part's CRC is the packet's
        packet += bytes([error, servo_id]) + data
        crc = p.crc16(bytes(packet))
        packet += bytes([crc & 0xFF, crc >> 8])
    if any(servo.corrupt_crc for servo, *_ in parts):
        packet[-2] ^= 0x5A
    return [(parts[-1][0], bytes(packet))]


_HANDLERS = {
    p.PING: EmulatedBus.ping, p.READ: EmulatedBus.read, p.WRITE: EmulatedBus.write,
    p.REG_WRITE: EmulatedBus.reg_write, p.ACTION: EmulatedBus.action,
    p.FACTORY_RESET: EmulatedBus.factory_reset, p.REBOOT: EmulatedBus.reboot,
    p.CLEAR: EmulatedBus.clear, p.SYNC_READ: EmulatedBus.sync_read,
    p.FAST_SYNC_READ: EmulatedBus.fast_sync_read, p.SYNC_WRITE: EmulatedBus.sync_write,
    p.BULK_READ: EmulatedBus.bulk_read, p.BULK_WRITE: EmulatedBus.bulk_write,
}
