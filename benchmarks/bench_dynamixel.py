"""Dynamixel bus benchmark: the control-loop rate for the six joints of the WidowX 250 (eight
servos on the bus with the two shadows) through dynamixel-sdk on a pseudo-terminal, each
emulator in its own process with realistic byte timing at 1 Mbps (10 bits a byte, Return
Delay Time 0, replies written when their last byte would have left the wire).

Run: ``python benchmarks/bench_dynamixel.py [--quick]``. Prints a markdown section: per
control period, the median wall time and the rate of

* *SDK alone* (the reference): ``GroupSyncRead`` of present current, velocity and position
  (126..135) of the six joint servos plus ``GroupSyncWrite`` of their goal positions, on
  dynamixel-sdk's ``PortHandler`` waiting in ``select`` for its bytes (as the bus does; the
  SDK's own spinning wait swung 1.9-10 ms a period with the load), against **its own emulator
  and pty**: a reply the SDK gives up on lands in its own input, which it flushes before each
  period (and 50 ms after a failed one), never in the plant's next transaction;
* *DynamixelBus*: the same two transactions through :class:`inkarm.hardware.dynamixel.bus.
  DynamixelBus` (retry frame, input flush, status error bytes kept, select-based reads);
* *DynamixelPlant*: ``read()`` and ``command(PositionCommand)`` of the plant (unit
  conversion, goal shaping and clamps, the bus watchdog polled every 10th period);

and the wire time of the sync read and its six replies (the bound no host can beat on the
emulator, which does not hold the next packet back for the sync write's bytes). The three
run in alternating blocks (:mod:`blocks`); a block's time is the median of its periods, a
row's the median of its blocks, and each ratio is the SDK's median over the row's.

Set for a loaded machine, alike on both sides: the reply timeout of every try is the SDK's rule
with a 150 ms latency timer (302 ms, not 34: at a load of 8-12 on 2 cores the emulator stalled
for over 100 ms at a time, three tries in a row, even at nice -10; a servo that never answers
still fails, after three tries, and the retries are counted in the output); the
emulators run at nice -10 where the user may raise them (real servos do not share the host's
CPU); the plant's bus watchdog is at its longest, 2.54 s, as its servos hear nothing while the
other rows run their blocks. The retries, the late-reply fault and the rest are as shipped.
Target: >= 100 Hz.
"""

from __future__ import annotations

import argparse
import functools
import os
import resource
import select
import sys
import time

import dynamixel_sdk as sdk
from blocks import interleave

from inkarm.core.plant import PositionCommand
from inkarm.hardware.dynamixel.config import DynamixelConfig, with_dynamixel
from inkarm.hardware.dynamixel.emulator import EmulatorProcess, simple_emulator, specs_for_profile
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from inkarm.robots.registry import load_robot

BAUD = 1_000_000
RETURN_DELAY_ADDRESS = 9   # Return Delay Time [2 us], EEPROM (e-Manual, X series)
QUIET_S = 0.05             # after a failed SDK period: let its late replies arrive, then drop
LATENCY_MS = 150.0         # in the reply timeout of both sides: 2 x 150 + 2 = 302 ms a try
EMULATOR_NICE = -10        # servos do not share the host's CPU: their emulators go first


def may_raise_priority() -> bool:
    """Whether this user may raise a process to ``EMULATOR_NICE`` (root, or RLIMIT_NICE)."""
    return os.geteuid() == 0 or 20 - resource.getrlimit(resource.RLIMIT_NICE)[0] <= EMULATOR_NICE


def niced_emulator(*args, **kwargs):
    """:func:`simple_emulator`, in a child raised to ``EMULATOR_NICE`` where allowed (picklable
    by reference: the factory of :class:`EmulatorProcess`)."""
    try:
        os.nice(EMULATOR_NICE)
    except OSError:
        pass  # no permission: the emulator competes with the load like any process
    return simple_emulator(*args, **kwargs)


class _WaitingPort(sdk.PortHandler):
    """The SDK's PortHandler, waiting in ``select`` (at most 0.5 ms a time) for its next byte
    instead of spinning on empty reads: spinning takes the CPU from the emulator that has to
    produce the reply, and on a loaded 2-core host made the SDK's own port swing from 1.9 to
    10 ms a period (block spreads up to 13x). The rest is the SDK's."""

    def setPacketTimeout(self, packet_length):
        # The SDK's rule (bytes on the wire + twice the latency timer + 2 ms), LATENCY_MS for
        # its module-wide 16 ms, as for the plant.
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + 2.0 * LATENCY_MS + 2.0

    def readPort(self, length):
        if not self.ser.in_waiting:
            select.select([self.ser.fd], [], [], 0.0005)
        return self.ser.read(length)


class _SdkLoop:
    """The reference: dynamixel-sdk's GroupSyncRead and GroupSyncWrite."""

    def __init__(self, port_name: str, ids, goals):
        self.port = _WaitingPort(port_name)
        if not (self.port.openPort() and self.port.setBaudRate(BAUD)):
            raise RuntimeError(f"dynamixel-sdk cannot open {port_name} at {BAUD} bit/s")
        ph = sdk.PacketHandler(2.0)
        for i in ids:  # as the plant writes it on its own bus
            result, _ = ph.write1ByteTxRx(self.port, i, RETURN_DELAY_ADDRESS, 0)
            if result != sdk.COMM_SUCCESS:
                raise RuntimeError(f"dynamixel-sdk: servo {i}: Return Delay Time not written "
                                   f"({ph.getTxRxResult(result)})")
        self.reader = sdk.GroupSyncRead(self.port, ph, 126, 10)
        self.writer = sdk.GroupSyncWrite(self.port, ph, 116, 4)
        for i, goal in zip(ids, goals):
            self.reader.addParam(i)
            self.writer.addParam(i, list(int(goal).to_bytes(4, "little", signed=True)))
        self.periods = self.failures = 0

    def period(self) -> None:
        self.periods += 1
        self.port.clearPort()
        if (self.reader.txRxPacket() == sdk.COMM_SUCCESS
                and self.writer.txPacket() == sdk.COMM_SUCCESS):
            return
        self.failures += 1   # counted in its time; its stragglers must not pass for the next
        time.sleep(QUIET_S)
        self.port.clearPort()

    def close(self) -> None:
        self.port.closePort()


def measure(blocks: int, repeats: int):
    """(rows of (name, seconds per period), the blocks, SDK failures, SDK periods, the bus's
    retries as a phrase)."""
    profile = with_dynamixel(load_robot("wx250s"), watchdog_ms=2540, latency_ms=LATENCY_MS)
    cfg = DynamixelConfig.of(profile)
    factory = functools.partial(niced_emulator, specs_for_profile(cfg, profile.n),
                                profile.home_q, byte_timing=True)
    with EmulatorProcess(factory) as ours, EmulatorProcess(factory) as theirs:
        plant = DynamixelPlant(ours.port, profile)   # writes Return Delay Time 0
        try:
            q = plant.read().q
            bus, ids = plant.bus, cfg.ids
            hold = bus.read_state(ids)[0]   # the same goals from every row: no tug of war
            reference = _SdkLoop(theirs.port, ids, hold)
            try:
                def plant_period():
                    plant.read()
                    plant.command(PositionCommand(q))

                def bus_period():
                    bus.read_state(ids)
                    bus.sync_write(ids, "goal_position", hold)

                result = interleave({"sdk": reference.period, "bus": bus_period,
                                     "plant": plant_period},
                                    blocks=blocks, repeats=repeats, warmup=5)
            finally:
                reference.close()
        finally:
            plant.close()
    wire = (len(ids) * 21 + (14 + len(ids))) * 10 / BAUD   # sync read + six status packets
    rows = [("dynamixel-sdk, waiting in select (reference, own emulator)", result.median("sdk")),
            ("DynamixelBus", result.median("bus")),
            ("DynamixelPlant read + command", result.median("plant")),
            ("wire time of the read and its replies (bound)", wire)]
    retried = f"{bus.stats['retries']} of its {bus.stats['transactions']}"
    return rows, result, reference.failures, reference.periods, retried


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer blocks")
    args = parser.parse_args(argv)
    blocks, repeats = (10, 5) if args.quick else (60, 5)
    rows, result, failures, periods, retried = measure(blocks, repeats)
    reference = rows[0][1]
    print("## Dynamixel bus: loop rate for 6 servos at 1 Mbps\n")
    print(f"Six joint servos of the wx250s (eight on the bus); {blocks} alternating blocks of "
          f"{repeats} periods per row, the subjects on one emulator, the SDK on its own (each "
          "in a child process with byte timing). Medians of the blocks' median wall time per "
          "control period; the spread is the slowest block over the fastest.\n")
    print("| what | ms / period | rate [Hz] | rate / SDK | block spread |")
    print("|---|---:|---:|---:|---:|")
    for (name, seconds), key in zip(rows, ("sdk", "bus", "plant", None)):
        spread = f"{result.spread(key):.2f}" if key else "-"
        print(f"| {name} | {1000 * seconds:.2f} | {1 / seconds:.0f} | "
              f"{reference / seconds:.2f} | {spread} |")
    plant_rate = 1 / rows[2][1]
    verdict = "meets" if plant_rate >= 100 else "misses"
    print(f"\nThe plant's loop runs at {plant_rate:.0f} Hz: {verdict} the 100 Hz target "
          "(the wx250s profile's period is 6 ms, 167 Hz). The bound leaves out the sync "
          "write's 0.44 ms on the wire (44 bytes), which the host does not wait for (a real "
          f"bus would make the next read wait). The SDK timed out in {failures} of "
          f"its {periods} periods (its own emulator; counted in its times); the plant's bus "
          f"retried {retried} transactions. Emulators at "
          f"nice {EMULATOR_NICE if may_raise_priority() else '0 (not allowed to raise them)'}. "
          f"{result.load_line()}")
    return 0 if failures <= periods // 4 else 1


if __name__ == "__main__":
    sys.exit(main())
