"""Dynamixel Protocol 2.0 packets: CRC-16, byte stuffing, framing (the emulator's codec).

A packet on the wire (ROBOTIS e-Manual, "Protocol 2.0")::

    FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAMS... | CRC_L CRC_H

``LEN`` counts the instruction, the (stuffed) parameters and the CRC. A status packet's
instruction is 0x55 followed by the error byte. The CRC is CRC-16 with polynomial
x^16 + x^15 + x^2 + 1 (0x8005), initial value 0, no reflection, over every byte from the
header to the last parameter. Byte stuffing: inside INST..PARAMS every ``FF FF FD`` gets an
extra ``FD`` so that the payload never looks like a header; the receiver removes it.

The driver side uses dynamixel-sdk's own codec; this module serves the emulator and the tests.
"""

from __future__ import annotations

from dataclasses import dataclass

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
MAX_ID = 252
STATUS = 0x55

PING, READ, WRITE, REG_WRITE, ACTION, FACTORY_RESET = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
REBOOT, CLEAR = 0x08, 0x10
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ = 0x82, 0x83, 0x8A
BULK_READ, BULK_WRITE = 0x92, 0x93
INSTRUCTIONS = {PING: "PING", READ: "READ", WRITE: "WRITE", REG_WRITE: "REG_WRITE",
                ACTION: "ACTION", FACTORY_RESET: "FACTORY_RESET", REBOOT: "REBOOT",
                CLEAR: "CLEAR", SYNC_READ: "SYNC_READ", SYNC_WRITE: "SYNC_WRITE",
                FAST_SYNC_READ: "FAST_SYNC_READ", BULK_READ: "BULK_READ",
                BULK_WRITE: "BULK_WRITE"}

# Status packet error field (bits 0-6: the error number; bit 7: hardware alert)
RESULT_FAIL, INSTRUCTION_ERROR, CRC_ERROR = 0x01, 0x02, 0x03
DATA_RANGE_ERROR, DATA_LENGTH_ERROR, DATA_LIMIT_ERROR, ACCESS_ERROR = 0x04, 0x05, 0x06, 0x07
ALERT = 0x80
ERRORS = {RESULT_FAIL: "result fail", INSTRUCTION_ERROR: "instruction error",
          CRC_ERROR: "CRC error", DATA_RANGE_ERROR: "data range error",
          DATA_LENGTH_ERROR: "data length error", DATA_LIMIT_ERROR: "data limit error",
          ACCESS_ERROR: "access error"}

MAX_PACKET = 1024  # longest packet the emulator accepts [bytes]


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """CRC-16/0x8005 (init 0, not reflected) of ``data``."""
    crc = 0
    for byte in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(payload: bytes) -> bytes:
    """Insert ``FD`` after every ``FF FF FD`` in ``payload`` (instruction and parameters)."""
    return bytes(payload).replace(b"\xff\xff\xfd", b"\xff\xff\xfd\xfd")


def unstuff(payload: bytes) -> bytes:
    """Remove the stuffing :func:`stuff` added."""
    return bytes(payload).replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def encode(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete packet: header, id, length, stuffed instruction and parameters, CRC."""
    body = stuff(bytes([instruction]) + bytes(params))
    length = len(body) + 2
    head = HEADER + bytes([servo_id, length & 0xFF, length >> 8]) + body
    crc = crc16(head)
    return head + bytes([crc & 0xFF, crc >> 8])


def status(servo_id: int, error: int = 0, params: bytes = b"") -> bytes:
    """A status packet from ``servo_id``."""
    return encode(servo_id, STATUS, bytes([error]) + bytes(params))


@dataclass(frozen=True)
class Packet:
    """A received packet: ``params`` unstuffed; ``crc_ok`` False when its CRC was wrong."""

    servo_id: int
    instruction: int
    params: bytes
    crc_ok: bool = True
    raw: bytes = b""


class PacketReader:
    """Frames packets out of a byte stream: junk before a header is skipped, a length beyond
    :data:`MAX_PACKET` drops the header, a packet with a wrong CRC is still returned (with
    ``crc_ok`` False) so that the servo can answer with a CRC error."""

    def __init__(self):
        self.buffer = bytearray()
        self.skipped = 0

    def feed(self, data: bytes) -> list[Packet]:
        self.buffer.extend(data)
        packets = []
        while True:
            start = self.buffer.find(HEADER)
            if start < 0:
                keep = 3  # a header may be split across reads
                self.skipped += max(0, len(self.buffer) - keep)
                del self.buffer[:max(0, len(self.buffer) - keep)]
                return packets
            if start:
                self.skipped += start
                del self.buffer[:start]
            if len(self.buffer) < 7:
                return packets
            length = self.buffer[5] | (self.buffer[6] << 8)
            if length < 3 or length + 7 > MAX_PACKET:
                del self.buffer[:1]
                self.skipped += 1
                continue
            total = 7 + length
            if len(self.buffer) < total:
                return packets
            raw = bytes(self.buffer[:total])
            del self.buffer[:total]
            crc_ok = crc16(raw[:-2]) == (raw[-2] | (raw[-1] << 8))
            body = unstuff(raw[7:-2])
            packets.append(Packet(raw[4], body[0], body[1:], crc_ok, raw))


def error_text(error: int) -> str:
    """A status packet's error byte in words."""
    words = []
    if error & 0x7F:
        words.append(ERRORS.get(error & 0x7F, f"error {error & 0x7F}"))
    if error & ALERT:
        words.append("hardware alert")
    return ", ".join(words) or "no error"
