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
    return p


def load_drawing(source: str):
    """The drawing to plot: a scenario's placed drawing, or a drawing file."""
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix in (".svg", ".csv"):
        from inkarm.io.trace import load_trace

        return load_trace(path)
    if suffix == ".npz":
        from inkarm.core.trajectory import Drawing

        return Drawing.from_npz(path)
    if suffix == ".toml":  # placed on its sheet, as `inkarm draw --backend plotter` places it
        from inkarm.jobs.backends.plotter import page_size_mm, placed_on_sheet
        from inkarm.jobs.scenario import load_scenario

        scenario = load_scenario(path)
        try:
            return placed_on_sheet(scenario, page_size_mm(scenario))
        except InkarmError as e:
            raise e.within(file=scenario.path) from None
    raise InputError(f"{source}: expected a scenario (.toml) or a drawing "
                     f"({', '.join(DRAWING_SUFFIXES)})", key="source", value=source)


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.gcode import drawing_to_gcode
    from inkarm.hardware.plotter.profiles import load_profile
    from inkarm.hardware.plotter.timing import estimate_seconds

    out = check_out_file(args.out, "G-code", (".gcode", ".nc", ".ngc"), inputs=[args.source])
    if args.speed is not None and not 0 < args.speed <= 5000:
        raise InputError(f"expected a speed in (0, 5000] mm/s, got {args.speed:g}",
                         key="--speed", value=args.speed)
    profile = load_profile(args.profile)
    drawing = load_drawing(args.source)
    job = drawing_to_gcode(drawing, profile, optimise=args.optimise, speed_mm_s=args.speed)
    seconds = estimate_seconds(job.lines)
    with atomic_file(out) as partial:
        partial.write_text(job.text())
    print(f"{out}: {len(job.lines)} lines, {len(drawing.strokes)} strokes, pen profile "
          f"{profile.name!r}; estimated {seconds:.1f} s on GRBL's planner (default settings)")
    return 0
