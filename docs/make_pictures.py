"""Regenerate the README's pictures in docs/img from the shipped scenarios and commands.

    python docs/make_pictures.py
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from inkarm.cli import main

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
SCENARIOS = ["letter_N", "word_fix_it", "house_human_lines", "N_five_samples", "text_inkarm",
             "tag", "trace_signature"]


def shrink(src: Path, dst: Path, width: int = 1000) -> None:
    im = Image.open(src).convert("RGB")
    if im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
    im.save(dst, optimize=True)


def ink_crop(path: Path, pad: int = 40) -> np.ndarray:
    im = np.asarray(Image.open(path).convert("L"))
    rows, cols = np.nonzero(im < 250)
    return im[max(rows.min() - pad, 0): rows.max() + pad, max(cols.min() - pad, 0): cols.max() + pad]


def scenario_sheet(out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(16, 7))
    for ax in axes.flat:
        ax.axis("off")
    for ax, name in zip(axes.flat, SCENARIOS):
        ax.imshow(ink_crop(out / name / "canvas.png"), cmap="gray", vmin=0, vmax=255)
        ax.set_title(name, fontsize=11)
    fig.tight_layout()
    fig.savefig(IMG / "scenarios.png", dpi=70)
    plt.close(fig)


def run() -> None:
    IMG.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for name in SCENARIOS:
            assert main(["draw", str(ROOT / "scenarios" / f"{name}.toml"), "--out", str(out / name), "--quiet"]) == 0
        shrink(out / "letter_N" / "report.png", IMG / "draw_report.png")
        scenario_sheet(out)
        plans = ROOT / "scenarios" / "plans"
        assert main(["plan", str(plans / "N_samples.toml"), "--out", str(out / "N")]) == 0
        shrink(out / "N" / "plan.png", IMG / "plan_N.png", 500)
        assert main(["plan", str(plans / "A_facilitation.toml"), "--out", str(out / "A")]) == 0
        shrink(out / "A" / "plan.png", IMG / "plan_facilitation.png", 600)
        assert main(["write", "inkarm", "--style", "cursive", "--out", str(out / "w")]) == 0
        shrink(out / "w" / "write.png", IMG / "write.png")
        assert main(["tag", "--seed", "3", "--out", str(out / "t")]) == 0
        shrink(out / "t" / "tag.png", IMG / "tag.png", 800)
        trace = ROOT / "scenarios" / "traces" / "signature.svg"
        assert main(["restyle", str(trace), "--out", str(out / "r"), "--compression", "0.9"]) == 0
        shrink(out / "r" / "signature_restyle.png", IMG / "restyle.png", 700)
        assert main(["analyse", str(out / "w" / "drawing.csv"), "--out", str(out / "a")]) == 0
        figures = sorted((out / "a").glob("*.png"))
        shutil.copy(figures[0], out / "a0.png")
        ims = [Image.open(f).convert("RGB") for f in figures[:2]]
        h = min(im.height for im in ims)
        ims = [im.resize((round(im.width * h / im.height), h)) for im in ims]
        sheet = Image.new("RGB", (sum(im.width for im in ims), h), "white")
        x = 0
        for im in ims:
            sheet.paste(im, (x, 0))
            x += im.width
        sheet.save(out / "analyse.png")
        shrink(out / "analyse.png", IMG / "analyse.png")


if __name__ == "__main__":
    run()
