"""Dynamixel bus benchmark: the control-loop rate for the six joints of the WidowX 250 (eight
servos on the bus with the two shadows) through dynamixel-sdk on a pseudo-terminal, the
emulator in another process with realistic byte timing at 1 Mbps (10 bits a byte, Return Delay
Time 0 as the profile writes it, replies written when their last byte would have left the
wire).

Run: ``python benchmarks/bench_dynamixel.py [--quick]``. Prints a markdown section: per
control period, the median wall time and the rate of

* *SDK alone* (the reference, measured in the same run): ``GroupSyncRead`` of present current,
  velocity and position (126..135) of the six joint servos plus ``GroupSyncWrite`` of their
  goal positions, on dynamixel-sdk's own ``PortHandler``;
* *DynamixelBus*: the same two transactions through :class:`inkarm.hardware.dynamixel.bus.
  DynamixelBus` (retry frame, input flush, status error bytes kept, select-based reads);
* *DynamixelPlant*: ``read()`` and ``command(PositionCommand)`` of the plant (unit
  conversion, goal shaping and clamps, the bus watchdog polled every 10th period);

and the wire time of the two packets and six replies (the bound no host can beat). Ratios are
each row's rate over the SDK's. Target: >= 100 Hz.
"""

from __future__ import annotations

import argparse
import functools
import statistics
import sys
import time

import dynamixel_sdk as sdk
import numpy as np

from inkarm.core.plant import PositionCommand
from inkarm.hardware.dynamixel.config import DynamixelConfig
from inkarm.hardware.dynamixel.emulator import EmulatorProcess, simple_emulator, specs_for_profile
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from inkarm.robots.registry import load_robot

BAUD = 1_000_000


class _SdkLoop:
    """The reference: the SDK's own PortHandler, GroupSyncRead and GroupSyncWrite."""

    def __init__(self, port_name: str, ids, goals):
        self.port = sdk.PortHandler(port_name)
        self.port.openPort()
        self.port.setBaudRate(BAUD)
        ph = sdk.PacketHandler(2.0)
        self.reader = sdk.GroupSyncRead(self.port, ph, 126, 10)
        self.writer = sdk.GroupSyncWrite(self.port, ph, 116, 4)
        for i, goal in zip(ids, goals):
            self.reader.addParam(i)
            self.writer.addParam(i, list(int(goal).to_bytes(4, "little", signed=True)))

    def period(self) -> bool:
        return (self.reader.txRxPacket() == sdk.COMM_SUCCESS
                and self.writer.txPacket() == sdk.COMM_SUCCESS)

    def close(self) -> None:
        self.port.closePort()


def measure(periods: int) -> list[tuple[str, float]]:
    profile = load_robot("wx250s")
    cfg = DynamixelConfig.of(profile)
    specs = specs_for_profile(cfg, profile.n)
    factory = functools.partial(simple_emulator, specs, profile.home_q, byte_timing=True)
    rows = []
    with EmulatorProcess(factory) as emulator:
        plant = DynamixelPlant(emulator.port, profile)   # writes Return Delay Time 0
        q = plant.read().q
        bus, ids = plant.bus, cfg.ids
        hold = bus.read_state(ids)[0]   # the same goals from every row: no tug of war
        reference = _SdkLoop(emulator.port, ids, hold)
        times = {"sdk": [], "bus": [], "plant": []}
        for _ in range(periods):  # interleaved, so that load on the machine hits all alike
            t = time.perf_counter()
            plant.read()
            plant.command(PositionCommand(q))
            times["plant"].append(time.perf_counter() - t)
            t = time.perf_counter()
            bus.read_state(ids)
            bus.sync_write(ids, "goal_position", hold)
            times["bus"].append(time.perf_counter() - t)
            t = time.perf_counter()
            ok = reference.period()
            times["sdk"].append(time.perf_counter() - t if ok else float("nan"))
        reference.close()
        plant.close()
    wire = (len(ids) * 21 + (14 + len(ids)) + (14 + 5 * len(ids))) * 10 / BAUD
    rows.append(("dynamixel-sdk alone (reference)", statistics.median(times["sdk"])))
    rows.append(("DynamixelBus", statistics.median(times["bus"])))
    rows.append(("DynamixelPlant read + command", statistics.median(times["plant"])))
    rows.append(("wire time of the bytes (bound)", wire))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer periods")
    args = parser.parse_args(argv)
    periods = 60 if args.quick else 400
    rows = measure(periods)
    reference = rows[0][1]
    print("## Dynamixel bus: loop rate for 6 servos at 1 Mbps\n")
    print(f"Six joint servos of the wx250s (eight on the bus), {periods} periods each, emulator "
          "in a child process with byte timing; median wall time per control period.\n")
    print("| what | ms / period | rate [Hz] | rate / SDK |")
    print("|---|---:|---:|---:|")
    for name, seconds in rows:
        print(f"| {name} | {1000 * seconds:.2f} | {1 / seconds:.0f} | "
              f"{reference / seconds:.2f} |")
    plant_rate = 1 / rows[2][1]
    verdict = "meets" if plant_rate >= 100 else "misses"
    print(f"\nThe plant's loop runs at {plant_rate:.0f} Hz: {verdict} the 100 Hz target "
          f"(the wx250s profile's period is 6 ms, 167 Hz).")
    return 0 if np.isfinite(reference) else 1


if __name__ == "__main__":
    sys.exit(main())
