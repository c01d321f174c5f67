"""``inkarm calibrate joints|paper|pen|kinematics|all``: find out how the real cell differs from the
model and store it in the robot's calibration file (the user's configuration folder).

- ``joints --port PORT --robot NAME``: a Dynamixel arm's joint zeros and directions (move each
  joint to its marks), written to ``<config>/calibration/<robot>.joints.toml``;
- ``paper [SCENARIO]``: probe the sheet along the scenario's drawing (or on a grid over it)
  and store its height map;
- ``pen [SCENARIO]``: the pen's tool-centre point (tip offset);
- ``kinematics [SCENARIO]``: link lengths and joint offsets from drawn marks.

``paper``, ``pen`` and ``kinematics`` merge their result into ``--out`` (default the robot's
``<config>/calibration/<robot>.toml``; ``inkarm draw --calibration auto`` reads it), keeping
what the file held besides; each probes believing what the file already holds, except the part
it measures (so run them in the order pen, kinematics, paper: each later one draws with what the
earlier found). ``all`` runs pen, kinematics and paper in that order (the order that
works: :mod:`inkarm.jobs.calibration_cell`). The old form ``inkarm calibrate --port PORT`` is
``calibrate joints``.

A real arm's marks are on a real sheet, not on a canvas: ``pen``, ``kinematics`` and ``paper``
then take two steps. ``--drawn FILE.npz`` draws the pattern on the backend, saves what the fit
needs (:mod:`inkarm.jobs.calibration_files`) and stops; ``--read FILE.npz --scan SHEET.png
[--corners "u,v u,v u,v u,v"]`` fits it to the scan's marks (nothing moves) and merges the
result as above. ``paper`` draws ramped dashes in both steps (their ink tells the height).
"""

from __future__ import annotations

import argparse
from pathlib import Path

SUBCOMMANDS = ("joints", "paper", "pen", "kinematics", "all")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "calibrate",
        help="calibrate the cell: joint zeros, the paper's height map, the pen tip, the "
        "arm's kinematics",
        description="Measure how the real cell differs from the model and store it in the "
        "robot's calibration file, in the user's configuration folder ($INKARM_CONFIG_DIR, "
        "else $XDG_CONFIG_HOME/inkarm, else ~/.config/inkarm), which `inkarm draw "
        "--calibration auto` (or a scenario's calibration = \"auto\") reads.",
    )
    # the form of inkarm <= 0.x: `inkarm calibrate --port P [--robot R] [--out F]` = joints
    p.add_argument("--port", dest="legacy_port", default=None, help=argparse.SUPPRESS)
    p.add_argument("--robot", dest="legacy_robot", default="wx250s", help=argparse.SUPPRESS)
    p.add_argument("--out", dest="legacy_out", default=None, help=argparse.SUPPRESS)
    sub = p.add_subparsers(dest="what", metavar="WHAT", parser_class=type(p))
    joints = sub.add_parser(
        "joints", help="a Dynamixel arm's joint zeros and directions",
        description="Turn the servos' torque off and, joint by joint, ask you to move the "
        "joint to its zero mark and to a mark 90 degrees positive (press Enter at each); "
        "writes <config>/calibration/<robot>.joints.toml (or --out), which `inkarm draw "
        "--backend dynamixel` reads. Answers come from stdin, so a script can drive it.")
    joints.add_argument("--port", required=True,
                        help="serial port of the arm (or an emulator's pty)")
    joints.add_argument("--robot", default="wx250s", metavar="NAME|FILE.toml",
                        help="robot profile with a [backends.dynamixel] table (default wx250s)")
    joints.add_argument("--out", metavar="FILE.toml", default=None,
                        help="joint calibration file (default: in the configuration folder)")
    for name, help_, description in (
        ("paper", "probe the sheet along the drawing and store its height map",
         ("Touch the sheet at dots every --spacing mm along the scenario's drawing (the force "
          "loop settles at each), take each dot's height from the joint readings, the model "
          "and the force, fit a smooth height map and store it.")),
        ("pen", "find the pen's tool-centre point (tip offset)",
         ("Draw marks with the pen at several orientations and fit where its tip really is "
          "in the flange frame; store the tip offset.")),
        ("kinematics", "fit link lengths and joint offsets from drawn marks",
         ("Draw a pattern of dots, measure where they landed and fit link-length and "
          "joint-offset corrections by least squares; store them and report before/after.")),
        ("all", "the pen, the kinematics and the paper, in that order",
         ("Calibrate the pen, then the arm's kinematics believing that pen, then the paper "
          "through both (a backend without a force sensor: ramped dashes read from their "
          "ink); store all three.")),
    ):
        s = sub.add_parser(name, help=help_, description=description)
        s.add_argument("scenario", nargs="?", default=None,
                       help="scenario file (TOML); default: the embedded letter N")
        s.add_argument("--robot", metavar="NAME|FILE.toml", default=None,
                       help="robot profile (default: the scenario's)")
        s.add_argument("--backend", default="sim", metavar="NAME",
                       help="where to probe: sim (default) or a device on --port (dynamixel)")
        s.add_argument("--port", default=None, help="serial port of the device")
        s.add_argument("--time-scale", type=float, default=1.0,
                       help="device seconds per wall second: an emulator's --speedup")
        s.add_argument("--out", metavar="FILE.toml", default=None,
                       help="calibration file to merge into (default: the robot's, in the "
                       "configuration folder)")
        s.add_argument("--quiet", action="store_true", help="no progress bar")
        if name != "all":  # a real arm: draw, scan the sheet, then read the scan
            s.add_argument("--drawn", metavar="FILE.npz", default=None,
                           help="draw the pattern, save what the fit needs to FILE.npz and "
                           "stop (then scan the sheet and run with --read)")
            s.add_argument("--read", metavar="FILE.npz", default=None,
                           help="fit a pattern drawn with --drawn from the scan --scan "
                           "(nothing moves)")
            s.add_argument("--scan", metavar="SHEET.png", default=None,
                           help="with --read: a scan or photograph of the drawn sheet")
            s.add_argument("--corners", metavar='"u,v u,v u,v u,v"', default=None,
                           help="with --scan: the sheet's corners in pixels (u right, v down; "
                           "lower-left, lower-right, upper-right, upper-left); default the "
                           "image's own (an emulator's PNG covers the page exactly)")
        if name in ("paper", "all"):
            s.add_argument("--spacing", type=float, default=10.0 if name == "paper" else 5.0,
                           metavar="MM",
                           help="distance between probe dots (default 10 mm, all: 5; 5 or less for "
                           "relief of 30 mm wavelength, a third of a bump's width)")
            s.add_argument("--pattern", choices=("path", "grid"), default="path",
                           help="where to probe: along the drawing's path (default; where it "
                           "inks anyway) or on a grid over its bounding box (dots off the "
                           "path: a scratch sheet)")
    return p


def run(args: argparse.Namespace) -> int:
    from inkarm.errors import InputError

    what = getattr(args, "what", None)
    if what is None:
        if args.legacy_port is None:
            raise InputError(f"expected what to calibrate: {', '.join(SUBCOMMANDS)} (e.g. "
                             "`inkarm calibrate joints --port PORT` for a Dynamixel arm's "
                             "zeros)", key="WHAT")
        return _joints(args.legacy_port, args.legacy_robot, args.legacy_out)
    if what == "joints":
        return _joints(args.port, args.robot, args.out)
    drawn, read = getattr(args, "drawn", None), getattr(args, "read", None)
    scan, corners = getattr(args, "scan", None), getattr(args, "corners", None)
    if drawn is not None and read is not None:
        raise InputError("--drawn draws a pattern and --read fits a drawn one: give one of "
                         "them", key="--read", value=read)
    if read is None and (scan is not None or corners is not None):
        raise InputError("--scan and --corners go with --read FILE.npz (the pattern they "
                         "show)", key="--scan" if scan is not None else "--corners")
    if read is not None:
        if scan is None:
            raise InputError(f"--read {read} needs the scan of its sheet: --scan SHEET.png",
                             key="--scan")
        return _read_scan(args, what)
    return _cell(args, what)


def _joints(port: str, robot: str, out: str | None) -> int:
    from inkarm.hardware.dynamixel.calibration import calibrate_arm
    from inkarm.robots.registry import load_robot

    profile = load_robot(robot)
    calibrate_arm(port, profile, Path(out) if out else None)
    return 0


def _cell(args: argparse.Namespace, what: str) -> int:
    import math

    from inkarm.commands.draw import ProgressBar
    from inkarm.errors import InputError
    from inkarm.jobs.backends import BackendOptions, get_backend
    from inkarm.jobs.calibration import believing
    from inkarm.jobs.scenario import load_scenario
    from inkarm.robots.calibration import calibration_path

    spacing = getattr(args, "spacing", 10.0)
    if not (math.isfinite(spacing) and 0.5 <= spacing <= 100.0):
        raise InputError(f"expected a spacing of 0.5 to 100 mm, got {spacing:g}",
                         key="--spacing", value=spacing)
    scenario = load_scenario(args.scenario)
    if args.robot is not None:
        key = "robot.file" if args.robot.endswith(".toml") else "robot.name"
        robot = str(Path(args.robot).resolve()) if key == "robot.file" else args.robot
        scenario = scenario.with_overrides({"robot": {}, key: robot})
    get_backend(args.backend)  # an unknown name fails here, before anything moves
    robot = scenario.robot.name
    out = Path(args.out) if args.out else calibration_path(robot)
    # `all` measures every part: it starts from the nominal cell (the file's robot still checked)
    scenario = believing(scenario, out, "paper" if what == "all" else what)
    if what == "all":
        from inkarm.jobs.calibration import with_calibration

        scenario = with_calibration(scenario, None)
    options = BackendOptions(port=args.port, time_scale=args.time_scale)
    bar = None if args.quiet else ProgressBar(f"calibrate {what} ({robot})")
    if getattr(args, "drawn", None) is not None:
        return _draw_only(args, what, scenario, options, bar, spacing)
    try:
        if what == "all":
            from inkarm.jobs.calibration_cell import calibrate_cell

            found = calibrate_cell(scenario, args.backend, options, bar, spacing,
                                   pattern=args.pattern)
            summary = found.describe()
            update = {"geometry": found.geometry}
            if found.paper is not None:
                update["paper"] = found.paper
        elif what == "paper":
            from inkarm.jobs.calibration import probe_paper, probe_paper_marks

            if getattr(get_backend(args.backend), "senses_force", True):
                probe = probe_paper(scenario, args.backend, options, spacing, bar,
                                    pattern=args.pattern)
            else:  # ramped dashes read from their ink (the emulator's twin draws it)
                probe = probe_paper_marks(scenario, args.backend, options, max(spacing, 10.0),
                                          bar)
            summary = probe.summary()
            update = {"paper": probe.map}
        else:
            summary, geometry = _geometry(what, scenario, args.backend, options, bar, out)
            update = {"geometry": geometry}
    finally:
        if bar is not None:
            bar.close()
    return _merged(what, summary, f"{args.backend}, scenario {scenario.title!r}", robot, out,
                   update)


def _merged(what: str, summary: str, source: str, robot: str, out, update: dict) -> int:
    """Merge ``update`` into the calibration file ``out`` with a note (the summary's first line
    and where it came from) and say what was found and written."""
    from inkarm.jobs.calibration import update_calibration
    from inkarm.robots.calibration import calibration_path

    first = summary.splitlines()[0] if summary else ""  # (a report's first line in the file)
    cal, path = update_calibration(robot, out, note=f"{what}: {first} ({source})", **update)
    print(f"{what}: {summary}")
    print(f"calibration of {robot}: {cal.describe()}")
    print(f"wrote {path} (draw with it: inkarm draw --calibration "
          f"{'auto' if path == calibration_path(robot) else path})")
    return 0


def _geometry(what: str, scenario, backend: str, options, progress, out: Path):
    """The pen's or the arm's fit (inkarm.jobs.calibration_pen / _kinematics) merged into the
    geometry the file ``out`` holds: pen -> the tip offset only, kinematics -> the link
    lengths and joint offsets only."""
    import dataclasses
    import importlib

    from inkarm.errors import InputError
    from inkarm.robots.calibration import read_calibration
    from inkarm.robots.geometry import GeometryErrors

    module = f"inkarm.jobs.calibration_{what}"
    try:
        fits = importlib.import_module(module)
    except ModuleNotFoundError as e:
        if e.name != module:
            raise
        raise InputError(f"calibrate {what} is not available in this installation (no "
                         f"{module})", key="WHAT", value=what) from None
    held = read_calibration(out).geometry if out.is_file() else GeometryErrors()
    if what == "pen":
        fitted = fits.calibrate_pen(scenario, backend, options, progress)
        tip = fitted.tip_offset_mm
        return (f"tip offset ({', '.join(f'{v:+.3f}' for v in tip)}) mm in the flange frame",
                dataclasses.replace(held, tip_offset_mm=tip))
    fitted, report = fits.calibrate_kinematics(scenario, backend, options, progress)
    return report, dataclasses.replace(held, link_length_mm=fitted.link_length_mm,
                                       joint_offset_deg=fitted.joint_offset_deg)


def _draw_only(args: argparse.Namespace, what: str, scenario, options, bar,
               spacing: float) -> int:
    """``--drawn FILE``: draw the pattern of ``what`` on the backend, save what its fit needs
    (:mod:`inkarm.jobs.calibration_files`) and say what to do next."""
    try:
        if what == "pen":
            from inkarm.jobs.calibration_pen import draw_pen, save_pen

            path = save_pen(draw_pen(scenario, args.backend, options, progress=bar), scenario,
                            args.drawn)
        elif what == "kinematics":
            from inkarm.jobs.calibration_kinematics import draw_pattern, save_pattern

            path = save_pattern(draw_pattern(scenario, args.backend, options, progress=bar),
                                scenario, args.drawn)
        else:  # the paper from ramped dashes' ink: what a scan shows on any arm
            from inkarm.jobs.calibration import draw_dashes, save_dashes

            path = save_dashes(draw_dashes(scenario, args.backend, options, max(spacing, 10.0),
                                           bar), scenario, args.drawn)
    finally:
        if bar is not None:
            bar.close()
    out = f" --out {args.out}" if args.out else ""
    print(f"drew the {what} pattern of {scenario.robot.name} ({args.backend}); wrote {path}")
    print(f"next: scan or photograph the sheet (the whole page), then run\n"
          f"  inkarm calibrate {what} --read {path} --scan SHEET.png{out}\n"
          "(add --corners \"u,v u,v u,v u,v\", the sheet's lower-left, lower-right, upper-right "
          "and upper-left corners in pixels, when the image shows more than the page)")
    return 0


def _read_scan(args: argparse.Namespace, what: str) -> int:
    """``--read FILE --scan SHEET [--corners ...]``: fit the pattern drawn with ``--drawn`` to
    the marks of the scan and merge the result into the calibration file, as the one-step
    form does. Nothing moves."""
    import dataclasses

    from inkarm.control.calibration.marks import image_marks, read_darkness
    from inkarm.errors import InputError
    from inkarm.jobs.calibration_files import parse_corners, scan_corners
    from inkarm.robots.calibration import calibration_path, read_calibration
    from inkarm.robots.geometry import GeometryErrors
    from inkarm.sim.cell_config import Cell

    robot = args.robot
    if robot is not None and robot.endswith(".toml"):  # a profile file: the name it gives
        from inkarm.robots.registry import load_robot

        robot = load_robot(robot).name
    if what == "pen":
        from inkarm.jobs.calibration_pen import load_pen

        drawn, scenario = load_pen(args.read, robot)
    elif what == "kinematics":
        from inkarm.jobs.calibration_kinematics import load_pattern

        drawn, scenario = load_pattern(args.read, robot)
    else:
        from inkarm.jobs.calibration import load_dashes

        drawn, scenario = load_dashes(args.read, robot)
    corners_given = parse_corners(args.corners)
    darkness = read_darkness(args.scan)
    page = Cell(scenario.cell, scenario.robot).paper_size_mm
    corners = scan_corners(darkness, corners_given, page, args.scan)
    if len(image_marks(darkness, corners, page).page_mm) == 0:
        raise InputError(f"no marks found in {args.scan} inside the sheet's corners "
                         f"{corners.tolist()} (is it the drawn sheet, dark ink on light "
                         "paper?)", key="--scan", value=str(args.scan))
    name = scenario.robot.name
    out = Path(args.out) if args.out else calibration_path(name)
    held = (read_calibration(out).geometry if out.is_file() and what != "paper"
            else GeometryErrors())
    if what == "pen":
        from inkarm.jobs.calibration_pen import fit_pen

        found = fit_pen(drawn, darkness, corners)
        tip = found.geometry.tip_offset_mm
        summary = (f"tip offset ({', '.join(f'{v:+.3f}' for v in tip)}) mm in the flange "
                   f"frame\n{found.fit.summary()}")
        update = {"geometry": dataclasses.replace(held, tip_offset_mm=tip)}
    elif what == "kinematics":
        from inkarm.jobs.calibration_kinematics import fit_pattern

        fit = fit_pattern(drawn, darkness, corners)
        summary = fit.report()
        update = {"geometry": dataclasses.replace(
            held, link_length_mm=fit.geometry.link_length_mm,
            joint_offset_deg=fit.geometry.joint_offset_deg)}
    else:
        from inkarm.jobs.calibration import read_dashes

        probe = read_dashes(drawn, darkness, corners)
        summary = probe.summary()
        update = {"paper": probe.map}
    return _merged(what, summary, f"scan {Path(args.scan).name} of {Path(args.read).name}",
                   name, out, update)
