"""GrblPlant: a GRBL 1.1 pen plotter behind the :class:`inkarm.core.plant.Plant` protocol.

A plotter's servo loop is its firmware's planner, so the plant streams ahead: each
:class:`~inkarm.core.plant.PositionCommand` (joints x, y in [m], the page frame's axes) becomes
a G-code line (``G1`` at the commanded speed |qd|, or ``G0`` without qd) and each
:class:`~inkarm.core.plant.PenCommand` the pen profile's lines with their dwell; :meth:`step`
pumps the character-counting stream and blocks only while more than ``lookahead_lines`` wait
to be sent. The measurements are GRBL's status reports, polled at 5 Hz: :meth:`readings`
gives one :class:`~inkarm.core.plant.PlantState` per report, times counted from the first line
sent, in device seconds (wall seconds times ``time_scale``: 1 on real hardware, the speed-up of
an emulator). :meth:`schedule` runs the same lines on the planner model
(:mod:`inkarm.hardware.plotter.timing`) with the device's own ``$`` settings: where the
firmware should be when, the plotter's reference.

At connect the plant sets the machine up as a real plotter is
(:func:`inkarm.hardware.plotter.workspace.set_up`): ``$$``, homing when ``$22=1``, the page
origin as G54's work offset; the G-code is in work (page) coordinates, and so are the
readings (``MPos`` less the work offset, which a report only sometimes carries).

The pen state is never read off a report's ``A:`` field: GRBL 1.1h writes ``A:`` only with
``Ov:``, every 20th report while busy (report.c). It follows from what was sent and what is
done: GRBL executes a spindle or coolant line (``M3``/``M5``...) and a dwell only after every
motion before it has ended and answers ``ok`` only then (gcode.c ``spindle_sync``,
``mc_dwell``: both ``protocol_buffer_synchronize``), so a report that arrives after the
``ok`` of the pen-down group's last line (its dwell: the servo has landed) sees the pen down,
and one after the ``ok`` of the pen-up group's first line sees it lifting. A pen moved by an
axis (a Z pen) is where the report puts that axis: down at work Z <= 0.
"""

from __future__ import annotations

import bisect
import contextlib
import math
import time

import numpy as np

from inkarm.core.plant import Command, PenCommand, PlantState, PositionCommand, unsupported
from inkarm.errors import InputError
from inkarm.hardware.pen_plant import PenPlotterPlant
from inkarm.hardware.plotter.planner import BLOCK_BUFFER
from inkarm.hardware.plotter.profiles import PenProfile
from inkarm.hardware.plotter.stream import GrblError, GrblStreamer, StatusReport
from inkarm.hardware.plotter.timing import Schedule, simulate
from inkarm.hardware.plotter.workspace import leave_check_mode, set_up

AXES = set("XYZABC")
PLANNER_BLOCKS = BLOCK_BUFFER  # GRBL 1.1h's planner blocks on an ATmega328p ($I: [OPT:V,15,128])
WAITED_S = 0.02  # a motion line answered this long [s] after it was sent waited for a block
# The segment prep frees a block when it has prepared the block's last segment: at most the
# executing segment and four more still to run (stepper.c: SEGMENT_BUFFER_SIZE 6, one slot
# kept free, of at most DT_SEGMENT = 1/(100 * 60) min = 10 ms each; segments at block ends are
# shorter). So a block ends at most this long after its slot is freed [s]
PREP_LEAD_S = 0.05

SAFE_STOP_S = 3.0  # longest wait of each step of a safe stop (reset, unlock, pen up) [s]


class GrblPlant(PenPlotterPlant):
    """See the module docstring.

    Args:
        streamer: A connected :class:`GrblStreamer` (woken, unlocked).
        profile: The pen profile.
        dt: Control period [s]: one G-code line per period of the pen path (<= 1/400 s is
            more than GRBL executes).
        time_scale: Device seconds per wall-clock second.
        lookahead_lines: Lines queued beyond the device's buffer before :meth:`step` waits.
        pen_force_n: Nominal force [N] logged while the pen is down (a plotter senses none).
        page_mm: The page's size [mm] (for a page origin at a corner of the travel).
        extent_mm: The lowest and highest page points [mm] the job visits: refused before
            anything moves when they leave the machine's travel; None: not checked.
        check_mode: Validate the job on the device without moving (GRBL's ``$C``): every
            line parsed and checked, soft limits included; the readings stand still.
    """

    def __init__(self, streamer: GrblStreamer, profile: PenProfile, *, dt: float = 0.01,
                 time_scale: float = 1.0, lookahead_lines: int = 200, pen_force_n: float = 1.0,
                 page_mm: tuple[float, float] = (210.0, 297.0),
                 extent_mm: tuple[np.ndarray, np.ndarray] | None = None,
                 check_mode: bool = False):
        if not 1.0 / profile.max_line_rate_hz <= dt <= 1.0:
            raise InputError(f"expected a period in [1/{profile.max_line_rate_hz:g}, 1] s, got "
                             f"{dt}", key="dt", value=dt)
        self.streamer = streamer
        self.profile = profile
        self._dt = float(dt)
        self.time_scale = float(time_scale)
        self.lookahead_lines = lookahead_lines
        self.pen_force_n = pen_force_n
        self.check_mode = check_mode
        self.workspace = set_up(streamer, profile.placement, page_mm, extent_mm, check_mode)
        self.settings = self.workspace.settings
        self.lines: list[str] = []
        self.command_line: list[int] = []  # index of the last line of each command
        self.clipped = 0  # moves asked faster than the profile's max_draw_speed_mm_s
        self._t0: float | None = None
        self._closed = False
        self._queue(profile.start_lines())
        self._z_pen = any(_moves(line) for line in profile.pen_down)
        self.pen_marks: list[tuple[int, bool]] = []  # (line number, pen down once it is done)
        here = streamer.status()
        self._start_mm = here.wpos if here.wpos is not None else here.mpos  # work [mm]

    # -- the Plant protocol (dt, senses, commands: PenPlotterPlant) ----------------------------

    def command(self, command: Command) -> None:
        lines, clipped = command_lines(self.profile, command)
        if lines is None:
            raise InputError(unsupported(self, command))
        self.clipped += clipped
        self._queue(lines)
        if isinstance(command, PenCommand):
            # down once the whole group (its dwell) is done, up from its first line on
            self.pen_marks.append((len(self.lines) - (0 if command.down else len(lines) - 1),
                                   command.down))
        self.command_line.append(len(self.lines) - 1)

    def step(self) -> None:
        """Pump the stream; wait while more than ``lookahead_lines`` are still to be sent."""
        self._pump()
        while self.streamer.queued > self.lookahead_lines and not self.failure:
            self._pump()

    def read(self) -> PlantState:
        """The latest status report (the origin before the first)."""
        s = self.streamer.last_status
        return self._state(s) if s is not None else PlantState(self.now(), np.zeros(2),
                                                               np.zeros(2))

    def close(self) -> None:
        """Pen up and stop: after a failure, soft reset, unlock and pen-up lines. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            safe_stop(self.streamer, self.profile, failed=bool(self.failure))
        finally:
            self.streamer.close()

    # -- streaming -----------------------------------------------------------------------------

    def pause(self, lift: bool = True):
        """Feed hold, then lift a servo pen (GRBL's spindle-stop override); the last status."""
        return self.streamer.pause(lift)

    def resume(self) -> None:
        """Pen back down where it was, then continue."""
        self.streamer.resume()

    @property
    def failure(self) -> str:
        """Why the job failed (the stream's failure), empty while it is healthy; set, it ends
        the job: :meth:`close` then stops the machine (soft reset, unlock, pen up)."""
        return self.streamer.state.failure

    @failure.setter
    def failure(self, reason: str) -> None:
        self.streamer.state.failure = reason

    def now(self) -> float:
        """Device time [s] since the first line was sent."""
        if self._t0 is None:
            return 0.0
        return (self.streamer.clock() - self._t0) * self.time_scale

    def finish(self, progress=None, timeout_s: float = 3600.0) -> bool:
        """Send every line and wait until the device is idle; False when the job failed."""
        end = time.monotonic() + timeout_s
        total = max(len(self.lines), 1)
        while not self.streamer.done and time.monotonic() < end:
            self._pump()
            if progress is not None:
                progress(0.5 + 0.5 * self.streamer.state.acked / total, "plot")
        if not self.failure:
            self.streamer.wait_idle(max(end - time.monotonic(), 1.0))
        if self.check_mode and not self.failure:
            self.check_mode = False
            leave_check_mode(self.streamer)
        return not self.failure

    def readings(self) -> list[PlantState]:
        """One state per status report since the first line was sent."""
        if self._t0 is None:
            return []
        return [self._state(s) for s in self.streamer.state.statuses if s.time >= self._t0]

    def schedule(self) -> tuple[np.ndarray, Schedule]:
        """Per command, the device time [s] its lines should have ended; and the planner
        model's run of the whole job (``samples``: where the pen should be when), on the
        device's clock.

        The model starts where the machine stood when the job began (after homing: not at
        the page origin), in work (page) coordinates, without the homed space's soft limits.
        It assumes a device that is never kept waiting and whose clock is the host's; a real
        link sometimes keeps it waiting (the delays add up over a job), and a simulated GRBL
        (grbl-sim) runs its machine clock at 0.5-1x the wall clock, as its host's load lets
        it. So the model is anchored at every line GRBL runs only once the planner is empty
        (``G4``, ``M3``/``M4``/``M5``, ``M7``-``M9``: each pen change and its dwell): GRBL
        answers it when it is done, a moment the model knows exactly. Within a stroke, the
        ``ok`` of a motion line that had to wait for a free planner block bounds the end of
        the block 15 before it (:func:`planner_anchors`); the device's lateness on the model
        is the tightest of these bounds (:func:`warp_offsets`), which keeps the model's
        speed: interpolating between the bounds at face value made the reference run up to
        twice the planned speed between two of them, 0.5-0.8 mm RMS on a 60 mm/s stroke.
        Outside the anchors, the first or last one's lateness."""
        start = self._start_mm
        pre = [f"G21 G90 G0 X{start[0]:.3f} Y{start[1]:.3f} Z{start[2]:.3f}"]
        plan = simulate(pre + self.lines, {**self.settings, 20: 0, 21: 0, 22: 0},
                        samples=True)
        begin = float(plan.line_end_s[0])  # the model's move to the start, cut off
        model_end = plan.line_end_s[1:] - begin
        warp = self._clock_warp(model_end)
        line_end = warp(model_end)
        samples = plan.samples[plan.samples[:, 0] >= begin].copy()
        samples[:, 0] = warp(samples[:, 0] - begin)
        forward = np.concatenate(([True], samples[1:, 0] > np.maximum.accumulate(
            samples[:-1, 0])))
        return (line_end[np.asarray(self.command_line, dtype=int)],
                Schedule(plan.seconds - begin, line_end, samples[forward]))

    def _clock_warp(self, line_end_s: np.ndarray):
        """Model time -> device time through the anchors of :meth:`schedule`
        (:func:`warp_offsets`)."""
        if self._t0 is None:
            return lambda t: np.asarray(t, dtype=float)
        state = self.streamer.state
        exact = [(line_end_s[i], (state.ack_times[i + 1] - self._t0) * self.time_scale)
                 for i, line in enumerate(self.lines)
                 if _synchronous(line) and (i + 1) in state.ack_times]
        bounds = [(line_end_s[i] - PREP_LEAD_S,
                   (state.ack_times[n] - self._t0) * self.time_scale)
                  for i, n in planner_anchors(self.lines, self.settings, state,
                                              self.time_scale, self.profile.unit_mm,
                                              self._start_mm)]
        if not exact and not bounds:
            return lambda t: np.asarray(t, dtype=float)
        model, offset = warp_offsets(exact, bounds)
        first, last = offset[0], offset[-1]

        def warp(t):
            t = np.asarray(t, dtype=float)
            inside = t + np.interp(t, model, offset)
            return np.where(t < model[0], t + first, np.where(t > model[-1], t + last, inside))

        return warp

    def _queue(self, lines: list[str]) -> None:
        self.lines.extend(lines)
        self.streamer.queue(lines)

    def _pump(self) -> None:
        sent = self.streamer.state.sent
        self.streamer.pump()
        if self._t0 is None and self.streamer.state.sent > sent:
            self._t0 = self.streamer.clock()

    def pen_down_at(self, s: StatusReport) -> bool:
        """Whether the pen touches at report ``s`` (see the module docstring)."""
        if self._z_pen:
            return s.wpos is not None and s.wpos[2] <= 1e-3
        # the marks' line numbers increase (every pen group has a line): the last one done
        k = bisect.bisect_right(self.pen_marks, (s.acked, True)) - 1
        down = k >= 0 and self.pen_marks[k][1]
        # a hold's spindle-stop override (:meth:`pause`) lifts a servo pen until the resume
        return down and not s.state.startswith("Check") and not self.streamer.lifted_at(s.time)

    def _state(self, s: StatusReport) -> PlantState:
        t = (s.time - (self._t0 if self._t0 is not None else s.time)) * self.time_scale
        wpos = np.array(s.wpos if s.wpos is not None else s.mpos, dtype=float)
        down = self.pen_down_at(s)
        return PlantState(
            time=t, q=wpos[:2] / 1000.0, qd=np.zeros(2),
            force=self.pen_force_n if down else 0.0,
            tip_mm=np.array([wpos[0], wpos[1], 0.0 if down else math.nan]),
            errors=(self.failure,) if self.failure else ())


def command_lines(profile: PenProfile, command: Command) -> tuple[list[str] | None, bool]:
    """The G-code lines :class:`GrblPlant` sends for ``command`` (None: not a plotter's
    command), and whether its speed was clipped to the profile's ``max_draw_speed_mm_s``: a
    :class:`PenCommand` is the profile's pen lines with their dwell, a
    :class:`PositionCommand` (joints in [m]) ``G0`` without qd, else ``G1`` at |qd|."""
    if isinstance(command, PenCommand):
        return profile.pen_lines(command.down), False
    if not isinstance(command, PositionCommand):
        return None, False
    xy = profile.xy(*(float(v) * 1000.0 for v in command.q[:2]))
    if command.qd is None:
        return [f"G0 {xy}"], False
    speed = float(np.linalg.norm(command.qd[:2])) * 1000.0
    clipped = speed > profile.max_draw_speed_mm_s * 1.0001
    speed = min(max(speed, profile.min_draw_speed_mm_s), profile.max_draw_speed_mm_s)
    return [f"G1 {xy} {profile.feed(speed)}"], clipped


def streamed_lines(profile: PenProfile, commands: list[Command]) -> list[str]:
    """Every line a :class:`GrblPlant` streams for ``commands``: the profile's start lines
    and each command's (what a plotter run sends, which ``inkarm gcode``'s file is not: the
    run sends one line per control period of the pen path)."""
    lines = profile.start_lines()
    for command in commands:
        more, _ = command_lines(profile, command)
        if more is None:
            raise InputError(f"a plotter takes position and pen commands, not "
                             f"{type(command).__name__}")
        lines += more
    return lines


def warp_offsets(exact: list[tuple[float, float]],
                 bounds: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """The device's lateness on the model [s] (device time - model time) at model times [s],
    from anchors (model time, device time).

    ``exact``: the ``ok`` of a line GRBL answers when it is done (a dwell, a pen change): the
    lateness there, give or take the link's latency. ``bounds``: planner-full ``ok`` s
    (:func:`planner_anchors`), paired with their block's end less ``PREP_LEAD_S``; as a block
    ends at most ``PREP_LEAD_S`` after its slot is freed, and the ``ok`` comes after the free,
    each only bounds the lateness from above (by up to one segment, 10 ms, plus the latency).
    Between two exact anchors (a stroke) the device is never ahead of the model and only falls
    further behind when it is kept waiting, so the lateness is nondecreasing there: at each
    bound it is the least of the bounds at and after it and of the next exact anchor. Taking
    each bound at its face value, or interpolating between them, makes the model's speed
    swing with the 10 ms segment phase (up to twice the real speed between two bounds).
    Within a stroke, the lateness before its first bound is that bound's (the device's delay
    in starting the stroke)."""
    model: list[float] = []
    offset: list[float] = []
    exact = sorted(exact)
    bounds = sorted(bounds)
    k = 0
    for i, (m, d) in enumerate(exact + [(np.inf, np.inf)]):
        stretch = []
        while k < len(bounds) and bounds[k][0] <= m:
            stretch.append(bounds[k])
            k += 1
        if stretch:
            late = np.array([dv - mv for mv, dv in stretch])
            if np.isfinite(d):
                late = np.minimum(late, d - m)
            late = np.minimum.accumulate(late[::-1])[::-1]
            if model:  # the stroke starts as late as its first bound says
                model.append(model[-1] + 1e-6)
                offset.append(float(late[0]))
            model.extend(mv for mv, _ in stretch)
            offset.extend(float(v) for v in late)
        if np.isfinite(d):
            model.append(float(m))
            offset.append(float(d - m))
    model_a, offset_a = np.array(model), np.array(offset)
    order = np.argsort(model_a, kind="stable")
    model_a, offset_a = model_a[order], offset_a[order]
    keep = np.concatenate((model_a[1:] > model_a[:-1] + 1e-9, [True]))  # last of equal times
    return model_a[keep], offset_a[keep]


def planner_anchors(lines: list[str], settings: dict[int, float], state, time_scale: float,
                    unit_mm: float = 1.0,
                    start_mm=(0.0, 0.0, 0.0)) -> list[tuple[int, int]]:
    """(i, n): the motion line at index i ended when line number n was answered ``ok``.

    GRBL 1.1h's planner holds ``PLANNER_BLOCKS`` blocks (planner.h BLOCK_BUFFER_SIZE 16, one
    slot kept free; ``$I`` prints ``[OPT:V,15,128]``). A motion line is parsed only once a
    block is free (motion_control.c ``mc_line`` waits while ``plan_check_full_buffer``), and
    its ``ok`` follows; a block is freed when the block it holds is done (its last segment
    prepared, at most ``PREP_LEAD_S`` before its last step). So while the planner is full,
    the ``ok`` of the k-th motion block since the planner was last drained (by a synchronous
    line) comes at most that long before block k - 15 ends (:func:`warp_offsets` takes it as
    a bound). Lines GRBL drops (fewer than one step: no block, planner.c
    ``plan_buffer_line``) are not counted. An ``ok`` counts only when the line waited
    (``WAITED_S`` of device time between sending and ``ok``): else the planner was not full.
    ``unit_mm``: millimetres per G-code unit; ``start_mm``: where the machine starts.
    """
    steps = np.array([settings.get(100, 250.0), settings.get(101, 250.0),
                      settings.get(102, 250.0)])
    here = np.round(np.asarray(start_mm, dtype=float) * steps).astype(np.int64)
    blocks: list[int] = []
    out = []
    for i, line in enumerate(lines):
        if _synchronous(line):
            blocks = []
            continue
        target = _target(line)
        if target is None:
            continue
        new = here.copy()
        for axis, value in target.items():
            new[axis] = round(value * unit_mm * steps[axis])
        if np.all(new == here):
            continue
        here = new
        blocks.append(i)
        n = i + 1
        if len(blocks) > PLANNER_BLOCKS and n in state.ack_times and n in state.send_times \
                and (state.ack_times[n] - state.send_times[n]) * time_scale >= WAITED_S:
            out.append((blocks[-1 - PLANNER_BLOCKS], n))
    return out


def _code(line: str) -> str:
    """``line`` upper-cased without its comment (``;...`` or ``(...)``)."""
    return line.upper().split(";")[0].split("(")[0]


def _target(line: str) -> dict[int, float] | None:
    """The axis words of a ``G0``/``G1`` line in millimetres (absolute, G21), by axis; None
    for any other line."""
    words = _code(line).split()
    if not words or words[0] not in ("G0", "G1", "G00", "G01"):
        return None
    out = {}
    for w in words[1:]:
        if w[0] in "XYZ":
            try:
                out["XYZ".index(w[0])] = float(w[1:])
            except ValueError:
                return None
    return out or None


def _synchronous(line: str) -> bool:
    """Whether GRBL runs ``line`` only after every motion before it has ended and answers
    ``ok`` when it is done (gcode.c: a dwell, spindle and coolant changes call
    ``protocol_buffer_synchronize``): a dwell or an ``M3``-``M5``/``M7``-``M9`` line without
    axis words."""
    code = _code(line)
    return not any(c in AXES for c in code) and any(
        w in ("G4", "G04", "M3", "M03", "M4", "M04", "M5", "M05", "M7", "M07", "M8", "M08",
              "M9", "M09") for w in code.split())


def _moves(line: str) -> bool:
    """Whether a G-code line has axis words (a motion the planner queues; its ``ok`` comes
    when it is queued, not done)."""
    return any(c in AXES for c in _code(line))


def safe_stop(streamer: GrblStreamer, profile: PenProfile, failed: bool) -> None:
    """Leave the plotter with its pen up: after a failure a soft reset (which also stops a
    servo pen's PWM), ``$X`` and the profile's pen-up lines; otherwise the pen-up lines.
    (After a soft-limit alarm GRBL 1.1h takes ``$X`` only after that reset.)"""
    if streamer.state.failure.startswith("the device disconnected"):
        return  # nothing to talk to; GRBL itself stops the spindle on a reset
    with contextlib.suppress(GrblError):  # best effort on the way out: the failure is reported
        if failed:
            streamer.wake(timeout_s=SAFE_STOP_S)
            streamer.command("$X", timeout_s=SAFE_STOP_S)
        for line in profile.pen_lines(False):
            streamer.command(line, timeout_s=SAFE_STOP_S)
