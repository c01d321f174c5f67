"""The ``human`` handstyle against people: held-out LASA demonstrations, the human statistics of
the recordings and of their restyles (issue 25, part 3).

Run: ``python benchmarks/bench_human.py [--refit]``. The ``human`` style
(``inkarm/data/handstyles_fitted.toml``) was fitted by ``inkarm fit-style lasa:all:0-4`` to
demonstrations 0-4 of the 26 single-shape LASA sets; this benchmark takes demonstrations 5 and 6
of the same shapes (52 recordings the fit never saw) and prints:

1. the human ranges (``inkarm/data/human_ranges.toml``, all 182 demonstrations) beside the
   statistics of the held-out recordings, of their restyles by the ``human`` style, and of their
   restyles by inkarm's default restyle (DPPLA targets held alike, compression 0.95, for
   comparison): median [inter-quartile range] of beta, speed peaks per second and normalised
   jerk per peak over the recordings, and whether the median lies inside the human range;
2. per recording, the restyle's speed peaks over the recording's and its normalised jerk per
   peak over the recording's: the share within 20 % and within 2x (the issue's verdicts);
3. how firm the medians' verdicts are: for each side, a 90 % bootstrap interval of the median
   over the 52 recordings (:data:`RESAMPLES` resamples, seed 0) and the share of resamples whose
   median lies inside the human range; and the recordings' median speed peaks per second per
   demonstration 0-6, which rises with practice (the held-out demonstrations are the last).

``--refit`` also runs the fit again (about a minute on 2 cores) and says whether it gives the
shipped style.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from inkarm.analysis.humanlike import HUMAN_RANGES
from inkarm.core.trajectory import Drawing
from inkarm.io.human import LASA_MULTI, lasa_shapes, read_lasa
from inkarm.plans.fitstyle import fit_style, human_measures, restyled
from inkarm.plans.handstyles import FITTED
from inkarm.plans.restyle import RestyleConfig, restyle

HELD_OUT = (5, 6)
RESAMPLES = 4000
"""Bootstrap resamples of the held-out recordings (section 3 of the module docstring)."""
MEASURES = (("beta", "beta"), ("peaks_per_second", "peaks per second"),
            ("jerk_per_peak", "jerk per peak"))


def held_out() -> list:
    shapes = [s for s in lasa_shapes() if s not in LASA_MULTI]
    return [d.strokes[0] for s in shapes for d in read_lasa(s, HELD_OUT)]


def per_trace(trace) -> dict[str, float]:
    stats = human_measures(trace)
    stats["peaks_per_second"] = stats["peaks"] / trace.duration
    return stats


def isochronous(trace):
    return restyle(Drawing([trace]), RestyleConfig(dt=0.005)).drawing.strokes[0]


def quartiles(values) -> tuple[float, float, float]:
    q1, q2, q3 = np.nanpercentile(np.asarray(values, dtype=float), [25, 50, 75])
    return float(q1), float(q2), float(q3)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refit", action="store_true", help="fit the style again and compare")
    args = parser.parse_args()
    start, load = time.perf_counter(), os.getloadavg()[0]
    hand = FITTED["human"]
    traces = held_out()
    sides = {"recordings (held out)": [per_trace(t) for t in traces],
             "restyled by `human`": [per_trace(restyled(t, hand)) for t in traces],
             "restyled by the default (DPPLA 0.95, isochronous)":
                 [per_trace(isochronous(t)) for t in traces]}
    print("## Human handwriting: the `human` style on held-out LASA demonstrations "
          "(bench_human.py)\n")
    print(f"{len(traces)} recordings: demonstrations {HELD_OUT[0]} and {HELD_OUT[1]} of the 26 "
          f"single-shape LASA sets, which the fit of `human` (order {hand.order}, h {hand.h:g} "
          f"mm^2, d {hand.d:.4g} mm, timing {hand.timing}) never saw. Median [inter-quartile "
          "range] over the recordings; `in` when the median lies inside the human range.\n")
    print("| | " + " | ".join(label for _, label in MEASURES) + " |")
    print("|---|" + "---|" * len(MEASURES))
    human = {key: HUMAN_RANGES.measures[key] for key, _ in MEASURES}
    print("| human range (LASA, all 182) | " + " | ".join(
        f"{r.median:.3g} [{r.q25:.3g}, {r.q75:.3g}]" for r in human.values()) + " |")
    for side, stats in sides.items():
        cells = []
        for key, _ in MEASURES:
            q1, q2, q3 = quartiles([s[key] for s in stats])
            inside = human[key].q25 <= q2 <= human[key].q75
            cells.append(f"{q2:.3g} [{q1:.3g}, {q3:.3g}] {'in' if inside else 'OUT'}")
        print(f"| {side} | " + " | ".join(cells) + " |")
    print("\nPer recording, restyle over recording (median [IQR]; share within the issue's "
          "bound):\n")
    print("| restyle | speed peaks | within 20 % | jerk per peak | within 2x |")
    print("|---|---|---|---|---|")
    base = sides["recordings (held out)"]
    for side in list(sides)[1:]:
        peaks = [s["peaks"] / b["peaks"] for s, b in zip(sides[side], base)]
        jerk = [s["jerk_per_peak"] / b["jerk_per_peak"] for s, b in zip(sides[side], base)]
        q1, q2, q3 = quartiles(peaks)
        j1, j2, j3 = quartiles(jerk)
        near = np.mean([abs(np.log(p)) <= np.log(1.2) for p in peaks])
        within = np.mean([abs(np.log(j)) <= np.log(2.0) for j in jerk])
        print(f"| {side} | {q2:.2f} [{q1:.2f}, {q3:.2f}] | {near:.0%} | {j2:.2f} [{j1:.2f}, "
              f"{j3:.2f}] | {within:.0%} |")
    print("\nHow firm the medians are (90 % bootstrap interval of the median over the "
          f"{len(traces)} recordings; share of {RESAMPLES} resamples inside the human range):\n")
    print("| | " + " | ".join(label for _, label in MEASURES) + " |")
    print("|---|" + "---|" * len(MEASURES))
    rng = np.random.default_rng(0)
    picks = rng.integers(0, len(traces), (RESAMPLES, len(traces)))
    for side, stats in list(sides.items())[:2]:
        cells = []
        for key, _ in MEASURES:
            medians = np.nanmedian(np.array([s[key] for s in stats], dtype=float)[picks], axis=1)
            low, high = np.percentile(medians, [5, 95])
            inside = np.mean((medians >= human[key].q25) & (medians <= human[key].q75))
            cells.append(f"[{low:.3g}, {high:.3g}], {inside:.0%} inside")
        print(f"| {side} | " + " | ".join(cells) + " |")
    shapes = [s for s in lasa_shapes() if s not in LASA_MULTI]
    per_demo = [np.median([per_trace(d.strokes[0])["peaks_per_second"]
                           for s in shapes for d in read_lasa(s, [demo])]) for demo in range(7)]
    print("\nRecordings' median speed peaks per second by demonstration (0-4 trained on, 5-6 "
          "held out): " + ", ".join(f"{v:.2f}" for v in per_demo) + ".")
    if args.refit:
        train = [d.strokes[0] for s in lasa_shapes() if s not in LASA_MULTI
                 for d in read_lasa(s, range(5))]
        fit = fit_style(train, human_measures)
        same = (fit.handstyle.order, round(fit.handstyle.d, 4)) == (hand.order, round(hand.d, 4))
        print(f"\nRefit on demonstrations 0-4: order {fit.handstyle.order}, d "
              f"{fit.handstyle.d:.4g} mm, score {fit.score:.3f}: "
              f"{'the shipped style' if same else 'NOT the shipped style'}.")
    print(f"\nLoad average (1 min) {load:.1f} before, {os.getloadavg()[0]:.1f} after; "
          f"{time.perf_counter() - start:.0f} s.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
