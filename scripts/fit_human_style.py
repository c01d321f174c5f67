"""Regenerate ``inkarm/data/handstyles_fitted.toml``: the ``human`` handstyle fitted to the LASA
handwriting set (issue 25, part 3), the fit ``inkarm fit-style lasa:all:0-4 --name human
--held-out 0`` makes, with the file's header.

Run: ``python scripts/fit_human_style.py [--check]`` (needs the extra ``lasa``; about 40 s of
CPU). The training recordings are demonstrations 0-4 of the 26 single-shape LASA sets (130
strokes, all measurable); demonstrations 5 and 6 are held out for
``benchmarks/bench_human.py``. ``--check`` writes nothing and exits 1 when the shipped file
differs from what the fit gives.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from inkarm.analysis.humanlike import unmeasurable
from inkarm.io.human import read_lasa_trace
from inkarm.plans.fitstyle import fit_style, human_measures
from inkarm.plans.handstyles import FITTED_FILE

TRAINING = "lasa:all:0-4"
"""The recordings the ``human`` style is fitted to."""

HEADER = """\
# Handstyles fitted to people: inkarm.plans.handstyles.FITTED, read like a user's --styles file.
# They restyle recordings with their own timing (timing = "pulses": key-points at the speed
# minima and peaks, with the hand's times, places, velocities and accelerations) and are refused
# for text, which has no recording to take a timing from.
#
# human: `python scripts/fit_human_style.py`, the fit of `inkarm fit-style lasa:all:0-4 --name
# human --held-out 0` (the LASA handwriting set, demonstrations 0-4 of the 26 single-shape sets;
# demonstrations 5-6 are held out for the verdict of benchmarks/bench_human.py). Units: h
# [mm^2], d [mm].
"""


def fitted_file() -> str:
    """The text of the fitted-styles file, from a fit on :data:`TRAINING`."""
    strokes = [s for d in read_lasa_trace(TRAINING) for s in d.strokes]
    strokes = [s for s in strokes if unmeasurable(s) is None]
    fit = fit_style(strokes, human_measures, name="human")
    hand = fit.handstyle
    errors = ", ".join(f"{m} {v:.2f}" for m, v in fit.errors.items())
    return (HEADER
            + f"# Training score {fit.score:.3f} (plans/fitstyle.py; 0 = every restyle keeps its "
            f"recording's statistics);\n# median errors in tolerances: {errors}.\n\n"
            f"[styles.human]\n"
            f'description = "fitted to {len(strokes)} LASA recordings: {_order(hand.order)} '
            f'between key-points at the speed minima and peaks"\n'
            f"order = {hand.order}\nh = {hand.h:g}\nd = {hand.d:.6g}\n"
            f'timing = "{hand.timing}"\n')


def _order(order: int) -> str:
    return "minimum jerk (order 3)" if order == 3 else f"order {order}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="compare with the shipped file instead of writing it")
    args = parser.parse_args()
    text = fitted_file()
    if args.check:
        same = Path(FITTED_FILE).read_text() == text
        print(f"{FITTED_FILE}: {'as the fit gives' if same else 'DIFFERS from the fit'}")
        return 0 if same else 1
    Path(FITTED_FILE).write_text(text)
    print(f"written {FITTED_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
