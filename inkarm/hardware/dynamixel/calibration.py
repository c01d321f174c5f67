"""Joint calibration of a Dynamixel arm: where each joint's zero is on its servo, which way it
turns, and the range it was seen to reach.

A joint's angle from its servo's Present Position ``p`` [ticks]::

    q = direction (p - offset - 4096 k) 2 pi / 4096     [rad]

``offset`` is the reading at the joint's zero mark (0..4095), ``direction`` +1 or -1 (the
reading grows or falls as the joint turns positive), and the whole turns ``k`` are chosen once
at start-up so that ``q`` lies in the joint's range: a zero mark near the encoder's wrap
(4095 -> 0) or a servo that booted a turn away reads the same.

The file lives in the user's configuration folder, beside the cell's calibration
(:mod:`inkarm.robots.calibration`), ``<calibration_dir()>/calibration/<robot>.joints.toml``
(:func:`calibration_path`); a file of an older inkarm beside the profile,
``<profile>.calibration.toml``, is still read when there is no new one (:func:`find_calibration`)::

    robot = "wx250s"
    [joints.shoulder]
    offset_ticks = 2048
    direction = 1

:func:`measure` asks the user to move each joint (torque off) to its zero mark and to a mark
``+90 deg`` away; ``ask(prompt)`` is :func:`input` on a terminal and a script in tests.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.errors import InputError
from inkarm.io.toml import TomlReader, load_toml
from inkarm.robots.servo import TICKS_PER_REV

TOLERANCE_TICKS = 150   # a +90 deg mark must read 1024 +- this many ticks


@dataclass(frozen=True)
class Calibration:
    """Per joint: ``offset_ticks`` (n,), ``direction`` (n,) of +-1."""

    joint_names: tuple[str, ...]
    offset_ticks: np.ndarray
    direction: np.ndarray

    @classmethod
    def identity(cls, joint_names: Sequence[str]) -> Calibration:
        n = len(joint_names)
        return cls(tuple(joint_names), np.full(n, 2048.0), np.ones(n))

    def turns(self, ticks, ranges: Sequence[tuple[float, float] | None]) -> np.ndarray:
        """Whole turns ``k`` per joint putting ``ticks`` inside (or nearest to) each range."""
        base = self.direction * (np.asarray(ticks, dtype=float) - self.offset_ticks)
        k = np.zeros(len(base))
        for j, r in enumerate(ranges):
            centre = 0.0 if r is None else 0.5 * (r[0] + r[1])
            k[j] = np.round((base[j] * 2 * np.pi / TICKS_PER_REV - centre) / (2 * np.pi))
        return k

    def to_rad(self, ticks, turns) -> np.ndarray:
        return (self.direction * (np.asarray(ticks, float) - self.offset_ticks)
                - TICKS_PER_REV * np.asarray(turns)) * (2 * np.pi / TICKS_PER_REV)

    def to_ticks(self, q, turns) -> np.ndarray:
        return self.offset_ticks + self.direction * (
            np.asarray(q, float) * TICKS_PER_REV / (2 * np.pi) + TICKS_PER_REV * np.asarray(turns))


def calibration_path(profile) -> Path:
    """Where the joint calibration of ``profile``'s robot is written:
    ``<calibration_dir()>/calibration/<robot>.joints.toml`` (never inside the installed
    package)."""
    from inkarm.robots.calibration import calibration_path as cell_calibration

    cell = cell_calibration(profile.name)
    return cell.with_name(f"{profile.name}.joints.toml")


def legacy_calibration_path(profile) -> Path:
    """Where inkarm <= 0.x wrote it: ``<profile>.calibration.toml`` beside the profile file."""
    source = Path(profile.source) if profile.source else Path(f"{profile.name}.toml")
    return source.with_name(f"{source.stem}.calibration.toml")


def find_calibration(profile) -> Path:
    """The joint calibration file to read for ``profile``: :func:`calibration_path` when it
    exists, else the older one beside the profile when that exists, else (neither there)
    :func:`calibration_path`."""
    path = calibration_path(profile)
    if path.is_file():
        return path
    legacy = legacy_calibration_path(profile)
    return legacy if legacy.is_file() else path


def load_calibration(path: str | Path, joint_names: Sequence[str]) -> Calibration:
    """Read a calibration file; every joint must be there (an InputError names what is not)."""
    data = load_toml(path, "calibration file")
    rd = TomlReader(str(path))
    rd.keys(data, ("robot", "joints"), "")
    joints = rd.table(data.get("joints", {}), "joints")
    rd.keys(joints, tuple(joint_names), "joints")
    offsets, directions = [], []
    for name in joint_names:
        if name not in joints:
            raise rd.error(f"joints.{name}", "missing: run `inkarm calibrate joints` again")
        j = rd.table(joints[name], f"joints.{name}")
        rd.keys(j, ("offset_ticks", "direction"), f"joints.{name}")
        offsets.append(rd.number(j.get("offset_ticks"), f"joints.{name}.offset_ticks", 0,
                                 maximum=TICKS_PER_REV - 1))
        direction = rd.integer(j.get("direction"), f"joints.{name}.direction", -1, 1)
        if direction == 0:
            raise rd.error(f"joints.{name}.direction", "expected 1 or -1, got 0", value=0)
        directions.append(direction)
    return Calibration(tuple(joint_names), np.array(offsets), np.array(directions, float))


def save_calibration(calibration: Calibration, path: str | Path, robot: str) -> Path:
    lines = [f'robot = "{robot}"', ""]
    for name, off, d in zip(calibration.joint_names, calibration.offset_ticks,
                            calibration.direction):
        lines += [f"[joints.{name}]", f"offset_ticks = {round(off)}",
                  f"direction = {int(d)}", ""]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.partial")
    tmp.write_text("\n".join(lines))
    tmp.replace(path)
    return path


def measure(read_ticks: Callable[[int], int], joint_names: Sequence[str],
            ask: Callable[[str], str] = input, say: Callable[[str], None] = print) -> Calibration:
    """Walk the user through each joint (module docstring); ``read_ticks(j)`` reads joint
    ``j``'s servo [ticks]. Raises InputError when a +90 deg mark is not about 1024 ticks away
    (a wrong mark, or the servo slipping)."""
    offsets, directions = [], []
    for j, name in enumerate(joint_names):
        ask(f"[{j + 1}/{len(joint_names)}] move {name} to its ZERO mark, then press Enter ")
        zero = read_ticks(j)
        ask(f"    now turn {name} +90 deg (its positive direction) to the next mark, then Enter ")
        quarter = read_ticks(j)
        delta = (quarter - zero + TICKS_PER_REV // 2) % TICKS_PER_REV - TICKS_PER_REV // 2
        if abs(abs(delta) - TICKS_PER_REV // 4) > TOLERANCE_TICKS:
            raise InputError(f"{name}: the +90 deg mark reads {delta:+d} ticks from zero, "
                             f"expected +-1024 (+-{TOLERANCE_TICKS}); check the marks and "
                             "that the horn does not slip", key=name, value=delta)
        direction = 1 if delta > 0 else -1
        offsets.append(zero % TICKS_PER_REV)
        directions.append(direction)
        say(f"    {name}: zero at {zero % TICKS_PER_REV} ticks, direction {direction:+d} "
            f"({math.degrees(delta * 2 * math.pi / TICKS_PER_REV):+.1f} deg measured)")
    return Calibration(tuple(joint_names), np.array(offsets, float), np.array(directions, float))


def calibrate_arm(port: str, profile, path: str | Path | None = None,
                  ask: Callable[[str], str] = input, say: Callable[[str], None] = print) -> Path:
    """Measure the arm on ``port`` (:func:`measure`, the servos' torque off so the joints move
    by hand) and write the calibration file (default :func:`calibration_path`). Refuses, as
    :class:`~inkarm.hardware.dynamixel.plant.DynamixelPlant` does, servos that do not match
    the profile."""
    from inkarm.hardware.dynamixel.bus import DynamixelBus
    from inkarm.hardware.dynamixel.config import DynamixelConfig
    from inkarm.hardware.dynamixel.tables import MODEL_NAMES

    cfg = DynamixelConfig.of(profile)
    path = Path(path) if path is not None else calibration_path(profile)
    names = dict(zip(cfg.ids, profile.joint_names))
    with DynamixelBus(port, cfg.baudrate, cfg.retries, names, cfg.latency_ms) as bus:
        problems = []
        for servo_id, model in zip(cfg.ids, cfg.models):
            found = bus.ping(servo_id)
            if found is None or MODEL_NAMES.get(found[0]) != model:
                what = "no reply" if found is None else \
                    f"a {MODEL_NAMES.get(found[0], found[0])} answers"
                problems.append(f"{bus.who(servo_id)}: {what} (expected a {model})")
        if problems:
            raise InputError(f"the servos on {port} do not match robot {profile.name!r}: "
                             + "; ".join(problems), key="backends.dynamixel")
        say("torque off: the arm goes limp; support it.")
        for servo_id in cfg.all_ids:
            bus.write(servo_id, "torque_enable", 0)
        calibration = measure(lambda j: bus.read(cfg.ids[j], "present_position"),
                              profile.joint_names, ask, say)
    saved = save_calibration(calibration, path, profile.name)
    say(f"calibration: {saved}")
    return saved
