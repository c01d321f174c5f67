"""``inkarm draw [SCENARIO.toml] [--robot NAME|FILE] [--out DIR]``: draw a scenario with a
simulated robot."""

from __future__ import annotations

import argparse
import functools
import math
import os
import sys
import time
from pathlib import Path

from inkarm.errors import InputError, unknown_name
from inkarm.io.outputs import check_out_dir
from inkarm.robots.registry import robot_names

MAX_FPS = 240.0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "draw",
        help="draw a scenario with the simulated arm (the embedded default without one), or on "
             "a Dynamixel arm, a GRBL plotter or an AxiDraw (--backend)",
        description="Build the scenario's drawing, check the arm can reach it, simulate the arm "
        "tracking it in MuJoCo and write canvas.png, trace.npz, metrics.json, report.png and "
        "reference.csv into --out. Schema: see inkarm.jobs.scenario.",
    )
    p.add_argument("scenario", nargs="?", default=None,
                   help="scenario file (TOML); default: the embedded letter N")
    p.add_argument("--robot", metavar="NAME|FILE.toml", default=None,
                   help="robot profile: a built-in name ("
                   f"{', '.join(robot_names())}) or a profile file; default: the scenario's")
    p.add_argument("--out", default="out/draw", help="output folder (default out/draw)")
    p.add_argument("--video", metavar="FILE.mp4", default=None,
                   help="also render an offscreen video (MUJOCO_GL=egl, else osmesa)")
    p.add_argument("--fps", type=float, default=30.0, help="video frame rate (default 30)")
    p.add_argument("--camera", default="drawing",
                   help="video camera: drawing, overview, paper_top or pen_cam (default drawing)")
    p.add_argument("--viewer", action="store_true",
                   help="open MuJoCo's viewer on the finished run (needs a display)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--backend", default="sim", metavar="NAME",
                   help="where to draw: sim (the MuJoCo arm, default), servo_sim (the arm on its "
                   "servos' firmware model), or a device on --port: plotter (GRBL 1.1), "
                   "axidraw (EiBotBoard), dynamixel; plug-ins add more (inkarm.jobs.backends)")
    p.add_argument("--port", default=None,
                   help="serial port of the device (a pseudo-terminal from `inkarm emulate`)")
    p.add_argument("--profile", metavar="NAME|FILE.toml", default=None,
                   help="device profile: for a plotter, the pen profile (servo, z) or a file; for an "
                   "AxiDraw, its model profile (v3, v3_a3) or a file; for a Dynamixel arm, its joint calibration file (default: <config>/calibration/<robot>.joints.toml, from `inkarm calibrate joints`)")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="device seconds per wall second: an emulator's --speedup (default 1)")
    p.add_argument("--calibration", metavar="FILE|auto|none", default=None,
                   help="what the controller believes of the cell (`inkarm calibrate`): a "
                   "calibration file, auto (the robot's file in the configuration folder, when "
                   "there is one) or none; default: the scenario's calibration key")
    p.add_argument("--check", action="store_true",
                   help="check the scenario (source, budgets, placement, reach) and stop before "
                   "simulating; writes nothing")
    return p


class ProgressBar:
    """A one-line progress bar on stderr, redrawn at most 10 times a second."""

    def __init__(self, label: str, stream=None, width: int = 30):
        self.label, self.stream, self.width = label, stream or sys.stderr, width
        self._last = 0.0
        self._t0 = time.perf_counter()

    def __call__(self, fraction: float, phase: str) -> None:
        now = time.perf_counter()
        if now - self._last < 0.1 and fraction < 1.0:
            return
        self._last = now
        filled = round(self.width * min(max(fraction, 0.0), 1.0))
        bar = "#" * filled + "-" * (self.width - filled)
        self.stream.write(f"\r{self.label} [{bar}] {100 * fraction:5.1f}% {phase:<8} "
                          f"{now - self._t0:5.1f}s")
        self.stream.flush()

    def close(self) -> None:
        self.stream.write("\n")
        self.stream.flush()


def check_video_options(args: argparse.Namespace) -> None:
    """``--video``, ``--fps`` and ``--camera``, checked before anything is simulated."""
    from inkarm.sim.cell import CAMERAS
    from inkarm.sim.replay import DRAWING_CAMERA

    cameras = (DRAWING_CAMERA, *CAMERAS)
    if args.camera not in cameras:
        raise unknown_name("camera", args.camera, cameras, key="--camera")
    if not (math.isfinite(args.fps) and 0 < args.fps <= MAX_FPS):
        raise InputError(f"expected frames per second in (0, {MAX_FPS:g}], got {args.fps:g}",
                         key="--fps", value=args.fps)
    if args.video is None:
        return
    video = Path(args.video)
    if video.suffix.lower() != ".mp4":
        raise InputError(f"{video}: expected a .mp4 file name", key="--video", value=args.video)
    folder = video.parent
    if video.is_dir() or not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{video}: cannot write there ({folder} is not a writable folder)",
                         key="--video", value=args.video)


def scenario_inputs(scenario) -> list[Path]:
    """The files a scenario reads (which its outputs must never overwrite)."""
    files = [Path(scenario.path)]
    source_file = getattr(scenario.source, "file", None)
    if source_file is not None:
        files.append(Path(source_file))
    if scenario.robot_ref.endswith(".toml"):
        files.append(Path(scenario.robot_ref))
    return [f for f in files if f.is_file()]


def summary_line(m) -> str:
    """The run's metrics in one line; what the backend does not sense says so (never "nan")."""
    from inkarm.core.run import metric_text

    f = {k: float(m.get(k, math.nan)) for k in ("contact_force_mean_n", "contact_force_std_n",
                                                 "force_p1_n", "force_p99_n")}
    force = ("not sensed" if math.isnan(f["contact_force_mean_n"]) else
             f"{f['contact_force_mean_n']:.2f} +- {f['contact_force_std_n']:.3f} N "
             f"({f['force_p1_n']:.2f}..{f['force_p99_n']:.2f} N while drawing)")
    return (f"tracking RMS {metric_text(m, 'tracking_rms_mm')}, max "
            f"{metric_text(m, 'tracking_max_mm')}; ink chamfer {metric_text(m, 'ink_chamfer_mm')}; "
            f"gaps {metric_text(m, 'gap_mm', spec='.2f')}; force {force}; joint margin "
            f"{metric_text(m, 'joint_limit_margin_rad', 'rad', '.2f')}; real-time factor "
            f"{metric_text(m, 'realtime_factor', '', '.1f')}")


def run(args: argparse.Namespace) -> int:
    check_out_dir(args.out)
    if args.video:  # offscreen GL must be chosen before anything imports mujoco
        from inkarm.sim.gl import configure_gl

        configure_gl()
    elif not args.viewer:  # this process renders nothing: MuJoCo without glfw
        from inkarm.sim.gl import import_mujoco_without_gl

        import_mujoco_without_gl()
    check_video_options(args)  # fail before a long simulation
    if args.video:
        from inkarm.sim.render import require_ffmpeg

        require_ffmpeg("inkarm draw --video")
    from inkarm.jobs.outputs import RUN_FILES, write_run
    from inkarm.jobs.run import RunInterrupted
    from inkarm.jobs.run import run as run_scenario
    from inkarm.jobs.scenario import load_scenario

    if args.viewer:
        from inkarm.sim.viewer import require_display

        require_display()
    scenario = load_scenario(args.scenario)
    if args.robot is not None:
        key = "robot.file" if args.robot.endswith(".toml") else "robot.name"
        robot = str(Path(args.robot).resolve()) if key == "robot.file" else args.robot
        scenario = scenario.with_overrides({"robot": {}, key: robot})
    if args.calibration is not None:
        from inkarm.jobs.calibration import with_calibration

        given = args.calibration
        scenario = with_calibration(scenario, None if given == "none" else given)
    out = check_out_dir(args.out, inputs=scenario_inputs(scenario), names=RUN_FILES)
    if args.check and args.backend != "sim":
        from inkarm.jobs.backends import BackendOptions, check_backend

        # with --port a device's own check (the plotter's GRBL check mode, $C); else offline
        summary = check_backend(args.backend, scenario, BackendOptions(
            port=args.port, profile=args.profile, time_scale=args.time_scale))
        if summary is not None:  # (else the arm's own check below)
            print(summary)
            return 0
    if args.check:
        from inkarm.jobs.run import check

        drawing = check(scenario)
        print(f"ok: {scenario.title!r}, {len(drawing.strokes)} strokes, "
              f"{sum(s.duration for s in drawing.strokes):.2f} s of drawing, within reach of "
              f"{scenario.robot.name}")
        return 0
    bar = None if args.quiet else ProgressBar(f"drawing {scenario.title!r} ({scenario.robot.name})")
    if args.backend != "sim" or args.port is not None:
        from inkarm.jobs.backends import BackendOptions, get_backend, run_backend

        get_backend(args.backend)  # an unknown name fails here, before the port is opened
        options = BackendOptions(port=args.port, profile=args.profile,
                                 time_scale=args.time_scale)
        run_scenario = functools.partial(run_backend, args.backend, options=options)
    try:
        result = run_scenario(scenario, progress=bar)
    except RunInterrupted as interrupted:
        if bar is not None:
            bar.close()
        write_run(interrupted.run, out)
        print(f"inkarm draw: interrupted; partial trace and canvas kept in {out}, status "
              f"'interrupted' in {out / 'status.json'}", file=sys.stderr)
        return 130
    if bar is not None:
        bar.close()
    files = write_run(result, out)
    for note in result.notes:
        print(f"note: {note}")
    if not result.finished:
        print(f"inkarm draw: error: the run failed: {result.reason} (partial trace and canvas "
              f"kept in {out}, status in {files['status.json']})", file=sys.stderr)
        return 1
    if not result.ok:
        print(f"inkarm draw: warning: the drawing is {result.status}: {result.reason}",
              file=sys.stderr)
    print(summary_line(dict(result.metrics)))
    for unjudged in result.unjudged:  # the backend cannot sense these: never passed in silence
        print(unjudged)  # "force_band_n not judged: <why>"
    out = Path(args.out)
    print(f"pictures: {out / 'canvas.png'} (ink), {out / 'report.png'} (ink over plan, "
          f"tracking error, force, speed)")
    print(f"data: {out / 'metrics.json'}, {out / 'trace.npz'}, {out / 'reference.csv'}")
    threshold = scenario.controller.contact_threshold_n
    if args.video:
        from inkarm.sim.replay import render_log_video

        bar = None if args.quiet else ProgressBar("video")
        final = Path(args.video)
        partial = final.with_name(f".{final.stem}.partial.mp4")
        try:
            video = render_log_video(result.log, partial, result.cell,
                                     px_per_mm=scenario.ink.px_per_mm, ink=scenario.ink.make(),
                                     fps=args.fps, camera=args.camera,
                                     contact_threshold_n=threshold, progress=bar)
            video = Path(os.replace(video, final) or final)
        finally:
            partial.unlink(missing_ok=True)
            if bar is not None:
                bar.close()
        print(f"video: {video}")
    if args.viewer:
        from inkarm.sim.viewer import open_viewer

        open_viewer(result.log, result.cell, ink=scenario.ink.make(),
                    contact_threshold_n=threshold)
    return 0
