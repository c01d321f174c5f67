"""``inkarm write TEXT --out DIR``: text in a Hershey script font, stylised by a handstyle
(seed 000 sec. 4.1)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from inkarm.commands import output_folder
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.plans.handstyles import PRESETS, get_handstyle, load_handstyles
from inkarm.plans.text import (
    DEFAULT_FONT,
    DEFAULT_HEIGHT,
    PageLayout,
    TextPlan,
    outline_deviation,
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
    p.add_argument("--out", type=Path, required=True, help="output folder")
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
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    output_folder(args.out)


def save_figure(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=200)
    plt.close(fig)


def run(args) -> int:
    check_common(args)
    extra = load_handstyles(args.styles) if args.styles else None
    style = get_handstyle(args.style, extra)
    layout = PageLayout(margins=(args.margin,) * 4, line_height=args.line_height)
    text = args.text.replace("\\n", "\n")
    tp, drawing = write_text(
        text, style, dt=args.dt, height=args.height, font=args.font, layout=layout, seed=args.seed
    )
    drawing.to_csv(args.out / "drawing.csv")
    drawing.to_svg(args.out / "drawing.svg")
    deviation = max(outline_deviation(tp, drawing).values())
    fig = write_figure(
        tp,
        drawing,
        title=f"{args.style}: {len(drawing.strokes)} strokes, max {deviation:.2f} mm from the font",
    )
    save_figure(fig, args.out / "write.png")
    letters = sum(1 for c in text if not c.isspace())
    print(
        f"{letters} letters in {len(drawing.strokes)} strokes, "
        f"{drawing.strokes[-1].t[-1]:.2f} s, at most {deviation:.2f} mm from the font outline; "
        f"wrote {args.out / 'drawing.csv'}, drawing.svg, write.png"
    )
    return 0


def ink(
    ax, drawing: Drawing, width: tuple[float, float] = (0.6, 2.2), colour: str = "black"
) -> None:
    """Draw the strokes with a width falling with speed, like ink pooling where the pen is
    slow (seed 000 sec. 4); ``width`` = (fastest, slowest) line width in points."""
    from matplotlib.collections import LineCollection

    speeds = np.concatenate([s.speed() for s in drawing.strokes])
    top = max(float(np.percentile(speeds, 95)), 1e-9)
    for s in drawing.strokes:
        segments = np.stack([s.pos[:-1, :2], s.pos[1:, :2]], axis=1)
        slow = 1.0 - np.clip(0.5 * (s.speed()[:-1] + s.speed()[1:]) / top, 0.0, 1.0)
        widths = width[0] + (width[1] - width[0]) * slow
        ax.add_collection(
            LineCollection(segments, linewidths=widths, colors=colour, capstyle="round", zorder=3)
        )


def write_figure(tp: TextPlan, drawing: Drawing, title: str = ""):
    """Font strokes in light grey, the Gaussian targets as dots, the stylised ink on top."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lo, hi = drawing.bounds()
    pad = 0.3 * tp.font.height
    w, h = hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad
    fig_w = 10.0
    fig, ax = plt.subplots(figsize=(fig_w, max(1.5, fig_w * h / w + 0.4)))
    for g in tp.glyphs:
        for s in g.strokes:
            ax.plot(*s.T, color="#d4d4d4", lw=4.0, solid_capstyle="round", zorder=1)
    means = [stroke.means for stroke in tp.plan.strokes]
    gaps = np.concatenate([np.linalg.norm(np.diff(m, axis=0), axis=1) for m in means] + [[]])
    spacing = float(np.median(gaps)) if gaps.size else tp.font.height
    dot = float(np.clip(10.0 * spacing / tp.font.height, 0.6, 2.2))  # dense targets, small dots
    for m in means:
        ax.plot(*m.T, "o", color="#e74c3c", ms=dot, mew=0, alpha=0.8, zorder=2)
    ink(ax, drawing)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=9, loc="left", color="#555555")
    fig.tight_layout()
    return fig
