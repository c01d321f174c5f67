"""One module per `inkarm` sub-command; each defines ``add_parser(subparsers)`` and ``run(args) -> int``."""

from __future__ import annotations

import argparse


def add_trace_options(parser: argparse.ArgumentParser) -> None:
    """The options that time an SVG trace, which has only a path (commands reading traces)."""
    from inkarm.models.trace import DEFAULT_RATE, DEFAULT_SPEED

    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED,
                        help=f"SVG only: pen speed in [mm/s] (default {DEFAULT_SPEED:g})")
    parser.add_argument("--rate", type=float, default=DEFAULT_RATE,
                        help=f"SVG only: sampling rate in [Hz] (default {DEFAULT_RATE:g})")
