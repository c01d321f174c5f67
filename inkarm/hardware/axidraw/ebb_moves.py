"""The EiBotBoard's FIFO entries built from commands' parameters, as EBB firmware 3.0.3 builds
them (``app.X/source/ebb.c``: ``process_simple_motor_move_fp`` for SM/XM,
``process_simple_rate_move_fp`` for HM, ``process_low_level_move`` for LM/LT/L3/T3,
``process_SP`` and ``RCServo2.c``'s ``RCServo2_Move`` for the pen). Functions that may have to
wait for FIFO room are generators (see :mod:`.ebb_commands`).

Facts: an SM/XM rate is ``int(float32(steps) * (float32(85899345.92) / float32(ms)))`` per
axis; above 2^31 (25 kHz) it is refused with ``!0 Err: <axisN> step rate too high`` and at 0
(under 1.164e-5 steps/s) with ``... too slow`` while limit checks are on (``CU,2``), else
clamped; a duration of 0 or a Clear above 3 is ``!6``; no steps is a delay capped at
100000 ms. Every move enables both drivers when it is parsed (``CU,50,1``, the default). HM's
primary axis runs at ``int(float32(Hz) * 85899.34592)``, the other in proportion (at least 1,
at most 2^31 - 1), accumulators not cleared. LM-type moves: a negative step count with a
positive rate flips rate, steps and acceleration (a negative rate too: ``!6``); the rate starts
at ``rate - accel/2 + jerk/6`` (C division), the acceleration at ``accel - jerk``; a Clear bit
zeroes the accumulator, or sets it to 2^31 - 1 when the move starts backwards.
"""

from __future__ import annotations

import numpy as np

from inkarm.hardware.axidraw.ebb_motion import ONE, TICKS_PER_MS, Move
from inkarm.hardware.axidraw.ebb_parse import PRINTED, Line

MAX_DELAY_MS = 100_000
F32 = np.float32


# -- shared pieces ---------------------------------------------------------------------------


def room(m):
    """What a command waits for when the FIFO is full."""
    return m.queue.has_room


def queue(m, move: Move):
    """Spin until the FIFO has room, then queue ``move`` (a generator step)."""
    if not m.queue.has_room():
        yield room(m)
    m.queue.push(move)


def _auto_enable(m) -> None:
    if m.auto_enable:
        m.enabled = [True, True]


def _rate_error(line: Line, axis: int, what: str) -> None:
    if line.future:
        line.put(",")
    line.put(f"!0 Err: <axis{axis}> step rate too {what}")
    line.ending("rev")
    line.set_error(PRINTED)


def simple_move(m, line: Line, duration: int, s1: int, s2: int, clear: int) -> Move | None:
    """``process_simple_motor_move_fp``: the FIFO entry of an SM/XM, or None after an error."""
    if m.limit_checks and (duration == 0 or clear > 3):
        line.set_error(6)
        return None
    if s1 == 0 and s2 == 0:
        return Move("delay", clear=clear & 0xFF,
                    delay_ticks=TICKS_PER_MS * min(duration, MAX_DELAY_MS))
    _auto_enable(m)
    per_step = F32(85899345.92) / F32(duration)
    rates = []
    for axis, steps in enumerate((abs(s1), abs(s2)), start=1):
        if steps == 0:
            rates.append(0)
            continue
        rate = int(F32(steps) * per_step)
        if rate > ONE:
            if m.limit_checks:
                _rate_error(line, axis, "high")
                return None
            rate = ONE
        if rate == 0:
            if m.limit_checks:
                _rate_error(line, axis, "slow")
                return None
            rate = 1
        rates.append(rate)
    return Move("steps", rate=(rates[0], rates[1]), steps=(abs(s1), abs(s2)),
                signs=(-1 if s1 < 0 else 1, -1 if s2 < 0 else 1), clear=clear & 0xFF)


def rate_move(m, rate_hz: int, s1: int, s2: int) -> Move | None:
    """``process_simple_rate_move_fp`` (HM): the primary axis at ``rate_hz`` steps/s, the other
    in proportion; None when there is nothing to move."""
    if s1 == 0 and s2 == 0:
        return None
    _auto_enable(m)
    a1, a2 = abs(s1), abs(s2)
    primary = int(F32(rate_hz) * F32(85899.34592))
    major, minor = (a1, a2) if a1 >= a2 else (a2, a1)
    second = 0
    if minor:
        value = F32(minor) * F32(rate_hz) / F32(major) * F32(85899.34592)
        second = 1 if value < 1 else (2147483647 if value > 2147483647 else int(value))
    rates = (primary, second) if a1 >= a2 else (second, primary)
    return Move("steps", rate=rates, steps=(a1, a2),
                signs=(-1 if s1 < 0 else 1, -1 if s2 < 0 else 1))


def _wrap(value: int) -> int:
    return ((value + ONE) % (1 << 32)) - ONE


def low_level_move(m, line: Line, timed: bool, ticks: int, rates, steps, accels, jerks,
                   clear: int) -> Move | None:
    """``process_low_level_move`` (LM, L3, LT, T3)."""
    rates, steps, accels = list(rates), list(steps), list(accels)
    clear = min(clear, 3)
    if not timed:
        for axis in (0, 1):
            if steps[axis] < 0:
                if rates[axis] < 0:
                    line.set_error(6)
                    return None
                steps[axis], rates[axis], accels[axis] = -steps[axis], -rates[axis], -accels[axis]
    bits = 0
    for axis in (0, 1):
        rates[axis] = _wrap(rates[axis] - int(accels[axis] / 2) + int(jerks[axis] / 6))
        if clear & (1 << axis):
            first = rates[axis] + accels[axis]
            negative = first < 0 or (first == 0 and ((accels[axis] + jerks[axis]) < 0 or (
                accels[axis] + jerks[axis] == 0 and jerks[axis] < 0)))
            bits |= (4 << axis) if negative else (1 << axis)
        accels[axis] = _wrap(accels[axis] - jerks[axis])
    _auto_enable(m)
    return Move("timed" if timed else "steps", rate=tuple(rates),
                steps=(ticks, 0) if timed else tuple(steps), accel=tuple(accels),
                jerk=tuple(jerks), signs=(0, 0), clear=bits)


def pen_command(m, line: Line, state: int, duration: int):
    """``process_SP``: state 0 down, 1 up (through the FIFO), 2 up now, 3 up now and make
    down = up (queued pen moves are re-aimed up)."""
    servo = m.servo
    if state == 0:
        position, rate, fifo = servo.down, servo.rate_down, True
    else:
        position, rate, fifo = servo.up, servo.rate_up, state == 1
    if state == 3:
        servo.down = servo.up
        for move in m.queue.fifo:
            if move.kind == "servo" and move.payload[2] == m.pen_rpn:
                move.payload = (servo.up, move.payload[1], move.payload[2])
    servo.power_on(m.time)
    yield from servo_move(m, position, m.pen_rpn, rate, duration, fifo)


def servo_move(m, position: int, rpn: int, rate: int, delay_ms: int, fifo: bool):
    """``RCServo2_Move``: queue a servo move, or start it now (then the pen reads up)."""
    if fifo:
        if not m.queue.has_room():
            yield room(m)
        if rpn == 4:
            m.servo.power_on(m.time)
        m.queue.push(Move("servo", delay_ticks=TICKS_PER_MS * delay_ms,
                          payload=(position, rate, rpn)))
        return
    if m.use_servo:
        if rpn == 4:
            m.servo.power_on(m.time)
        m.servo_now(position, rate, rpn)


__all__ = ["low_level_move", "pen_command", "queue", "rate_move", "servo_move", "simple_move"]
