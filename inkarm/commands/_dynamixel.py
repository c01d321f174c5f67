"""``inkarm emulate dynamixel``: the Protocol 2.0 emulator of a robot's servos on a
pseudo-terminal (registered in :mod:`inkarm.commands.emulate`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from inkarm.commands._serve import check_png, serve
from inkarm.errors import InputError


def add_emulate_parser(sub) -> None:
    p = sub.add_parser(
        "dynamixel",
        help="a Dynamixel X-series arm on a Protocol 2.0 bus (the MuJoCo twin or simple joints)",
        description="Emulate the Dynamixel servos of a robot profile on a pseudo-terminal: "
        "Protocol 2.0 (CRC, stuffing, every instruction, status return level, EEPROM lock, "
        "bus watchdog, hardware errors), byte timing at the baud rate, the servos' firmware "
        "moving the robot's MuJoCo twin in real time, its pen drawing on an ink canvas. "
        "Prints the port for `inkarm draw --backend dynamixel --port PORT`; Ctrl-C stops it.",
    )
    p.add_argument("--robot", default=None, metavar="NAME|FILE.toml",
                   help="robot profile with a [backends.dynamixel] table (default: the "
                   "scenario's, else wx250s)")
    p.add_argument("--scenario", default=None, metavar="FILE.toml",
                   help="the scenario you will draw: the twin's cell, sheet and ink are its "
                   "(default: the embedded default job's, with --robot)")
    p.add_argument("--simple", action="store_true",
                   help="no twin: each joint a damped rotor (no gravity, no paper, no ink)")
    p.add_argument("--baudrate", type=int, default=None,
                   help="bit/s for the byte timing (default: the profile's)")
    p.add_argument("--no-byte-timing", action="store_true",
                   help="answer at once (no wire or return-delay time)")
    p.add_argument("--fault", action="append", default=[], metavar="KIND:ID:SECONDS",
                   help="inject a fault SECONDS after the driver first turns a servo's torque "
                   "on (not from boot): silent, crc, late, overload, overheat, watchdog, "
                   "disconnect (e.g. overload:4:2.5); repeatable")
    p.add_argument("--status-return-level", type=int, choices=(0, 1, 2), default=None,
                   help="the servos boot at this Status Return Level (68): 2 answers every "
                   "instruction (the factory setting, default), 1 only PING and reads (writes "
                   "go unanswered), 0 only PING; try a bus set up that way")
    p.add_argument("--out", metavar="FILE.png", default=None,
                   help="write the twin's ink canvas here on exit")
    p.set_defaults(_emulate=run_emulate)


def run_emulate(args: argparse.Namespace) -> int:
    from inkarm.hardware.dynamixel.config import DynamixelConfig
    from inkarm.hardware.dynamixel.emulator import (
        parse_fault,
        simple_emulator,
        specs_for_profile,
    )
    from inkarm.hardware.dynamixel.tables import BAUD_RATES
    from inkarm.jobs.backends.dynamixel import twin_emulator
    from inkarm.jobs.scenario import load_scenario
    from inkarm.sim.cell import Cell

    check_png(args.out)
    if args.baudrate is not None and args.baudrate not in BAUD_RATES.values():
        raise InputError(f"expected one of the X series' rates {sorted(BAUD_RATES.values())} "
                         f"bit/s, got {args.baudrate}", key="--baudrate", value=args.baudrate)
    faults = [parse_fault(text) for text in args.fault]
    scenario = load_scenario(args.scenario)
    robot = args.robot or (None if args.scenario else "wx250s")
    if robot is not None:
        key = "robot.file" if robot.endswith(".toml") else "robot.name"
        robot = str(Path(robot).resolve()) if key == "robot.file" else robot
        scenario = scenario.with_overrides({"robot": {}, key: robot})
    profile = scenario.robot
    level = args.status_return_level
    if args.simple:
        cfg = DynamixelConfig.of(profile)
        emulator = simple_emulator(specs_for_profile(cfg, profile.n), profile.home_q, faults,
                                   args.baudrate or cfg.baudrate,
                                   byte_timing=not args.no_byte_timing)
        for servo in emulator.bus.servos if level is not None else ():
            servo.memory.set("status_return_level", level)
    else:
        emulator = twin_emulator(scenario, faults, args.baudrate,
                                 byte_timing=not args.no_byte_timing,
                                 status_return_level=2 if level is None else level)
        cell = Cell(scenario.cell, profile)
        (w, h), (x, y) = cell.paper_size_mm, cell.paper_centre_mm
        print(f"twin's sheet: {w:g} x {h:g} mm centred at ({x:g}, {y:g}) mm", file=sys.stderr)
    on_bus = [s.id for s in emulator.bus.servos]
    for fault in faults:
        if fault.servo_id not in on_bus:
            raise InputError(f"no servo {fault.servo_id} on the bus of {profile.name} (its ids: "
                             f"{', '.join(map(str, on_bus))})", key="--fault",
                             value=f"{fault.kind}:{fault.servo_id}:{fault.at_s:g}")
    ids = ", ".join(map(str, on_bus))
    serve(emulator, lambda port: f"Dynamixel Protocol 2.0 emulator of {profile.name} (servos "
                                 f"{ids}) at {emulator.baudrate} bit/s on {port}; Ctrl-C to stop",
          args.out)
    s = emulator.stats
    print(f"{s.packets} packets, {s.replies} replies, {s.bytes_skipped} bytes skipped, "
          f"{s.dropped_s:.3f} s of physics dropped; faults: {', '.join(s.faults) or 'none'}",
          file=sys.stderr)
    if emulator.error is not None and not isinstance(emulator.error, OSError):
        print(f"inkarm emulate: error: {emulator.error}", file=sys.stderr)
        return 1
    return 0
