"""``inkarm analyse TRACE``: DPPLA target density against curvature, and the target-based
power law (seed 001, sec. 5); with ``--human``, the human-likeness statistics of the trace
against the human ranges (:mod:`inkarm.analysis.humanlike`, issue 25).

TRACE is a CSV trace ``t,x,y[,z][,stroke]``, an SVG, a tablet recording (a CSV with a
``pressure`` column, or any CSV read with ``--time-unit``/``--scale``: :mod:`inkarm.io.human`)
or ``lasa:SHAPE[:DEMO]``, a LASA demonstration (every one of the shape without DEMO)."""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.commands import add_recording_options, add_trace_options, load_recordings
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
    p.add_argument("trace", type=Path,
                   help="trace: CSV (t,x,y[,z][,stroke]), SVG, tablet CSV (t,x,y,pressure) or "
                        "lasa:SHAPE[:DEMO] (the LASA handwriting dataset; needs inkarm[lasa])")
    p.add_argument("--human", action="store_true",
                   help="print the human-likeness statistics (power law, speed peaks, jerk, "
                        "pulse asymmetry, lognormality) and where they fall against the human "
                        "ranges (LASA), instead of the DPPLA analysis")
    p.add_argument("--no-lognormal", action="store_true",
                   help="with --human: skip the sigma-lognormal fit (faster; no SNR)")
    add_recording_options(p)
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
    if args.human:
        return _human(args)
    if args.out is not None:
        check_out_dir(args.out)
    drawings = load_recordings(args.trace, args)
    drawing = drawings[0] if len(drawings) == 1 else _as_one(drawings)
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

            stem = f"{args.trace.stem.replace(':', '_')}_stroke{i}"
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


def _as_one(drawings: list):
    """The single-stroke drawings of a LASA shape's demonstrations as one drawing, a stroke
    each."""
    from inkarm.core.trajectory import Drawing

    page = tuple(max(d.page_size[i] for d in drawings) for i in (0, 1))
    return Drawing([s for d in drawings for s in d.strokes], page_size=page)


def _human(args: argparse.Namespace) -> int:
    from inkarm.analysis.humanlike import HUMAN_RANGES, human_likeness, human_stats

    if args.out is not None:
        raise InputError("figures are not drawn with --human yet", key="--out")
    drawings = load_recordings(args.trace, args)
    for k, drawing in enumerate(drawings):
        label = str(args.trace)
        if "demo" in drawing.meta and len(drawings) > 1:
            label = f"lasa:{drawing.meta['shape']}:{drawing.meta['demo']}"
        try:
            stats = human_stats(drawing, lognormal=not args.no_lognormal)
        except InputError as e:
            raise e.within(file=label) from None
        if k:
            print()
        print(f"{label}:")
        for i, s in zip((i for i in range(len(drawing.strokes)) if i not in stats.skipped),
                        stats.strokes):
            print(f"  stroke {i}: {s.duration_s:.2f} s, {s.length_mm:.1f} mm, beta {s.beta:.3f} "
                  f"(r2 {s.r2:.2f}), {s.peaks} speed peaks ({s.peaks_per_second:.2f}/s), "
                  f"jerk/peak {s.jerk_per_peak:.1f}, asymmetry {s.asymmetry:.2f}, lognormal "
                  f"SNR {s.lognormal_snr_db:.1f} dB")
        if stats.skipped:
            print(f"  skipped strokes too short to measure: {list(stats.skipped)}")
        verdict = human_likeness(stats, HUMAN_RANGES)
        print(f"  {'measure':<18} {'value':>8}   human median [IQR]")
        for name, value in stats.measures().items():
            r = HUMAN_RANGES.measures.get(name)
            if r is None:
                print(f"  {name:<18} {value:8.3g}")
                continue
            where = {True: "inside", False: "OUTSIDE", None: "undefined"}[verdict.inside[name]]
            judged = "" if r.judged else " (not judged)"
            print(f"  {name:<18} {value:8.3g}   {r.median:.3g} [{r.q25:.3g}, {r.q75:.3g}]  "
                  f"{where}{judged}")
        print(f"  human-like: {'yes' if verdict.human_like else 'no'}")
    return 0
