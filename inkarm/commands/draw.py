"""``inkarm draw [SCENARIO.toml] [--robot NAME|FILE] [--out DIR]``: draw a scenario with a
simulated robot."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from inkarm.commands import output_folder
from inkarm.robots.registry import robot_names


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "draw",
        help="draw a scenario with the simulated 7-DOF arm (the embedded default without one)",
        description="Build the scenario's drawing, check the arm can reach it, simulate the arm "
        "tracking it in MuJoCo and write canvas.png, trace.npz, metrics.json, report.png and "
        "reference.csv into --out. Schema: see inkarm.jobs.scenario.",
    )
    p.add_argument("scenario", nargs="?", default=None,
                   help="scenario file (TOML); default: the embedded letter N")
    p.add_argument("--robot", metavar="NAME|FILE.toml", default=None,
                   help="robot profile: a built-in name (inkarm robots: "
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
    return p


class ProgressBar:
    """A one-line progress bar on stderr, redrawn at most 10 times a second."""

    def __init__(self, label: str, stream=sys.stderr, width: int = 30):
        self.label, self.stream, self.width = label, stream, width
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


def run(args: argparse.Namespace) -> int:
    if args.video:  # fail before a long simulation, and pick offscreen GL before mujoco loads
        from inkarm.sim.gl import configure_gl

        configure_gl()
        from inkarm.sim.render import require_ffmpeg

        require_ffmpeg("inkarm draw --video")
    if args.viewer:
        from inkarm.sim.viewer import require_display

        require_display()
    from inkarm.jobs.outputs import write_run
    from inkarm.jobs.run import run as run_scenario
    from inkarm.jobs.scenario import load_scenario

    output_folder(args.out)
    scenario = load_scenario(args.scenario)
    if args.robot is not None:
        key = "robot.file" if args.robot.endswith(".toml") else "robot.name"
        robot = str(Path(args.robot).resolve()) if key == "robot.file" else args.robot
        scenario = scenario.with_overrides({"robot": {}, key: robot})
    bar = None if args.quiet else ProgressBar(f"drawing {scenario.title!r} ({scenario.robot.name})")
    try:
        result = run_scenario(scenario, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    files = write_run(result, args.out)
    out = Path(args.out)
    for note in result.notes:
        print(f"note: {note}")
    if not result.ok:
        print(f"inkarm draw: error: the run failed: {result.reason} (partial trace and canvas "
              f"kept in {out}, status in {files['status.json']})", file=sys.stderr)
        return 1
    m = result.metrics
    print(
        f"tracking RMS {m['tracking_rms_mm']:.3f} mm, max {m['tracking_max_mm']:.3f} mm; "
        f"ink chamfer {m['ink_chamfer_mm']:.3f} mm; gaps {m['gap_mm']:.2f} mm; "
        f"force {m['contact_force_mean_n']:.2f} +- {m['contact_force_std_n']:.3f} N; "
        f"joint margin {m['joint_limit_margin_rad']:.2f} rad; "
        f"real-time factor {m['realtime_factor']:.1f}"
    )
    out = Path(args.out)
    print(f"pictures: {out / 'canvas.png'} (ink), {out / 'report.png'} (ink over plan, "
          f"tracking error, force, speed)")
    print(f"data: {out / 'metrics.json'}, {out / 'trace.npz'}, {out / 'reference.csv'}")
    threshold = scenario.controller.contact_threshold_n
    if args.video:
        from inkarm.sim.replay import render_log_video

        bar = None if args.quiet else ProgressBar("video")
        try:
            video = render_log_video(result.log, args.video, result.cell,
                                     px_per_mm=scenario.ink.px_per_mm, ink=scenario.ink.make(),
                                     fps=args.fps, camera=args.camera,
                                     contact_threshold_n=threshold, progress=bar)
        finally:
            if bar is not None:
                bar.close()
        print(f"video: {video}")
    if args.viewer:
        from inkarm.sim.viewer import open_viewer

        open_viewer(result.log, result.cell, ink=scenario.ink.make(),
                    contact_threshold_n=threshold)
    return 0
