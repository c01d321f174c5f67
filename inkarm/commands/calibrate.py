"""``inkarm calibrate --port PORT --robot NAME``: measure a Dynamixel arm's joint zeros and
directions (move each joint to its marks) and write them beside the robot profile."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "calibrate",
        help="measure a Dynamixel arm's joint zeros and directions",
        description="Turn the servos' torque off and, joint by joint, ask you to move the "
        "joint to its zero mark and to a mark 90 degrees positive (press Enter at each); "
        "writes <profile>.calibration.toml beside the robot profile (or --out), which "
        "`inkarm draw --backend dynamixel` reads. Answers come from stdin, so a script can "
        "drive it.",
    )
    p.add_argument("--port", required=True, help="serial port of the arm (or an emulator's pty)")
    p.add_argument("--robot", default="wx250s", metavar="NAME|FILE.toml",
                   help="robot profile with a [backends.dynamixel] table (default wx250s)")
    p.add_argument("--out", metavar="FILE.toml", default=None,
                   help="calibration file (default: beside the robot profile)")
    return p


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.dynamixel.calibration import calibrate_arm
    from inkarm.robots.registry import load_robot

    profile = load_robot(args.robot)
    calibrate_arm(args.port, profile, Path(args.out) if args.out else None)
    return 0
