"""Protocol 2.0 codec: the manual's CRC vectors, byte stuffing, framing."""

from __future__ import annotations

import dynamixel_sdk as sdk
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.hardware.dynamixel import protocol as p

# ROBOTIS e-Manual, Protocol 2.0: the example packets, CRC included.
MANUAL = {
    "ping": (p.encode(1, p.PING), "ff ff fd 00 01 03 00 01 19 4e"),
    "ping status": (p.status(1, 0, bytes([0x06, 0x04, 0x26])),
                    "ff ff fd 00 01 07 00 55 00 06 04 26 65 5d"),
    "read": (p.encode(1, p.READ, bytes([0x84, 0, 4, 0])),
             "ff ff fd 00 01 07 00 02 84 00 04 00 1d 15"),
    "sync read": (p.encode(0xFE, p.SYNC_READ, bytes([0x84, 0, 4, 0, 1, 2])),
                  "ff ff fd 00 fe 09 00 82 84 00 04 00 01 02 ce fa"),
    "sync write": (p.encode(0xFE, p.SYNC_WRITE, bytes([0x74, 0, 4, 0, 1, 0x96, 0, 0, 0,
                                                      2, 0xAA, 0, 0, 0])),
                   "ff ff fd 00 fe 11 00 83 74 00 04 00 01 96 00 00 00 02 aa 00 00 00 82 87"),
    "bulk read": (p.encode(0xFE, p.BULK_READ, bytes([1, 0x90, 0, 2, 0, 2, 0x92, 0, 1, 0])),
                  "ff ff fd 00 fe 0d 00 92 01 90 00 02 00 02 92 00 01 00 1a 05"),
}


def test_the_manuals_packets_and_crcs_are_reproduced():
    for name, (packet, expected) in MANUAL.items():
        assert packet.hex(" ") == expected, name


@given(st.binary(max_size=300))
@settings(max_examples=300, deadline=None)
def test_crc_agrees_with_dynamixel_sdk(data):
    assert p.crc16(data) == sdk.PacketHandler(2.0).updateCRC(0, list(data), len(data))


_STUFFY = st.lists(st.sampled_from([b"\xff", b"\xfd", b"\xff\xff\xfd", b"\x00", b"\xfd\xfd"]),
                   max_size=40).map(b"".join)


@given(st.one_of(st.binary(max_size=200), _STUFFY))
@settings(max_examples=400, deadline=None)
def test_stuffing_round_trips_and_hides_every_header(payload):
    stuffed = p.stuff(payload)
    assert p.unstuff(stuffed) == payload
    # no header inside: every FF FF FD is followed by the stuffed FD
    k = stuffed.find(b"\xff\xff\xfd")
    while k >= 0:
        assert stuffed[k + 3:k + 4] == b"\xfd"
        k = stuffed.find(b"\xff\xff\xfd", k + 4)


@given(st.integers(0, 252), st.integers(0, 255), st.one_of(st.binary(max_size=64), _STUFFY),
       st.binary(max_size=20))
@settings(max_examples=300, deadline=None)
def test_reader_frames_packets_after_junk(servo_id, instruction, params, junk):
    junk = junk.replace(b"\xff\xff\xfd", b"")
    packet = p.encode(servo_id, instruction, params)
    reader = p.PacketReader()
    got = reader.feed(junk + packet[:5]) + reader.feed(packet[5:])
    assert len(got) == 1
    assert (got[0].servo_id, got[0].instruction, got[0].params, got[0].crc_ok) == \
        (servo_id, instruction, params, True)


def test_reader_flags_a_wrong_crc():
    packet = bytearray(p.encode(1, p.PING))
    packet[-1] ^= 0xFF
    (got,) = p.PacketReader().feed(bytes(packet))
    assert not got.crc_ok and got.instruction == p.PING


def test_error_text_names_the_error_and_the_alert():
    assert p.error_text(0x84) == "data range error, hardware alert"
    assert p.error_text(0) == "no error"
