"""``inkarm analyse TRACE``: DPPLA target density against curvature, and the target-based
power law (seed 001, sec. 5)."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import add_trace_options, load_trace_for
from inkarm.errors import InputError
from inkarm.io.outputs import check_out_dir, out_path, staged


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "analyse",
        help="target density vs curvature and the power law of a trace's DPPLA targets",
        description="Adaptive sampling of a trace by DPPLA (Marteau and Gibet 2005) at a compression rate; "
        "prints the correlation of target density with curvature and the exponent gamma of "
        "V_T = K (1/D_s)^gamma, per stroke and pooled over all strokes.",
    )
    p.add_argument("trace", type=Path, help="trace file: CSV (t,x,y[,z][,stroke]) or SVG")
    p.add_argument(
        "--compression",
        type=float,
        default=0.75,
        help="compression rate rho in (0, 1) (default 0.75)",
    )
    p.add_argument("--out", type=out_path, help="folder for the figures (density-curvature, power law)")
    p.add_argument(
        "--banded", action="store_true", help="banded DPPLA, O(w^2/k), instead of the exact one"
    )
    add_trace_options(p)
    return p


def run(args: argparse.Namespace) -> int:
    from inkarm.analysis.density import analyse_drawing
    from inkarm.core.budget import BudgetError

    if not 0 < args.compression < 1:
        raise InputError(f"must lie in (0, 1), got {args.compression:g}", key="--compression",
                         value=args.compression)
    if args.out is not None:
        check_out_dir(args.out)
    drawing = load_trace_for(args)
    try:
        result = analyse_drawing(drawing, args.compression, banded=args.banded)
    except BudgetError as e:
        if not args.banded and "exact DPPLA" in e.message:
            e.message += "; or use --banded"
        raise e.within(file=str(args.trace)) from None
    except InputError as e:
        raise e.within(file=str(args.trace)) from None
    figures = {}  # file name -> Figure, written together at the end
    strokes = [i for i in range(len(drawing.strokes)) if i not in result.skipped]
    for i, a in zip(strokes, result.strokes):
        law = (
            "no power law (equal segments)"
            if a.power_law is None
            else (f"gamma {a.power_law.gamma:.3f} (R2 {a.power_law.r2:.2f})")
        )
        band = ""
        if a.result.banded:
            band = {True: ", band holds the optimum", False: ", band MISSED the exact optimum",
                    None: ", band not verified (too large for the exact check)"}[a.result.optimal_in_band]
        print(
            f"stroke {i}: {a.traj.n} samples, {a.result.k} segments, correlation {a.correlation:.3f}, {law}{band}"
        )
        if args.out is not None:
            from inkarm.plots.density import plot_density_curvature, plot_power_law

            stem = f"{args.trace.stem}_stroke{i}"
            figures[f"{stem}_density_curvature.png"] = plot_density_curvature(a)
            if a.power_law is not None:
                figures[f"{stem}_power_law.png"] = plot_power_law(a)
    if result.skipped:
        print(f"skipped strokes too short for 3 segments: {list(result.skipped)}")
    print(f"correlation {result.correlation:.3f}")
    print(f"gamma {result.power_law.gamma:.3f}")
    if args.out is not None:
        from inkarm.plots.figure import save_figure

        with staged(args.out) as stage:
            for name, fig in figures.items():
                save_figure(fig, stage / name, dpi=120)
        print(f"figures written to {args.out}")
    return 0
