"""``inkarm preview FILE.gcode --out FILE.png``: a G-code file as the emulator's planner runs
it: the pen-down moves coloured by their planned speed, the travel, the machine's travel, the
total time and the speed against time."""

from __future__ import annotations

import argparse

from inkarm.errors import InputError
from inkarm.io.outputs import check_out_file

FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "preview",
        help="picture and timing of a G-code file on GRBL's planner",
        description="Run a G-code file on the GRBL emulator's planner (no port, nothing "
        "moves) and draw it: pen-down (feed) moves coloured by planned speed, travel (G0) "
        "dashed, the machine's travel rectangle, and speed against time; prints the total "
        "time (what `inkarm stream` estimates on a device with the same settings).",
    )
    p.add_argument("file", metavar="FILE.gcode", help="the G-code file")
    p.add_argument("--out", required=True, metavar="FILE.png", help="picture to write "
                   f"({', '.join(FIGURE_SUFFIXES)})")
    p.add_argument("--setting", action="append", default=[], metavar="N=VALUE",
                   help="a GRBL $ setting of the plotter over the emulator's defaults, e.g. "
                   "110=500 (X max rate, mm/min), 120=10 (X acceleration, mm/s^2), 130=200 "
                   "(X travel, mm); repeat for more")
    return p


def run(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.gcode_file import read_gcode_file
    from inkarm.hardware.plotter.job_timeline import job_timeline
    from inkarm.plots.figure import save_figure
    from inkarm.plots.gcode_preview import preview_figure

    out = check_out_file(args.out, "picture", FIGURE_SUFFIXES, inputs=[args.file])
    settings = parse_settings(args.setting)
    job = read_gcode_file(args.file)
    tl = job_timeline(job, settings)
    fig = preview_figure(tl.t, tl.xyz, tl.speed, tl.drawing, tl.travel_mm, tl.seconds,
                         title=f"{args.file} ({len(job.lines)} lines)")
    save_figure(fig, out)  # (complete under a hidden name, then renamed: io.outputs)
    print(f"{out}: {len(job.lines)} lines, estimated {tl.seconds:.1f} s on GRBL's planner "
          f"({tl.drawing_s:.1f} s pen down); travel {tl.travel_mm[0]:g} x "
          f"{tl.travel_mm[1]:g} mm")
    return 0


def parse_settings(texts: list[str]) -> dict[int, float]:
    """``--setting N=VALUE`` (``$`` optional) as GRBL would store them; refused ones named."""
    from inkarm.hardware.plotter.settings import checked_settings

    settings: dict[int, float] = {}
    for text in texts:
        key, _, value = text.partition("=")
        try:
            settings[int(key.strip().lstrip("$"))] = float(value)
        except ValueError:
            raise InputError(f"expected N=VALUE (a GRBL $ setting, e.g. 110=500), got "
                             f"{text!r}", key="--setting", value=text) from None
    _, why = checked_settings(settings)
    if why:
        raise InputError(why, key="--setting", value=texts)
    return settings
