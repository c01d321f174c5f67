"""``inkarm sweep SCENARIO --set KEY=lo:hi:n ... [--zip | --random N] [--seeds a:b] --out DIR
[--workers N] [--ray [ADDRESS]]``: run a scenario over a design of overrides
(:mod:`inkarm.jobs.sweep`)."""

from __future__ import annotations

import argparse
import sys

from inkarm.errors import InputError
from inkarm.io.outputs import check_out_dir

DEFAULT_METRICS = ("tracking_rms_mm", "ink_chamfer_mm", "contact_force_std_n")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "sweep",
        help="run a scenario over a grid, zip or random design of settings (process pool or "
        "Ray), results as a Parquet table and figures",
        description="Run SCENARIO once per point of a design over dotted keys (every point "
        "checked by the scenario's rules before anything runs) and per seed; write "
        "results.parquet (one row per run: parameters, metrics, status, reason, seed, "
        "versions) as runs finish, and figures. Run the same command again to resume an "
        "interrupted sweep.",
    )
    p.add_argument("scenario", help="scenario file (TOML)")
    p.add_argument("--set", dest="axes", action="append", default=[], metavar="KEY=SPEC",
                   help="an axis: KEY=lo:hi:n (n values), KEY=lo:hi (--random only), "
                   "KEY=a,b,c or KEY=value; repeat for more axes")
    design = p.add_mutually_exclusive_group()
    design.add_argument("--zip", action="store_true",
                        help="pair the axes' values (equal lengths) instead of the full grid")
    design.add_argument("--random", type=int, metavar="N", default=None,
                        help="N points: ranges by a Latin hypercube, lists by uniform choice")
    p.add_argument("--design-seed", type=int, default=0, metavar="S",
                   help="seed of the --random design (default 0)")
    p.add_argument("--seeds", default=None, metavar="a:b",
                   help="run every point with each scenario seed a..b-1 (or a,b,c); default: "
                   "the scenario's seed")
    p.add_argument("--out", required=True, help="output folder (resumed when it holds this "
                   "sweep)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="processes of the local pool (default: the CPUs available)")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run on a Ray cluster at ADDRESS (default: a local one); write "
                   "--ray=ADDRESS, or --ray last, so that it does not take the scenario as its "
                   "address; needs pip install 'inkarm[ray]'")
    p.add_argument("--metric", dest="metrics", action="append", default=None, metavar="NAME",
                   help=f"metric to plot (repeatable; default {', '.join(DEFAULT_METRICS)})")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def build_points(args: argparse.Namespace, scenario):
    """The design's points, every one checked against the scenario."""
    from inkarm.jobs.sweep.design import (
        check_design_size,
        grid_design,
        make_points,
        parse_axis,
        parse_seeds,
        random_design,
        validate,
        zip_design,
    )

    if not args.axes:
        raise InputError("give at least one axis, e.g. --set controller.force_n=0.5:2.0:7",
                         key="--set")
    axes = [parse_axis(text) for text in args.axes]
    keys = [a.key for a in axes]
    if "seed" in keys:
        raise InputError("the scenario seed is swept with --seeds a:b, not --set",
                         key="--set", value="seed")
    if len(set(keys)) != len(keys):
        raise InputError(f"an axis is given twice: {keys}", key="--set")
    seeds = parse_seeds(args.seeds) if args.seeds is not None else (scenario.seed,)
    if args.random is not None and args.random < 1:
        raise InputError(f"expected --random N >= 1, got {args.random}", key="--random",
                         value=args.random)
    check_design_size(axes, zip_axes=args.zip, random=args.random, seeds=len(seeds))
    validate(scenario, make_points([{a.key: a.first for a in axes}], seeds[:1]))  # a bad key in a fraction of a second
    if args.random is not None:
        design = random_design(axes, args.random, args.design_seed)
    elif args.zip:
        design = zip_design(axes)
    else:
        design = grid_design(axes)
    points = make_points(design, seeds)
    validate(scenario, points)
    return keys, points


def run(args: argparse.Namespace) -> int:
    from inkarm.commands.draw import ProgressBar
    from inkarm.jobs.scenario import load_scenario
    from inkarm.jobs.sweep import run_sweep, write_figures
    from inkarm.jobs.sweep.table import TABLE_FILE

    out = check_out_dir(args.out)
    if args.workers is not None and args.workers < 1:
        raise InputError(f"expected --workers >= 1, got {args.workers}", key="--workers",
                         value=args.workers)
    if args.ray is not None:
        try:
            import ray  # noqa: F401  (checked before any work)
        except ImportError:
            raise InputError("Ray is not installed: pip install 'inkarm[ray]'",
                             key="--ray") from None
    scenario = load_scenario(args.scenario)
    keys, points = build_points(args, scenario)
    executor = "ray" if args.ray is not None else "process"
    bar = None if args.quiet else ProgressBar(f"sweep {scenario.title!r} ({len(points)} runs)")

    def progress(done: int, total: int, failed: int) -> None:
        if bar is not None:
            bar(done / total if total else 1.0, f"{done}/{total} {failed} failed")

    try:
        summary = run_sweep(scenario, points, out, executor=executor, workers=args.workers,
                            ray_address=args.ray or None, progress=progress)
    except KeyboardInterrupt:
        if bar is not None:
            bar.close()
        print(f"inkarm sweep: interrupted; the finished runs are in {out / TABLE_FILE}: run "
              "the same command again to resume", file=sys.stderr)
        return 130
    if bar is not None:
        bar.close()
    figures = write_figures(out, keys, list(args.metrics or DEFAULT_METRICS))
    print(f"{summary.total} runs: {len(summary.ran)} run now ({summary.failed} failed), "
          f"{summary.skipped} finished before")
    print(f"table: {out / TABLE_FILE}")
    if figures:
        print(f"figures: {', '.join(str(f) for f in figures)}")
    return 0  # failed runs are results of the sweep (rows with their reason), not its failure
