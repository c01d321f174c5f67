"""``inkarm primitives learn|scribble``: motor primitives of handwriting, the factorial HMM of
seed 004 (:mod:`inkarm.models.primitives`)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from inkarm.commands import options_named
from inkarm.errors import InputError, unknown_name
from inkarm.io.outputs import atomic_file, check_out_file, out_path

LETTER_PREFIX = "letter:"
LASA_PREFIX = "lasa:"
LASA_SIZE_MM = 15.0
"""Size [mm] of a LASA shape (its demonstrations' median larger side) once scaled."""
LASA_RATE_HZ = 25.0
"""Sample rate [Hz] of LASA features: the demonstrations are slow (a shape in 2-8 s)."""
LASA_TRAIN_DEMOS = (0, 1, 2, 3, 4)
"""Demonstrations (of 7 per shape) that train; 5 and 6 are held out."""


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
        "(one sample per file), letter:X for --samples stochastic LQT samples of the letter "
        "X across handstyles, or lasa:SHAPE[,SHAPE...] | lasa:all for demonstrations 0-4 of "
        "LASA handwriting shapes (pip install 'inkarm[lasa]'), scaled to 15 mm, x and y "
        "velocity at 25 Hz. Prints one line per EM iteration to stderr; writes MODEL (.npz).")
    learn.add_argument("data", help="CSV file, folder of CSV files, letter:X, or "
                       "lasa:SHAPE[,SHAPE...] | lasa:all")
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
    learn.add_argument("--anneal", default="", metavar="T1,T2,...",
                       help="deterministic annealing: temperatures > 1, hottest first, before "
                       "each start's EM (e.g. 4,2; default none)")
    learn.add_argument("--anneal-iterations", type=int, default=5,
                       help="EM iterations at each temperature (default 5)")
    learn.add_argument("--moves", type=int, default=0,
                       help="re-seeding moves (split-and-merge) rejected in a row before the "
                       "search stops (default 0: none)")
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
    if data.startswith(LASA_PREFIX):
        return lasa_training_set(data[len(LASA_PREFIX):])
    if not Path(data).exists():
        raise InputError(f"no such file or folder: {data}; expected a CSV file, a folder of "
                         f"them, or {LETTER_PREFIX}X", key="DATA", value=data)
    return recording_training_set(data)


def lasa_shapes(spec: str) -> tuple[str, ...]:
    """The LASA shape names in ``spec`` (``all``: all 30, the Multi_Models sets included; or
    names separated by commas)."""
    from inkarm.io.human import lasa_shapes as names_of

    with options_named(lasa="DATA"):
        names = names_of()
    if spec == "all":
        return names
    chosen = tuple(n.strip() for n in spec.split(",") if n.strip())
    if not chosen:
        raise InputError(f"expected {LASA_PREFIX}SHAPE[,SHAPE...] or {LASA_PREFIX}all; shapes: "
                         f"{', '.join(names)}", key="DATA", value=LASA_PREFIX + spec,
                         choices=("all", *names))
    for n in chosen:
        if n not in names:
            raise unknown_name("LASA shape", n, ("all", *names), key="DATA")
    return chosen


def lasa_paths(shapes, demos, size_mm: float = LASA_SIZE_MM):
    """(list of (t [s], pos (N, 2) [mm]), labels ``Shape #d``): demonstrations ``demos`` of each
    LASA shape (:func:`inkarm.io.human.read_lasa`), each shape scaled about its end point (the
    LASA target) so that its demonstrations' median larger side is ``size_mm``."""
    import numpy as np

    from inkarm.io.human import read_lasa

    paths, labels = [], []
    for name in shapes:
        strokes = [d.strokes[0] for d in read_lasa(name)]
        factor = size_mm / float(np.median([np.ptp(s.pos, axis=0).max() for s in strokes]))
        for k in demos:
            stroke = strokes[k]
            paths.append((stroke.t, (stroke.pos - stroke.pos[-1]) * factor))
            labels.append(f"{name} #{k}")
    return paths, tuple(labels)


def lasa_training_set(spec: str, demos=LASA_TRAIN_DEMOS, size_mm: float = LASA_SIZE_MM,
                      rate_hz: float = LASA_RATE_HZ, scale=None):
    """LASA demonstrations as x, y normalised first differences at ``rate_hz`` [Hz] (no
    pressure: LASA has none, and a pen-down indicator would only mark both ends). ``scale``
    (2,) [mm/sample]: divide by it (a held-out set uses the training set's) instead of the
    data's own RMS."""
    import numpy as np

    from inkarm.models.primitives.features import first_differences, normalise
    from inkarm.plans.primitives_data import TrainingSet

    paths, labels = lasa_paths(lasa_shapes(spec), demos, size_mm)
    # the pen is down throughout: drop the pressure channel and the two pen-up steps
    raw = [first_differences(t, pos, None, rate_hz)[1:-1, :2] for t, pos in paths]
    if scale is None:
        sequences, scale = normalise(raw)
    else:
        scale = np.asarray(scale, dtype=float)
        sequences = [r / scale for r in raw]
    return TrainingSet(sequences, scale, rate_hz, labels, channels=("dx", "dy"))


def _search_config(args):
    """The outer search the options ask for, or None for plain EM restarts."""
    from inkarm.models.primitives.search import SearchConfig

    if not args.anneal and not args.moves:
        return None
    try:
        temps = tuple(float(t) for t in args.anneal.split(",") if t.strip())
    except ValueError:
        raise InputError(f"expected temperatures separated by commas, got {args.anneal!r}",
                         key="--anneal", value=args.anneal) from None
    with options_named(starts="--restarts", temperatures="--anneal",
                       anneal_iterations="--anneal-iterations", moves="--moves"):
        return SearchConfig(starts=args.restarts, temperatures=temps,
                            anneal_iterations=args.anneal_iterations, moves=args.moves)


def _learn(args) -> int:
    from inkarm.models.primitives import PrimitivesConfig, fit
    from inkarm.models.primitives.generate import reconstruction_error_mm
    from inkarm.models.primitives.search import search_fit

    out = check_out_file(args.out, "model", (".npz",))
    with options_named(n_chains="--chains", n_states="--states", max_outer="--iterations",
                       max_inner="--sweeps", restarts="--restarts"):
        config = PrimitivesConfig(n_chains=args.chains, n_states=args.states,
                                  max_outer=args.iterations, max_inner=args.sweeps,
                                  self_loops=not args.no_self_loops)
        if not 1 <= args.restarts <= 100:
            raise InputError(f"expected an integer in 1..100, got {args.restarts}",
                             key="restarts", value=args.restarts)
    search = _search_config(args)
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

    if search is None:
        result = fit(data.sequences, config, seed=args.seed, restarts=args.restarts,
                     scale=data.scale, rate_hz=data.rate_hz, channels=data.channels,
                     progress=progress)
    else:
        result = search_fit(data.sequences, config, search, seed=args.seed, scale=data.scale,
                            rate_hz=data.rate_hz, channels=data.channels,
                            progress=None if args.quiet else lambda line: print(
                                f"{line}, {time.perf_counter() - start:.1f} s",
                                file=sys.stderr, flush=True))
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
