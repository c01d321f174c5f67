"""Protocol fuzzing: random and mutated packets into the emulator, random replies into the
driver's parser. No crash, no hang, no state corruption; the case counts are printed."""

from __future__ import annotations

import os
import select
import threading
import time
import tty

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.bus import DynamixelBus, DynamixelFault
from inkarm.hardware.dynamixel.instructions import EmulatedBus, EmulatedServo
from inkarm.hardware.dynamixel.physics import Mount, ServoBank, SimpleJoints
from inkarm.hardware.dynamixel.tables import table

pytestmark = pytest.mark.hardware_emulated
COUNTS: dict[str, int] = {}


def _bus() -> EmulatedBus:
    servos = [EmulatedServo(table("XM430-W350"), 1), EmulatedServo(table("XL430-W250"), 2)]
    bus = EmulatedBus(servos)
    bank = ServoBank(servos, [Mount(0), Mount(1)], SimpleJoints.at(np.zeros(2)))
    bus.on_write = bank.on_write
    return bus


VALID = [p.encode(1, p.PING), p.encode(1, p.READ, bytes([132, 0, 4, 0])),
         p.encode(1, p.WRITE, bytes([84, 0, 0x20, 0x03])),
         p.encode(0xFE, p.SYNC_READ, bytes([126, 0, 10, 0, 1, 2])),
         p.encode(0xFE, p.SYNC_WRITE, bytes([116, 0, 4, 0, 1, 0, 8, 0, 0, 2, 0, 8, 0, 0])),
         p.encode(0xFE, p.BULK_READ, bytes([1, 0, 0, 2, 0, 2, 146, 0, 1, 0])),
         p.encode(2, p.REG_WRITE, bytes([65, 0, 1])), p.encode(0xFE, p.ACTION),
         p.encode(1, p.REBOOT), p.encode(1, p.FACTORY_RESET, b"\x02"),
         p.encode(0xFE, p.FAST_SYNC_READ, bytes([132, 0, 4, 0, 1, 2]))]


@st.composite
def hostile_bytes(draw):
    """Random bytes, or a valid packet with bytes flipped, cut, repeated or inserted, or a
    header with a random body."""
    kind = draw(st.sampled_from(["random", "mutated", "header"]))
    if kind == "random":
        return draw(st.binary(max_size=300))
    if kind == "header":
        body = draw(st.binary(max_size=80))
        return p.encode(draw(st.integers(0, 255)), draw(st.integers(0, 255)), body)
    packet = bytearray(draw(st.sampled_from(VALID)))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "cut", "insert", "length"]))
        k = draw(st.integers(0, len(packet) - 1)) if packet else 0
        if op == "flip" and packet:
            packet[k] ^= draw(st.integers(1, 255))
        elif op == "cut":
            del packet[k:]
        elif op == "insert":
            packet[k:k] = draw(st.binary(min_size=1, max_size=8))
        elif len(packet) > 6:
            packet[5] = draw(st.integers(0, 255))
    return bytes(packet)


@given(st.lists(hostile_bytes(), min_size=1, max_size=6), st.integers(0, 4095))
@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_hostile_packets_into_the_emulator_leave_it_sound(chunks, value):
    COUNTS["emulator"] = COUNTS.get("emulator", 0) + 1
    bus = _bus()
    reader = p.PacketReader()
    for chunk in chunks:
        for packet in reader.feed(chunk):
            for _, reply in bus.handle(packet):
                (status,) = p.PacketReader().feed(reply)   # every answer is a framed packet
                assert status.crc_ok and status.instruction in (p.STATUS, ) or \
                    status.servo_id == p.BROADCAST_ID
    # A clean bus after the junk: a valid write is read back (torque off, so EEPROM too).
    reader.feed(b"\x00" * 4 + p.encode(0xFE, p.PING))      # resynchronise on a ping
    servo = bus.by_id(1) or bus.servos[0]
    servo.memory.set("torque_enable", 0)
    servo.memory.set("status_return_level", 2)
    servo.memory.set("bus_watchdog", 0)
    sid = servo.id if servo.id != p.BROADCAST_ID else 1
    bus.handle(next(iter(p.PacketReader().feed(
        p.encode(sid, p.WRITE, bytes([112, 0]) + value.to_bytes(4, "little"))))))
    (reply,) = bus.handle(next(iter(p.PacketReader().feed(
        p.encode(sid, p.READ, bytes([112, 0, 4, 0]))))))
    status = p.PacketReader().feed(reply[1])[0]
    assert status.params[1:] == value.to_bytes(4, "little")


def test_hostile_bytes_on_the_pty_then_the_sdk_still_reads_back(emulator, sdk_port):
    """Through the real port: junk, then dynamixel-sdk writes and reads back."""
    port, ph = sdk_port
    rng = np.random.default_rng(7)
    cases = 0
    for k in range(150):
        junk = rng.integers(0, 256, size=rng.integers(1, 120)).astype(np.uint8).tobytes()
        if k % 3 == 0:  # a mutated valid packet
            packet = bytearray(VALID[k % len(VALID)])
            packet[rng.integers(0, len(packet))] ^= int(rng.integers(1, 256))
            junk = bytes(packet)
        port.writePort(junk)
        cases += 1
        if k % 10 == 9:
            time.sleep(0.01)
            port.clearPort()
            # a header split by junk may swallow the next packet, and a late answer to a junk
            # request may be taken for the next reply (the SDK matches the id, not the
            # length): retry as a driver does
            for _ in range(3):
                if ph.write4ByteTxRx(port, 1, 112, k) == (0, 0):
                    break
            for _ in range(3):
                data, result, error = ph.readTxRx(port, 1, 112, 4)
                if result == 0 and len(data) == 4:
                    break
                time.sleep(0.01)
                port.clearPort()
            assert (int.from_bytes(bytes(data), "little"), result, error) == (k, 0, 0)
    assert emulator.running and emulator.error is None
    print(f"\nfuzz: {cases} hostile byte strings through the pty, emulator sound")


class RandomServos:
    """A pty peer answering every packet with random (or mutated valid) bytes."""

    def __init__(self, replies):
        self.replies = list(replies)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)
        self.running = True
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        reader = p.PacketReader()
        while self.running:
            if not select.select([self.master], [], [], 0.01)[0]:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            for _ in reader.feed(data):
                if self.replies:
                    os.write(self.master, self.replies.pop(0))

    def close(self):
        self.running = False
        self.thread.join(1)
        os.close(self.master)
        os.close(self.slave)


@st.composite
def hostile_reply(draw):
    kind = draw(st.sampled_from(["random", "status", "mutated"]))
    if kind == "random":
        return draw(st.binary(min_size=1, max_size=120))
    servo_id = draw(st.sampled_from([1, 2, 3, 200]))
    params = draw(st.binary(max_size=30))
    packet = bytearray(p.status(servo_id, draw(st.integers(0, 255)), params))
    if kind == "mutated":
        k = draw(st.integers(0, len(packet) - 1))
        packet[k] ^= draw(st.integers(1, 255))
        if draw(st.booleans()):
            del packet[draw(st.integers(0, len(packet) - 1)):]
    return bytes(packet)


@given(st.lists(hostile_reply(), min_size=1, max_size=8))
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_replies_into_the_driver_raise_or_return_in_bounded_time(replies):
    COUNTS["driver"] = COUNTS.get("driver", 0) + 1
    peer = RandomServos(replies)
    bus = DynamixelBus(peer.port, retries=1, latency_ms=2)
    try:
        t = time.monotonic()
        for call in (lambda: bus.read_state([1, 2, 3]), lambda: bus.read(1, "goal_position"),
                     lambda: bus.ping(1), lambda: bus.sync_read([1, 2], "bus_watchdog")):
            try:
                call()
            except DynamixelFault:
                pass
        assert time.monotonic() - t < 2.0
    finally:
        bus.close()
        peer.close()


def test_zz_report_fuzz_counts():
    print(f"\nfuzz: {COUNTS.get('emulator', 0)} hostile packet sequences into the emulator, "
          f"{COUNTS.get('driver', 0)} hostile reply sequences into the driver")
    assert COUNTS.get("emulator", 0) >= 100 and COUNTS.get("driver", 0) >= 50
