"""The page-layout options of the commands that read a drawing (``restyle``, ``gcode``), named
as vpype names them (``vpype layout --fit-to-margins 10mm --landscape --align center
--valign center a4``; ``scale``; ``rotate``): see :mod:`inkarm.plans.page`."""

from __future__ import annotations

import argparse

from inkarm.commands import options_named

LAYOUT_OPTIONS = {"page_size": "--page-size", "landscape": "--landscape",
                  "fit_to_margins": "--fit-to-margins", "scale": "--scale", "align": "--align",
                  "valign": "--valign", "rotation_deg": "--rotate", "overshoot": "--overshoot"}
"""Keys of :class:`inkarm.plans.page.Layout`'s errors and their options."""


def add_layout_options(parser: argparse.ArgumentParser, overshoot: bool = False) -> None:
    """``--page-size``, ``--landscape``, ``--fit-to-margins``, ``--align``, ``--valign``,
    ``--scale``, ``--rotate`` (and ``--overshoot`` for a command that restyles). Without any
    of them the drawing stays where it is."""
    g = parser.add_argument_group(
        "page layout (as vpype's layout, scale and rotate; lengths take mm, cm, in, px, pt, "
        "a number alone is mm)")
    g.add_argument("--page-size", metavar="SIZE", default=None,
                   help="the page: a0-a6, letter, legal, executive, tabloid, or WxH such as "
                   "210x297mm or 8.5x11in; portrait unless --landscape (as vpype); the drawing "
                   "is centred on it")
    g.add_argument("--landscape", action="store_true",
                   help="landscape orientation of the page (default portrait)")
    g.add_argument("--fit-to-margins", metavar="LENGTH", default=None,
                   help="scale the drawing (aspect kept) to the page less this margin on "
                   "every side, e.g. 10mm")
    g.add_argument("--align", metavar="left|center|right", default=None,
                   help="horizontal place on the page, within the margins (default center)")
    g.add_argument("--valign", metavar="top|center|bottom", default=None,
                   help="vertical place on the page, within the margins (default center)")
    g.add_argument("--scale", type=float, metavar="FACTOR", default=None,
                   help="scale the drawing about its centre (not with --fit-to-margins)")
    g.add_argument("--rotate", type=float, metavar="DEG", default=None,
                   help="rotate the drawing about its centre, clockwise on the page as vpype's "
                   "rotate, before it is scaled and placed")
    if overshoot:
        g.add_argument("--overshoot", metavar="refit|clip", default="refit",
                       help="where the restyled lines overshoot the page (less the margins; "
                       "the source's page without layout options, when the source lies on "
                       "it): refit scales the drawing down just enough and moves it inside "
                       "(default), clip cuts the lines at the edge")


def layout_from(args: argparse.Namespace):
    """The :class:`~inkarm.plans.page.Layout` the options ask for; None when none was given
    (the drawing stays as read). Errors name the option."""
    from inkarm.errors import InputError
    from inkarm.plans.page import Layout, parse_length, parse_page_size

    given = [args.page_size, args.fit_to_margins, args.align, args.valign, args.scale,
             args.rotate]
    if all(v is None for v in given) and not args.landscape:
        return None
    if args.rotate is not None and not abs(args.rotate) <= 3600:
        raise InputError(f"expected an angle in [-3600, 3600] deg, got {args.rotate}",
                         key="--rotate", value=args.rotate)
    with options_named(**LAYOUT_OPTIONS):
        return Layout(
            page_size=None if args.page_size is None else parse_page_size(args.page_size,
                                                                          "page_size"),
            landscape=args.landscape,
            fit_to_margins_mm=None if args.fit_to_margins is None else
            parse_length(args.fit_to_margins, "fit_to_margins"),
            scale=args.scale,
            align=args.align,
            valign=args.valign,
            rotation_deg=0.0 if args.rotate is None else -args.rotate,
        )


def laid_out(drawing, layout, source: str):
    """``drawing`` on its page by ``layout`` (unchanged when None); errors name the option and
    the ``source`` file."""
    if layout is None:
        return drawing
    from inkarm.errors import InputError
    from inkarm.plans.page import lay_out

    try:
        with options_named(**LAYOUT_OPTIONS):
            return lay_out(drawing, layout)
    except InputError as e:
        raise e.within(file=source) from None


def layout_summary(fit_mm: float | None, drawing) -> str:
    """One phrase: the page, the margins fitted to (``fit_mm``, None: not fitted) and where
    the drawing lies [mm]."""
    lo, hi = drawing.bounds()
    w, h = drawing.page_size
    fit = f", fitted to {fit_mm:g} mm margins" if fit_mm is not None else ""
    return (f"page {w:g} x {h:g} mm{fit}, drawing ({lo[0]:.1f}, {lo[1]:.1f}) to "
            f"({hi[0]:.1f}, {hi[1]:.1f}) mm")


def overshoot_from(args: argparse.Namespace) -> str:
    """``--overshoot``, checked before any work: "refit" or "clip"."""
    from inkarm.plans.page import check_overshoot

    return check_overshoot(args.overshoot, "--overshoot")
