"""One module per `inkarm` sub-command; each defines ``add_parser(subparsers)`` and ``run(args) -> int``."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager

from inkarm.errors import InputError


def add_trace_options(parser: argparse.ArgumentParser) -> None:
    """The options that time an SVG trace, which has only a path (commands reading traces)."""
    from inkarm.io.trace import DEFAULT_RATE, DEFAULT_SPEED

    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED,
                        help=f"SVG only: pen speed in [mm/s] (default {DEFAULT_SPEED:g})")
    parser.add_argument("--rate", type=float, default=DEFAULT_RATE,
                        help=f"SVG only: sampling rate in [Hz] (default {DEFAULT_RATE:g})")


@contextmanager
def options_named(**options: str) -> Iterator[None]:
    """Name the command-line option of an :class:`InputError` raised inside: an error whose
    ``key`` is one of ``options`` (a library argument such as ``n_glyphs``) gets the option
    (``--glyphs``) as its key instead, so the one line the CLI prints says what to change."""
    try:
        yield
    except InputError as e:
        if e.key in options:
            e.key = options[e.key]
            e.args = (str(e),)
        raise


TRACE_OPTIONS = {"speed": "--speed", "rate": "--rate"}
"""Library keys of :func:`inkarm.io.trace.load_trace` and their options."""


def load_trace_for(args: argparse.Namespace):
    """The trace ``args.trace`` read with the ``--speed`` and ``--rate`` options, errors naming
    the option at fault; what an SVG reading skipped is said on stderr in one line
    ("note: FILE: skipped 3 elements: 2 hidden, 1 <text> (convert text to paths)")."""
    from inkarm.io.trace import load_trace

    with options_named(**TRACE_OPTIONS):
        drawing = load_trace(args.trace, speed=args.speed, rate=args.rate)
    say_skipped(drawing, str(args.trace))
    return drawing


def add_recording_options(parser: argparse.ArgumentParser) -> None:
    """The options of a pen-tablet recording (commands reading human recordings)."""
    parser.add_argument("--time-unit", choices=("s", "ms"), default="s",
                        help="tablet CSV: unit of the t column; timed SVG: of its times where the file names "
                        "none (default s)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="tablet CSV: millimetres per device unit of x and y (default 1)")


def load_recordings(trace, args: argparse.Namespace) -> list:
    """The drawings ``trace`` names: every demonstration of ``lasa:SHAPE`` (one for
    ``lasa:SHAPE:DEMO``), a tablet CSV (a ``pressure`` column, or ``--time-unit``/``--scale``
    given) in one drawing, an SVG pen recording with the time of every point
    (:mod:`inkarm.io.svgtiming`; ``--time-unit`` where the file names no unit) in one drawing,
    or any other trace (CSV, SVG: :func:`load_trace_for`'s options).

    An SVG without times is a path, not a recording: it is read at ``--speed`` only where
    ``args.human`` is False (``analyse`` without ``--human``); where human statistics are
    asked for (``analyse --human``, and commands without a ``human`` option: ``fit-style``)
    it is refused naming the file, since a speed it would measure is the one ``--speed``
    invented."""
    from pathlib import Path

    from inkarm.io.human import LASA_PREFIX, is_tablet_csv, read_lasa_trace, read_tablet_csv

    name = str(trace)
    tablet_options = args.time_unit != "s" or args.scale != 1.0
    option = "--time-unit" if args.time_unit != "s" else "--scale"
    if name.startswith(LASA_PREFIX):
        if tablet_options:
            raise InputError("only for a tablet CSV or a timed SVG, not a LASA trace",
                             key=option)
        with options_named(shape="TRACE", demo="TRACE"):
            return read_lasa_trace(name)
    path = Path(trace)
    if path.suffix.lower() == ".csv" and (tablet_options or is_tablet_csv(path)):
        with options_named(time_unit="--time-unit", scale_mm="--scale"):
            return [read_tablet_csv(path, args.time_unit, args.scale)]
    if path.suffix.lower() == ".svg" and path.is_file():
        from inkarm.io.svgtiming import no_times_error, read_timed_svg, svg_has_times

        if args.scale != 1.0:
            raise InputError("only for a tablet CSV (an SVG's units place it on the page)",
                             key="--scale", file=name)
        if svg_has_times(path):
            with options_named(time_unit="--time-unit"):
                drawing = read_timed_svg(path, args.time_unit)
            say_skipped(drawing, name)
            return [drawing]
        if getattr(args, "human", True) and not tablet_options:
            raise no_times_error(path)
    if tablet_options:
        raise InputError("only for a tablet CSV or a timed SVG", key=option, file=name)
    from inkarm.io.trace import load_trace

    with options_named(**TRACE_OPTIONS):
        drawing = load_trace(path, speed=args.speed, rate=args.rate)
    say_skipped(drawing, name)
    return [drawing]


def say_skipped(drawing, source: str) -> None:
    """What an SVG reading skipped, on stderr in one line (nothing when nothing was)."""
    import sys

    from inkarm.io.trace import skipped_summary

    said = skipped_summary(drawing)
    if said:
        print(f"note: {source}: {said}", file=sys.stderr)
