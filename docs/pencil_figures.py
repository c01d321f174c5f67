"""The README's pencil figures (seed 002 ch. 4) from the shipped grades.

    python docs/pencil_figures.py

Writes docs/img/pencil_grades.png (each grade: a piece of the synthetic scan its profile was
extracted from, the target texture, beside a straight stroke drawn with it on the canvas at the
scan's resolution, and a wave at the canvas's default 10 px/mm; all at 1 N, the reference force)
and docs/img/pencil_profile.png (``inkarm pencil show HB --length-mm 8``: the HB profile and a
line synthesized from it step by step beside its scan). Prints each grade's mean darkness and
co-occurrence distance on the page.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from inkarm.cli import main as inkarm
from inkarm.ink.canvas import Canvas, PencilInk
from inkarm.ink.graphite import reference_scan
from inkarm.ink.pencil_extract import upright_line
from inkarm.ink.pencil_profile import GRADES, resolve_profile
from inkarm.ink.pencil_synthesis import glcm_distance, strip_glcm
from inkarm.plots.figure import new_figure, save_figure
from inkarm.plots.pencil import crop_line

IMG = Path(__file__).resolve().parent / "img"
PIECE_MM = 12.0
BAND_MM = 1.6


def straight_stroke(grade: str, px_per_mm: float) -> np.ndarray:
    """Darkness of a horizontal stroke of PIECE_MM [mm] at 1 N, on a band BAND_MM [mm] high."""
    canvas = Canvas(size_mm=(PIECE_MM + 2.0, BAND_MM), px_per_mm=px_per_mm,
                    ink=PencilInk(grade=grade, seed=1))
    xs = np.linspace(0.5, PIECE_MM + 1.5, 800)
    for k, x in enumerate(xs):
        canvas.touch((x, BAND_MM / 2), 1.0, 0.001 * k)
    canvas.lift()
    return canvas.image[:, round(1.0 * px_per_mm) : round((PIECE_MM + 1.0) * px_per_mm)]


def wave(grade: str) -> np.ndarray:
    """Darkness of a 100 mm wave at 1 N on the canvas's default 10 px/mm."""
    canvas = Canvas(size_mm=(110.0, 10.0), px_per_mm=10.0, ink=PencilInk(grade=grade, seed=1))
    xs = np.linspace(5.0, 105.0, 2000)
    for k, x in enumerate(xs):
        canvas.touch((x, 5.0 + 3.0 * np.sin(x / 9.0)), 1.0, 0.001 * k)
    canvas.lift()
    return canvas.image


def grades_figure() -> None:
    fig = new_figure((13, 1.2 * len(GRADES)), layout="constrained")
    grid = fig.add_gridspec(len(GRADES), 3, width_ratios=[1, 1, 3.2])
    for row, grade in enumerate(GRADES):
        profile = resolve_profile(grade)
        ppm = profile.px_per_mm
        scan = crop_line(upright_line(reference_scan(grade)), PIECE_MM, BAND_MM, ppm).T
        page = straight_stroke(grade, ppm)
        core = page > 0
        grey = np.round(255.0 * (1.0 - page.T)).astype(np.uint8)
        d = glcm_distance(strip_glcm(grey, core.T, profile.levels), profile.glcm)
        print(f"{grade}: page mean darkness {page[core].mean():.3f}, co-occurrence distance on "
              f"the page {d:.2f}")
        panels = ((scan / 255.0, "scan (target)"),
                  (1.0 - page, f"synthesized, d = {d:.2f}"),
                  (1.0 - wave(grade), "wave, 10 px/mm"))
        for col, (image, title) in enumerate(panels):
            ax = fig.add_subplot(grid[row, col])
            ax.imshow(image, cmap="gray", vmin=0, vmax=1, interpolation="nearest",
                      aspect="auto" if col < 2 else "equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title, fontsize=7)
            if col == 0:
                ax.set_ylabel(grade, rotation=0, labelpad=14, fontsize=9, va="center")
    save_figure(fig, IMG / "pencil_grades.png", dpi=110)


def main() -> None:
    grades_figure()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "show"
        inkarm(["pencil", "show", "HB", "--length-mm", "8", "--out", str(out)])
        (IMG / "pencil_profile.png").write_bytes((out / "profile.png").read_bytes())
    print(f"written {IMG / 'pencil_grades.png'} and {IMG / 'pencil_profile.png'}")


if __name__ == "__main__":
    main()
