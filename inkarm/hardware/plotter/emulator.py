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

from dataclasses import dataclass, field

from inkarm.hardware.plotter.machine import GrblMachine, PenConfig
from inkarm.hardware.plotter.realtime import OVERRIDE_BYTES
from inkarm.hardware.plotter.reports import RX_BYTES
from inkarm.hardware.pty_device import EmulatorStats, PtyDevice, check_speedup, parse_fault_text

RX_BUFFER = RX_BYTES  # GRBL 1.1's serial receive buffer [bytes]
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
    kind, line, code = parse_fault_text(
        text, FAULT_KINDS, f"KIND:LINE[:CODE] with KIND one of {', '.join(FAULT_KINDS)}",
        range(1, 256))
    return Fault(kind, line, DEFAULT_CODES[kind] if code is None else code)


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
        check_speedup(self.speedup)


class GrblEmulator(PtyDevice):
    """A GRBL 1.1 on a pseudo-terminal (see the module docstring); :meth:`start` returns the
    port's path, :meth:`stop` closes it. Usable as a context manager."""

    NAME = "grbl"
    LOOP = "the GRBL emulator's protocol loop"
    EOL = "\r\n"
    machine: GrblMachine

    def __init__(self, config: EmulatorConfig | None = None, canvas=None,
                 faults: list[Fault] | tuple[Fault, ...] = ()):
        self.config = config or EmulatorConfig()
        super().__init__(GrblMachine(dict(self.config.settings), self.config.pen, canvas=canvas),
                         canvas, faults, self.config.speedup, self.config.tick_s)
        self._realtime: list[int] = []

    # -- the receiver (GRBL's serial interrupt) --------------------------------------------------

    def _received(self, data: bytes) -> None:
        for byte in data:
            if byte in REALTIME or byte >= 0x80:
                self._realtime.append(byte)
            elif len(self._rx) < RX_BUFFER:
                self._rx.append(byte)
            else:
                self.stats.bytes_dropped += 1

    # -- the protocol loop (GRBL's main loop) ----------------------------------------------------

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
        out.extend(self._replies(machine, was_idle))
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
        fault = self._taken(machine)
        if fault is None:
            machine.take_line(text)
            return
        machine.lines_done += 1
        if fault.kind == "error":
            machine.outbox.append(f"error:{fault.code}")
        elif fault.kind == "alarm":
            machine.raise_alarm(fault.code)
        else:
            self._disconnect()


__all__ = ["RX_BUFFER", "EmulatorConfig", "EmulatorStats", "Fault", "GrblEmulator",
           "parse_fault"]
