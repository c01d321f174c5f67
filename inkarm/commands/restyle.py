"""``inkarm restyle TRACE --out DIR``: a trace re-drawn through its DPPLA targets by the
Gaussian-target LQT (seeds 001 and 000), laid out on a page first (vpype's layout options,
:mod:`inkarm.commands._layout`) and kept inside it after (``--overshoot refit|clip``): the LQT
cuts and rounds corners, and its curves may pass up to a few millimetres outside the source's
bounding box."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import add_trace_options, load_trace_for, options_named
from inkarm.commands._layout import (
    LAYOUT_OPTIONS,
    add_layout_options,
    laid_out,
    layout_from,
    overshoot_from,
)
from inkarm.errors import InputError
from inkarm.io.outputs import check_out_dir, out_path, staged
from inkarm.plans.handstyles import PULSE_DT, TIMINGS, get_handstyle, load_handstyles
from inkarm.plans.restyle import STYLES, RestyleConfig

_DEFAULTS = RestyleConfig()


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "restyle",
        help="re-draw a trace (CSV or SVG) through its DPPLA targets with the LQT",
        description="Each stroke of the trace is reduced to DPPLA targets (Marteau and Gibet 2005), which "
        "become Gaussians shaped by the local geometry, tracked by the LQT (Berio, Calinon and Leymarie 2017). Writes "
        "the stylised drawing as CSV and SVG and a figure comparing trace, targets and result. "
        "The trace is laid out on the page first (vpype's options: --page-size a4 "
        "--fit-to-margins 10mm ...), and the restyled lines, which may overshoot the trace's "
        "corners by a few mm, are kept inside the page less its margins (--overshoot: refit, "
        "the default, scales the drawing down just enough; clip cuts the lines at the edge).",
    )
    p.add_argument("trace", type=Path, help="trace file: CSV (t,x,y[,z][,stroke]) or SVG")
    p.add_argument("--out", type=out_path, required=True, help="output folder")
    p.add_argument(
        "--compression",
        type=float,
        default=_DEFAULTS.compression,
        help=f"DPPLA compression rate in (0, 1) (default {_DEFAULTS.compression})",
    )
    p.add_argument(
        "--order",
        type=int,
        default=None,
        help=f"LQT integrator order (default {_DEFAULTS.order})",
    )
    p.add_argument(
        "--d",
        type=float,
        default=None,
        help=f"LQT maximum displacement in [mm] (default {_DEFAULTS.d})",
    )
    p.add_argument(
        "--dt",
        type=float,
        default=None,
        help=f"LQT time step in [s] (default {_DEFAULTS.dt}; with timing pulses "
        f"{PULSE_DT:g})",
    )
    p.add_argument(
        "--segment-time",
        type=float,
        help="time per target in [s] (default: keep each stroke's duration)",
    )
    p.add_argument(
        "--style",
        choices=STYLES,
        default=None,
        help="target covariances (default geometric)",
    )
    p.add_argument(
        "--timing",
        choices=TIMINGS,
        default=None,
        help="isochronous: DPPLA targets held alike (default); pulses: key-points at the "
        "trace's own speed minima and peaks, at its times and velocities (a human recording's "
        "timing)",
    )
    p.add_argument(
        "--hand",
        metavar="NAME",
        help="a handstyle's covariances, order, d and timing (a preset, e.g. human, or one of "
        "--styles) instead of --style, --order and --d",
    )
    p.add_argument("--styles", type=Path, help="TOML file with extra [styles.NAME] handstyles")
    p.add_argument(
        "--along",
        type=float,
        default=None,
        help="std along the path / local segment length",
    )
    p.add_argument(
        "--across",
        type=float,
        default=None,
        help="std across the path / local segment length",
    )
    add_trace_options(p)
    add_layout_options(p, overshoot=True)
    return p


_OPTIONS = {name: "--" + name.replace("_", "-") for name in
            ("compression", "order", "d", "dt", "segment_time", "style", "along", "across",
             "timing")}


def run(args: argparse.Namespace) -> int:
    from inkarm.plans.restyle import restyle
    from inkarm.plots.figure import save_figure
    from inkarm.plots.restyle import plot_restyle

    cfg = _config(args)
    stem = args.trace.stem
    names = [f"{stem}_restyled.csv", f"{stem}_restyled.svg", f"{stem}_restyle.png"]
    out = check_out_dir(args.out, inputs=[args.trace], names=names)
    layout, overshoot = layout_from(args), overshoot_from(args)
    trace = load_trace_for(args)
    trace = laid_out(trace, layout, str(args.trace))
    try:
        with options_named(**_OPTIONS):
            result = restyle(trace, cfg)
    except InputError as e:
        raise e.within(file=str(args.trace)) from None
    result, kept = kept_on_page(result, trace, layout, overshoot)
    with staged(out) as stage:
        result.drawing.to_csv(stage / names[0])
        result.drawing.to_svg(stage / names[1])
        save_figure(plot_restyle(trace, result), stage / names[2], dpi=120)
    targets = sum(r.k + 1 for r in result.targets)
    print(
        f"{len(result.drawing.strokes)} strokes, {targets} targets "
        f"({'at the speed minima and peaks' if cfg.timing == 'pulses' else f'compression {cfg.compression}'})"
        f"{kept}, written to {args.out}"
    )
    return 0


_HAND_SETS = ("order", "d", "style", "along", "across")  # what --hand gives instead


def _config(args: argparse.Namespace) -> RestyleConfig:
    """The restyle the options ask for: a handstyle's (``--hand``), or the options' own."""
    given = {name: getattr(args, name) for name in ("compression", "dt", "segment_time",
                                                     "timing", *_HAND_SETS)
             if getattr(args, name) is not None}
    with options_named(**_OPTIONS):
        if args.hand is None:
            if args.styles is not None:
                raise InputError("names styles for --hand; give --hand NAME", key="--styles")
            if given.get("timing") == "pulses" and "dt" not in given:
                given["dt"] = PULSE_DT
            return RestyleConfig(**given)
        clash = [name for name in _HAND_SETS if name in given]
        if clash:
            raise InputError(f"--hand {args.hand} sets the order, d and covariances; leave out "
                             f"{', '.join(_OPTIONS[n] for n in clash)}", key=_OPTIONS[clash[0]])
        extra = load_handstyles(args.styles) if args.styles else None
        return RestyleConfig.from_handstyle(get_handstyle(args.hand, extra), **given)


def kept_on_page(result, trace, layout, how: str):
    """The restyled ``result`` kept inside the page by ``how`` (``--overshoot``): the page
    less the margins when the options laid the trace out, else the trace's own page when the
    trace lies on it (else nothing to keep inside); and a phrase for the output line."""
    from dataclasses import replace

    from inkarm.plans.page import keep_inside, outside

    if layout is not None and layout.places:
        lo, hi = layout.area(trace.page_size)
    else:
        lo, hi = (0.0, 0.0), trace.page_size
        if outside(trace, lo, hi) is not None:
            return result, ""
    with options_named(**LAYOUT_OPTIONS):
        drawing, said = keep_inside(result.drawing, lo, hi, how)
    return replace(result, drawing=drawing), f"; {said}"
