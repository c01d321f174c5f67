"""``inkarm gcode SCENARIO.toml|DRAWING.{svg,csv,npz} --out FILE.gcode``: G-code for a GRBL pen
plotter, with its time estimate on the emulator's planner."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.errors import InkarmError, InputError
from inkarm.io.outputs import atomic_file, check_out_file

DRAWING_SUFFIXES = (".svg", ".csv", ".npz")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "gcode",
        help="write G-code for a GRBL pen plotter from a scenario or a drawing",
        description="Place the scenario's drawing on its page (or read a drawing: SVG as vpype "
        "writes it, CSV t,x,y,stroke, NPZ), and write G-code for a GRBL 1.1 pen plotter with "
        "a pen profile; prints the time estimate of the emulator's planner.",
    )
    p.add_argument("source", help="scenario (.toml) or drawing (.svg, .csv, .npz), page mm")
    p.add_argument("--out", required=True, metavar="FILE.gcode", help="G-code file to write")
    p.add_argument("--profile", metavar="NAME|FILE.toml", default=None,
                   help="pen profile: servo (default), z, or a profile file")
    p.add_argument("--optimise", action="store_true",
                   help="join and reorder strokes to shorten pen-up travel (changes writing "
                   "order and direction)")
    p.add_argument("--speed", type=float, default=None, metavar="MM_S",
                   help="pen-down speed in mm/s (default: the drawing's own timing)")
    p.add_argument("--travel", default=None, metavar="X,Y",
                   help="the machine's X and Y travel in mm ($130, $131; default: those of "
                   "`inkarm emulate grbl`): every point must lie within it, from the page's "
                   "lower-left corner")
    return p


def _default_travel() -> tuple[float, float]:
    from inkarm.hardware.plotter.settings import DEFAULT_SETTINGS

    return (DEFAULT_SETTINGS[130], DEFAULT_SETTINGS[131])


def parse_travel(text: str | None) -> tuple[float, float]:
    """``--travel X,Y`` [mm], each in (0, 10000]."""
    if text is None:
        return _default_travel()
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 2 or not all(0 < v <= 10000 for v in values):
        raise InputError(f"expected the X and Y travel in mm as X,Y (each in (0, 10000]), got "
                         f"{text!r}", key="--travel", value=text)
    return (values[0], values[1])


def load_job(source: str, profile: str | None):
    """The drawing to plot and its pen profile (``profile``: for a scenario, its own
    ``[plotter]`` profile and placement otherwise), and the scenario (None for a drawing
    file)."""
    from inkarm.hardware.plotter.profiles import load_profile

    path = Path(source)
    if path.suffix.lower() == ".toml":
        from inkarm.jobs.backends.plotter import prepared
        from inkarm.jobs.scenario import load_scenario

        scenario = load_scenario(path)
        pen, _, drawing = prepared(scenario, profile)
        return drawing, pen, scenario
    return load_drawing_file(source), load_profile(profile), None


def load_drawing_file(source: str):
    """A drawing file (SVG as vpype writes it, CSV, NPZ) in page millimetres."""
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix in (".svg", ".csv"):
        from inkarm.io.trace import load_trace

        return load_trace(path)
    if suffix == ".npz":
        from inkarm.core.trajectory import Drawing

        return Drawing.from_npz(path)
    raise InputError(f"{source}: expected a scenario (.toml) or a drawing "
                     f"({', '.join(DRAWING_SUFFIXES)})", key="source", value=source)


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.gcode import check_travel, drawing_to_gcode
    from inkarm.hardware.plotter.timing import estimate_seconds

    out = check_out_file(args.out, "G-code", (".gcode", ".nc", ".ngc"), inputs=[args.source])
    if args.speed is not None and not 0 < args.speed <= 5000:
        raise InputError(f"expected a speed in (0, 5000] mm/s, got {args.speed:g}",
                         key="--speed", value=args.speed)
    travel = parse_travel(args.travel)
    drawing, profile, scenario = load_job(args.source, args.profile)
    try:
        check_travel(drawing, travel)
    except InkarmError as e:
        raise e.within(file=args.source) from None
    job = drawing_to_gcode(drawing, profile, optimise=args.optimise, speed_mm_s=args.speed)
    seconds = estimate_seconds(job.lines)
    with atomic_file(out) as partial:
        partial.write_text(job.text())
    print(f"{out}: {len(job.lines)} lines, {len(drawing.strokes)} strokes, pen profile "
          f"{profile.name!r}; estimated {seconds:.1f} s on GRBL's planner (default settings)")
    if scenario is not None:
        from inkarm.jobs.backends.plotter import PERIOD_S, run_lines

        sent = run_lines(scenario, profile, drawing)
        print(f"note: `inkarm draw --backend plotter` streams {len(sent)} lines for this "
              f"scenario instead (one per {PERIOD_S * 1000:g} ms of the pen path, the arms' "
              f"pen sequencing), about {estimate_seconds(sent):.1f} s; this file follows the "
              "drawing's own samples")
    return 0
