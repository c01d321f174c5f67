"""``inkarm plan FILE.toml --out DIR``: realise a plan file into trajectories and a figure.

Writes into DIR:

- ``mean.csv``: the mean trajectory of every stroke, columns ``t,x,y[,z],stroke``, strokes
  concatenated in order and re-timed to follow each other with the plan's pen-up pause
  (the :meth:`inkarm.core.trajectory.Drawing.to_csv` format);
- ``samples.npz`` when K > 0: ``pos`` (K, N, D), the K sampled trajectories with the strokes
  concatenated along N in stroke order exactly as the rows of mean.csv, plus ``t`` (N,) and
  ``stroke`` (N,) for those rows;
- ``plan.png`` and ``plan.svg``: targets (1 and 2 sigma ellipses), mean path, samples in
  grey, speed profile beneath.

The schema of FILE is documented in :mod:`inkarm.io.planfile`. Out-of-range numbers and
jobs beyond the budgets (samples, time steps, memory; :mod:`inkarm.core.budget`) are refused
before any work with one line naming the file, the key and the setting that raises the limit
(exit status 2).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from inkarm.core import budget
from inkarm.errors import InputError
from inkarm.io.outputs import check_out_dir, out_path, staged


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "plan",
        help="realise a plan file (Gaussian targets, key-points, human lines) into trajectories",
        description="Realise a plan file into trajectories: mean.csv, samples.npz (with --samples) "
        "and the plan figure (plan.png, plan.svg). Schema: see inkarm.io.planfile.",
    )
    p.add_argument("file", type=Path, help="plan file (TOML); schema in inkarm.io.planfile")
    p.add_argument("--out", type=out_path, required=True, help="output directory (created if missing)")
    p.add_argument(
        "--samples",
        type=int,
        default=None,
        metavar="K",
        help="samples per stroke, at most INKARM_MAX_SAMPLES (10000) (default: the file's "
        "'samples', else 0)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=None,
        metavar="S",
        help="random seed (default: the file's 'seed', else 0)",
    )
    p.add_argument("--no-figure", action="store_true", help="skip plan.png and plan.svg")
    return p


PLAN_FILES = ("mean.csv", "samples.npz", "plan.png", "plan.svg")


def run(args) -> int:
    from inkarm.io.planfile import load_plan
    from inkarm.plans.realise import realise_plan

    if args.samples is not None and args.samples < 0:
        raise InputError(f"--samples: expected an integer >= 0, got {args.samples}")
    if args.samples is not None:  # before reading anything (the plan is checked again)
        budget.require(args.samples, budget.SAMPLES, "samples per stroke", key="--samples",
                       value=args.samples)
    if args.seed is not None and args.seed < 0:
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    out = check_out_dir(args.out, inputs=[args.file], names=PLAN_FILES)
    plan = load_plan(args.file, seed=args.seed)
    result = realise_plan(plan, samples=args.samples)
    with staged(out) as stage:
        result.drawing.to_csv(stage / "mean.csv")
        if result.n_samples > 0:
            np.savez(stage / "samples.npz", **result.stacked_samples())
        if not args.no_figure:
            from inkarm.plots.plans import save_plan_figure

            save_plan_figure(result, stage / "plan")
        written = [out / p.name for p in sorted(stage.iterdir())]
    n = sum(s.n for s in result.drawing.strokes)
    duration = result.drawing.strokes[-1].t[-1]
    print(
        f"{args.file}: {len(result.strokes)} strokes, {n} samples over {duration:.2f} s, "
        f"{result.n_samples} sampled trajectories per stroke"
    )
    for path in written:
        print(f"  wrote {path}")
    return 0
