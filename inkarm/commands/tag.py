"""``inkarm tag --seed S --out DIR``: an asemic tag of GA-ordered random glyphs, stylised by a
handstyle (seed 000 sec. 4.2)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from inkarm.commands.write import check_common, ink, save_figure
from inkarm.core.trajectory import Drawing
from inkarm.plans.glyphs import Tag, make_tag
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
    p.add_argument("--out", type=Path, required=True, help="output folder")
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
    check_common(args)
    extra = load_handstyles(args.styles) if args.styles else None
    style = get_handstyle(args.style, extra)
    tag = make_tag(style, seed=args.seed, n_glyphs=args.glyphs, size=args.size)
    drawing = tag.realise(dt=args.dt)
    drawing.to_csv(args.out / "drawing.csv")
    drawing.to_svg(args.out / "drawing.svg")
    fig = tag_figure(tag, drawing, title=f"seed {args.seed}, style {args.style}")
    save_figure(fig, args.out / "tag.png")
    n = sum(len(p) for p in tag.points)
    print(
        f"{len(tag.points)} glyphs, {n} targets, {drawing.strokes[-1].t[-1]:.2f} s; "
        f"wrote {args.out / 'drawing.csv'}, drawing.svg, tag.png"
    )
    return 0


def tag_figure(tag: Tag, drawing: Drawing, title: str = ""):
    """(a) the random targets and their GA order, (b) the tag over its semi-tied covariances
    (1-sigma ellipses), (c) the GA's best fitness per generation, one line per glyph."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse

    lo, hi = drawing.bounds()
    allpts = np.vstack(tag.points)
    lo, hi = np.minimum(lo, allpts.min(axis=0)), np.maximum(hi, allpts.max(axis=0))
    pad = 0.08 * (hi[0] - lo[0])
    aspect = (hi[1] - lo[1] + 2 * pad) / (hi[0] - lo[0] + 2 * pad)
    fig = plt.figure(figsize=(10, 2 * 10 * aspect + 2.6))
    grid = fig.add_gridspec(3, 1, height_ratios=[aspect, aspect, 0.22])
    ax_ga, ax_tag, ax_fit = (fig.add_subplot(grid[i]) for i in range(3))
    colours = plt.get_cmap("tab10").colors

    for k, pts in enumerate(tag.points):
        ax_ga.plot(*pts.T, "-", color=colours[k % 10], lw=1.0, alpha=0.8)
        ax_ga.plot(*pts.T, "o", color=colours[k % 10], ms=3)
        ax_ga.plot(*pts[0], "o", mfc="none", mec="black", ms=6)
    ax_ga.set_title(
        "(a) random polar targets, ordered by the GA (circle: first)", fontsize=9, loc="left"
    )

    for stroke in tag.plan.strokes:
        for mean, cov in zip(stroke.means, stroke.covs):
            val, vec = np.linalg.eigh(cov)
            angle = np.degrees(np.arctan2(vec[1, 1], vec[0, 1]))
            ax_tag.add_patch(
                Ellipse(
                    mean,
                    2 * np.sqrt(val[1]),
                    2 * np.sqrt(val[0]),
                    angle=angle,
                    facecolor="#f7d774",
                    edgecolor="#d9a400",
                    alpha=0.45,
                    lw=0.5,
                )
            )
        ax_tag.plot(*stroke.means.T, "-", color="#bbbbbb", lw=0.6)
        ax_tag.plot(*stroke.means.T, ".", color="#c0392b", ms=3)
    ink(ax_tag, drawing, width=(0.8, 3.2))
    ax_tag.set_title(f"(b) the tag, {title}", fontsize=9, loc="left")

    for ax in (ax_ga, ax_tag):
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.axis("off")

    for k, evo in enumerate(tag.evolutions):
        ax_fit.plot(evo.history, color=colours[k % 10], lw=1.2)
    ax_fit.set_xlabel("generation", fontsize=8)
    ax_fit.set_ylabel("best fitness", fontsize=8)
    ax_fit.tick_params(labelsize=7)
    ax_fit.set_title(
        "(c) GA with elitism: best fitness per glyph never falls", fontsize=9, loc="left"
    )
    fig.tight_layout()
    return fig
