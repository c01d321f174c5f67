"""``inkarm primitives learn|scribble``: motor primitives of handwriting, the factorial HMM of
seed 004 (:mod:`inkarm.models.primitives`)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from inkarm.commands import options_named
from inkarm.errors import InputError
from inkarm.io.outputs import atomic_file, check_out_file, out_path

LETTER_PREFIX = "letter:"


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "primitives",
        help="learn motor primitives from handwriting (factorial HMM) and scribble with them",
        description="Seed 004 (Williams, Toussaint, Storkey): M primitives, each a left-to-right "
        "chain of K states (state 0 silent), superposed to give the pen's normalised velocity "
        "(dx, dy, pressure at 200 Hz); learned by EM with a structured variational E-step.",
    )
    sub = p.add_subparsers(dest="action", required=True, metavar="{learn,scribble}")
    learn = sub.add_parser(
        "learn", help="learn a model from pen recordings or from inkarm's own letters",
        description="DATA is a CSV recording t,x,y[,pressure] [s, mm, 0-1], a folder of them "
        "(one sample per file), or letter:X for --samples stochastic LQT samples of the letter "
        "X across handstyles. Prints one line per EM iteration to stderr; writes MODEL (.npz).")
    learn.add_argument("data", help="CSV file, folder of CSV files, or letter:X")
    learn.add_argument("--out", type=out_path, required=True, help="model file to write (.npz)")
    learn.add_argument("--chains", type=int, default=20, help="primitives M (default 20)")
    learn.add_argument("--states", type=int, default=10,
                       help="states per chain K, silent state included (default 10)")
    learn.add_argument("--samples", type=int, default=200,
                       help="letter:X only: LQT samples (default 200)")
    learn.add_argument("--styles", default="faithful,cursive,loose,italic,hurried",
                       help="letter:X only: handstyles, comma separated")
    learn.add_argument("--iterations", type=int, default=50,
                       help="most EM iterations (default 50, the paper's)")
    learn.add_argument("--sweeps", type=int, default=20,
                       help="most E-step sweeps (default 20, the paper's)")
    learn.add_argument("--restarts", type=int, default=1,
                       help="random initialisations, best bound kept (default 1)")
    learn.add_argument("--no-self-loops", action="store_true",
                       help="active states always advance (primitives of fixed length)")
    learn.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    learn.add_argument("--quiet", action="store_true", help="no progress lines")

    scribble = sub.add_parser(
        "scribble", help="run a model generatively: a scribble (Fig. 8) and its figures",
        description="Runs every primitive from its learned onset rate, without timing code, "
        "and integrates the output to a pen path from (0, 0). Writes drawing.csv, drawing.svg, "
        "scribble.png and primitives.png into --out.")
    scribble.add_argument("model", type=Path, help="model file (.npz) from `primitives learn`")
    scribble.add_argument("--out", type=out_path, required=True, help="output folder")
    scribble.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    scribble.add_argument("--duration", type=float, default=4.0,
                          help="length of the scribble in [s] (default 4)")
    return p


def run(args) -> int:
    if args.seed < 0:
        raise InputError(f"expected an integer >= 0, got {args.seed}", key="--seed",
                         value=args.seed)
    return _learn(args) if args.action == "learn" else _scribble(args)


def load_training_set(data: str, samples: int, styles: str, seed: int):
    """The :class:`inkarm.plans.primitives_data.TrainingSet` named by DATA."""
    from inkarm.plans.primitives_data import letter_training_set, recording_training_set

    if data.startswith(LETTER_PREFIX):
        letter = data[len(LETTER_PREFIX):]
        names = tuple(s.strip() for s in styles.split(",") if s.strip())
        with options_named(letter="DATA", n_samples="--samples", styles="--styles"):
            return letter_training_set(letter, samples, names, seed=seed)
    if not Path(data).exists():
        raise InputError(f"no such file or folder: {data}; expected a CSV file, a folder of "
                         f"them, or {LETTER_PREFIX}X", key="DATA", value=data)
    return recording_training_set(data)




def _learn(args) -> int:
    from inkarm.models.primitives import PrimitivesConfig, fit
    from inkarm.models.primitives.generate import reconstruction_error_mm

    out = check_out_file(args.out, "model", (".npz",))
    with options_named(n_chains="--chains", n_states="--states", max_outer="--iterations",
                       max_inner="--sweeps", restarts="--restarts"):
        config = PrimitivesConfig(n_chains=args.chains, n_states=args.states,
                                  max_outer=args.iterations, max_inner=args.sweeps,
                                  self_loops=not args.no_self_loops)
        if not 1 <= args.restarts <= 100:
            raise InputError(f"expected an integer in 1..100, got {args.restarts}",
                             key="restarts", value=args.restarts)
    data = load_training_set(args.data, args.samples, args.styles, args.seed)
    lengths = [len(s) for s in data.sequences]
    print(f"{len(lengths)} sequences, {sum(lengths)} samples at {data.rate_hz:g} Hz; "
          f"M = {config.n_chains}, K = {config.n_states}", file=sys.stderr)
    start = time.perf_counter()

    def progress(restart, it):
        if not args.quiet:
            print(f"restart {restart + 1}/{args.restarts} iteration {it.number:3d}: "
                  f"bound {it.bound:.6g}, {it.sweeps} sweeps, max change {it.w_change:.3g}, "
                  f"{time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)

    result = fit(data.sequences, config, seed=args.seed, restarts=args.restarts,
                 scale=data.scale, rate_hz=data.rate_hz, channels=data.channels,
                 progress=progress)
    batch = result.batch
    error = reconstruction_error_mm(result.model, batch.Y, batch.mask,
                                    result.posterior.expectations)
    with atomic_file(out) as partial:
        result.model.save(partial)
    print(f"{len(result.history)} EM iterations, bound {result.final_bound:.6g}; "
          f"reconstruction error {error.mean():.3f} mm mean, {error.max():.3f} mm worst "
          f"sequence; wrote {out}")
    return 0


def _scribble(args) -> int:
    from inkarm.core.trajectory import Drawing
    from inkarm.io.outputs import check_out_dir, staged
    from inkarm.models.primitives import PrimitiveModel
    from inkarm.models.primitives.generate import scribble
    from inkarm.plots.figure import save_figure
    from inkarm.plots.primitives import plot_primitives, plot_scribble

    check_out_dir(args.out, inputs=[args.model], names=OUTPUTS)
    model = PrimitiveModel.load(args.model)
    with options_named(duration_s="--duration"):
        path, _ = scribble(model, args.duration, seed=args.seed)
    lo, _ = Drawing([path]).bounds()
    drawing = Drawing([path.shifted(dpos=MARGIN_MM - lo)])  # on the page, from its corner
    with staged(args.out) as stage:
        drawing.to_csv(stage / "drawing.csv")
        drawing.to_svg(stage / "drawing.svg")
        save_figure(plot_scribble(path, title=f"{args.model.name}, seed {args.seed}"),
                    stage / "scribble.png")
        save_figure(plot_primitives(model), stage / "primitives.png")
    lo, hi = drawing.bounds()
    print(f"scribble of {path.duration:.2f} s, {hi[0] - lo[0]:.1f} x {hi[1] - lo[1]:.1f} mm; "
          f"wrote {args.out / 'drawing.csv'}, drawing.svg, scribble.png, primitives.png")
    return 0


MARGIN_MM = 20.0
OUTPUTS = ("drawing.csv", "drawing.svg", "scribble.png", "primitives.png")
