"""The real dynamixel-sdk against the emulator, every instruction and error code."""

from __future__ import annotations

import time

import dynamixel_sdk as sdk
import pytest

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.bus import _PortHandler

pytestmark = pytest.mark.hardware_emulated

OK = sdk.COMM_SUCCESS


def test_ping_and_broadcast_ping(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.ping(port, 1) == (1020, OK, 0)
    assert ph.ping(port, 2)[0] == 1060 and ph.ping(port, 3)[0] == 1120
    assert ph.ping(port, 9)[1] == sdk.COMM_RX_TIMEOUT
    found, result = ph.broadcastPing(port)
    assert result == OK and {k: v[0] for k, v in found.items()} == {1: 1020, 2: 1060, 3: 1120}


def test_write_then_read_every_size(sdk_port):
    port, ph = sdk_port
    assert ph.write1ByteTxRx(port, 1, 65, 1) == (OK, 0)          # LED
    assert ph.write2ByteTxRx(port, 1, 84, 1234) == (OK, 0)       # Position P Gain
    assert ph.write4ByteTxRx(port, 1, 112, 321) == (OK, 0)       # Profile Velocity
    assert ph.read1ByteTxRx(port, 1, 65) == (1, OK, 0)
    assert ph.read2ByteTxRx(port, 1, 84) == (1234, OK, 0)
    assert ph.read4ByteTxRx(port, 1, 112) == (321, OK, 0)
    assert ph.read2ByteTxRx(port, 1, 0) == (1020, OK, 0)         # Model Number


def test_reg_write_waits_for_action(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.regWriteTxRx(port, 1, 112, 4, [50, 0, 0, 0]) == (OK, 0)
    assert ph.read4ByteTxRx(port, 1, 112)[0] == 0
    assert ph.read1ByteTxRx(port, 1, 69)[0] == 1                 # Registered Instruction
    assert ph.action(port, 1) == OK
    # A unicast ACTION is answered, but the SDK does not read that status: drop it before the
    # next read takes it for its own reply.
    time.sleep(0.01)
    port.clearPort()
    assert ph.read4ByteTxRx(port, 1, 112)[0] == 50
    assert ph.read1ByteTxRx(port, 1, 69)[0] == 0
    # ACTION with nothing registered: Instruction Error (answered: unicast)
    packet = [0] * 10
    packet[sdk.PKT_ID], packet[sdk.PKT_LENGTH_L], packet[sdk.PKT_INSTRUCTION] = 1, 3, p.ACTION
    port.setPacketTimeout(11)
    ph.txPacket(port, packet)
    reply, result = ph.rxPacket(port, False)
    assert result == OK and reply[sdk.PKT_ERROR] == p.INSTRUCTION_ERROR


def test_sync_and_bulk_read_and_write(sdk_port):
    port, ph = sdk_port
    writer = sdk.GroupSyncWrite(port, ph, 112, 4)
    for i, v in ((1, 10), (2, 20), (3, 30)):
        writer.addParam(i, [v, 0, 0, 0])
    assert writer.txPacket() == OK
    reader = sdk.GroupSyncRead(port, ph, 112, 4)
    for i in (1, 2, 3):
        reader.addParam(i)
    assert reader.txRxPacket() == OK
    assert [reader.getData(i, 112, 4) for i in (1, 2, 3)] == [10, 20, 30]
    assert reader.fastSyncRead() == OK
    assert [reader.getData(i, 112, 4) for i in (1, 2, 3)] == [10, 20, 30]
    bulk_w = sdk.GroupBulkWrite(port, ph)
    bulk_w.addParam(1, 84, 2, [0x10, 0x02])
    bulk_w.addParam(3, 65, 1, [1])
    assert bulk_w.txPacket() == OK
    bulk_r = sdk.GroupBulkRead(port, ph)
    bulk_r.addParam(1, 84, 2)
    bulk_r.addParam(3, 65, 1)
    bulk_r.addParam(2, 0, 2)
    assert bulk_r.txRxPacket() == OK
    assert bulk_r.getData(1, 84, 2) == 0x0210 and bulk_r.getData(3, 65, 1) == 1
    assert bulk_r.getData(2, 0, 2) == 1060


def test_factory_reset_reboot_and_clear(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.write1ByteTxRx(port, 1, 9, 0) == (OK, 0)           # Return Delay (EEPROM)
    assert ph.write2ByteTxRx(port, 1, 84, 999) == (OK, 0)        # RAM
    assert ph.reboot(port, 1) == (OK, 0)
    assert ph.read1ByteTxRx(port, 1, 9)[0] == 0                  # EEPROM kept
    assert ph.read2ByteTxRx(port, 1, 84)[0] == 800               # RAM back to default
    assert ph.factoryReset(port, 1, 0x02) == (OK, 0)
    assert ph.read1ByteTxRx(port, 1, 9)[0] == 250
    assert ph.clearMultiTurn(port, 1) == (OK, 0)
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, 0)
    assert ph.clearMultiTurn(port, 1) == (OK, p.RESULT_FAIL)     # not while the torque is on
    assert ph.factoryReset(port, 1, 0xFF) == (OK, p.ACCESS_ERROR)


def test_status_return_level_and_shadow_ids(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.write1ByteTxRx(port, 2, 68, 1) == (OK, 0)
    assert ph.write1ByteTxRx(port, 2, 65, 1)[0] == sdk.COMM_RX_TIMEOUT   # no status for writes
    assert ph.read1ByteTxRx(port, 2, 65) == (1, OK, 0)                   # reads still answer
    assert ph.write1ByteTxRx(port, 2, 68, 0)[0] == sdk.COMM_RX_TIMEOUT
    assert ph.read1ByteTxRx(port, 2, 65)[1] == sdk.COMM_RX_TIMEOUT
    assert ph.ping(port, 2)[1] == OK                                      # ping always
    assert ph.write1ByteTxRx(port, 3, 12, 1) == (OK, 0)                   # servo 3 shadows 1
    assert ph.write2ByteTxRx(port, 1, 84, 777) == (OK, 0)
    assert ph.read2ByteTxRx(port, 3, 84)[0] == 777


def _raw(port, ph, servo_id, instruction, params=()):
    packet = [0] * (10 + len(params))
    packet[sdk.PKT_ID] = servo_id
    packet[sdk.PKT_LENGTH_L] = 3 + len(params)
    packet[sdk.PKT_INSTRUCTION] = instruction
    packet[sdk.PKT_PARAMETER0:sdk.PKT_PARAMETER0 + len(params)] = list(params)
    _, result, error = ph.txRxPacket(port, packet)
    return result, error


def test_each_error_code_where_a_servo_returns_it(sdk_port, emulator):
    port, ph = sdk_port
    assert _raw(port, ph, 1, 0x77) == (OK, p.INSTRUCTION_ERROR)
    # CRC: a READ with its CRC broken, written raw
    bad = bytearray(p.encode(1, p.READ, bytes([132, 0, 4, 0])))
    bad[-1] ^= 0x55
    port.clearPort()
    port.writePort(bytes(bad))
    port.setPacketTimeout(11)
    reply, result = ph.rxPacket(port, False)
    assert result == OK and reply[sdk.PKT_ERROR] == p.CRC_ERROR
    assert ph.write1ByteTxRx(port, 1, 64, 2) == (OK, p.DATA_RANGE_ERROR)   # Torque Enable 2
    assert ph.write2ByteTxRx(port, 1, 112, 5) == (OK, p.DATA_LENGTH_ERROR)  # half a register
    assert _raw(port, ph, 1, p.READ, (132, 0)) == (OK, p.DATA_LENGTH_ERROR)
    assert ph.write4ByteTxRx(port, 1, 52, 1000) == (OK, 0)                 # Min Position Limit
    assert ph.write4ByteTxRx(port, 1, 116, 500) == (OK, p.DATA_LIMIT_ERROR)  # below it
    assert ph.write2ByteTxRx(port, 1, 36, 900) == (OK, p.DATA_RANGE_ERROR)  # PWM Limit > 885
    assert ph.write2ByteTxRx(port, 1, 100, 100) == (OK, 0)
    assert ph.write2ByteTxRx(port, 1, 36, 50) == (OK, 0)
    assert ph.write2ByteTxRx(port, 1, 100, 100) == (OK, p.DATA_LIMIT_ERROR)  # Goal PWM > limit
    assert ph.write4ByteTxRx(port, 1, 132, 7) == (OK, p.ACCESS_ERROR)      # read-only
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, 0)
    assert ph.write1ByteTxRx(port, 1, 11, 4) == (OK, p.ACCESS_ERROR)       # EEPROM, torque on
    assert ph.readTxRx(port, 1, 660, 4)[2] == p.ACCESS_ERROR               # past the table
    assert ph.read4ByteTxRx(port, 1, 132)[1:] == (OK, 0)


def test_hardware_error_shuts_down_until_reboot(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, 0)
    emulator.inject("overload", 1)
    value, result, error = ph.read1ByteTxRx(port, 1, 70)
    assert (value, result, error) == (0x20, OK, p.ALERT)
    assert ph.read1ByteTxRx(port, 1, 64)[0] == 0                           # torque off
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, p.RESULT_FAIL | p.ALERT)
    assert ph.reboot(port, 1) == (OK, p.ALERT)
    assert ph.read1ByteTxRx(port, 1, 70) == (0, OK, 0)
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, 0)


def test_bus_watchdog_stops_the_servo_and_refuses_goals(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (OK, 0)
    assert ph.write1ByteTxRx(port, 1, 98, 2) == (OK, 0)                    # 40 ms
    time.sleep(0.15)
    assert ph.read1ByteTxRx(port, 1, 98)[0] == 255                         # -1: fired
    assert ph.write4ByteTxRx(port, 1, 116, 2100) == (OK, p.DATA_RANGE_ERROR)
    assert ph.write1ByteTxRx(port, 1, 98, 0) == (OK, 0)
    assert ph.write4ByteTxRx(port, 1, 116, 2100) == (OK, 0)


def test_byte_timing_follows_the_baud_rate(wx250s, arm_emulator):
    """A 6-servo sync read at 1 Mbps with no return delay needs at least its bytes' time."""
    with arm_emulator(wx250s, byte_timing=True) as emu:
        for s in emu.bus.servos:
            s.memory.set("return_delay_time", 0)
        port = _PortHandler(emu.port)
        port.openPort()
        port.setBaudRate(1_000_000)
        ph = sdk.PacketHandler(2.0)
        reader = sdk.GroupSyncRead(port, ph, 126, 10)
        for i in (1, 2, 4, 6, 7, 8):
            reader.addParam(i)
        t = time.perf_counter()
        for _ in range(10):
            assert reader.txRxPacket() == OK
        per_read = (time.perf_counter() - t) / 10
        port.closePort()
    wire = (20 + 6 * 21) * 10 / 1e6   # request and six 21-byte replies, 10 bits a byte
    assert per_read >= wire


def test_stuffed_status_packets_reach_the_sdk_intact(sdk_port, emulator):
    """Present values whose bytes hold FF FF FD are stuffed on the wire and unstuffed by
    dynamixel-sdk."""
    port, ph = sdk_port
    emulator.bank.sync_registers = lambda: None   # hold the registers as set here
    raw = bytes.fromhex("ffff" "fdffffff" "fdfeffff")   # current -1, velocity -3, pos -259
    for s in emulator.bus.servos:
        s.memory.data[126:136] = raw
    reader = sdk.GroupSyncRead(port, ph, 126, 10)
    for i in (1, 2, 3):
        reader.addParam(i)
    assert reader.txRxPacket() == OK
    for i in (1, 2, 3):
        assert reader.getData(i, 126, 2) == 0xFFFF
        assert reader.getData(i, 128, 4) == 0xFFFFFFFD
        assert reader.getData(i, 132, 4) == (-259) & 0xFFFFFFFF
