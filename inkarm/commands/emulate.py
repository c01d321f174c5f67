"""``inkarm emulate {grbl,axidraw,...}``: start a device emulator on a pseudo-terminal, print the port
to connect to and run until Ctrl-C.

One sub-parser per emulated device; to add one, write ``_add_<name>(subparsers)`` that sets
``_emulate`` to a function ``(args) -> int`` and list it in :data:`EMULATORS`.
"""

from __future__ import annotations

import argparse
import math
import sys

from inkarm.commands._dynamixel import add_emulate_parser
from inkarm.commands._serve import check_png, serve
from inkarm.errors import InputError


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (0 < value < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def _add_pen_options(p: argparse.ArgumentParser, page: str | None, page_help: str) -> None:
    """What a pen plotter's emulator takes, in this order: --speedup, --out, --page (default
    ``page``, described by ``page_help``) and --px-per-mm."""
    p.add_argument("--speedup", type=_positive, default=1.0,
                   help="machine seconds per wall-clock second (default 1: real time)")
    p.add_argument("--out", metavar="FILE.png", default=None,
                   help="write the emulated pen's canvas here on exit")
    p.add_argument("--page", metavar="W,H", default=page, help=page_help)
    p.add_argument("--px-per-mm", type=_positive, default=10.0,
                   help="canvas resolution in px/mm (default 10)")


def _add_grbl(sub) -> None:
    p = sub.add_parser(
        "grbl",
        help="a GRBL 1.1 pen plotter (planner, 128-byte buffer, pen servo, ink canvas)",
        description="Emulate a GRBL 1.1 pen plotter on a pseudo-terminal: 128-byte receive "
        "buffer (overflow is lost silently), 15-block planner with acceleration and junction "
        "deviation, real-time commands, status reports, soft limits and alarms, a pen servo "
        "with a settle time drawing on an ink canvas. Prints the port; Ctrl-C stops it.",
    )
    _add_pen_options(p, "210,297", "page (width, height) in mm under the pen (default 210,297: "
                     "A4)")
    p.add_argument("--pen", choices=("servo", "z"), default="servo",
                   help="pen mechanism: servo (M3 S>=500 puts it down, 0.12 s to settle; "
                   "profile servo) or z (touches at Z <= 0; profile z)")
    p.add_argument("--setting", action="append", default=[], metavar="N=VALUE",
                   help="a GRBL $ setting, e.g. 110=6000 (X max rate, mm/min) or 22=1 "
                   "(homing on); repeatable")
    p.add_argument("--fault", action="append", default=[], metavar="KIND:LINE[:CODE]",
                   help="inject a fault at the LINE-th G-code line received: error:LINE[:CODE] "
                   "(reply error:CODE, default 20), alarm:LINE[:CODE] (ALARM:CODE, default 1: "
                   "hard limit), disconnect:LINE (close the port); repeatable")
    p.set_defaults(_emulate=_run_grbl)


def _add_axidraw(sub) -> None:
    p = sub.add_parser(
        "axidraw",
        help="an AxiDraw on its EiBotBoard (EBB firmware 3.0.3: motion FIFO, pen servo, ink "
        "canvas)",
        description="Emulate an AxiDraw V3 or V3/A3 on a pseudo-terminal: the EiBotBoard's "
        "serial commands as firmware 3.0.3 answers them (SM, XM, LM, LT, HM, EM, SP, TP, SC, "
        "SR, QS, QM, QG, ES, ...), the motion FIFO in 40 us ISR ticks, the H-bot carriage "
        "held by the frame, and the pen-lift servo at its configured rates drawing on an ink "
        "canvas (the sheet against the home corner). Prints the port; Ctrl-C stops it.",
    )
    p.add_argument("--model", choices=("V3", "V3A3"), default="V3",
                   help="the travel: V3 (300 x 218 mm, default) or V3A3 (430 x 297 mm)")
    _add_pen_options(p, None, "sheet (width, height) in mm, its upper-left corner at the home "
                     "corner (default: A4 landscape 297,210 for V3, A3 landscape 420,297 for "
                     "V3A3)")
    p.add_argument("--fault", action="append", default=[], metavar="KIND:K[:CODE]",
                   help="inject a fault at the K-th command received: drop:K (it runs, its "
                   "reply is never sent), error:K[:CODE] (it does not run; the reply is the "
                   "firmware's !CODE error, default 6), disconnect:K (close the port); "
                   "repeatable")
    p.set_defaults(_emulate=_run_axidraw)


EMULATORS = {"grbl": _add_grbl, "axidraw": _add_axidraw, "dynamixel": add_emulate_parser}


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "emulate",
        help="start a device emulator on a pseudo-terminal and print its port",
        description="Start an emulator of a real device on a pseudo-terminal, print the port "
        "to give to `inkarm draw --backend ... --port PORT`, and run until Ctrl-C.",
    )
    sub = p.add_subparsers(dest="device", metavar="DEVICE", parser_class=type(p))
    for add in EMULATORS.values():
        add(sub)
    return p


def _page(text: str) -> tuple[float, float]:
    try:
        w, h = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"expected W,H in mm, got {text!r}", key="--page", value=text) from None
    if not (0 < w <= 2000 and 0 < h <= 2000):
        raise InputError(f"expected a page of at most 2000 x 2000 mm, got {text!r}",
                         key="--page", value=text)
    return w, h


def _setting(text: str) -> tuple[int, float]:
    from inkarm.hardware.plotter.machine import DEFAULT_SETTINGS

    key, _, value = text.partition("=")
    try:
        number, setting = int(key.lstrip("$")), float(value)
    except ValueError:
        raise InputError(f"expected N=VALUE (a GRBL $ setting), got {text!r}", key="--setting",
                         value=text) from None
    if number not in DEFAULT_SETTINGS:
        raise InputError(f"${number} is not a GRBL 1.1 setting (expected one of "
                         f"{', '.join(f'${k}' for k in DEFAULT_SETTINGS)})", key="--setting",
                         value=text)
    if not math.isfinite(setting) or setting < 0:
        raise InputError(f"expected a finite value >= 0, got {text!r}", key="--setting",
                         value=text)
    return number, setting


def _run_grbl(args: argparse.Namespace) -> int:
    from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator, parse_fault
    from inkarm.hardware.plotter.machine import PenConfig
    from inkarm.ink.canvas import Canvas

    check_png(args.out)
    faults = [parse_fault(text) for text in args.fault]
    settings = tuple(_setting(text) for text in args.setting)
    pen = PenConfig() if args.pen == "servo" else PenConfig(contact_z_mm=0.0)
    canvas = Canvas(size_mm=_page(args.page), px_per_mm=args.px_per_mm)
    emulator = GrblEmulator(EmulatorConfig(speedup=args.speedup, settings=settings, pen=pen),
                            canvas=canvas, faults=faults)
    serve(emulator, lambda port: f"GRBL 1.1 emulator on {port} (speed-up {args.speedup:g}); "
                                 "Ctrl-C to stop", args.out)
    stats = emulator.stats
    print(f"received {stats.lines} lines, {stats.bytes_dropped} bytes lost to overflow, "
          f"{stats.machine_time_s:.2f} s of machine time", file=sys.stderr)
    return 0


def _run_axidraw(args: argparse.Namespace) -> int:
    from inkarm.hardware.axidraw.emulator import PAGE_MM, EbbEmulator, parse_fault
    from inkarm.ink.canvas import Canvas

    check_png(args.out)
    faults = [parse_fault(text) for text in args.fault]
    page = _page(args.page) if args.page is not None else PAGE_MM[args.model]
    canvas = Canvas(size_mm=page, px_per_mm=args.px_per_mm)
    emulator = EbbEmulator(speedup=args.speedup, canvas=canvas, model=args.model, faults=faults)
    serve(emulator, lambda port: f"AxiDraw {args.model} (EBB firmware 3.0.3) emulator on {port} "
                                 f"(speed-up {args.speedup:g}); Ctrl-C to stop", args.out)
    stats = emulator.stats
    print(f"received {stats.lines} commands, {stats.steps} motor steps, "
          f"{stats.machine_time_s:.2f} s of machine time", file=sys.stderr)
    return 0


def run(args: argparse.Namespace) -> int:
    handler = getattr(args, "_emulate", None)
    if handler is None:
        raise InputError(f"which device? expected one of {', '.join(EMULATORS)} (inkarm emulate "
                         "DEVICE --help)", key="DEVICE", choices=tuple(EMULATORS))
    return int(handler(args) or 0)
