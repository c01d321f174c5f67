"""One EiBotBoard on a serial port: send a command, wait for its reply, with a deadline.

The EBB is a USB CDC device (the line speed is ignored; it enumerates as ``EiBotBoard``, USB
VID:PID 04D8:FD92: ``/dev/ttyACM0`` on Linux, ``/dev/cu.usbmodem...`` on macOS, ``COMn`` on
Windows). Flow control is the firmware's own: it answers a command once it has taken it, and
a motion command is taken only when its 1-deep FIFO has room, so the third queued move's
``OK`` waits for the first to end (EBB reference, ``QM``). So every command is answered
before the next is sent, and a reply is due ``due_s`` (the motion still ahead of it, which the
caller knows) plus :attr:`EbbBus.reply_timeout_s` after it was sent: later, the reply is taken
as lost and the command fails with :class:`EbbError` (``kind="timeout"``) naming it and the
time waited.

One driver per port: :mod:`inkarm.hardware.port_lock` is held from before the port opens until
:meth:`EbbBus.close`. On open the bus asks ``V`` (twice, as the AxiDraw software does: the
first answer may be lost to a stale buffer) and refuses anything that is not an EBB with
firmware :data:`MIN_FIRMWARE` or newer (``QS``/``CS`` 2.4.3, ``QM``'s FIFO field 2.4.4).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable

import serial

from inkarm.hardware.axidraw import ebb
from inkarm.hardware.axidraw.ebb import EbbError
from inkarm.hardware.port_lock import open_locked

MIN_FIRMWARE = (2, 4, 4)
REPLY_TIMEOUT_S = 2.0  # a reply later than this after it was due is lost [s, wall]


def version_text(version: tuple[int, ...]) -> str:
    return ".".join(str(v) for v in version)


class EbbBus:
    """An EBB on ``port`` (module docstring).

    Args:
        port: The serial port (or an emulator's pseudo-terminal).
        baudrate: [bit/s] (a USB CDC device ignores it).
        reply_timeout_s: How long after it was due a reply is waited for [s, wall]; None:
            :data:`REPLY_TIMEOUT_S`.
        clock: Where times come from [s].
    """

    def __init__(self, port: str, baudrate: int = 115200, *,
                 reply_timeout_s: float | None = None,
                 clock: Callable[[], float] = time.monotonic):
        self._lock, self.serial = open_locked(
            port, baudrate, lambda message: EbbError(message, kind="disconnected", port=port))
        self.port = port
        self.reply_timeout_s = float(REPLY_TIMEOUT_S if reply_timeout_s is None
                                     else reply_timeout_s)
        self.clock = clock
        self.version: tuple[int, ...] = ()
        self.version_line = ""
        self.sent_at = 0.0  # when the last command was written [s, clock]
        self.replied_at = 0.0  # when its reply was complete [s, clock]
        self.transcript: list[tuple[str, tuple[str, ...]]] = []  # (command, reply lines)
        self.keep_transcript = False
        self._rx = b""
        self._closed = False

    # -- connection ----------------------------------------------------------------------------

    def hello(self, minimum: tuple[int, ...] = MIN_FIRMWARE) -> tuple[int, ...]:
        """Ask ``V`` (twice if the first goes unanswered) and check the firmware version."""
        with contextlib.suppress(serial.SerialException, OSError):
            self.serial.reset_input_buffer()
        self._rx = b""
        line = ""
        for attempt in range(2):
            try:
                line = self.transact(ebb.simple("V"))[0]
                break
            except EbbError as e:
                if e.kind != "timeout" or attempt == 1:
                    raise
        try:
            version = ebb.parse_version(line)
        except ValueError:
            raise EbbError(f"{self.port} answered 'V' with {line!r}: not an EiBotBoard (expected "
                           "'EBB... Firmware Version X.Y.Z')", command="V", reply=line,
                           kind="unexpected", port=self.port) from None
        if version < minimum:
            raise EbbError(f"the EBB on {self.port} has firmware {version_text(version)}; "
                           f"inkarm needs {version_text(minimum)} or newer (QS, CS, QM); "
                           "update it with Evil Mad Scientist's firmware updater",
                           command="V", reply=line, kind="unexpected", port=self.port)
        self.version, self.version_line = version, line
        return version

    def close(self) -> None:
        """Close the port and release its lock (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            with contextlib.suppress(serial.SerialException, OSError):
                self.serial.close()
        finally:
            self._lock.close()

    # -- commands ------------------------------------------------------------------------------

    def transact(self, text: str, due_s: float = 0.0) -> list[str]:
        """Send one command (``text`` from :mod:`.ebb`) and wait for its whole reply; the value
        lines (none for a plain ``OK``). ``due_s``: how long [s, wall] the firmware may
        rightly take before answering (the motion ahead of a queued command).

        Raises:
            EbbError: ``!`` error (refused), no reply in time (timeout), a reply of the wrong
                form (unexpected), the port gone (disconnected).
        """
        shape = ebb.reply_shape(text)
        shown = text.strip()
        self._write(text, shown)
        self.sent_at = self.clock()
        deadline = self.sent_at + max(due_s, 0.0) + self.reply_timeout_s
        values: list[str] = []
        while True:
            for line in self._lines(shown, deadline, due_s):
                if ebb.is_error(line):
                    self._note(shown, values + [line])
                    self.drain()  # firmware 3's reference ends an error with OK; its code not
                    raise EbbError(f"the EBB refused {shown!r}: {line}", command=shown,
                                   reply=line, kind="refused", port=self.port)
                if shape == "value" or (shape == "value+ok" and not values):
                    values.append(line)
                elif line == "OK":
                    self.replied_at = self.clock()
                    self._note(shown, values)
                    return values
                else:
                    raise EbbError(f"the EBB answered {shown!r} with {line!r} (expected OK)",
                                   command=shown, reply=line, kind="unexpected", port=self.port)
                if shape == "value":
                    self.replied_at = self.clock()
                    self._note(shown, values)
                    return values

    def _note(self, shown: str, lines: list[str]) -> None:
        if self.keep_transcript:
            self.transcript.append((shown, tuple(lines)))

    def _write(self, text: str, shown: str) -> None:
        try:
            self.serial.write(text.encode("ascii"))
        except (serial.SerialException, OSError) as e:
            raise EbbError(f"the EBB disconnected while {shown!r} was sent ({e})", command=shown,
                           kind="disconnected", port=self.port) from None

    def _lines(self, shown: str, deadline: float, due_s: float) -> list[str]:
        """The next complete reply lines (blocking until there is one or the deadline)."""
        while True:
            lines, self._rx = ebb.split_lines(self._rx)
            if lines:
                return lines
            if self.clock() > deadline:
                raise EbbError(f"no reply to {shown!r} from {self.port} within "
                               f"{due_s + self.reply_timeout_s:.3g} s (the reply was lost or the "
                               "EBB stopped answering)", command=shown, kind="timeout",
                               port=self.port)
            try:
                chunk = self.serial.read(max(1, self.serial.in_waiting))
            except (serial.SerialException, OSError, TypeError) as e:
                raise EbbError(f"the EBB disconnected while waiting for the reply to {shown!r} "
                               f"({e})", command=shown, kind="disconnected",
                               port=self.port) from None
            self._rx += chunk

    def drain(self, quiet_s: float = 0.01) -> list[str]:
        """Read and drop what the device still sends until it has been quiet ``quiet_s``
        [s, wall] (a stray reply after a fault); the lines dropped."""
        dropped: list[str] = []
        end = self.clock() + quiet_s
        while self.clock() < end:
            try:
                chunk = self.serial.read(max(1, self.serial.in_waiting))
            except (serial.SerialException, OSError, TypeError):
                break
            if chunk:
                self._rx += chunk
                end = self.clock() + quiet_s
        lines, self._rx = ebb.split_lines(self._rx + b"\n")
        self._rx = b""
        return dropped + lines


__all__ = ["MIN_FIRMWARE", "REPLY_TIMEOUT_S", "EbbBus", "version_text"]
