"""A line-oriented device emulated on a pseudo-terminal (the GRBL plotter, the AxiDraw's EBB):
the plumbing both share, each adding only how it reads bytes and lines.

Two threads share the machine under one lock:

* the *receiver* reads the port (the master end of :func:`inkarm.hardware.pty.open_raw_pty`)
  and hands each chunk to :meth:`PtyDevice._received` (default: append to the receive buffer);
* the *main loop* wakes when bytes arrive (or every ``tick_s`` while busy, every
  :data:`IDLE_TICK_S` when idle with nothing received), runs :meth:`PtyDevice._tick` (the
  device's own: take lines, advance the machine against the clock) and writes the replies it
  returns. An exception there is a bug in the machine: the loop stops, the port closes and
  :meth:`PtyDevice.stop` re-raises it.

Machine time runs ``speedup`` times faster than the wall clock. Faults are injected by line
number (1-based); each device parses its own (:func:`parse_fault_text` does the shared part).
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, ClassVar, Self

from inkarm.errors import InputError
from inkarm.hardware.pty import close_quietly, open_raw_pty

MAX_REPLIES_KEPT = 10_000
IDLE_TICK_S = 0.02  # the main loop's wait when idle with nothing received [s]
MAX_SPEEDUP = 1000.0


def check_speedup(speedup: float) -> None:
    """Refuse a speed-up (machine seconds per wall-clock second) outside (0, 1000]."""
    if not 0 < speedup <= MAX_SPEEDUP:
        raise InputError(f"expected a speed-up in (0, 1000], got {speedup}", key="speedup",
                         value=speedup)


def parse_fault_text(text: str, kinds: tuple[str, ...], usage: str, codes: range,
                     coded: tuple[str, ...] | None = None,
                     line: str = "LINE") -> tuple[str, int, int | None]:
    """(kind, line number, code or None) of a ``--fault`` ``KIND:LINE[:CODE]``: KIND one of
    ``kinds`` (only those in ``coded`` may carry a CODE; None: all), LINE >= 1, CODE in
    ``codes``. ``usage`` says the accepted forms and ``line`` names LINE in the messages."""
    parts = text.split(":")
    if parts[0] not in kinds or not 2 <= len(parts) <= 3 or (
            len(parts) == 3 and parts[0] not in (coded or kinds)):
        raise InputError(f"expected {usage}, got {text!r}", key="--fault", value=text,
                         choices=kinds)
    try:
        numbers = [int(p) for p in parts[1:]]
    except ValueError:
        raise InputError(f"expected whole numbers in {text!r}", key="--fault",
                         value=text) from None
    if numbers[0] < 1 or (len(numbers) > 1 and numbers[1] not in codes):
        raise InputError(f"expected {line} >= 1 and CODE in {codes[0]}..{codes[-1]}, got "
                         f"{text!r}", key="--fault", value=text)
    return parts[0], numbers[0], numbers[1] if len(numbers) > 1 else None


@dataclass
class EmulatorStats:
    """What the emulator saw.

    Attributes:
        lines: Lines (commands) taken from the receive buffer.
        bytes_received: Bytes read from the port (real-time ones included).
        bytes_dropped: Bytes lost because the receive buffer was full.
        machine_time_s: Machine time now [s].
        first_line_s: Machine time when the first line was taken [s] (None before).
        idle_since_s: Machine time when it last became idle with nothing to do [s].
        replies: The last replies written back, in order (status reports excluded).
    """

    lines: int = 0
    bytes_received: int = 0
    bytes_dropped: int = 0
    machine_time_s: float = 0.0
    first_line_s: float | None = None
    idle_since_s: float = 0.0
    replies: deque[str] | None = None


class PtyDevice:
    """The shared life cycle of a line-oriented emulator (see the module docstring):
    :meth:`start` returns the port's path, :meth:`stop` closes it; a context manager.

    A subclass sets :attr:`NAME` (the threads' prefix), :attr:`LOOP` (its main loop, as the
    error of :meth:`stop` names it), :attr:`EOL` and :attr:`ENCODING` (how its replies are
    written) and implements :meth:`_tick`; ``machine`` has ``idle``, ``time`` and ``outbox``.
    """

    NAME: ClassVar[str] = "pty"
    LOOP: ClassVar[str] = "the emulator's main loop"
    EOL: ClassVar[str] = ""
    ENCODING: ClassVar[str] = "ascii"
    Stats: ClassVar[type[EmulatorStats]] = EmulatorStats

    def __init__(self, machine: Any, canvas, faults, speedup: float, tick_s: float) -> None:
        self.machine = machine
        self.canvas = canvas
        self.faults = {f.line: f for f in faults}
        self.speedup = float(speedup)
        self.tick_s = tick_s
        self.stats = self.Stats(replies=deque(maxlen=MAX_REPLIES_KEPT))
        self._rx = bytearray()
        self._line = bytearray()
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
        self._threads = [
            threading.Thread(target=self._receive, name=f"{self.NAME}-rx", daemon=True),
            threading.Thread(target=self._loop, name=f"{self.NAME}-main", daemon=True)]
        for t in self._threads:
            t.start()
        return self.port

    @property
    def running(self) -> bool:
        return not self._stop.is_set()

    def stop(self) -> None:
        """Stop both threads and close the port (idempotent); the pen is lifted (a stroke in
        progress ends). Raises the error that stopped the main loop, if one did (a bug in the
        machine)."""
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
            raise RuntimeError(f"{self.LOOP} failed: {error!r}") from error

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def _quiet(self) -> bool:
        """The machine is idle and nothing received waits (call under the lock)."""
        return self.machine.idle and not self._rx and not self._line

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Wait until the machine is idle with an empty receive buffer; False on timeout."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self._lock:
                if self._quiet():
                    return True
            time.sleep(0.005)
        return False

    def _disconnect(self) -> None:
        """Stop and close the port: the host sees it vanish."""
        self._stop.set()
        close_quietly(self._master)
        self._master = -1

    # -- the receiver ----------------------------------------------------------------------------

    def _receive(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                data = os.read(self._master, 4096)
            except (OSError, ValueError):  # closed (a disconnect, a stop)
                return
            if not data:
                continue
            with self._lock:
                self.stats.bytes_received += len(data)
                self._received(data)
            self._wake.set()

    def _received(self, data: bytes) -> None:
        """Take bytes read from the port (under the lock)."""
        self._rx += data

    # -- the main loop ---------------------------------------------------------------------------

    def _machine_now(self) -> float:
        return self.speedup * (time.monotonic() - self._wall0)

    def _loop(self) -> None:
        machine = self.machine
        while not self._stop.is_set():
            # Idle and nothing received: wake less often (a byte arriving wakes it at once).
            self._wake.wait(IDLE_TICK_S if self._quiet() else self.tick_s)
            self._wake.clear()
            try:
                with self._lock:
                    out = self._tick(machine)
            except Exception as error:  # noqa: BLE001 - a machine bug: stop, re-raised by stop()
                self.error = error
                self._disconnect()
                return
            if out and not self._write(out):
                return

    def _tick(self, machine) -> list[str]:
        """Run the machine up to now and take what it can; the replies to write (under the
        lock)."""
        raise NotImplementedError

    def _taken(self, machine) -> Any:
        """Count a line taken; the fault injected at it, if any."""
        self.stats.lines += 1
        if self.stats.first_line_s is None:
            self.stats.first_line_s = machine.time
        return self.faults.get(self.stats.lines)

    def _replies(self, machine, was_idle: bool) -> list[str]:
        """Note the machine's time (and when it became idle) and take its replies."""
        if machine.idle and not was_idle:
            self.stats.idle_since_s = machine.time
        self.stats.machine_time_s = machine.time
        out = list(machine.outbox)
        machine.outbox.clear()
        self.stats.replies.extend(out)
        return out

    def _write(self, replies: list[str]) -> bool:
        data = "".join(reply + self.EOL for reply in replies).encode(self.ENCODING)
        try:
            while data and not self._stop.is_set():
                _, ready, _ = select.select([], [self._master], [], 0.05)
                if ready:
                    data = data[os.write(self._master, data):]
        except (OSError, ValueError):
            return False
        return True


__all__ = ["IDLE_TICK_S", "MAX_REPLIES_KEPT", "EmulatorStats", "PtyDevice", "check_speedup",
           "parse_fault_text"]
