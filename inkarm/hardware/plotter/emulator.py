"""A GRBL 1.1 pen plotter on a pseudo-terminal: connect any serial client (pyserial, a G-code
sender) to the slave path it prints.

Two threads share the machine (:class:`inkarm.hardware.plotter.machine.GrblMachine`):

* the *receiver* reads the port as GRBL's serial interrupt does: real-time bytes (``?``
  status, ``!`` feed hold, ``~`` resume, 0x18 soft reset, and 0x80-0xFF: 0x85 jog cancel,
  0x90-0x9D the feed, rapid and spindle overrides, 0x9E the spindle stop in a hold, which
  lifts a servo pen, 0xA0 the flood toggle; the rest are dropped) are acted on at once and
  never buffered; every other byte goes into a 128-byte receive buffer, and a byte
  that finds it full is lost without a word (:attr:`EmulatorStats.bytes_dropped` counts them);
* the *protocol loop* takes characters out of the buffer into its line only when the machine
  can take a line (``\n`` and ``\r`` each end one, and an empty line is answered ``ok``, as
  GRBL does: send ``\n`` alone) (not while the planner is full or a dwell or pen change is pending), runs
  the machine against the clock, and writes replies.

Machine time runs ``speedup`` times faster than the wall clock; the buffers, the sender's round
trips and the real-time latency stay wall-clock things, so a sender that does not count
characters still overflows the buffer at any speed-up.

Faults on command (:class:`Fault`): an ``error:N`` reply to the k-th line, an ``ALARM:N`` when
the k-th line arrives (motion stopped, pen up, G-code locked out until ``$X``), or the port
closing (a disconnect) at the k-th line.
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Self

from inkarm.errors import InputError
from inkarm.hardware.plotter.machine import GrblMachine, PenConfig
from inkarm.hardware.plotter.realtime import OVERRIDE_BYTES
from inkarm.hardware.plotter.reports import RX_BYTES
from inkarm.hardware.pty import close_quietly, open_raw_pty

RX_BUFFER = RX_BYTES  # GRBL 1.1's serial receive buffer [bytes]
MAX_REPLIES_KEPT = 10_000
IDLE_TICK_S = 0.02
REALTIME = {ord("?"), ord("!"), ord("~"), 0x18}
SPINDLE_STOP = 0x9E  # GRBL 1.1's spindle-stop override (extended real-time byte)
JOG_CANCEL = 0x85
FAULT_KINDS = ("error", "alarm", "disconnect")
DEFAULT_CODES = {"error": 20, "alarm": 1, "disconnect": 0}


@dataclass(frozen=True)
class Fault:
    """A fault the emulator injects when the ``line``-th line (1-based) arrives."""

    kind: str
    line: int
    code: int = 0


def parse_fault(text: str) -> Fault:
    """``error:LINE[:CODE]``, ``alarm:LINE[:CODE]`` or ``disconnect:LINE``."""
    parts = text.split(":")
    if parts[0] not in FAULT_KINDS or not 2 <= len(parts) <= 3:
        raise InputError(f"expected KIND:LINE[:CODE] with KIND one of {', '.join(FAULT_KINDS)}, "
                         f"got {text!r}", key="--fault", value=text, choices=FAULT_KINDS)
    try:
        numbers = [int(p) for p in parts[1:]]
    except ValueError:
        raise InputError(f"expected whole numbers in {text!r}", key="--fault",
                         value=text) from None
    if numbers[0] < 1 or (len(numbers) > 1 and not 1 <= numbers[1] <= 255):
        raise InputError(f"expected LINE >= 1 and CODE in 1..255, got {text!r}", key="--fault",
                         value=text)
    code = numbers[1] if len(numbers) > 1 else DEFAULT_CODES[parts[0]]
    return Fault(parts[0], numbers[0], code)


@dataclass(frozen=True)
class EmulatorConfig:
    """The emulated plotter.

    Attributes:
        speedup: Machine seconds per wall-clock second.
        settings: ``$`` settings over the machine's defaults.
        pen: The pen servo (or Z pen).
        tick_s: Longest wall-clock wait of the protocol loop [s].
    """

    speedup: float = 1.0
    settings: tuple[tuple[int, float], ...] = ()
    pen: PenConfig = field(default_factory=PenConfig)
    tick_s: float = 0.001

    def __post_init__(self) -> None:
        if not 0 < self.speedup <= 1000:
            raise InputError(f"expected a speed-up in (0, 1000], got {self.speedup}",
                             key="speedup", value=self.speedup)


@dataclass
class EmulatorStats:
    """What the emulator saw.

    Attributes:
        lines: Lines taken from the receive buffer.
        bytes_received: Bytes read from the port (real-time ones included).
        bytes_dropped: Bytes lost because the receive buffer was full.
        machine_time_s: Machine time now [s].
        first_line_s: Machine time when the first line was taken [s] (None before).
        idle_since_s: Machine time when it last became idle with nothing to do [s].
        replies: The last lines written back, in order (status reports excluded).
    """

    lines: int = 0
    bytes_received: int = 0
    bytes_dropped: int = 0
    machine_time_s: float = 0.0
    first_line_s: float | None = None
    idle_since_s: float = 0.0
    replies: deque[str] | None = None


class GrblEmulator:
    """A GRBL 1.1 on a pseudo-terminal (see the module docstring); :meth:`start` returns the
    port's path, :meth:`stop` closes it. Usable as a context manager."""

    def __init__(self, config: EmulatorConfig | None = None, canvas=None,
                 faults: list[Fault] | tuple[Fault, ...] = ()):
        self.config = config or EmulatorConfig()
        self.machine = GrblMachine(dict(self.config.settings), self.config.pen, canvas=canvas)
        self.canvas = canvas
        self.faults = {f.line: f for f in faults}
        self.stats = EmulatorStats(replies=deque(maxlen=MAX_REPLIES_KEPT))
        self._rx = bytearray()
        self._line = bytearray()
        self._realtime: list[int] = []
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
        self._threads = [threading.Thread(target=self._receive, name="grbl-rx", daemon=True),
                         threading.Thread(target=self._protocol, name="grbl-main", daemon=True)]
        for t in self._threads:
            t.start()
        return self.port

    @property
    def running(self) -> bool:
        return not self._stop.is_set()

    def stop(self) -> None:
        """Stop both threads and close the port (idempotent); the pen is lifted. Raises the
        error that stopped the protocol loop, if one did (a bug in the machine)."""
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
            raise RuntimeError(f"the GRBL emulator's protocol loop failed: {error!r}") from error

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Wait until the machine is idle with an empty receive buffer; False on timeout."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self._lock:
                if self.machine.idle and not self._rx and not self._line:
                    return True
            time.sleep(0.005)
        return False

    # -- the receiver (GRBL's serial interrupt) --------------------------------------------------

    def _receive(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                data = os.read(self._master, 4096)
            except OSError:
                return
            if not data:
                continue
            with self._lock:
                self.stats.bytes_received += len(data)
                for byte in data:
                    if byte in REALTIME or byte >= 0x80:
                        self._realtime.append(byte)
                    elif len(self._rx) < RX_BUFFER:
                        self._rx.append(byte)
                    else:
                        self.stats.bytes_dropped += 1
            self._wake.set()

    # -- the protocol loop (GRBL's main loop) ----------------------------------------------------

    def _machine_now(self) -> float:
        return self.config.speedup * (time.monotonic() - self._wall0)

    def _protocol(self) -> None:
        machine = self.machine
        while not self._stop.is_set():
            # Idle and nothing received: wake less often (a byte arriving wakes it at once).
            busy = not machine.idle or self._rx or self._line
            self._wake.wait(self.config.tick_s if busy else IDLE_TICK_S)
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

    def _tick(self, machine: GrblMachine) -> list[str]:
        out: list[str] = []
        for byte in self._realtime:
            if byte == ord("?"):
                report = machine.status_report(RX_BUFFER - len(self._rx))
                if report is not None:
                    out.append(report)
            elif byte == ord("!"):
                machine.feed_hold()
            elif byte == ord("~"):
                machine.cycle_start()
            elif byte == SPINDLE_STOP:
                machine.toggle_spindle_stop()
            elif byte == JOG_CANCEL:
                machine.jog_cancel_byte()
            elif byte in OVERRIDE_BYTES:
                machine.override(byte)
            elif byte == 0x18:
                machine.soft_reset()
                self._rx.clear()
                self._line.clear()
        self._realtime.clear()
        was_idle = machine.idle
        self._take_lines(machine, out)
        now = self._machine_now()
        machine.streaming = bool(self._rx)
        if now > machine.time:
            machine.advance(now - machine.time)
        machine.pump()
        self._take_lines(machine, out)
        if machine.idle and not was_idle:
            self.stats.idle_since_s = machine.time
        self.stats.machine_time_s = machine.time
        if machine.outbox:
            self.stats.replies.extend(machine.outbox)
            out.extend(machine.outbox)
            machine.outbox.clear()
        return out

    def _take_lines(self, machine: GrblMachine, out: list[str]) -> None:
        while machine.accepts_line() and self._rx and not self._stop.is_set():
            newline = next((i for i, b in enumerate(self._rx) if b in (0x0A, 0x0D)), -1)
            if newline < 0:  # move what there is into the line buffer, as GRBL reads chars
                self._line += self._rx
                self._rx.clear()
                return
            self._line += self._rx[:newline]
            del self._rx[: newline + 1]
            text = self._line.decode("ascii", "replace")
            self._line.clear()
            self._line_received(machine, text)
            machine.pump()

    def _line_received(self, machine: GrblMachine, text: str) -> None:
        self.stats.lines += 1
        if self.stats.first_line_s is None:
            self.stats.first_line_s = machine.time
        fault = self.faults.get(self.stats.lines)
        if fault is None:
            machine.take_line(text)
            return
        machine.lines_done += 1
        if fault.kind == "error":
            machine.outbox.append(f"error:{fault.code}")
        elif fault.kind == "alarm":
            machine.raise_alarm(fault.code)
        else:
            self._stop.set()
            close_quietly(self._master)
            self._master = -1

    def _write(self, lines: list[str]) -> bool:
        data = "".join(f"{line}\r\n" for line in lines).encode("ascii")
        try:
            while data and not self._stop.is_set():
                _, ready, _ = select.select([], [self._master], [], 0.05)
                if ready:
                    data = data[os.write(self._master, data):]
        except (OSError, ValueError):
            return False
        return True


__all__ = ["RX_BUFFER", "EmulatorConfig", "EmulatorStats", "Fault", "GrblEmulator",
           "parse_fault"]
