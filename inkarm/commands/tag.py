"""``inkarm tag --seed S --out DIR``: an asemic tag of GA-ordered random glyphs, stylised by a
handstyle (seed 000 sec. 4.2)."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import options_named
from inkarm.commands.write import check_common
from inkarm.io.outputs import check_out_dir, out_path, staged
from inkarm.plans.glyphs import check_tag, make_tag
from inkarm.plans.handstyles import get_handstyle, load_handstyles

DEFAULT_STYLE = "graffiti"


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "tag",
        help="generate an asemic tag: random glyphs ordered by a GA, joined, drawn by the LQT",
        description="Each glyph is a few random targets in polar coordinates, ordered by a "
        "genetic algorithm (tournament selection, PMX crossover, elitism) that maximises the "
        "distance between consecutive targets and rewards downward and left-to-right strokes. "
        "The glyphs are joined with ligatures into one stroke that the LQT draws in the chosen "
        "handstyle. Writes drawing.csv, drawing.svg and tag.png.",
    )
    p.add_argument("--out", type=out_path, required=True, help="output folder")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--style", default=DEFAULT_STYLE, help=f"handstyle name (default {DEFAULT_STYLE})"
    )
    p.add_argument("--styles", type=Path, help="TOML file with extra [styles.NAME] handstyles")
    p.add_argument("--glyphs", type=int, default=5, help="glyphs in the tag (default 5)")
    p.add_argument("--size", type=float, default=12.0, help="glyph height in [mm] (default 12)")
    p.add_argument("--dt", type=float, default=0.01, help="LQT time step in [s] (default 0.01)")
    return p


def run(args) -> int:
    from inkarm.plots.figure import save_figure
    from inkarm.plots.tag import tag_figure

    check_common(args)
    out = check_out_dir(args.out)
    extra = load_handstyles(args.styles) if args.styles else None
    style = get_handstyle(args.style, extra)
    with options_named(n_glyphs="--glyphs", size="--size", dt="--dt"):
        check_tag(style, args.glyphs, size=args.size, dt=args.dt)  # before any work
        tag = make_tag(style, seed=args.seed, n_glyphs=args.glyphs, size=args.size)
        drawing = tag.realise(dt=args.dt)
    with staged(out) as stage:
        drawing.to_csv(stage / "drawing.csv")
        drawing.to_svg(stage / "drawing.svg")
        fig = tag_figure(tag, drawing, title=f"seed {args.seed}, style {args.style}")
        save_figure(fig, stage / "tag.png", dpi=200)
    n = sum(len(p) for p in tag.points)
    print(
        f"{len(tag.points)} glyphs, {n} targets, {drawing.strokes[-1].t[-1]:.2f} s; "
        f"wrote {out / 'drawing.csv'}, drawing.svg, tag.png"
    )
    return 0
