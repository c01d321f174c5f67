"""``inkarm write TEXT --out DIR``: text in a Hershey script font, stylised by a handstyle
(seed 000 sec. 4.1)."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.errors import InputError
from inkarm.io.outputs import check_out_dir, out_path, staged
from inkarm.plans.handstyles import PRESETS, get_handstyle, load_handstyles
from inkarm.plans.text import (
    DEFAULT_FONT,
    DEFAULT_HEIGHT,
    PageLayout,
    text_fidelity,
    write_text,
)

DEFAULT_STYLE = "cursive"


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "write",
        help="write text in a script font with a handstyle (Gaussian targets + LQT)",
        description="The glyphs of a Hershey script font become Gaussian targets, letters are "
        "joined by ligatures and the LQT draws them in the chosen handstyle. Writes "
        "drawing.csv, drawing.svg and write.png (font in grey, targets, stylised ink). "
        "Handstyles: " + "; ".join(f"{s.name}: {s.description}" for s in PRESETS.values()),
    )
    p.add_argument("text", help="the text (use \\n in the shell's quoting for new lines)")
    p.add_argument("--out", type=out_path, required=True, help="output folder")
    p.add_argument(
        "--style", default=DEFAULT_STYLE, help=f"handstyle name (default {DEFAULT_STYLE})"
    )
    p.add_argument("--styles", type=Path, help="TOML file with extra [styles.NAME] handstyles")
    p.add_argument(
        "--height",
        type=float,
        default=DEFAULT_HEIGHT,
        help="letter (cap) height in [mm] (default 10)",
    )
    p.add_argument("--font", default=DEFAULT_FONT, help=f"Hershey font (default {DEFAULT_FONT})")
    p.add_argument("--seed", type=int, default=0, help="seed for the covariance perturbation rho")
    p.add_argument("--dt", type=float, default=0.01, help="LQT time step in [s] (default 0.01)")
    p.add_argument("--margin", type=float, default=20.0, help="page margins in [mm] (default 20)")
    p.add_argument(
        "--line-height", type=float, help="base line spacing in [mm] (default 2 x height)"
    )
    return p


def check_common(args) -> None:
    """Refuse a negative seed and an output path that is a file (shared with ``tag``)."""
    if args.seed < 0:
        raise InputError(f"expected an integer >= 0, got {args.seed}", key="--seed",
                         value=args.seed)
    check_out_dir(args.out)


def run(args) -> int:
    from inkarm.plots.figure import save_figure
    from inkarm.plots.text import plot_text

    check_common(args)
    extra = load_handstyles(args.styles) if args.styles else None
    style = get_handstyle(args.style, extra)
    layout = PageLayout(margins=(args.margin,) * 4, line_height=args.line_height)
    text = args.text.replace("\\n", "\n")
    tp, drawing = write_text(
        text, style, dt=args.dt, height=args.height, font=args.font, layout=layout, seed=args.seed
    )
    strokes, seconds = len(drawing.strokes), drawing.strokes[-1].t[-1]
    with staged(args.out) as stage:
        drawing.to_csv(stage / "drawing.csv")
        drawing.to_svg(stage / "drawing.svg")
        fidelity = text_fidelity(tp, drawing)
        fig = plot_text(tp, drawing, title=f"{args.style}: {strokes} strokes", fidelity=fidelity)
        del tp, drawing  # done with: the figure holds copies of what it draws
        save_figure(fig, stage / "write.png", dpi=200, pil_kwargs={"compress_level": 1})
    letters = sum(1 for c in text if not c.isspace())
    print(
        f"{letters} letters in {strokes} strokes, {seconds:.2f} s; from the font: "
        f"{fidelity.summary()}; wrote {args.out / 'drawing.csv'}, drawing.svg, write.png"
    )
    return 0
