"""AxiDrawPlant: an AxiDraw (EiBotBoard firmware) behind the
:class:`inkarm.core.plant.Plant` protocol, streaming ahead like the GRBL plant.

The EBB plans nothing: the plant does (:mod:`.motion`). Draw commands
(:class:`~inkarm.core.plant.PositionCommand` with a speed, joints x, y in [m] of the page
frame) are gathered into a stroke, which is timed from rest to rest within the pen-down speed
and acceleration, each row at most the speed it asks for; a position without a speed is a
pen-up travel at the pen-up limits; a :class:`~inkarm.core.plant.PenCommand` is ``SP`` with the
profile's servo wait. Every move is an ``SM`` in whole steps and milliseconds.

Flow control is the firmware's (:mod:`.bus`): each command is answered once taken, a move only
when the FIFO has room; so the plant knows when each move starts: a move answered at ``s``
starts at ``max(s, end of the move before)`` at the latest and lasts its duration (device
time: wall time x ``time_scale``, the speed-up of an emulator); and as the 1-deep FIFO takes a
move only once the one two before it has ended, each OK also bounds the end of the move two
before: a device found ahead of the timeline moves it earlier (:meth:`AxiDrawPlant._anchor`). That timeline is
:meth:`schedule`: the reference the readings are judged against.

What an EBB senses (:meth:`readings`): its step counters (``QS``) and the pen's commanded
state (``QP``), polled every ``poll_s`` of device time between moves (the AxiDraw software
polls every 50 ms); no force, no ink. At the end the counters must equal the steps sent, else
the job failed (steps the firmware dropped). The pause button (``QB``, polled with each
reading) stops the job as a fault does.

Set-up at connect (AxiDraw software facts): ``EM,1,1`` (both motors on at 1/16 steps: 2032
steps per inch of x + y, :mod:`.geometry`), ``CS`` (the counters read from home: the carriage starts
parked at home), ``SC,4``/``SC,5`` pen heights, ``SC,11``/``SC,12`` servo rates, ``SR`` servo
power timeout (firmware 2.6.0+), then the pen up. :meth:`close`: after a clean job the pen up,
the carriage home and the motors off (``EM,0,0``); after a fault ``ES`` (the queued moves
dropped), the pen up and the motors off (push the carriage home by hand), nothing at all when
the port is gone.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass

import numpy as np

from inkarm.core.plant import Command, PenCommand, PlantState, PositionCommand, unsupported
from inkarm.errors import InputError
from inkarm.hardware.axidraw import ebb
from inkarm.hardware.axidraw.bus import EbbBus
from inkarm.hardware.axidraw.ebb import EbbError
from inkarm.hardware.axidraw.motion import Move, StepCursor, path_moves, profile_limits
from inkarm.hardware.axidraw.placement import SheetPlacement
from inkarm.hardware.axidraw.profiles import AxiDrawProfile
from inkarm.hardware.pen_plant import PenPlotterPlant

POLL_S = 0.05  # device seconds between readings (QS, QP)
SAFE_STOP_S = 3.0  # the longest wait for each reply of a safe stop [s, wall]
PAUSED = "the pause button was pressed (the EBB's PRG button, QB)"
MICROSTEP_16 = 1  # EM's enable1 for 1/16 steps


@dataclass
class Motion:
    """A queued EBB motion command: its text, duration [s], the steps and pen after it."""

    text: str
    duration_s: float
    steps: tuple[int, int]
    pen_down: bool
    sent: float | None = None  # device time it was sent [s]
    taken: float = 0.0  # device time its OK came [s]
    start: float = 0.0
    end: float = 0.0


@dataclass(frozen=True)
class Plan:
    """The timeline as samples: rows (t [s], x, y [mm] page, z [mm], pen touching)."""

    samples: np.ndarray
    seconds: float


class AxiDrawPlant(PenPlotterPlant):
    """See the module docstring.

    Args:
        bus: An open :class:`EbbBus` (``hello`` answered); None plans without sending (what
            ``draw --check`` reports).
        profile: The machine's profile; placement: the sheet on it.
        dt: Control period of the pen path [s].
        time_scale: Device seconds per wall second.
        pen_force_n: Nominal force [N] logged while the pen is down (an EBB senses none).
        poll_s: Device seconds between readings.
    """

    def __init__(self, bus: EbbBus | None, profile: AxiDrawProfile, placement: SheetPlacement, *,
                 dt: float = 0.01, time_scale: float = 1.0, pen_force_n: float = 1.0,
                 poll_s: float = POLL_S):
        self.bus, self.profile, self.placement = bus, profile, placement
        self._dt, self.time_scale, self.pen_force_n = float(dt), float(time_scale), pen_force_n
        self.poll_s = poll_s
        self.cursor = StepCursor(profile.steps_per_mm)
        self.motions: list[Motion] = []
        self.command_motion: list[int] = []  # per command, the motion it ends with
        self.pending: list[tuple[int, np.ndarray, float]] = []  # a stroke being gathered
        self.pen_down = False
        self.failure = ""
        self.clipped = 0  # draw rows asked faster than the pen-down speed limit
        self._sent = 0
        self._t0: float | None = None
        self._last_poll = -math.inf
        self._last_steps = (0, 0)  # QS's last reading
        self._readings: list[PlantState] = []
        self._closed = False
        self._set_up()

    # -- the Plant protocol (dt, senses, commands: PenPlotterPlant) ----------------------------

    def command(self, command: Command) -> None:
        if isinstance(command, PenCommand):
            self._flush()
            if command.down != self.pen_down:
                self._queue(ebb.sp(not command.down, self.profile.pen_move_ms(not command.down)),
                            self.profile.pen_move_ms(not command.down) / 1000.0, command.down)
            self.command_motion.append(len(self.motions) - 1)
        elif isinstance(command, PositionCommand):
            target = self.placement.to_machine(np.asarray(command.q[:2], dtype=float) * 1000.0)
            self.placement.check_machine(target)
            if command.qd is None:
                self._flush()
                self._travel(target)
                self.command_motion.append(len(self.motions) - 1)
            else:
                speed = float(np.linalg.norm(command.qd[:2])) * 1000.0
                self.clipped += speed > self.profile.speed_pendown_mm_s * 1.0001
                self.command_motion.append(-2)  # set when the stroke is planned
                self.pending.append((len(self.command_motion) - 1, target, speed))
        else:
            raise InputError(unsupported(self, command))

    def step(self) -> None:
        """Send what is queued (each move waits for the firmware's FIFO: the host keeps pace)."""
        self._pump()

    def read(self) -> PlantState:
        if self._readings:
            return self._readings[-1]
        return PlantState(self.now(), np.zeros(2), np.zeros(2))

    def close(self) -> None:
        """Leave the machine safe (module docstring); idempotent."""
        if self._closed:
            return
        self._closed = True
        if self.bus is None:
            return
        try:
            if self.failure.startswith("the EBB disconnected"):
                return
            self.bus.reply_timeout_s = min(self.bus.reply_timeout_s, SAFE_STOP_S)
            with contextlib.suppress(EbbError, ValueError):
                clean = not self.failure and self._sent == len(self.motions)
                if not clean:
                    self.bus.drain()
                    self.bus.transact(ebb.simple("ES"))
                self.bus.transact(ebb.sp(True, self.profile.pen_move_ms(True)))
                self.pen_down = False
                wait_s = self.profile.pen_move_ms(True) / 1000.0
                if clean:
                    self._travel(np.zeros(2))
                    self._pump(poll=False)
                    self._timeline()
                    wait_s += max(self.motions[-1].end - self.now(), 0.0)
                self._settle(wait_s / self.time_scale + SAFE_STOP_S)
                self.bus.transact(ebb.em(0, 0))
        finally:
            self.bus.close()

    # -- streaming -----------------------------------------------------------------------------

    def now(self) -> float:
        """Device time [s] since the first motion was sent."""
        if self._t0 is None:
            return 0.0
        return (self.bus.clock() - self._t0) * self.time_scale

    def finish(self, progress=None, timeout_s: float = 3600.0) -> bool:
        """Send everything and wait until the EBB is idle; False when the job failed."""
        self._flush()
        if self.bus is None:
            self._timeline()
            return True
        self._pump(progress=progress)
        if not self.failure:
            self._wait_idle(timeout_s=timeout_s)
        if not self.failure:
            self._poll(force=True)
            steps = self._last_steps
            if steps != self.cursor.steps:
                self.failure = (f"the EBB's step counters read {steps} (QS) after the job; the "
                                f"moves sent sum to {self.cursor.steps}: steps were lost")
        return not self.failure

    def readings(self) -> list[PlantState]:
        """One state per reading (QS and QP), device times from the first motion."""
        return list(self._readings)

    def schedule(self) -> tuple[np.ndarray, Plan]:
        """Per command, the device time [s] it ends on the timeline; and the timeline's
        samples (module docstring). Moves not sent follow the last one sent."""
        self._timeline()
        last = self.motions[-1].end if self.motions else 0.0
        ends = np.array([self.motions[i].end if i >= 0 else (0.0 if i == -1 else last)
                         for i in self.command_motion], dtype=float)  # -2: not planned yet
        rows = []
        steps, down = (0, 0), False
        for m in self.motions:
            page = self.placement.to_page(self.cursor.position_mm(steps))
            rows.append((m.start, page[0], page[1], 0.0 if down else 1.0, float(down)))
            steps, down = m.steps, m.pen_down
            page = self.placement.to_page(self.cursor.position_mm(steps))
            rows.append((m.end, page[0], page[1], 0.0 if down else 1.0, float(down)))
        samples = np.array(rows) if rows else np.zeros((1, 5))
        return ends, Plan(samples, float(samples[-1, 0]))

    # -- internals -----------------------------------------------------------------------------

    def _set_up(self) -> None:
        p, bus = self.profile, self.bus
        if bus is None:
            self._queue(ebb.sp(True, p.pen_move_ms(True)), p.pen_move_ms(True) / 1000.0, False)
            return
        bus.transact(ebb.em(MICROSTEP_16, MICROSTEP_16))
        bus.transact(ebb.simple("CS"))
        bus.transact(ebb.sc(4, p.servo_position(p.pen_pos_up)))
        bus.transact(ebb.sc(5, p.servo_position(p.pen_pos_down)))
        bus.transact(ebb.sc(11, p.servo_rate(p.pen_rate_raise)))
        bus.transact(ebb.sc(12, p.servo_rate(p.pen_rate_lower)))
        if bus.version >= (2, 6, 0):
            bus.transact(ebb.sr(p.servo_timeout_ms))
        self._queue(ebb.sp(True, p.pen_move_ms(True)), p.pen_move_ms(True) / 1000.0, False)

    def _queue(self, text: str, duration_s: float, pen_down: bool) -> None:
        self.motions.append(Motion(text, duration_s, self.cursor.steps, pen_down))
        self.pen_down = pen_down

    def _queue_moves(self, moves: list[Move]) -> None:
        for m in moves:
            steps = self.motions[-1].steps if self.motions else (0, 0)
            after = (steps[0] + m.steps1, steps[1] + m.steps2)
            self.motions.append(Motion(ebb.sm(m.duration_ms, m.steps1, m.steps2),
                                       m.duration_ms / 1000.0, after, self.pen_down))

    def _travel(self, target: np.ndarray) -> None:
        here = self.cursor.position_mm()
        lim = profile_limits(self.profile, self.pen_down)
        moves, _ = path_moves(self.cursor, [here, target], [lim.speed_mm_s], lim)
        self._queue_moves(moves)

    def _flush(self) -> None:
        """Plan the stroke gathered so far (rest to rest) and queue its moves."""
        if not self.pending:
            return
        p = self.profile
        points = [self.cursor.position_mm()] + [t for _, t, _ in self.pending]
        caps = np.clip([s for _, _, s in self.pending], p.min_draw_speed_mm_s,
                       p.speed_pendown_mm_s)
        base = len(self.motions)
        moves, reached = path_moves(self.cursor, points, caps, profile_limits(p, True))
        self._queue_moves(moves)
        for (index, _, _), r in zip(self.pending, reached[1:], strict=True):
            self.command_motion[index] = base + r if r >= 0 else base - 1
        self.pending = []

    def _pump(self, progress=None, poll: bool = True) -> None:
        while self.bus is not None and self._sent < len(self.motions) and not self.failure:
            self._send(self._sent)
            if poll:
                self._poll()
            if progress is not None and self._sent % 50 == 0:
                progress(0.5 + 0.5 * self._sent / len(self.motions), "plot")

    def _send(self, i: int) -> None:
        m = self.motions[i]
        ahead = self.motions[i - 2].end if i >= 2 else 0.0  # the FIFO frees when it ends
        due = max(0.0, ahead - self.now()) / self.time_scale
        try:
            self.bus.transact(m.text, due_s=due)
        except EbbError as e:
            self.failure = f"{e.message} (motion command {i + 1} of {len(self.motions)})"
            return
        if self._t0 is None:
            self._t0 = self.bus.sent_at
        m.sent = (self.bus.sent_at - self._t0) * self.time_scale
        # taken (and, with room in the FIFO, started) at the latest when its OK came
        m.taken = (self.bus.replied_at - self._t0) * self.time_scale
        m.start = max(self.motions[i - 1].end if i else 0.0, m.taken)
        m.end = m.start + m.duration_s
        self._sent = i + 1
        if i >= 2:
            self._anchor(i - 2, m.taken, i)

    def _anchor(self, j: int, latest: float, last: int) -> None:
        """Motion ``j`` ended at the latest at ``latest`` [s]: the FIFO (1 deep) took motion
        j + 2 only once j had ended. Where the timeline has j end later, the device ran
        earlier than it: j and the moves run back to back before it move earlier, and the
        moves after it (up to ``last``, those sent) start as soon as they could."""
        ms = self.motions
        if ms[j].end <= latest + 1e-9:
            return
        ms[j].end = latest
        ms[j].start = latest - ms[j].duration_s
        k = j - 1
        while k >= 0 and ms[k].end > ms[k + 1].start + 1e-9:
            ms[k].end = ms[k + 1].start
            ms[k].start = ms[k].end - ms[k].duration_s
            k -= 1
        for k in range(j + 1, last + 1):
            ms[k].start = max(ms[k - 1].end, ms[k].taken)
            ms[k].end = ms[k].start + ms[k].duration_s

    def _poll(self, force: bool = False) -> None:
        """A reading (QP, QS; and QB, the pause button) when ``poll_s`` has passed since the last
    (or ``force``)."""
        if self.failure or self._t0 is None:
            return
        if not force and self.now() - self._last_poll < self.poll_s:
            return
        try:
            # the pen first: a pen that changes between the two queries is then seen in the
            # state it had while the counters moved, never lifted in the middle of a stroke
            up = ebb.parse_pen_up(self.bus.transact(ebb.simple("QP"))[0])
            steps = ebb.parse_steps(self.bus.transact(ebb.simple("QS"))[0])
            t = (self.bus.replied_at - self._t0) * self.time_scale  # (read when answered)
            pressed = ebb.parse_button(self.bus.transact(ebb.simple("QB"))[0])
        except EbbError as e:
            self.failure = e.message
            return
        except ValueError as e:
            self.failure = f"the EBB answered a query with {e}"
            return
        self._last_poll = t
        self._last_steps = steps
        if pressed:
            self.failure = PAUSED
        page = self.placement.to_page(self.cursor.position_mm(steps))
        self._readings.append(PlantState(
            time=t, q=page / 1000.0, qd=np.zeros(2), force=0.0 if up else self.pen_force_n,
            tip_mm=np.array([page[0], page[1], math.nan if up else 0.0])))

    def _settle(self, timeout_s: float) -> None:
        """Wait [s, wall] until the EBB has no motion left (QM), the pen-up move included."""
        end = time.monotonic() + timeout_s
        while not ebb.parse_motors(self.bus.transact(ebb.simple("QM"))[0]).idle:
            if time.monotonic() > end:
                return
            time.sleep(0.001)

    def _wait_idle(self, timeout_s: float = 3600.0, poll: bool = True) -> None:
        """Poll ``QM`` (and read) until no motion is left; a fault after the timeline's end
        plus the reply timeout."""
        self._timeline()
        end = time.monotonic() + min(timeout_s, max(self.motions[-1].end - self.now(), 0.0)
                                     / self.time_scale + self.bus.reply_timeout_s)
        while not self.failure:
            try:
                motors = ebb.parse_motors(self.bus.transact(ebb.simple("QM"))[0])
            except EbbError as e:
                self.failure = e.message
                return
            except ValueError as e:
                self.failure = f"the EBB answered QM with {e}"
                return
            if motors.idle:
                return
            if time.monotonic() > end:
                self.failure = "the EBB kept moving past the end of the job's timeline (QM)"
                return
            if poll:
                self._poll()
            time.sleep(min(0.002, self.poll_s / self.time_scale / 4))

    def _timeline(self) -> None:
        """Start and end of the moves not sent yet: right after the one before."""
        for i in range(self._sent, len(self.motions)):
            m = self.motions[i]
            m.start = self.motions[i - 1].end if i else 0.0
            m.end = m.start + m.duration_s


__all__ = ["AxiDrawPlant", "Motion", "Plan"]
