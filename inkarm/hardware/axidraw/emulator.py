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

import os
import select
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Self

from inkarm.errors import InputError
from inkarm.hardware.axidraw.ebb_machine import EbbMachine, travel_mm
from inkarm.hardware.axidraw.ebb_parse import ERROR_TEXT, Line, checksum
from inkarm.hardware.pty import close_quietly, open_raw_pty

RX_LIMIT = 255  # characters of one command (kRX_BUF_SIZE 256 with its terminator)
MAX_REPLIES_KEPT = 10_000
IDLE_TICK_S = 0.02
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
    parts = text.split(":")
    if parts[0] not in FAULT_KINDS or not 2 <= len(parts) <= 3 or (
            len(parts) == 3 and parts[0] != "error"):
        raise InputError(f"expected drop:K, error:K[:CODE] or disconnect:K, got {text!r}",
                         key="--fault", value=text, choices=FAULT_KINDS)
    try:
        numbers = [int(p) for p in parts[1:]]
    except ValueError:
        raise InputError(f"expected whole numbers in {text!r}", key="--fault",
                         value=text) from None
    if numbers[0] < 1 or (len(numbers) > 1 and not 0 <= numbers[1] <= 10):
        raise InputError(f"expected K >= 1 and CODE in 0..10, got {text!r}", key="--fault",
                         value=text)
    return Fault(parts[0], numbers[0], numbers[1] if len(numbers) > 1 else 6)


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
class EmulatorStats:
    """What the emulator saw.

    Attributes:
        lines: Commands taken.
        bytes_received: Bytes read from the port.
        bytes_dropped: Always 0: USB flow control holds the host back, nothing is lost (kept
            for parity with the GRBL emulator's stats).
        machine_time_s: Machine time now [s].
        first_line_s: Machine time when the first command was taken [s] (None before).
        idle_since_s: Machine time when it last became idle [s].
        replies: The last replies written, in order (each a command's whole reply).
        steps: Motor steps taken (both motors).
        frame_hits: Samples at which the carriage was held by the frame (lost steps).
    """

    lines: int = 0
    bytes_received: int = 0
    bytes_dropped: int = 0
    machine_time_s: float = 0.0
    first_line_s: float | None = None
    idle_since_s: float = 0.0
    replies: deque[str] | None = None
    steps: int = 0
    frame_hits: int = 0


class EbbEmulator:
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

    def __init__(self, speedup: float = 1.0, canvas=None, model: str = "V3",
                 faults=(), sheet_origin_mm=(0.0, 0.0), contact_pct: float = 40.0,
                 tick_s: float = 0.001) -> None:
        if not 0 < speedup <= 1000:
            raise InputError(f"expected a speed-up in (0, 1000], got {speedup}", key="speedup",
                             value=speedup)
        travel_mm(model)
        if canvas is None:
            from inkarm.ink.canvas import Canvas

            canvas = Canvas(size_mm=PAGE_MM[model])
        self.speedup = float(speedup)
        self.canvas = canvas
        self.model = model
        self.machine = EbbMachine(model, canvas, sheet_origin_mm, contact_pct)
        self.faults = {f.line: f for f in faults}
        self.stats = EmulatorStats(replies=deque(maxlen=MAX_REPLIES_KEPT))
        self.tick_s = tick_s
        self._rx = bytearray()
        self._line = bytearray()
        self._in_cr = False
        self._overrun = False
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._master = self._slave = -1
        self._threads: list[threading.Thread] = []
        self.port = ""
        self.error: Exception | None = None

    # -- life cycle ----------------------------------------------------------------------------

    def start(self) -> str:
        """Open the pseudo-terminal, start both threads, return the port path."""
        self._master, self._slave, self.port = open_raw_pty()
        self._wall0 = time.monotonic()
        self._threads = [threading.Thread(target=self._receive, name="ebb-rx", daemon=True),
                         threading.Thread(target=self._loop, name="ebb-main", daemon=True)]
        for t in self._threads:
            t.start()
        return self.port

    @property
    def running(self) -> bool:
        return not self._stop.is_set()

    def stop(self) -> None:
        """Stop both threads and close the port (idempotent); a stroke in progress ends.
        Raises the error that stopped the command loop, if one did (a bug in the machine)."""
        self._stop.set()
        self._wake.set()
        for t in self._threads:
            if t is not threading.current_thread():
                t.join(timeout=2.0)
        with self._lock:
            if self.canvas is not None and self.canvas.in_contact:
                self.canvas.lift()
        close_quietly(self._master, self._slave)
        self._master = self._slave = -1
        if self.error is not None:
            error, self.error = self.error, None
            raise RuntimeError(f"the EBB emulator's command loop failed: {error!r}") from error

    close = stop

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Wait until the machine is idle with nothing left to read; False on timeout."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self._lock:
                if self.machine.idle and not self._rx and not self._line:
                    return True
            time.sleep(0.005)
        return False

    def press_button(self) -> None:
        """Press the EBB's PRG button (the AxiDraw's pause button): ``QB`` and ``QG`` bit 5
        report it until read."""
        with self._lock:
            self.machine.button = True

    # -- the receiver ----------------------------------------------------------------------------

    def _receive(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                data = os.read(self._master, 4096)
            except (OSError, ValueError):
                return
            if not data:
                continue
            with self._lock:
                self.stats.bytes_received += len(data)
                self._rx += data
            self._wake.set()

    # -- the command loop ------------------------------------------------------------------------

    def _machine_now(self) -> float:
        return self.speedup * (time.monotonic() - self._wall0)

    def _loop(self) -> None:
        machine = self.machine
        while not self._stop.is_set():
            busy = not machine.idle or self._rx
            self._wake.wait(self.tick_s if busy else IDLE_TICK_S)
            self._wake.clear()
            try:
                with self._lock:
                    out = self._tick(machine)
            except Exception as error:  # noqa: BLE001 - a machine bug: stop, re-raised by stop()
                self.error = error
                self._stop.set()
                close_quietly(self._master)
                return
            if out and not self._write(out):
                return

    def _tick(self, machine: EbbMachine) -> list[str]:
        was_idle = machine.idle
        # the clock first: bytes that arrived while the loop waited are commands of now, and a
        # command taken at the last tick's time would start early and read stale positions
        now = self._machine_now()
        if now > machine.time:
            machine.advance(now - machine.time)
        self._take_lines(machine)
        if machine.idle and not was_idle:
            self.stats.idle_since_s = machine.time
        self.stats.machine_time_s = machine.time
        self.stats.steps = machine.queue.steps_taken
        self.stats.frame_hits = machine.frame_hits
        out = list(machine.outbox)
        machine.outbox.clear()
        self.stats.replies.extend(out)
        return out

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
        self.stats.lines += 1
        if self.stats.first_line_s is None:
            self.stats.first_line_s = machine.time
        fault = self.faults.get(self.stats.lines)
        if fault is None:
            machine.take_line(text)
        elif fault.kind == "drop":
            machine.take_line(text, reply=False)
        elif fault.kind == "error":
            machine.outbox.append(fault_reply(text, fault.code, machine.future))
        else:
            self._stop.set()
            close_quietly(self._master)
            self._master = -1

    def _write(self, replies: list[str]) -> bool:
        data = "".join(replies).encode("latin-1")
        try:
            while data and not self._stop.is_set():
                _, ready, _ = select.select([], [self._master], [], 0.05)
                if ready:
                    data = data[os.write(self._master, data):]
        except (OSError, ValueError):
            return False
        return True


__all__ = ["EbbEmulator", "EmulatorStats", "Fault", "fault_reply", "parse_fault"]
