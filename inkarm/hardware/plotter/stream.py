"""Streaming G-code to GRBL 1.1 on pyserial, with character counting.

GRBL answers every line with ``ok`` or ``error:N`` once it has taken the line out of its
128-byte receive buffer; a byte that arrives while the buffer is full is lost silently. So the
sender keeps the bytes of the lines not yet answered, newlines included, at or below 128:
each answer frees its line's bytes (GRBL's own ``stream.py`` and every serious sender do this).
Answers come in the order of the lines, so the oldest unanswered line is the one an
``error:N`` is about. Real-time bytes (``?``, ``!``, ``~``, 0x18) bypass the buffer and are
sent at any time; status is polled with ``?`` at most 5 times a second (GRBL's advice).

One driver per port: the advisory lock of :mod:`inkarm.hardware.port_lock` is taken before
the port opens and released when the streamer closes (and when opening fails); a second
driver on the port is refused at once naming the holder (two senders on one GRBL lose each
other's ``ok`` s: the second waited 240 s for answers the first one took).

The first ``error:N`` or ``ALARM:N`` stops the stream: nothing more is sent, and
:attr:`StreamState.failure` names the line number (1-based, counting the lines of the job).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import serial

from inkarm.errors import InkarmError
from inkarm.hardware.port_lock import open_locked

RX_BUFFER = 128
STATUS_PERIOD_S = 0.2  # at most 5 status reports a second
POLL_LOST_S = 1.0  # a "?" unanswered this long [s, wall] is taken as lost
REPORT_AFTER_POLL_S = 0.001  # latest stamp of a report after its poll [s, wall] (_answer)
STATUS_RETRY_S = 0.25  # :meth:`GrblStreamer.status` asks again after this long [s, wall]


class GrblError(InkarmError):
    """A GRBL device refused a line, raised an alarm, or stopped answering."""


@dataclass(frozen=True)
class StatusReport:
    """One ``<...>`` status report, as GRBL 1.1h's ``report_realtime_status`` (report.c) writes
    it: the state, one position (``MPos:`` or, with ``$10`` bit 0 clear, ``WPos:``), then
    optional fields. Which fields a report has depends on the firmware's cadence, not on the
    machine: ``Bf:`` only with ``$10`` bit 1; ``Ln:`` only for lines sent with ``N``;
    ``WCO:`` every 30th report while busy (10th idle); ``Ov:`` every 20th busy (10th idle) and on
    the report after a ``WCO:``, and ``A:`` *only with* ``Ov:`` (absent there when the spindle
    and coolant are off). A field a report lacks is None here, never "off".

    Attributes:
        time: When the device made it, on the streamer's clock [s] (see
            :meth:`GrblStreamer.pump`).
        state: Idle, Run, Hold:0, Alarm, Home, Check, ...
        mpos: Machine position (x, y, z) [mm or inch, per ``$13``]: as reported (``MPos:``), or
            ``WPos:`` plus the last work offset the streamer knows.
        feed: Current feed [mm/min]; spindle: the S value of ``FS:``.
        spindle_on: The ``A:S``/``A:C`` flag, False where the report has no ``A:``; trust it
            only where ``accessories`` is not None.
        planner_free: Free planner blocks (``Bf:``), when reported; rx_free: free bytes of the
            serial receive buffer (``Bf:``'s second number).
        wpos: Work position [mm]: as reported (``WPos:``) or ``mpos`` less the work offset.
        wco: The work coordinate offset this report carries (``WCO:``), else None.
        overrides: (feed, rapid, spindle) overrides [%] (``Ov:``), else None.
        accessories: The ``A:`` letters where the report has ``Ov:`` ("" = all off), else None.
        line: The line number of the block being executed (``Ln:``), else None.
        acked: Lines of the job answered ``ok`` before this report arrived.
    """

    time: float
    state: str
    mpos: tuple[float, float, float]
    feed: float = 0.0
    spindle: float = 0.0
    spindle_on: bool = False
    planner_free: int | None = None
    rx_free: int | None = None
    wpos: tuple[float, float, float] | None = None
    wco: tuple[float, float, float] | None = None
    overrides: tuple[int, int, int] | None = None
    accessories: str | None = None
    line: int | None = None
    acked: int = 0
    work: bool = False  # the report gave WPos, not MPos


def parse_status(text: str, t: float,
                 wco: tuple[float, float, float] | None = None) -> StatusReport | None:
    """A :class:`StatusReport` from ``<Idle|MPos:1.000,2.000,0.000|FS:0,0>``; None if the
    text is not one. ``wco`` is the last work offset known (for the position the report does
    not give); the report's own ``WCO:`` takes its place."""
    if not (text.startswith("<") and text.endswith(">")):
        return None
    fields = text[1:-1].split("|")
    values: dict = {"state": fields[0]}
    try:
        for f in fields[1:]:
            key, _, value = f.partition(":")
            numbers = value.split(",")
            if key in ("MPos", "WPos"):
                values["mpos" if key == "MPos" else "wpos"] = _xyz(numbers)
                values["work"] = key == "WPos"
            elif key == "FS":
                values["feed"], values["spindle"] = float(numbers[0]), float(numbers[1])
            elif key == "F":
                values["feed"] = float(numbers[0])
            elif key == "Bf":
                values["planner_free"], values["rx_free"] = int(numbers[0]), int(numbers[1])
            elif key == "WCO":
                values["wco"] = _xyz(numbers)
            elif key == "Ov":
                values["overrides"] = tuple(int(v) for v in numbers[:3])
                values.setdefault("accessories", "")
            elif key == "A":
                values["accessories"] = value
                values["spindle_on"] = "S" in value or "C" in value
            elif key == "Ln":
                values["line"] = int(numbers[0])
    except (ValueError, IndexError):
        return None
    if "mpos" not in values and "wpos" not in values:
        return None
    offset = values.get("wco") or wco or (0.0, 0.0, 0.0)
    if "mpos" in values:
        values["wpos"] = tuple(m - o for m, o in zip(values["mpos"], offset, strict=True))
    else:
        values["mpos"] = tuple(w + o for w, o in zip(values["wpos"], offset, strict=True))
    return StatusReport(time=t, **values)


def _xyz(numbers: list[str]) -> tuple[float, float, float]:
    v = [float(n) for n in numbers[:3]]
    if not v:
        raise ValueError("no coordinates")
    return (*v, *([0.0] * (3 - len(v))))[:3]


@dataclass
class StreamState:
    """Progress of a stream.

    Attributes:
        sent: Lines written so far; acked: lines answered ``ok``.
        ack_times: When each line's ``ok`` arrived, by line number [s, streamer clock].
        send_times: When each line was written, by line number [s, streamer clock].
        failure: Why the stream stopped early (``error:N`` / ``ALARM:N`` at line L, or a
            disconnect), empty while it is healthy.
        failed_line: The 1-based line the failure is about (0 when none).
        statuses: Status reports received, in order.
        messages: Other lines the device sent (``[MSG:...]``, banners).
        lost_polls: Status polls never answered (GRBL answers several ``?`` that arrive
            before its main loop looks with one report, and none during a reset).
        rx_overcounts: Reports whose ``Bf:`` showed more bytes in GRBL's receive buffer than
            this sender has unanswered (another sender on the port, or a miscount).
        lifted: (from, until) [s, streamer clock] of each hold in which the pen was lifted by
            the spindle-stop override (``until`` is inf while it lasts).
    """

    sent: int = 0
    acked: int = 0
    ack_times: dict[int, float] = field(default_factory=dict)
    send_times: dict[int, float] = field(default_factory=dict)
    failure: str = ""
    failed_line: int = 0
    statuses: list[StatusReport] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)
    lost_polls: int = 0
    rx_overcounts: int = 0
    lifted: list[tuple[float, float]] = field(default_factory=list)


class GrblStreamer:
    """A GRBL 1.1 device on a serial port.

    Args:
        port: The serial port (or an emulator's pseudo-terminal).
        baudrate: [bit/s]; GRBL 1.1 uses 115200.
        clock: Where times come from [s] (``time.monotonic``).
        on_status: Called with each :class:`StatusReport` as it arrives.
        time_scale: Device seconds per wall second (an emulator's speed-up): status is polled
            every 0.2 s of device time.
    """

    def __init__(self, port: str, baudrate: int = 115200,
                 clock: Callable[[], float] = time.monotonic,
                 on_status: Callable[[StatusReport], None] | None = None,
                 time_scale: float = 1.0):
        self._lock, self.serial = open_locked(
            port, baudrate, lambda message: GrblError(message, key="--port", value=port))
        self.port = port
        self.clock = clock
        self.on_status = on_status
        self.status_period_s = STATUS_PERIOD_S / time_scale
        self.state = StreamState()
        self._pending: deque[str] = deque()
        self._in_flight: deque[tuple[int, int]] = deque()  # (line number, bytes)
        self._bytes = 0
        self._rx = b""
        self._last_poll = -1e9
        self._poll_at: float | None = None  # when the unanswered "?" was sent
        self.last_status: StatusReport | None = None
        self.wco: tuple[float, float, float] | None = None  # the last work offset known
        self._planner_blocks = 0  # the most free planner blocks seen (``Bf:``)

    # -- connection ----------------------------------------------------------------------------

    def wake(self, timeout_s: float = 3.0) -> list[str]:
        """Soft-reset the device and wait for its banner (``Grbl 1.1...``); the lines it sent."""
        self.serial.reset_input_buffer()
        self._rx = b""
        self.realtime(b"\x18")
        lines = self._wait_for(lambda line: line.startswith("Grbl "), timeout_s, "banner")
        end = self.clock() + 0.05
        while self.clock() < end:  # a [MSG:...] may follow the banner
            lines += self._read_lines()
        self._in_flight.clear()
        self._poll_at = None
        self._bytes = 0
        return lines

    def command(self, line: str, timeout_s: float = 5.0) -> list[str]:
        """Send one line (``$X``, ``$H``, ``$$``) and wait for its ``ok``; the lines before it.
        Raises :class:`GrblError` on ``error:N`` or ``ALARM:N``."""
        self._write(f"{line}\n".encode("ascii"))
        lines = self._wait_for(lambda r: r == "ok" or r.startswith(("error:", "ALARM:")),
                               timeout_s, f"an answer to {line!r}")
        if lines[-1] != "ok":
            raise GrblError(f"{line!r} was answered {lines[-1]}", key="--port", value=self.port)
        return lines[:-1]

    def unlock(self) -> None:
        """``$X``: leave the alarm state."""
        self.command("$X")

    def home(self, timeout_s: float = 120.0) -> None:
        """``$H``: the homing cycle (needs ``$22=1``)."""
        self.command("$H", timeout_s)

    def realtime(self, byte: bytes) -> None:
        """Send a real-time command: ``b"?"`` status (see :meth:`poll`), ``b"!"`` feed hold,
        ``b"~"`` resume, ``b"\\x18"`` soft reset."""
        if byte == b"?":
            self.poll(force=True)
            return
        self._write(byte)

    def poll(self, force: bool = False) -> bool:
        """Ask for a status report (``?``) unless one is still on its way; True if asked.

        One poll at a time, so each report is stamped by the poll that asked for it: GRBL
        1.1h only raises a flag on ``?`` (serial.c) and its main loop writes one report per
        flag (protocol.c), so two ``?`` sent close together can get one answer, and a
        sender that pairs reports with polls in order then stamps every later report one
        poll early. A poll unanswered after ``POLL_LOST_S`` [s, wall] counts as lost.
        ``force``: ask now all the same (the next report is stamped by this poll)."""
        now = self.clock()
        if self._poll_at is not None and not force:
            if now - self._poll_at < POLL_LOST_S:
                return False
            self.state.lost_polls += 1
        self._poll_at = now
        self._write(b"?")
        return True

    def status(self, timeout_s: float = 3.0) -> StatusReport:
        """Poll and wait for the next status report."""
        end = self.clock() + timeout_s
        count = len(self.state.statuses)
        while self.clock() < end and not self.state.failure.startswith("the device disc"):
            if self._poll_at is not None and self.clock() - self._poll_at > STATUS_RETRY_S:
                self._poll_at = None  # (a "?" during a reset is dropped with its flag)
                self.state.lost_polls += 1
            self.poll()
            for line in self._read_lines():
                self._answer(line)
            if len(self.state.statuses) > count:
                return self.state.statuses[-1]
        raise GrblError(f"no status report from {self.port} within {timeout_s:g} s",
                        key="--port", value=self.port)

    def feed_hold(self) -> None:
        self.realtime(b"!")

    def resume(self) -> None:
        """``~``: resume (a pen lifted by :meth:`pause` goes down first, where it left)."""
        self.realtime(b"~")
        lifted = self.state.lifted
        if lifted and lifted[-1][1] == float("inf"):
            lifted[-1] = (lifted[-1][0], self.clock())

    def lifted_at(self, t: float) -> bool:
        """Whether the pen was held lifted by :meth:`pause` at ``t`` [s, streamer clock]."""
        return any(a <= t < b for a, b in self.state.lifted)

    def pause(self, lift: bool = True, timeout_s: float = 10.0) -> StatusReport | None:
        """Feed hold (``!``) until the device stops (Hold:0), then, with ``lift``, GRBL 1.1's
        spindle-stop override (0x9E) that lifts a servo pen; :meth:`resume` puts it back down
        and continues from the same position. Returns the last status."""
        self.feed_hold()
        end = self.clock() + timeout_s
        while not self.state.failure and self.clock() < end:
            self.poll()
            for line in self._read_lines():
                self._answer(line)
            s = self.last_status
            if s is not None and s.state == "Hold:0":
                if lift:
                    # GRBL 1.1h protocol.c: in Hold, 0x9E stops the spindle (the servo pen
                    # lifts) until the cycle resumes; the pen is up from here on
                    self.state.lifted.append((self.clock(), float("inf")))
                    self.realtime(b"\x9e")
                return s
            time.sleep(0.05)
        return self.last_status

    def close(self) -> None:
        """Close the port and release its lock (idempotent)."""
        try:
            self.serial.close()
        except (serial.SerialException, OSError):
            pass
        finally:
            self._lock.close()

    # -- streaming -----------------------------------------------------------------------------

    def queue(self, lines: Iterable[str]) -> None:
        """Add lines to the job (sent by :meth:`pump`)."""
        for line in lines:
            text = line.strip()
            if len(text) + 1 > RX_BUFFER:
                raise GrblError(f"G-code line of {len(text) + 1} bytes does not fit GRBL's "
                                f"{RX_BUFFER}-byte buffer: {text[:40]!r}...")
            self._pending.append(text)

    @property
    def queued(self) -> int:
        """Lines not yet sent."""
        return len(self._pending)

    @property
    def done(self) -> bool:
        """Every queued line answered, or the stream failed."""
        return bool(self.state.failure) or (not self._pending and not self._in_flight)

    def pump(self, counting: bool = True, poll: bool = True) -> None:
        """Send what fits, read the answers, poll the status when due; never blocks long.
        Without ``counting`` every queued line is sent at once (how a naive sender loses
        bytes)."""
        if self.state.failure:
            return
        while self._pending and (not counting or self._bytes + len(self._pending[0]) + 1
                                 <= RX_BUFFER):
            text = self._pending.popleft()
            self._write(f"{text}\n".encode("ascii"))
            self.state.sent += 1
            self.state.send_times[self.state.sent] = self.clock()
            self._in_flight.append((self.state.sent, len(text) + 1))
            self._bytes += len(text) + 1
        if poll and self.clock() - self._last_poll >= self.status_period_s and self.poll():
            self._last_poll = self.clock()
        for line in self._read_lines():
            self._answer(line)

    def stream(self, lines: Iterable[str], timeout_s: float = 600.0,
               counting: bool = True) -> StreamState:
        """Queue ``lines`` and pump until every one is answered (or the stream failed)."""
        self.queue(lines)
        end = self.clock() + timeout_s
        while not self.done:
            self.pump(counting)
            if self.clock() > end:
                self._fail(f"no answer within {timeout_s:g} s", self._oldest())
        return self.state

    def wait_idle(self, timeout_s: float = 600.0) -> StatusReport | None:
        """Poll until the device reports Idle after the last line was answered, its planner
        drained where the report says (``Bf:``), or the stream failed; the last report."""
        end = self.clock() + timeout_s
        while not self.state.failure:
            self.pump()
            s = self.last_status
            if s is not None and s.state in ("Idle", "Check") and not self._in_flight \
                    and s.acked >= self.state.acked and (
                        s.planner_free is None or s.planner_free >= self._planner_blocks):
                return s
            if self.clock() > end:
                self._fail(f"not idle within {timeout_s:g} s", self._oldest())
        return self.last_status

    # -- internals -----------------------------------------------------------------------------

    def _answer(self, line: str) -> None:
        if line.startswith("<"):
            # GRBL writes the report as soon as its main loop sees the "?" (serial.c raises a
            # flag; protocol.c answers it at its next pass, well under a millisecond), so the
            # report describes the device just after the poll; the rest of the round trip is
            # the way back (about 6 ms for 70 bytes at 115200 bit/s, a USB adapter's latency
            # timer) and this host's own delay in reading. Stamped half-way through the round
            # trip, but never more than REPORT_AFTER_POLL_S after the poll.
            now = self.clock()
            asked = self._poll_at if self._poll_at is not None else now
            self._poll_at = None
            stamp = asked + min(0.5 * (now - asked), REPORT_AFTER_POLL_S)
            status = parse_status(line, stamp, self.wco)
            if status is not None:
                self._note(replace(status, acked=self.state.acked))
            return
        if line == "ok":
            if self._in_flight:
                number, n = self._in_flight.popleft()
                self._bytes -= n
                self.state.acked += 1
                self.state.ack_times[number] = self.clock()
            return
        if line.startswith(("error:", "ALARM:")):
            self._fail(f"{line} at G-code line {self._oldest()}", self._oldest())
            return
        if line:
            self.state.messages.append(line)

    def _note(self, status: StatusReport) -> None:
        """Keep a report: its work offset, and the receive-buffer check (``Bf:``)."""
        if status.wco is not None:
            self.wco = status.wco
        if status.planner_free is not None:
            self._planner_blocks = max(self._planner_blocks, status.planner_free)
        if status.rx_free is not None and RX_BUFFER - status.rx_free > self._bytes:
            self.state.rx_overcounts += 1
        self.last_status = status
        self.state.statuses.append(status)
        if self.on_status is not None:
            self.on_status(status)

    def _oldest(self) -> int:
        return self._in_flight[0][0] if self._in_flight else self.state.sent

    def _fail(self, why: str, line: int) -> None:
        if not self.state.failure:
            self.state.failure = why
            self.state.failed_line = line
            self._pending.clear()

    def _write(self, data: bytes) -> None:
        try:
            self.serial.write(data)
        except (serial.SerialException, OSError) as e:
            self._fail(f"the device disconnected ({e})", self._oldest())

    def _read_lines(self) -> list[str]:
        try:
            chunk = self.serial.read(max(1, self.serial.in_waiting))
        except (serial.SerialException, OSError) as e:
            self._fail(f"the device disconnected ({e})", self._oldest())
            return []
        if not chunk:
            return []
        self._rx += chunk
        *lines, self._rx = self._rx.split(b"\n")
        return [line.strip().decode("ascii", "replace") for line in lines]

    def _wait_for(self, accept: Callable[[str], bool], timeout_s: float,
                  what: str) -> list[str]:
        end = self.clock() + timeout_s
        seen: list[str] = []
        while self.clock() < end:
            if self.state.failure.startswith("the device disconnected"):
                break
            for line in self._read_lines():
                if line.startswith("<"):
                    self._answer(line)
                    continue
                seen.append(line)
                if accept(line):
                    return seen
        raise GrblError(f"no {what} from {self.port} within {timeout_s:g} s"
                        + (f" ({self.state.failure})" if self.state.failure else ""),
                        key="--port", value=self.port)
