"""An AxiDraw (EiBotBoard firmware 3.0.3) on a pseudo-terminal: connect any serial client
(pyserial, the AxiDraw software) to the slave path it prints.

Two threads share the machine (:class:`inkarm.hardware.axidraw.ebb_machine.EbbMachine`):

* the *receiver* reads the port into a buffer. The EBB is a USB CDC device: when it cannot take
  more, the host waits (USB flow control), so nothing is ever lost;
* the *command loop* takes characters as the firmware's ``ProcessIO`` does (``\\r`` or ``\\n``
  ends a command, the second of a ``\\r\\n`` pair and empty lines are ignored, backspace
  removes a character and echoes `` \\b``, other control characters are dropped, a command
  longer than 255 characters is ``!3 Err: RX Buffer overrun``) and runs each command only when
  the parser is free: a motion command that finds the FIFO full holds the parser, and its
  ``OK`` comes once it is queued, as on the board. It advances the machine against the clock
  and writes the replies.

Machine time runs ``speedup`` times faster than the wall clock. :meth:`EbbEmulator.press_button`
presses the PRG (pause) button.

Faults on command (:class:`Fault`), counted in commands (1-based): ``drop`` (the command runs
but its reply is never sent), ``error`` (the command does not run; the reply is the firmware's
``!CODE`` error for it, as it would word it) and ``disconnect`` (the port closes when the
command arrives).
"""

from __future__ import annotations

from dataclasses import dataclass

from inkarm.errors import InputError
from inkarm.hardware import pty_device
from inkarm.hardware.axidraw.ebb_machine import EbbMachine, travel_mm
from inkarm.hardware.axidraw.ebb_parse import ERROR_TEXT, Line, checksum
from inkarm.hardware.pty_device import PtyDevice, check_speedup, parse_fault_text

RX_LIMIT = 255  # characters of one command (kRX_BUF_SIZE 256 with its terminator)
FAULT_KINDS = ("drop", "error", "disconnect")
A4_LANDSCAPE_MM = (297.0, 210.0)
A3_LANDSCAPE_MM = (420.0, 297.0)
PAGE_MM = {"V3": A4_LANDSCAPE_MM, "V3A3": A3_LANDSCAPE_MM}


@dataclass(frozen=True)
class Fault:
    """A fault injected when the ``line``-th command (1-based) arrives; ``code`` is the error
    number of an "error" fault (0-10, as the firmware's ``!N Err: ...`` messages)."""

    kind: str
    line: int
    code: int = 6

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise InputError(f"expected a fault kind in {', '.join(FAULT_KINDS)}, got "
                             f"{self.kind!r}", key="kind", value=self.kind, choices=FAULT_KINDS)
        if self.line < 1 or not 0 <= self.code <= 10:
            raise InputError(f"expected a command number >= 1 and a code in 0..10, got "
                             f"{self.line} and {self.code}", key="line", value=self.line)


def parse_fault(text: str) -> Fault:
    """``drop:K``, ``error:K[:CODE]`` or ``disconnect:K`` (K: the K-th command)."""
    kind, line, code = parse_fault_text(text, FAULT_KINDS,
                                        "drop:K, error:K[:CODE] or disconnect:K",
                                        range(11), coded=("error",), line="K")
    return Fault(kind, line, 6 if code is None else code)


def fault_reply(text: str, code: int, future: bool = False) -> str:
    """The firmware's error reply for ``code`` to the command ``text`` (legacy mode)."""
    line = Line(text or " ", future=future)
    if code == 8:
        codes = "".join(f"{ord(c) & 0xFF:02X}" for c in line.name)
        message = f"!8 Err: Unknown command '{line.name}:{codes}'"
    elif code == 5:
        message = f"!5 Err: Need comma next, found: '{line.buf[line.pos]}'"
    elif code == 9:
        message = f"!9 Err: Checksum incorrect, expected {checksum(text)}"
    elif code == 0:
        message = "!0 Err: <axis1> step rate too high\n\r"
    else:
        message = ERROR_TEXT.get(code, ERROR_TEXT[6])
    prefix = f"{line.name}," if future else ""
    return prefix + message + ("\n" if future else "\r\n")


@dataclass
class EmulatorStats(pty_device.EmulatorStats):
    """What the emulator saw: :class:`inkarm.hardware.pty_device.EmulatorStats` (``lines``
    counts commands, ``replies`` holds each command's whole reply, ``bytes_dropped`` stays 0:
    USB flow control holds the host back, nothing is lost), and

    Attributes:
        steps: Motor steps taken (both motors).
        frame_hits: Samples at which the carriage was held by the frame (lost steps).
    """

    steps: int = 0
    frame_hits: int = 0


class EbbEmulator(PtyDevice):
    """An AxiDraw's EiBotBoard on a pseudo-terminal (see the module docstring).

    Args:
        speedup: Machine seconds per wall-clock second.
        canvas: The ink canvas under the pen, in page [mm]; None: a sheet of the model's
            paper (A4 landscape for "V3", A3 landscape for "V3A3") at 10 px/mm.
        model: "V3" or "V3A3" (the travel).
        faults: Faults to inject (:class:`Fault`).
        sheet_origin_mm: Machine (x, y) of the sheet's upper-left corner [mm].
        contact_pct: Pen height [%] at which the pen touches the paper.
    """

    NAME = "ebb"
    LOOP = "the EBB emulator's command loop"
    ENCODING = "latin-1"
    Stats = EmulatorStats
    machine: EbbMachine
    stats: EmulatorStats

    def __init__(self, speedup: float = 1.0, canvas=None, model: str = "V3",
                 faults=(), sheet_origin_mm=(0.0, 0.0), contact_pct: float = 40.0,
                 tick_s: float = 0.001) -> None:
        check_speedup(speedup)
        travel_mm(model)
        if canvas is None:
            from inkarm.ink.canvas import Canvas

            canvas = Canvas(size_mm=PAGE_MM[model])
        self.model = model
        super().__init__(EbbMachine(model, canvas, sheet_origin_mm, contact_pct), canvas,
                         faults, speedup, tick_s)
        self._in_cr = False
        self._overrun = False

    close = PtyDevice.stop

    def press_button(self) -> None:
        """Press the EBB's PRG button (the AxiDraw's pause button): ``QB`` and ``QG`` bit 5
        report it until read."""
        with self._lock:
            self.machine.button = True

    # -- the command loop ------------------------------------------------------------------------

    def _tick(self, machine: EbbMachine) -> list[str]:
        was_idle = machine.idle
        # the clock first: bytes that arrived while the loop waited are commands of now, and a
        # command taken at the last tick's time would start early and read stale positions
        now = self._machine_now()
        if now > machine.time:
            machine.advance(now - machine.time)
        self._take_lines(machine)
        self.stats.steps = machine.queue.steps_taken
        self.stats.frame_hits = machine.frame_hits
        return self._replies(machine, was_idle)

    def _take_lines(self, machine: EbbMachine) -> None:
        i, rx = 0, self._rx
        while i < len(rx) and machine.accepts_line() and not self._stop.is_set():
            byte = rx[i]
            i += 1
            if byte in (0x0D, 0x0A):
                if self._in_cr:
                    continue
                self._in_cr = True
                text = self._line.decode("latin-1")
                self._line.clear()
                if self._overrun:
                    self._overrun = False
                    machine.outbox.append(ERROR_TEXT[3] + "\r\n")
                elif text:
                    self._command(machine, text)
            elif byte == 0x08:
                if self._line:
                    self._line.pop()
                    machine.outbox.append(" \b")
            elif byte >= 0x20:
                self._in_cr = False
                self._line.append(byte)
                if len(self._line) >= RX_LIMIT:
                    self._line.clear()
                    self._overrun = True
        del rx[:i]

    def _command(self, machine: EbbMachine, text: str) -> None:
        fault = self._taken(machine)
        if fault is None:
            machine.take_line(text)
        elif fault.kind == "drop":
            machine.take_line(text, reply=False)
        elif fault.kind == "error":
            machine.outbox.append(fault_reply(text, fault.code, machine.future))
        else:
            self._disconnect()


__all__ = ["EbbEmulator", "EmulatorStats", "Fault", "fault_reply", "parse_fault"]
