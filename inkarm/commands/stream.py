"""``inkarm stream FILE.gcode --port PORT``: stream a G-code file made elsewhere (vpype-gcode,
Inkscape, a CAM program) to a GRBL 1.1 plotter, with progress and the planner's estimate."""

from __future__ import annotations

import argparse
import math
import sys

from inkarm.errors import InputError

ORIGINS = ("auto", "lower-left", "lower-right", "upper-left", "upper-right", "machine-zero",
           "current")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "stream",
        help="stream a G-code file to a GRBL plotter (character counting, progress, estimate)",
        description="Check a G-code file as GRBL 1.1 reads it (every line, and every move "
        "against the machine's travel read from the device: $130/$131, homing and soft "
        "limits), estimate its time on the emulator's planner with the device's settings, "
        "then stream it with character counting. Exit 2: the file or a move is refused "
        "(nothing moved); 1: the device answered error:N or ALARM:N (the motion was stopped "
        "and the pen lifted); 130: Ctrl-C (feed hold, soft reset, pen up).",
    )
    p.add_argument("file", metavar="FILE.gcode", help="the G-code file")
    p.add_argument("--port", required=True,
                   help="serial port of the plotter (or a pseudo-terminal from `inkarm emulate "
                   "grbl`)")
    p.add_argument("--baudrate", type=int, default=115200, help="bit/s (default 115200)")
    p.add_argument("--origin", default="auto", choices=ORIGINS,
                   help="where the file's X0 Y0 goes: auto (the travel's lower-left corner on "
                   "a machine that homes, machine zero otherwise), a corner of the travel, "
                   "machine-zero, or current (where the pen stands)")
    p.add_argument("--no-home", action="store_true",
                   help="do not run $H on a machine with homing ($22=1): unlock with $X and "
                   "take it as standing at home")
    p.add_argument("--profile", metavar="NAME|FILE.toml", default=None,
                   help="pen profile whose pen-up lines end a stopped job: servo (M5, default), "
                   "z (G0 Z5), or a profile file")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="device seconds per wall second: an emulator's --speedup (default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress")
    return p


class ProgressPrinter:
    """Progress on stderr: one line redrawn in place on a terminal (at most 5 times a second),
    else a line every 10 %."""

    def __init__(self, stream=None):
        import time

        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self._clock = time.monotonic
        self._last = -math.inf
        self._decile = -1

    def __call__(self, p) -> None:
        from inkarm.hardware.plotter.file_stream import progress_line

        if self.tty:
            now = self._clock()
            if now - self._last >= 0.2 or p.acked == p.total:
                self._last = now
                self.stream.write(f"\r{progress_line(p)}\x1b[K")
                self.stream.flush()
        elif int(p.percent // 10) > self._decile:
            self._decile = int(p.percent // 10)
            print(progress_line(p), file=self.stream, flush=True)

    def end(self) -> None:
        if self.tty and self._last > -math.inf:
            self.stream.write("\n")


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.file_stream import clock_text, stream_file
    from inkarm.hardware.plotter.gcode_file import read_gcode_file
    from inkarm.hardware.plotter.workspace import Placement

    if not 0 < args.time_scale <= 1000:
        raise InputError(f"expected a time scale in (0, 1000], got {args.time_scale:g}",
                         key="--time-scale", value=args.time_scale)
    job = read_gcode_file(args.file)
    printer = None if args.quiet else ProgressPrinter()

    def ready(report, schedule) -> None:
        print(f"{report.path}: {report.lines} lines, {report.bytes} bytes; estimated "
              f"{report.estimate_s:.1f} s ({clock_text(report.estimate_s)}) on the device's "
              f"settings; page origin at machine ({report.origin_mm[0]:g}, "
              f"{report.origin_mm[1]:g}) mm" + (", homed" if report.homed else ""), flush=True)

    placement = Placement(args.origin, "skip" if args.no_home else "auto")
    try:
        report = stream_file(args.file, args.port, baudrate=args.baudrate,
                             time_scale=args.time_scale, placement=placement,
                             profile=args.profile, progress=printer, on_estimate=ready,
                             job=job)
    except KeyboardInterrupt as stop:
        if printer is not None:
            printer.end()
        report = getattr(stop, "report", None)
        where = f" at line {report.failed_line} of {args.file}" if report and \
            report.failed_line else ""
        print(f"inkarm stream: interrupted{where}: feed hold, soft reset, pen up",
              file=sys.stderr)
        return 130
    if printer is not None:
        printer.end()
    if not report.ok:
        after = ("nothing more could be sent or stopped" if "disconnected" in report.failure
                 else "motion stopped, pen up")
        print(f"inkarm stream: error: {args.file}: line {report.failed_line}: the plotter "
              f"stopped: {report.failure}; {report.acked} of {report.lines} lines answered ok; "
              f"{after}", file=sys.stderr)
        return 1
    diff = 100.0 * (report.measured_s / report.estimate_s - 1.0) if report.estimate_s else 0.0
    print(f"done: {report.lines} lines, {report.bytes} bytes in {report.measured_s:.1f} s "
          f"(estimated {report.estimate_s:.1f} s, {diff:+.1f} %)")
    return 0
