"""``inkarm gcode SCENARIO.toml|DRAWING.{svg,csv,npz} --out FILE.gcode``: G-code for a GRBL pen
plotter, with its time estimate on the emulator's planner."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import say_skipped
from inkarm.commands._layout import (
    LAYOUT_OPTIONS,
    add_layout_options,
    laid_out,
    layout_from,
    layout_summary,
)
from inkarm.errors import InkarmError, InputError
from inkarm.io.outputs import atomic_file, check_out_file

DRAWING_SUFFIXES = (".svg", ".csv", ".npz")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "gcode",
        help="write G-code for a GRBL pen plotter from a scenario or a drawing",
        description="Place the scenario's drawing on its page (or read a drawing: SVG as vpype "
        "writes it, CSV t,x,y,stroke, NPZ), and write G-code for a GRBL 1.1 pen plotter with "
        "a pen profile; prints the time estimate of the emulator's planner. A drawing is laid "
        "out with vpype's options (--page-size a4 --fit-to-margins 10mm ...); a scenario, by "
        "its [placement] table. Every point must lie within the machine's travel (--travel): "
        "the first one outside is named and nothing is written.",
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
    add_layout_options(p)
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
    """A drawing file (SVG as vpype writes it, CSV, NPZ) in page millimetres; what an SVG
    reading skipped is said on stderr in one line."""
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix in (".svg", ".csv"):
        from inkarm.io.trace import load_trace

        drawing = load_trace(path)
        say_skipped(drawing, source)
        return drawing
    if suffix == ".npz":
        from inkarm.core.trajectory import Drawing

        return Drawing.from_npz(path)
    raise InputError(f"{source}: expected a scenario (.toml) or a drawing "
                     f"({', '.join(DRAWING_SUFFIXES)})", key="source", value=source)


def warn_off_page(drawing, source: str) -> None:
    """Say on stderr where a laid-out drawing leaves its page (the pen would draw beyond the
    paper, within the machine's travel): its first point off the page."""
    import sys

    from inkarm.plans.page import outside

    first = outside(drawing, (0.0, 0.0), drawing.page_size)
    if first is not None:
        s, i = first
        x, y = drawing.strokes[s].pos[i, :2]
        w, h = drawing.page_size
        print(f"inkarm gcode: warning: {source}: stroke {s + 1} point {i + 1} at ({x:.2f}, "
              f"{y:.2f}) mm lies off the {w:g} x {h:g} mm page; --fit-to-margins fits the "
              "drawing to it", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.gcode import check_travel, drawing_to_gcode
    from inkarm.hardware.plotter.timing import estimate_seconds

    out = check_out_file(args.out, "G-code", (".gcode", ".nc", ".ngc"), inputs=[args.source])
    if args.speed is not None and not 0 < args.speed <= 5000:
        raise InputError(f"expected a speed in (0, 5000] mm/s, got {args.speed:g}",
                         key="--speed", value=args.speed)
    travel = parse_travel(args.travel)
    layout = layout_from(args)
    if layout is not None and Path(args.source).suffix.lower() == ".toml":
        option = next(o for k, o in LAYOUT_OPTIONS.items() if k != "overshoot"
                      and getattr(args, o[2:].replace("-", "_")) not in (None, False))
        raise InputError(f"a scenario is laid out by its [placement] table (page_size, "
                         "landscape, fit_to_margins_mm, align, valign, scale, rotation_deg); "
                         f"{option} lays out a drawing file (.svg, .csv, .npz)", key=option,
                         value=args.source)
    drawing, profile, scenario = load_job(args.source, args.profile)
    drawing = laid_out(drawing, layout, args.source)
    try:
        check_travel(drawing, travel)
    except InkarmError as e:
        raise e.within(file=args.source) from None
    if layout is not None and layout.places:
        warn_off_page(drawing, args.source)
    job = drawing_to_gcode(drawing, profile, optimise=args.optimise, speed_mm_s=args.speed)
    seconds = estimate_seconds(job.lines)
    with atomic_file(out) as partial:
        partial.write_text(job.text())
    fit = (layout.fit_to_margins_mm if layout is not None else
           scenario.placement.fit_to_margins_mm if scenario is not None else None)
    laid = layout is not None or (scenario is not None and scenario.placement.lays_out)
    placed = f" ({layout_summary(fit, drawing)})" if laid else ""
    print(f"{out}: {len(job.lines)} lines, {len(drawing.strokes)} strokes{placed}, pen profile "
          f"{profile.name!r}; estimated {seconds:.1f} s on GRBL's planner (default settings)")
    if scenario is not None:
        from inkarm.jobs.backends.plotter import PERIOD_S, run_lines

        sent = run_lines(scenario, profile, drawing)
        print(f"note: `inkarm draw --backend plotter` streams {len(sent)} lines for this "
              f"scenario instead (one per {PERIOD_S * 1000:g} ms of the pen path, the arms' "
              f"pen sequencing), about {estimate_seconds(sent):.1f} s; this file follows the "
              "drawing's own samples")
    return 0
