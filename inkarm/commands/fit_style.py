"""``inkarm fit-style RECORDINGS --out STYLE.toml``: a handstyle fitted to human recordings
(:mod:`inkarm.plans.fitstyle`), written as a handstyles file."""

from __future__ import annotations

import argparse
import re
import sys

from inkarm.commands import add_recording_options, add_trace_options, load_recordings
from inkarm.errors import InputError
from inkarm.io.outputs import atomic_file, check_out_file, out_path


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "fit-style",
        help="fit a handstyle to human recordings (LQT order and stiffness, the hand's timing)",
        description="Restyles every stroke of the recordings with key-points at its own speed "
        "minima and peaks (the hand's timing) for a grid of LQT orders and stiffnesses d / sqrt(h), and "
        "keeps the one whose restyles best keep each stroke's speed peaks (within 20 %), "
        "normalised jerk per peak (within 2x) and 2/3 power-law exponent. Writes a handstyles "
        "file ([styles.NAME]) that --styles options read, and prints the verdict on the "
        "held-out recordings.",
    )
    p.add_argument("recordings", nargs="+",
                   help="pen recordings: a tablet CSV (t,x,y[,pressure]: see --time-unit, "
                   "--scale), a trace CSV (t,x,y[,z][,stroke]), an SVG with the time of every "
                   "point (data-t on each polyline or path; an SVG without times is refused), or "
                   "lasa:SHAPE[:DEMO|:FIRST-LAST] (lasa:all: every single-shape set; the LASA "
                   "handwriting set, extra 'lasa')")
    p.add_argument("--out", type=out_path, required=True, help="handstyles file to write (.toml)")
    p.add_argument("--name", default="fitted", help="the style's name (default fitted)")
    p.add_argument("--held-out", type=float, default=0.25, metavar="FRACTION",
                   help="share of the strokes kept out of the fit for the verdict, spread "
                   "evenly (default 0.25; 0: none)")
    add_recording_options(p)
    add_trace_options(p)
    return p


def run(args: argparse.Namespace) -> int:
    from inkarm.plans.fitstyle import fit_style, human_measures, style_toml, trace_errors

    if not 0.0 <= args.held_out < 1.0:
        raise InputError(f"expected a fraction in [0, 1), got {args.held_out:g}",
                         key="--held-out", value=args.held_out)
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", args.name):
        raise InputError(f"expected a name of ASCII letters, digits and _, got {args.name!r}",
                         key="--name", value=args.name)
    out = check_out_file(args.out, "handstyles", (".toml",), inputs=[
        r for r in args.recordings if not r.startswith("lasa:")])
    strokes = _measurable([s for source in args.recordings
                           for d in load_recordings(source, args) for s in d.strokes])
    # stroke i is held out where the share's running count steps: exactly the share, spread
    held_out = [int((i + 1) * args.held_out) > int(i * args.held_out) for i in range(len(strokes))]
    held = [s for s, out_ in zip(strokes, held_out) if out_]
    train = [s for s, out_ in zip(strokes, held_out) if not out_]
    if not train:
        raise InputError(f"{len(strokes)} strokes: none left to fit to after --held-out",
                         key="--held-out", value=args.held_out)

    def progress(done: int, total: int) -> None:
        print(f"\rfitting to {len(train)} strokes: candidate {done}/{total}", end="",
              file=sys.stderr, flush=True)

    fit = fit_style(train, human_measures, name=args.name, progress=progress)
    print(file=sys.stderr)
    with atomic_file(out) as stage:
        stage.write_text(style_toml(fit, ", ".join(args.recordings)))
    hand = fit.handstyle
    print(f"{hand.name}: order {hand.order}, h {hand.h:g} mm^2, d {hand.d:.4g} mm, timing "
          f"{hand.timing}; training score {fit.score:.2f}; written to {out}")
    if held:
        errors = trace_errors(held, [human_measures(s) for s in held], hand,
                              human_measures)
        for measure, (what, tol) in _VERDICTS.items():
            within = sum(abs(e.get(measure, float("nan"))) <= 1.0 for e in errors)
            print(f"held out: {within}/{len(held)} strokes keep their {what} (within {tol})")
    return 0


_VERDICTS = {"peaks": ("speed peaks", "20 %"), "jerk_per_peak": ("normalised jerk per peak",
                                                                  "2x"),
             "beta": ("power-law exponent", "0.08")}


def _measurable(strokes: list) -> list:
    """The strokes the measures can take; the others are said in one line on stderr."""
    from inkarm.analysis.humanlike import unmeasurable

    kept = [s for s in strokes if unmeasurable(s) is None]
    if len(kept) < len(strokes):
        print(f"note: {len(strokes) - len(kept)} of {len(strokes)} strokes left out (too short "
              "or not moving to be measured)", file=sys.stderr)
    if not kept:
        raise InputError("no stroke of the recordings can be measured (each needs 12 samples "
                         "and a moving pen)", key="recordings")
    return kept
