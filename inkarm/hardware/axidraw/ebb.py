"""The EiBotBoard (EBB) firmware's serial commands as data: formatting with the firmware's
parameter ranges, and parsing its replies.

Facts from the EBB command reference (evil-mad, ``ebb.html``: the v2.x edition in the EggBot
repository, checked against the firmware 3.0 edition); where the editions differ the stricter
range is kept, so a command valid here is valid on either:

* A command is ASCII, case-insensitive, without whitespace, comma-separated, ended by ``\\r``,
  at most 64 characters including the ``\\r``.
* Most commands answer ``OK\\r\\n``. Queries answer a value line first: ``QS`` (steps),
  ``QP`` (pen), ``QB`` (button), ``ES`` (what was stopped) follow it with ``OK``; ``V``,
  ``QG`` and ``QM`` answer the value line alone. Some value lines end ``\\n\\r``: lines are
  split on either byte. An error is a line starting with ``!`` (``!8 Err: Unknown command``,
  ``!0 Err: <axis1> step rate too high``, ...), which firmware 3's reference ends with ``OK``
  in its legacy syntax and its code does not: a reader drops what follows an error.
* ``SM,duration,steps1[,steps2]``: duration 1..16777215 ms, steps -16777215..16777215; each
  moving axis must step at 1.31..25000 steps/s, else the firmware refuses the move.
  (Firmware 3 widens the ranges to 32 bits and clamps the rate instead of refusing it, and
  caps a delay, an SM without steps, at 100000 ms.) ``XM,duration,A,B`` is ``SM`` with
  steps1 = A + B, steps2 = A - B (checked on axes 1 and 2).
  ``LM,rate1,steps1,accel1,rate2,steps2,accel2[,clear]``: rates 0..2^31-1, steps and accels
  signed 32-bit, clear 0..3 (v2.7.0).
* ``SP,value[,duration[,pin]]``: 1 = up (servo_min, ``SC,4``), 0 = down (servo_max,
  ``SC,5``); duration 1..65535 ms (the delay before the next queued command; omitted = 0);
  pin 0..7. ``TP[,duration]`` toggles the pen.
* ``SC,param,value``: param 0..255, value 0..65535 (4: pen-up position, 5: pen-down position,
  both 1..65535 in 1/12 MHz units; 10, 11, 12: servo rates in those units per 24 ms).
* ``EM,e1[,e2]``: 0 disables a motor, 1..5 enable it (e1 also sets the microstep mode:
  1 = 1/16 .. 5 = full step); since v2.6.2 it zeroes the step counters.
* ``HM,rate[,pos1,pos2]``: rate 2..25000 steps/s, positions within +-4294967.
* ``SR,timeout_ms[,state]``: the servo power timeout (v2.6.0), ms as an unsigned 32-bit value.
* ``QS`` -> ``steps1,steps2`` (v2.4.3); ``CS`` clears them (v2.4.3). ``QP`` -> 1 up, 0 down.
  ``QM`` -> ``QM,command,motor1,motor2,fifo`` (v2.4.4). ``QG`` -> a hex status byte (v2.6.2;
  its bit 4 is "pen down" in the v2 edition, "pen up" in firmware 3: use ``QP``).
  ``QB`` -> 1 if the PRG button was pressed since the last query. ``V`` -> ``EBBv13_and_above
  EB Firmware Version 2.4.2``. ``R`` resets to the power-on state. ``ES`` aborts the moves and
  answers ``interrupted,fifo1,fifo2,left1,left2`` (v2.2.9; a lone 0/1 before).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from inkarm.errors import InkarmError, InputError

MAX_COMMAND = 64  # characters, the terminating CR included
MAX_DURATION_MS = 16777215  # SM/XM duration (24 bits)
MAX_STEPS = 16777215  # SM/XM steps per axis (24 bits, signed)
MAX_DELAY_MS = 100000  # an SM without steps (a delay): firmware 3.x caps it here
MIN_STEP_RATE = 1.31  # slowest step rate of a moving axis [steps/s]
MAX_STEP_RATE = 25000.0  # fastest step rate [steps/s]: the 25 kHz (40 us) step interrupt
INT31 = 2**31 - 1
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
MAX_HM_POSITION = 4294967

# What each command answers: "ok" (OK alone), "value+ok" (a value line, then OK), "value" (a
# value line alone).
REPLIES = {
    "SM": "ok", "XM": "ok", "LM": "ok", "SP": "ok", "TP": "ok", "SC": "ok", "EM": "ok",
    "CS": "ok", "HM": "ok", "SR": "ok", "R": "ok",
    "QS": "value+ok", "QP": "value+ok", "QB": "value+ok", "ES": "value+ok",
    "V": "value", "QG": "value", "QM": "value",
}


class EbbError(InkarmError):
    """The EBB refused a command (``!`` error), did not answer in time, answered what it
    should not, or the port went away. ``command``: the command text; ``reply``: the
    firmware's line (empty when none); ``kind``: refused, timeout, unexpected, disconnected."""

    def __init__(self, message: str, *, command: str = "", reply: str = "",
                 kind: str = "refused", port: str | None = None):
        super().__init__(message, key="--port" if port else None,
                         value=port if port else InkarmError.NO_VALUE)
        self.command, self.reply, self.kind = command, reply, kind


def _int(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{name}: expected an integer, got {value!r}", key=name, value=value)
    if not low <= value <= high:
        raise InputError(f"{name}: expected an integer in {low}..{high} (EBB firmware), got "
                         f"{value}", key=name, value=value)
    return value


def command(name: str, *args: int | str) -> str:
    """``NAME,arg,...`` with its ``\\r``; refused when longer than the firmware takes."""
    text = ",".join([name, *(str(a) for a in args)]) + "\r"
    if len(text) > MAX_COMMAND:
        raise InputError(f"{text.strip()!r}: an EBB command has at most {MAX_COMMAND} "
                         f"characters (CR included), this one {len(text)}", key=name)
    return text


def check_rate(name: str, steps: int, duration_ms: int) -> None:
    """A moving axis steps at MIN_STEP_RATE..MAX_STEP_RATE steps/s (SM's check)."""
    if steps == 0:
        return
    rate = abs(steps) * 1000.0 / duration_ms
    if not MIN_STEP_RATE <= rate <= MAX_STEP_RATE:
        raise InputError(f"{name}: {steps} steps in {duration_ms} ms is {rate:.6g} steps/s; the "
                         f"EBB steps an axis at {MIN_STEP_RATE:g}..{MAX_STEP_RATE:g} steps/s",
                         key=name, value=steps)


def sm(duration_ms: int, steps1: int, steps2: int = 0) -> str:
    """``SM``: a straight move at constant speed (both steps 0: a delay) [ms, steps]."""
    _int("SM duration_ms", duration_ms, 1, MAX_DURATION_MS)
    _int("SM steps1", steps1, -MAX_STEPS, MAX_STEPS)
    _int("SM steps2", steps2, -MAX_STEPS, MAX_STEPS)
    if steps1 == 0 and steps2 == 0 and duration_ms > MAX_DELAY_MS:
        raise InputError(f"SM duration_ms: a delay (no steps) of at most {MAX_DELAY_MS} ms "
                         f"(firmware 3 caps it there), got {duration_ms}",
                         key="SM duration_ms", value=duration_ms)
    check_rate("SM steps1", steps1, duration_ms)
    check_rate("SM steps2", steps2, duration_ms)
    return command("SM", duration_ms, steps1, steps2)


def xm(duration_ms: int, steps_a: int, steps_b: int) -> str:
    """``XM``: SM on the mixed axes (steps1 = A + B, steps2 = A - B, checked as SM's)."""
    _int("XM duration_ms", duration_ms, 1, MAX_DURATION_MS)
    _int("XM steps_a", steps_a, -MAX_STEPS, MAX_STEPS)
    _int("XM steps_b", steps_b, -MAX_STEPS, MAX_STEPS)
    for name, steps in (("XM axis 1", steps_a + steps_b), ("XM axis 2", steps_a - steps_b)):
        _int(name, steps, -MAX_STEPS, MAX_STEPS)
        check_rate(name, steps, duration_ms)
    return command("XM", duration_ms, steps_a, steps_b)


def lm(rate1: int, steps1: int, accel1: int, rate2: int, steps2: int, accel2: int,
       clear: int | None = None) -> str:
    """``LM``: a low-level move with per-axis rate and acceleration (v2.7.0); some axis must
    be able to move."""
    for name, v, lo, hi in (("LM rate1", rate1, 0, INT31), ("LM rate2", rate2, 0, INT31),
                            ("LM steps1", steps1, INT32_MIN, INT32_MAX),
                            ("LM steps2", steps2, INT32_MIN, INT32_MAX),
                            ("LM accel1", accel1, INT32_MIN, INT32_MAX),
                            ("LM accel2", accel2, INT32_MIN, INT32_MAX)):
        _int(name, v, lo, hi)
    if not any(s != 0 and (r != 0 or a != 0)
               for s, r, a in ((steps1, rate1, accel1), (steps2, rate2, accel2))):
        raise InputError("LM: no axis can move (steps and a rate or acceleration needed on one "
                         "axis)", key="LM")
    args = [rate1, steps1, accel1, rate2, steps2, accel2]
    if clear is not None:
        args.append(_int("LM clear", clear, 0, 3))
    return command("LM", *args)


def sp(up: bool, duration_ms: int = 0, pin: int | None = None) -> str:
    """``SP``: pen up (servo_min) or down (servo_max), then wait ``duration_ms`` before the
    next queued command (0: omitted)."""
    args: list[int] = [1 if up else 0]
    if duration_ms or pin is not None:
        args.append(_int("SP duration_ms", duration_ms, 1, 65535))
    if pin is not None:
        args.append(_int("SP pin", pin, 0, 7))
    return command("SP", *args)


def tp(duration_ms: int = 0) -> str:
    """``TP``: toggle the pen, then wait ``duration_ms`` (0: omitted)."""
    if duration_ms:
        return command("TP", _int("TP duration_ms", duration_ms, 1, 65535))
    return command("TP")


def sc(param: int, value: int) -> str:
    """``SC``: a configuration value (4/5: pen-up/down positions 1..65535)."""
    _int("SC param", param, 0, 255)
    _int(f"SC,{param} value", value, 1 if param in (4, 5) else 0, 65535)
    return command("SC", param, value)


def em(enable1: int, enable2: int | None = None) -> str:
    """``EM``: 0 disables a motor, 1..5 enables it (enable1 sets the step mode: 1 = 1/16)."""
    args = [_int("EM enable1", enable1, 0, 5)]
    if enable2 is not None:
        args.append(_int("EM enable2", enable2, 0, 5))
    return command("EM", *args)


def hm(rate: int, position1: int | None = None, position2: int | None = None) -> str:
    """``HM``: move to home, or to (position1, position2) steps from home, at ``rate``
    steps/s (v2.6.2; positions v2.7.0)."""
    _int("HM rate", rate, 2, 25000)
    if (position1 is None) != (position2 is None):
        raise InputError("HM: give both positions or neither", key="HM")
    if position1 is None:
        return command("HM", rate)
    _int("HM position1", position1, -MAX_HM_POSITION, MAX_HM_POSITION)
    _int("HM position2", position2, -MAX_HM_POSITION, MAX_HM_POSITION)
    return command("HM", rate, position1, position2)


def sr(timeout_ms: int, state: int | None = None) -> str:
    """``SR``: servo power timeout [ms] (0: never off), and optionally power now (v2.6.0)."""
    args = [_int("SR timeout_ms", timeout_ms, 0, 2**32 - 1)]
    if state is not None:
        args.append(_int("SR state", state, 0, 1))
    return command("SR", *args)


def simple(name: str) -> str:
    """A command without arguments: QS, QP, QM, QB, QG, V, R, CS, ES."""
    if name not in ("QS", "QP", "QM", "QB", "QG", "V", "R", "CS", "ES"):
        raise InputError(f"{name!r} is not an argument-free EBB command", key="command")
    return command(name)


def name_of(text: str) -> str:
    """The command's name (``SM`` of ``SM,10,1,2\\r``), upper-cased."""
    return text.strip().split(",")[0].upper()


def reply_shape(text: str) -> str:
    """What the command answers (see :data:`REPLIES`); unknown ones are taken as OK."""
    return REPLIES.get(name_of(text), "ok")


def split_lines(buffer: bytes) -> tuple[list[str], bytes]:
    """The complete lines in ``buffer`` (split on CR or LF, blank ones dropped) and the rest."""
    parts = re.split(rb"[\r\n]", buffer)
    rest = parts.pop()
    return [p.decode("ascii", "replace").strip() for p in parts if p.strip()], rest


def is_error(line: str) -> bool:
    """Whether a reply line is a firmware error (``!...``)."""
    return line.startswith("!")


def parse_steps(line: str) -> tuple[int, int]:
    """``QS``'s ``steps1,steps2``."""
    try:
        a, b = line.split(",")
        return int(a), int(b)
    except ValueError:
        raise ValueError(f"expected 'steps1,steps2', got {line!r}") from None


def parse_pen_up(line: str) -> bool:
    """``QP``'s 1 (up) or 0 (down)."""
    if line not in ("0", "1"):
        raise ValueError(f"expected 0 or 1, got {line!r}")
    return line == "1"


@dataclass(frozen=True)
class Motors:
    """``QM``: a motion command executing; each motor moving; the FIFO not empty."""

    executing: bool
    motor1: bool
    motor2: bool
    fifo: bool

    @property
    def idle(self) -> bool:
        return not (self.executing or self.motor1 or self.motor2 or self.fifo)


def parse_motors(line: str) -> Motors:
    """``QM,command,motor1,motor2[,fifo]`` (the FIFO field since v2.4.4)."""
    parts = line.split(",")
    if parts[0] != "QM" or len(parts) not in (4, 5):
        raise ValueError(f"expected 'QM,c,m1,m2,f', got {line!r}")
    try:
        flags = [int(p) != 0 for p in parts[1:]] + [False]
    except ValueError:
        raise ValueError(f"expected 'QM,c,m1,m2,f', got {line!r}") from None
    return Motors(*flags[:4])


def parse_general(line: str) -> dict[str, bool]:
    """``QG``'s status byte (hex): RB5, RB2, PRG, PEN (down in the v2 edition, up in firmware
    3), CMD, MTR1, MTR2, FIFO."""
    try:
        byte = int(line, 16)
    except ValueError:
        raise ValueError(f"expected a hexadecimal status byte, got {line!r}") from None
    names = ("FIFO", "MTR2", "MTR1", "CMD", "PEN", "PRG", "RB2", "RB5")
    return {n: bool(byte >> i & 1) for i, n in enumerate(names)}


def parse_button(line: str) -> bool:
    """``QB``: whether the PRG button was pressed since the last query."""
    return parse_pen_up(line)


def parse_version(line: str) -> tuple[int, ...]:
    """The firmware version of a ``V`` reply (``... Firmware Version 2.4.2``)."""
    m = re.search(r"Firmware Version (\d+)\.(\d+)\.(\d+)", line)
    if not line.startswith("EBB") or m is None:
        raise ValueError(f"expected 'EBB... Firmware Version X.Y.Z', got {line!r}")
    return tuple(int(g) for g in m.groups())


def parse_stop(line: str) -> tuple[int, ...]:
    """``ES``: (interrupted, fifo1, fifo2, left1, left2), or (interrupted,) before v2.2.9."""
    try:
        values = tuple(int(v) for v in line.split(","))
    except ValueError:
        raise ValueError(f"expected 'interrupted[,fifo1,fifo2,left1,left2]', got {line!r}") \
            from None
    if len(values) not in (1, 5):
        raise ValueError(f"expected 1 or 5 numbers, got {line!r}")
    return values


__all__ = [
    "REPLIES",
    "EbbError",
    "Motors",
    "command",
    "em",
    "hm",
    "is_error",
    "lm",
    "name_of",
    "parse_button",
    "parse_general",
    "parse_motors",
    "parse_pen_up",
    "parse_steps",
    "parse_stop",
    "parse_version",
    "reply_shape",
    "sc",
    "simple",
    "sm",
    "sp",
    "split_lines",
    "sr",
    "tp",
    "xm",
]
