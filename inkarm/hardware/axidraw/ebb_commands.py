"""The EiBotBoard's commands, one handler each, as EBB firmware 3.0.3 runs them
(``app.X/source/ebb.c`` and ``UBW.c``, the ``parse_XX_packet`` functions; reference: the
command's section of ``docs/ebb.html``). A handler reads its parameters from a
:class:`~inkarm.hardware.axidraw.ebb_parse.Line`, acts on the machine and writes the reply; a
handler that must wait (the firmware spins while the FIFO is full; ``HM`` and ``CU,4`` until
all motion is done) is a generator that yields the predicate it waits for.

Reply shapes in legacy mode (the default), from the code: ``OK\\r\\n`` for commands; ``QS``,
``QE``, ``QP``, ``QR``, ``ES`` answer ``VALUE\\n\\rOK\\r\\n``; ``QB``, ``QC``, ``QL``, ``QN``,
``QT`` ``VALUE\\r\\nOK\\r\\n``; ``QG`` ``HH\\r\\n`` (two hex digits, no OK); ``QM``
``QM,C,M1,M2,F\\n\\r`` (no OK); ``V`` the version string and ``\\r\\n``; ``QU``
``QU,VALUE\\r\\nOK\\r\\n``. Quirks kept from the code: ``EM`` with one parameter answers nothing
and does nothing; ``XM``, ``HM``, ``LM``, ``LT``, ``L3``, ``T3`` say ``OK`` even after an
error (the error follows); ``QC`` does not zero-pad.

Not emulated (answered as the firmware would, without an effect): ``C``, ``O``, ``PD``, ``PO``,
``SE`` (the engraver), ``S2`` on pins other than B1, the limit switches (``CU,51..53``), the
power-lost and stepper-timeout settings (stored only); ``BL`` and ``RB`` answer nothing.
"""

from __future__ import annotations

from inkarm.hardware.axidraw import ebb_moves as mv
from inkarm.hardware.axidraw.ebb_motion import FIFO_MAX, Move
from inkarm.hardware.axidraw.ebb_parse import MISSING, OK, Line, unknown
from inkarm.hardware.axidraw.ebb_servo import PEN_RPN

VERSION = "EBBv13_and_above EB Firmware Version 3.0.3"
QC_VALUES = (394, 300)  # REF_RA0 and V+ ADC counts (the reference's QC example)


def dispatch(m, line: Line):
    """Run ``line`` on machine ``m``: None, or a generator while it waits."""
    handler = HANDLERS.get(line.name)
    if handler is None:
        unknown(line)
        return None
    if line.name in ECHO_FIRST:
        line.echo()  # print_command(FALSE, FALSE) before any parameter is read
    return handler(m, line)


# -- motion ----------------------------------------------------------------------------------


def sm(m, line: Line):
    duration = line.number("ulong")[1]
    s1 = line.number("long")[1]
    s2 = line.number("long", False)[1]
    clear = line.number("ulong", False)[1]
    if line.error:
        return
    move = mv.simple_move(m, line, duration, s1, s2, clear)
    if move is None:
        return
    yield from mv.queue(m, move)
    line.ending("ok")


def xm(m, line: Line):
    duration = line.number("ulong")[1]
    a = line.number("long")[1]
    b = line.number("long")[1]
    clear = line.number("ulong", False)[1]
    s1, s2 = mv._wrap(a + b), mv._wrap(a - b)
    move = mv.simple_move(m, line, duration, s1, s2, clear)
    if move is not None:
        yield from mv.queue(m, move)
    line.ending("ok")


def hm(m, line: Line):
    rate = line.number("ulong")[1]
    p1 = line.number("long", False)[1]
    p2 = line.number("long", False)[1]
    rate = min(max(rate, 1), 25_000)
    if not m.queue.idle:
        yield lambda: m.queue.idle
    c1, c2 = m.queue.counters
    move = mv.rate_move(m, rate, mv._wrap(p1 - c1), mv._wrap(p2 - c2))
    if move is not None:
        yield from mv.queue(m, move)
    line.ending("ok")


def _low_level(m, line: Line, timed: bool, jerk: bool):
    ticks = line.number("ulong")[1] if timed else 0
    values = []
    for _axis in (0, 1):
        rate = line.number("long")[1]
        steps = 0 if timed else line.number("long")[1]
        accel = line.number("long")[1]
        j = line.number("long")[1] if jerk else 0
        values.append((rate, steps, accel, j))
    clear = line.number("ulong", False)[1]
    if line.error:
        return
    (r1, s1, a1, j1), (r2, s2, a2, j2) = values
    if m.limit_checks:
        if timed and ticks == 0:
            line.set_error(6)
            return
        # (L3's check reads Jerk1 for both axes, as the firmware does)
        still1 = r1 == 0 and a1 == 0 and (not jerk or j1 == 0)
        still2 = r2 == 0 and a2 == 0 and (not jerk or j1 == 0)
        if not timed and (still1 or s1 == 0) and (still2 or s2 == 0):
            line.set_error(6)
            return
    move = mv.low_level_move(m, line, timed, ticks, (r1, r2), (s1, s2), (a1, a2), (j1, j2),
                             clear)
    if move is not None:
        yield from mv.queue(m, move)
    line.ending("ok")


def lm(m, line):
    return _low_level(m, line, timed=False, jerk=False)


def l3(m, line):
    return _low_level(m, line, timed=False, jerk=True)


def lt(m, line):
    return _low_level(m, line, timed=True, jerk=False)


def t3(m, line):
    return _low_level(m, line, timed=True, jerk=True)


def td(m, line: Line):
    """Two T3 moves: (Rate A, no acceleration, Jerk, Clear) then (Rate B, Accel, -Jerk, no
    clear) ("TD", ``parse_TD_packet``)."""
    ticks = line.number("ulong")[1]
    axes = [[line.number("long")[1] for _ in range(4)] for _axis in (0, 1)]
    clear = line.number("ulong", False)[1]
    if line.error:
        return
    if m.limit_checks and ticks == 0:
        line.set_error(6)
        return
    (ra1, rb1, a1, j1), (ra2, rb2, a2, j2) = axes
    for rates, accels, jerks, bits in (((ra1, ra2), (0, 0), (j1, j2), clear),
                                       ((rb1, rb2), (a1, a2), (-j1, -j2), 0)):
        move = mv.low_level_move(m, line, True, ticks, rates, (0, 0), accels, jerks, bits)
        if move is not None:
            yield from mv.queue(m, move)
    line.ending("ok")


def em(m, line: Line):
    status1, ea1 = line.number("uchar")
    if line.error or status1 != OK:
        return
    status2, ea2 = line.number("uchar", False)
    if line.error or status2 != OK:
        return  # (one parameter: no reply at all, as in the code)
    yield from mv.queue(m, Move("enable", payload=(ea1, ea2)))
    line.ending("ok")


def es(m, line: Line):
    line.echo(comma=True)
    disable = line.number("uchar", False)[1]
    if line.error:
        return
    interrupted = m.queue.stop()
    if disable == 1:
        m.enabled = [False, False]
    line.put(str(int(interrupted)))
    if not line.future:
        line.ending("rev")
    line.ending("ok")


def cs(m, line: Line):
    m.queue.clear_counters()
    line.ending("ok")


# -- pen -------------------------------------------------------------------------------------


def sp(m, line: Line):
    state = line.number("uchar")[1]
    duration = line.number("uint", False)[1]
    status, pin = line.number("uchar", False)
    if line.error:
        return
    pin = 1 if status != OK or pin > 7 else pin
    state = min(state, 3)
    if m.pen_rpn != pin + 3:
        m.pen_rpn = pin + 3
    yield from mv.pen_command(m, line, state, duration)
    line.ending("ok")


def tp(m, line: Line):
    duration = line.number("uint", False)[1]
    if line.error:
        return
    yield from mv.pen_command(m, line, 0 if m.pen_up else 1, duration)
    line.ending("ok")


def sc(m, line: Line):
    which = line.number("uchar")[1]
    value = line.number("uint")[1]
    if line.error:
        return
    servo = m.servo
    if which == 1:
        m.use_servo = value != 0
        yield from mv.pen_command(m, line, 1 if m.pen_up else 0, 0)
    elif which == 4:
        servo.up = value
    elif which == 5:
        servo.down = value
    elif which == 8:
        servo.slots = max(1, min(value, 8))
    elif which == 9:
        servo.slot_ms = max(1, min(value, 6))
    elif which in (10, 11):
        servo.rate_up = value
        if which == 10:
            servo.rate_down = value
    elif which == 12:
        servo.rate_down = value
    else:
        m.user[f"SC{which}"] = value
    line.ending("ok")


def s2(m, line: Line):
    position = line.number("uint", False)[1]
    pin = line.number("uchar", False)[1]
    rate = line.number("uint", False)[1]
    delay = line.number("uint", False)[1]
    line.echo()
    if line.error:
        return
    if pin > 24:
        line.set_error(6)
        return
    if position == 0:  # S2,0,pin: that output stops at once (not through the FIFO)
        if pin == PEN_RPN and m.use_servo:
            m.servo.enabled = False
            m.servo.value = m.servo.target = 0.0
    else:
        yield from mv.servo_move(m, position, pin, rate, delay, fifo=True)
    line.ending("ok")


def sr(m, line: Line):
    timeout = line.number("ulong")[1]
    status, state = line.number("uchar", False)
    if line.error:
        return
    m.servo.timeout_ms = timeout
    if status == OK:
        m.servo.set_power(bool(state), m.time)
    line.ending("ok")


# -- queries ---------------------------------------------------------------------------------


def _value(line: Line, text: str, ending: str) -> None:
    """The shape of most queries: echo, value, a legacy line ending, then OK."""
    line.echo(comma=True)
    line.put(text)
    if not line.future:
        line.ending(ending)
    line.ending("ok")


def qs(m, line):
    c1, c2 = m.queue.counters
    _value(line, f"{c1},{c2}", "rev")


def qp(m, line):
    _value(line, str(int(m.pen_up)), "rev")


def qr(m, line):
    _value(line, str(int(m.servo.powered)), "rev")


def qe(m, line):
    states = [m.microsteps if on else 0 for on in m.enabled]
    _value(line, f"{states[0]},{states[1]}", "rev")


def qb(m, line):
    _value(line, str(int(m.button)), "norm")
    m.button = False


def qc(m, line):
    _value(line, f"{QC_VALUES[0]},{QC_VALUES[1]}", "norm")


def qn(m, line):
    _value(line, str(m.node_count), "norm")


def qt(m, line):
    _value(line, m.tag, "norm")


def ql(m, line: Line):
    line.echo(comma=True)
    index = line.number("uchar", False)[1]
    if line.error:
        return
    line.put(str(m.variables[min(index, 31)]))
    if not line.future:
        line.ending("norm")
    line.ending("ok")


def qm(m, line: Line):
    line.echo(always=True, comma=True)
    line.put(",".join(str(v) for v in m.motion_status()))
    line.ending("rev")


def qg(m, line: Line):
    executing, motor1, motor2, fifo = m.motion_status()
    bits = (executing << 3) | (motor1 << 2) | (motor2 << 1) | fifo
    bits |= (int(m.pen_up) << 4) | (int(m.button) << 5)
    line.echo(comma=True)
    line.put(f"{bits:02X}")
    line.ending("norm")
    m.button = False


def qu(m, line: Line):
    line.echo(always=True, comma=True)
    which = line.number("uchar")[1]
    if line.error:
        return
    values = {1: "00", 2: str(FIFO_MAX), 3: str(m.queue.capacity), 4: "E00", 5: "E00",
              6: str(len(m.queue.fifo)), 60: str(m.user.get("CU60", 0)),
              61: str(m.user.get("CU61", 0)), 200: f"{m.queue.acc[0]},{m.queue.acc[1]}"}
    if which not in values:
        line.set_error(6)
        return
    line.put(values[which])
    line.ending("norm")
    line.ending("ok")


def v(m, line: Line):
    line.echo(comma=True)
    line.put(VERSION)
    line.ending("norm")


# -- configuration and bookkeeping -----------------------------------------------------------


def cu(m, line: Line):
    which = line.number("uint")[1]
    value = line.number("int")[1]
    if line.error:
        return
    flags = {1: "ack", 2: "limit_checks", 10: "future", 50: "auto_enable", 54: "checksums"}
    if which in flags or which == 3:
        if value not in (0, 1):
            line.set_error(6)
            return
        if which in flags:
            setattr(m, flags[which], bool(value))
            line.future, line.ack = m.future, m.ack  # (the ending below is printed after)
    elif which == 4:
        if not m.queue.idle:
            yield lambda: m.queue.idle
        m.queue.capacity = max(1, min(value, FIFO_MAX))
    else:
        m.user[f"CU{which}"] = value
    line.ending("ok")


def sl(m, line: Line):
    value = line.number("uchar")[1]
    index = line.number("uchar", False)[1]
    if line.error:
        return
    m.variables[min(index, 31)] = value
    line.ending("ok")


def sn(m, line: Line):
    status, value = line.number("ulong")
    if status == OK:
        m.node_count = value
    line.ending("ok")


def ni(m, line: Line):
    m.node_count = m.node_count + 1 if m.node_count < 0xFFFFFFFE else m.node_count
    line.ending("ok")


def nd(m, line: Line):
    m.node_count = max(m.node_count - 1, 0)
    line.ending("ok")


def st(m, line: Line):
    m.tag = line.string(16)
    line.ending("ok")


def r(m, line: Line):
    line.ending("ok")
    m.reset()


def silent(m, line: Line):
    """``RB`` and ``BL``: the board leaves the USB; nothing is answered."""
    line.pos = len(line.buf) - 1


def accepted(m, line: Line):
    """Commands whose effect is not modelled: parameters skipped, ``OK``."""
    line.pos = len(line.buf) - 1
    line.ending("ok")


def pi(m, line: Line):
    line.number("upper")
    line.number("uchar")
    if line.error:
        return
    line.echo(always=True, comma=True)
    line.put("1")
    line.ending("norm")


def se(m, line: Line):
    state = line.number("uchar")[1]
    power = line.number("uint", False)[1]
    status, use_queue = line.number("uchar", False)
    if line.error:
        return
    if status == OK and use_queue:
        yield from mv.queue(m, Move("engraver", payload=(min(state, 1), min(power, 1023))))
    line.ending("ok")


HANDLERS = {
    "SM": sm, "XM": xm, "HM": hm, "LM": lm, "L3": l3, "LT": lt, "T3": t3, "TD": td, "EM": em,
    "ES": es, "CS": cs, "SP": sp, "TP": tp, "SC": sc, "S2": s2, "SR": sr, "QS": qs, "QP": qp,
    "QR": qr, "QE": qe, "QB": qb, "QC": qc, "QN": qn, "QT": qt, "QL": ql, "QM": qm, "QG": qg,
    "QU": qu, "V": v, "CU": cu, "SL": sl, "SN": sn, "NI": ni, "ND": nd, "ST": st, "R": r,
    "RB": silent, "BL": silent, "C": accepted, "O": accepted, "PD": accepted, "PO": accepted,
    "PI": pi, "SE": se,
}

# commands whose handler starts with print_command(FALSE, FALSE) (queries echo with a comma)
ECHO_FIRST = {"SM", "XM", "HM", "LM", "L3", "LT", "T3", "TD", "EM", "CS", "SP", "TP", "SC", "SR",
              "CU", "SL", "SN", "NI", "ND", "ST", "R", "C", "O", "PD", "PO", "SE"}

__all__ = ["HANDLERS", "MISSING", "VERSION", "dispatch"]
