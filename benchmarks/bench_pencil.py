"""Pencil texture synthesis speed (seed 002 ch. 4.2) in lines per second, against the plain
marker ink drawing the same line in the same run.

Run: ``python benchmarks/bench_pencil.py`` (``--quick`` for fewer repeats). The line: a 100 mm
wave drawn at 1 N and touched at 1 kHz (the plant's physics rate: 1000 touches), on a canvas
of 10 and 20 px/mm. Rows: the marker (reference), the pencil without texture (its plain
force-dependent mark), the textured pencil (HB and 8B: the texture is synthesized at the lift),
and the synthesis alone (fill, repair, blur) of a straight 100 mm strip of the grade's width.
The cases run in alternating blocks (:mod:`blocks`; a block is ``repeats`` lines of one case,
each with its own seed); prints a markdown table of the medians of the blocks' median times,
lines per second and the ratio to the marker, with the load average beside it.
"""

from __future__ import annotations

import argparse
import itertools
import time

import numpy as np
from blocks import interleave, load_line

from inkarm.ink.canvas import Canvas, MarkerInk, PencilInk
from inkarm.ink.pencil_synthesis import synthesize_line

LENGTH_MM = 100.0
TOUCHES = 1000


def wave() -> np.ndarray:
    """(TOUCHES, 2) points of a 100 mm-wide wave across the page [mm]."""
    x = np.linspace(10.0, 10.0 + LENGTH_MM, TOUCHES)
    return np.column_stack([x, 30.0 + 8.0 * np.sin(x / 9.0)])


def draw(ink, px_per_mm: float, points: np.ndarray) -> float:
    """Seconds to touch the line point by point and lift (the canvas made beforehand)."""
    canvas = Canvas(size_mm=(120.0, 60.0), px_per_mm=px_per_mm, ink=ink)
    start = time.perf_counter()
    for k, p in enumerate(points):
        canvas.touch(p, 1.0, 0.001 * k)
    canvas.lift()
    return time.perf_counter() - start


def synthesis(grade: str, px_per_mm: float, seed: int) -> float:
    ink = PencilInk(grade=grade)
    widths = np.full(round(LENGTH_MM * px_per_mm), ink.line_width_mm * px_per_mm)
    start = time.perf_counter()
    synthesize_line(ink.profile, widths, np.random.default_rng(seed))
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args()
    blocks, repeats = (2, 2) if args.quick else (5, 3)
    points = wave()
    seeds = itertools.count()
    cases = {
        "marker (reference)": lambda ppm: draw(MarkerInk(), ppm, points),
        "pencil, no texture": lambda ppm: draw(PencilInk(texture=False), ppm, points),
        "pencil HB, textured at the lift":
            lambda ppm: draw(PencilInk(seed=next(seeds)), ppm, points),
        "pencil 8B, textured at the lift":
            lambda ppm: draw(PencilInk(grade="8B", seed=next(seeds)), ppm, points),
        "synthesis alone, HB strip": lambda ppm: synthesis("HB", ppm, next(seeds)),
        "synthesis alone, 8B strip": lambda ppm: synthesis("8B", ppm, next(seeds)),
    }
    print("## Pencil texture (seed 002 ch. 4)\n")
    print(f"One {LENGTH_MM:g} mm line, {TOUCHES} touches at 1 N; the cases in {blocks} "
          f"alternating blocks of {repeats} lines, medians of the blocks' medians. Ratio: time "
          "over the marker's at the same resolution.\n")
    print("| case | px/mm | median [ms] | lines/s | ratio to marker |")
    print("|---|---|---|---|---|")
    loads = []
    for ppm in (10.0, 20.0):
        result = interleave({name: (lambda run=run, ppm=ppm: run(ppm)) for name, run in cases.items()},
                            blocks=blocks, repeats=repeats, clock=None)
        loads.append(result)
        reference = next(iter(cases))
        for name in cases:
            median = result.median(name)
            print(f"| {name} | {ppm:g} | {1e3 * median:.1f} | {1.0 / median:.1f} | "
                  f"{result.ratio(name, reference):.1f} |")
    print(f"\n{load_line(loads[0].load_before, loads[-1].load_after)}\n")


if __name__ == "__main__":
    main()
