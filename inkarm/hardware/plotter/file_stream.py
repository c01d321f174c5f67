"""Stream a G-code file made elsewhere to a GRBL 1.1 plotter: ``inkarm stream``'s library call.

:func:`stream_file` does, in order:

1. read and check the file (:func:`~inkarm.hardware.plotter.gcode_file.read_gcode_file`): a
   bad line is refused naming the file and line before the port is opened;
2. open the port (one driver per port: :class:`~inkarm.hardware.plotter.stream.GrblStreamer`
   takes its lock), soft-reset, read ``$$`` and ``$#`` and where the machine stands;
3. refuse any move outside the machine's travel (:func:`.gcode_file.check_reach`, with the
   page origin :mod:`.workspace` will set), naming the line, the point and the travel:
   nothing has moved yet;
4. estimate the job on the emulator's planner with the device's own settings and offsets
   (:func:`~inkarm.hardware.plotter.timing.schedule_from`);
5. set the machine up as every inkarm plotter run does (:func:`.workspace.set_up`: ``$H`` when
   ``$22=1``, the page origin as G54's work offset);
6. stream the lines with character counting against GRBL's 128-byte receive buffer, calling
   ``progress`` as lines are answered, and wait until the device is idle.

On ``error:N``, ``ALARM:N`` or a disconnect nothing more is sent: a feed hold stops the motion
already queued (GRBL keeps executing its planner after an ``error:N``), then a soft reset,
``$X`` and the pen profile's pen-up lines (:func:`.plant.safe_stop`); the report names the
file's line (the oldest unanswered one: GRBL answers in order). On Ctrl-C
(KeyboardInterrupt) the same safe stop runs and the interrupt goes on, carrying the report
(``report``).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.hardware.plotter.gcode_file import (
    GcodeJob,
    check_reach,
    read_gcode_file,
    stored_params,
    work_extent,
)
from inkarm.hardware.plotter.plant import safe_stop
from inkarm.hardware.plotter.profiles import PenProfile, load_profile
from inkarm.hardware.plotter.stream import GrblError, GrblStreamer
from inkarm.hardware.plotter.timing import Schedule, schedule_from
from inkarm.hardware.plotter.workspace import (
    Placement,
    homed_position,
    homes,
    page_origin,
    read_offsets,
    read_settings,
    set_up,
)

HOLD_TIMEOUT_S = 10.0  # longest wait for a feed hold to stop the motion [s, wall]
IDLE_TIMEOUT_S = 3600.0  # longest wait for the device to finish after the last ok [s, wall]


@dataclass(frozen=True)
class Progress:
    """Where a stream stands.

    Attributes:
        acked: Lines answered ``ok``; total: lines to send.
        elapsed_s: Device time since the first line was sent [s].
        remaining_s: The planner's time left [s]: after the last answered line, or after
            ``elapsed_s``, whichever leaves more.
        estimate_s: The planner's estimate of the whole job [s].
    """

    acked: int
    total: int
    elapsed_s: float
    remaining_s: float
    estimate_s: float

    @property
    def percent(self) -> float:
        return 100.0 * self.acked / max(self.total, 1)


@dataclass
class StreamReport:
    """What a stream did.

    Attributes:
        path, port: The file and the port.
        lines, bytes: Lines and bytes of the job (newlines included).
        acked: Lines answered ``ok``.
        estimate_s: The planner's estimate [s] on the device's settings.
        measured_s: Device time from the first line sent to idle [s] (wall time times
            ``time_scale``); NaN when the job did not finish.
        failure: Why the job stopped early (``error:N``, ``ALARM:N``, a disconnect, an
            interrupt), empty when it ran to the end.
        failed_line: The file's line number the failure is about (0 when none).
        origin_mm: The page origin in machine coordinates [mm]; homed: whether ``$H`` ran.
        settings: The device's ``$`` settings.
    """

    path: str
    port: str
    lines: int
    bytes: int
    estimate_s: float
    acked: int = 0
    measured_s: float = float("nan")
    failure: str = ""
    failed_line: int = 0
    origin_mm: tuple[float, float] = (0.0, 0.0)
    homed: bool = False
    settings: dict[int, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.failure


def stream_file(path: str | Path, port: str, *, baudrate: int = 115200,
                time_scale: float = 1.0, placement: Placement | None = None,
                profile: PenProfile | str | None = None,
                progress: Callable[[Progress], None] | None = None,
                on_estimate: Callable[[StreamReport, Schedule], None] | None = None,
                job: GcodeJob | None = None) -> StreamReport:
    """Stream the G-code file ``path`` to the GRBL device on ``port`` (module docstring).

    Args:
        baudrate: [bit/s]. time_scale: device seconds per wall second (an emulator's
            speed-up; 1 on a real plotter).
        placement: Where the file's origin goes and how to home (:class:`.workspace.Placement`:
            ``auto`` puts it at the travel's lower-left corner on a machine that homes, at
            machine zero otherwise).
        profile: The pen profile whose pen-up lines end a failed or interrupted job (``servo``
            by default: ``M5``).
        progress: Called after each answered line.
        on_estimate: Called once the job is checked and estimated, before anything moves.
        job: The file already read (else it is read here).

    Raises :class:`InputError` (naming the file and line) for a bad file or a move outside the
    travel, :class:`GrblError` when the device cannot be set up; a failed stream returns
    a report with ``failure`` set.
    """
    job = job or read_gcode_file(path)
    placement = placement or Placement()
    pen = profile if isinstance(profile, PenProfile) else load_profile(profile)
    streamer = GrblStreamer(port, baudrate, time_scale=time_scale)
    report: StreamReport | None = None
    try:
        streamer.wake()
        report, schedule = _prepare(streamer, job, placement)
        if on_estimate is not None:
            on_estimate(report, schedule)
        _run(streamer, job, report, schedule, time_scale, progress)
        if report.failure:
            _stop(streamer, pen, moving=not report.failure.startswith("ALARM"))
        return report
    except KeyboardInterrupt as stop:  # (also while homing: the reset stops the cycle)
        if report is not None:
            report.failure = "interrupted by the user (Ctrl-C)"
            report.acked = streamer.state.acked
            report.failed_line = _line_of(job, streamer.state.acked + 1) \
                if streamer.state.sent else 0
        _stop(streamer, pen, moving=True)
        stop.report = report
        raise
    finally:
        streamer.close()


def _prepare(streamer: GrblStreamer, job: GcodeJob,
             placement: Placement) -> tuple[StreamReport, Schedule]:
    """Read the device, check the job's reach, estimate it, set the machine up."""
    settings = read_settings(streamer)
    offsets = read_offsets(streamer)
    status = streamer.status()
    homed = homes(settings)
    will_home = homed and placement.homing == "auto"
    here = np.array(status.mpos, dtype=float)
    if will_home:
        here[:2] = homed_position(settings)
    lo, hi = work_extent(job)
    page = (max(float(hi[0]), 1.0), max(float(hi[1]), 1.0))
    origin = page_origin(placement, settings, page, tuple(here[:2]))
    params = stored_params(offsets, origin)
    check_reach(job, settings, homed, origin, params, here)
    schedule = schedule_from(list(job.lines), settings, here, params)
    workspace = set_up(streamer, placement, page, (lo[:2], hi[:2]))
    report = StreamReport(job.path, streamer.port, len(job.lines), job.bytes,
                          schedule.seconds, origin_mm=workspace.origin_mm,
                          homed=workspace.homed, settings=settings)
    return report, schedule


def _run(streamer: GrblStreamer, job: GcodeJob, report: StreamReport, schedule: Schedule,
         time_scale: float, progress: Callable[[Progress], None] | None) -> None:
    """Stream every line and wait for idle; fill in the report."""
    streamer.queue(job.lines)
    state = streamer.state
    t0: float | None = None
    told = -1
    ends = schedule.line_end_s
    while not streamer.done:
        streamer.pump()
        if t0 is None and state.sent:
            t0 = state.send_times[1]
        if progress is not None and state.acked != told:
            told = state.acked
            elapsed = (streamer.clock() - (t0 or streamer.clock())) * time_scale
            done_s = float(ends[told - 1]) if told else 0.0
            # (the ok of a motion line comes when it is queued: the planner's 15 blocks and
            # the receive buffer run ahead of the machine, so the wall clock bounds it too)
            left = max(schedule.seconds - done_s, schedule.seconds - elapsed, 0.0)
            progress(Progress(told, len(job.lines), elapsed, left, schedule.seconds))
    if not state.failure:
        streamer.wait_idle(IDLE_TIMEOUT_S)
    report.acked = state.acked
    if state.failure:
        report.failure = state.failure.replace(f" at G-code line {state.failed_line}", "")
        report.failed_line = _line_of(job, state.failed_line)
        return
    if t0 is not None:
        report.measured_s = (streamer.clock() - t0) * time_scale


def _line_of(job: GcodeJob, sent: int) -> int:
    """The file's line number of the ``sent``-th line sent (1-based; clamped)."""
    if not job.numbers:
        return 0
    return job.numbers[min(max(sent, 1), len(job.numbers)) - 1]


def _stop(streamer: GrblStreamer, pen: PenProfile, moving: bool) -> None:
    """Leave the plotter stopped with its pen up: a feed hold until the motion has stopped
    (a soft reset while moving loses the position: GRBL 1.1h raises ALARM:3 when homed), then
    :func:`.plant.safe_stop` (soft reset, ``$X``, the pen-up lines)."""
    if streamer.state.failure.startswith("the device disconnected"):
        return
    if moving:
        with contextlib.suppress(GrblError):
            streamer.feed_hold()
            end = time.monotonic() + HOLD_TIMEOUT_S
            while time.monotonic() < end:
                s = streamer.status(timeout_s=1.0)
                if s.state in ("Hold:0", "Idle") or s.state.startswith(("Alarm", "Door")):
                    break
                time.sleep(0.01)
    streamer.state.failure = streamer.state.failure or "stopped"
    safe_stop(streamer, pen, failed=True)


def progress_line(p: Progress) -> str:
    """One line of progress: ``1234/5080 lines  24.3 %  elapsed 3:12  remaining 9:40``."""
    return (f"{p.acked}/{p.total} lines  {p.percent:5.1f} %  elapsed {clock_text(p.elapsed_s)}"
            f"  remaining {clock_text(p.remaining_s)}")


def clock_text(seconds: float) -> str:
    """``seconds`` as ``M:SS`` (``H:MM:SS`` from an hour)."""
    s = max(round(seconds), 0)
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


__all__ = ["Progress", "StreamReport", "clock_text", "progress_line", "stream_file"]
