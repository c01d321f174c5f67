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
"""

from __future__ import annotations

import contextlib
import math
import time

import numpy as np

from inkarm.core.plant import Command, PenCommand, PlantState, PositionCommand, unsupported
from inkarm.errors import InputError
from inkarm.hardware.plotter.profiles import PenProfile
from inkarm.hardware.plotter.stream import GrblError, GrblStreamer, StatusReport
from inkarm.hardware.plotter.timing import Schedule, simulate

SAFE_STOP_S = 3.0  # longest wait of each step of a safe stop (reset, unlock, pen up) [s]


class GrblPlant:
    """See the module docstring.

    Args:
        streamer: A connected :class:`GrblStreamer` (woken, unlocked).
        profile: The pen profile.
        dt: Control period [s]: one G-code line per period of the pen path (<= 1/400 s is
            more than GRBL executes).
        time_scale: Device seconds per wall-clock second.
        lookahead_lines: Lines queued beyond the device's buffer before :meth:`step` waits.
        pen_force_n: Nominal force [N] logged while the pen is down (a plotter senses none).
    """

    def __init__(self, streamer: GrblStreamer, profile: PenProfile, *, dt: float = 0.01,
                 time_scale: float = 1.0, lookahead_lines: int = 200, pen_force_n: float = 1.0):
        if not 1.0 / profile.max_line_rate_hz <= dt <= 1.0:
            raise InputError(f"expected a period in [1/{profile.max_line_rate_hz:g}, 1] s, got "
                             f"{dt}", key="dt", value=dt)
        self.streamer = streamer
        self.profile = profile
        self._dt = float(dt)
        self.time_scale = float(time_scale)
        self.lookahead_lines = lookahead_lines
        self.pen_force_n = pen_force_n
        self.settings = read_settings(streamer)
        self.lines: list[str] = []
        self.command_line: list[int] = []  # index of the last line of each command
        self.clipped = 0  # moves asked faster than the profile's max_draw_speed_mm_s
        self._t0: float | None = None
        self._closed = False
        self._queue(profile.start_lines())
        self._z_pen = any("Z" in line.upper() for line in profile.pen_down)

    # -- the Plant protocol --------------------------------------------------------------------

    @property
    def dt(self) -> float:
        return self._dt

    @property
    def senses(self) -> frozenset[str]:
        return frozenset({"tip"})

    @property
    def commands(self) -> frozenset[str]:
        return frozenset({"position", "pen"})

    def command(self, command: Command) -> None:
        if isinstance(command, PenCommand):
            self._queue(self.profile.pen_lines(command.down))
        elif isinstance(command, PositionCommand):
            xy = self.profile.xy(*(float(v) * 1000.0 for v in command.q[:2]))
            if command.qd is None:
                self._queue([f"G0 {xy}"])
            else:
                speed = float(np.linalg.norm(command.qd[:2])) * 1000.0
                if speed > self.profile.max_draw_speed_mm_s * 1.0001:
                    self.clipped += 1
                speed = min(max(speed, self.profile.min_draw_speed_mm_s),
                            self.profile.max_draw_speed_mm_s)
                self._queue([f"G1 {xy} {self.profile.feed(speed)}"])
        else:
            raise InputError(unsupported(self, command))
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
        return self.streamer.state.failure

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

        The model assumes a device that is never kept waiting; a real link sometimes does,
        and the delays would add up over a job. So the model is re-anchored at every dwell
        (``G4``, after each pen change): GRBL answers it when the dwell ends, a moment the
        model knows exactly, and from each such ``ok`` on, model times are shifted by its
        measured lateness."""
        plan = simulate(self.lines, self.settings, samples=True)
        warp = self._clock_warp(plan.line_end_s)
        line_end = warp(plan.line_end_s)
        samples = plan.samples.copy()
        samples[:, 0] = warp(samples[:, 0])
        forward = np.concatenate(([True], samples[1:, 0] > np.maximum.accumulate(
            samples[:-1, 0])))
        return (line_end[np.asarray(self.command_line, dtype=int)],
                Schedule(plan.seconds, line_end, samples[forward]))

    def _clock_warp(self, line_end_s: np.ndarray):
        """Model time -> device time, shifted at each answered dwell (see :meth:`schedule`)."""
        acks = self.streamer.state.ack_times
        anchors = [(line_end_s[i], (acks[i + 1] - self._t0) * self.time_scale)
                   for i, line in enumerate(self.lines)
                   if line.startswith("G4") and (i + 1) in acks and self._t0 is not None]
        if not anchors:
            return lambda t: np.asarray(t, dtype=float)
        model = np.array([a[0] for a in anchors])
        shift = np.array([a[1] - a[0] for a in anchors])

        def warp(t):
            t = np.asarray(t, dtype=float)
            k = np.searchsorted(model, t, side="right") - 1
            return t + np.where(k >= 0, shift[np.maximum(k, 0)], 0.0)

        return warp

    def _queue(self, lines: list[str]) -> None:
        self.lines.extend(lines)
        self.streamer.queue(lines)

    def _pump(self) -> None:
        sent = self.streamer.state.sent
        self.streamer.pump()
        if self._t0 is None and self.streamer.state.sent > sent:
            self._t0 = self.streamer.clock()

    def _state(self, s: StatusReport) -> PlantState:
        t = (s.time - (self._t0 if self._t0 is not None else s.time)) * self.time_scale
        mpos = np.array(s.mpos, dtype=float) * (25.4 if self.settings.get(13) else 1.0)
        down = s.spindle_on if not self._z_pen else mpos[2] <= 1e-3
        return PlantState(
            time=t, q=mpos[:2] / 1000.0, qd=np.zeros(2),
            force=self.pen_force_n if down else 0.0,
            tip_mm=np.array([mpos[0], mpos[1], 0.0 if down else math.nan]),
            errors=(self.failure,) if self.failure else ())


def read_settings(streamer: GrblStreamer) -> dict[int, float]:
    """The device's ``$`` settings (``$$``), by number."""
    settings = {}
    for line in streamer.command("$$"):
        key, _, value = line.partition("=")
        if key.startswith("$") and key[1:].isdigit():
            try:
                settings[int(key[1:])] = float(value.split()[0])
            except (ValueError, IndexError):
                continue
    return settings


def safe_stop(streamer: GrblStreamer, profile: PenProfile, failed: bool) -> None:
    """Leave the plotter with its pen up: after a failure a soft reset (which also stops a
    servo pen's PWM), ``$X`` and the profile's pen-up lines; otherwise the pen-up lines."""
    if streamer.state.failure.startswith("the device disconnected"):
        return  # nothing to talk to; GRBL itself stops the spindle on a reset
    with contextlib.suppress(GrblError):  # best effort on the way out: the failure is reported
        if failed:
            streamer.wake(timeout_s=SAFE_STOP_S)
            streamer.command("$X", timeout_s=SAFE_STOP_S)
        for line in profile.pen_lines(False):
            streamer.command(line, timeout_s=SAFE_STOP_S)
