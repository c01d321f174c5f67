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


def say_skipped(drawing, source: str) -> None:
    """What an SVG reading skipped, on stderr in one line (nothing when nothing was)."""
    import sys

    from inkarm.io.trace import skipped_summary

    said = skipped_summary(drawing)
    if said:
        print(f"note: {source}: {said}", file=sys.stderr)
