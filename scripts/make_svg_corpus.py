"""Regenerate the SVG files of tests/data/svg/ that Python writers make (matplotlib, vpype,
svgwrite, drawsvg); tests/data/svg/README.md lists every file, its writer and its licence.

    .venv/bin/python scripts/make_svg_corpus.py            # rewrite them
    .venv/bin/python scripts/make_svg_corpus.py --check    # exit 1 if one would change

Writers' versions go into the README by hand. The hand-written files and those copied from
installed packages are not made here.
"""

from __future__ import annotations

import argparse
import io
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "svg"


def matplotlib_figure(fonttype: str) -> bytes:
    """A small plot with a title, axis labels and a legend; text as glyph paths placed with
    <use> (``svg.fonttype='path'``, matplotlib's default) or as <text> ('none')."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    with matplotlib.rc_context({"svg.fonttype": fonttype, "svg.hashsalt": "inkarm",
                                "svg.id": "inkarm"}):
        fig, ax = plt.subplots(figsize=(3.0, 2.0))
        t = np.linspace(0, 2 * np.pi, 40)
        ax.plot(t, np.sin(t), label="sin")
        ax.set_title("inkarm")
        ax.set_xticks([0, 3, 6])
        ax.set_yticks([-1, 0, 1])
        buf = io.BytesIO()
        fig.savefig(buf, format="svg", metadata={"Date": None})
        plt.close(fig)
    return buf.getvalue()


def matplotlib_patches() -> bytes:
    """Patches (circle, rectangle, rounded box, ellipse, polygon) without axes or text."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import patches

    with matplotlib.rc_context({"svg.hashsalt": "inkarm", "svg.id": "inkarm"}):
        fig = plt.figure(figsize=(2.0, 2.0))
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_axis_off()
        ax.set_xlim(0, 10)
        ax.set_ylim(0, 10)
        style = {"fill": False, "edgecolor": "black"}
        ax.add_patch(patches.Circle((3, 3), 2, **style))
        ax.add_patch(patches.Rectangle((6, 1), 3, 2, **style))
        ax.add_patch(patches.FancyBboxPatch((1, 6.5), 3, 2, boxstyle="round,pad=0.3", **style))
        ax.add_patch(patches.Ellipse((7.5, 7), 3, 1.5, angle=30, **style))
        ax.add_patch(patches.Polygon([(5, 4), (6, 6), (4, 6)], closed=True, facecolor="grey"))
        buf = io.BytesIO()
        fig.savefig(buf, format="svg", metadata={"Date": None})
        plt.close(fig)
    return buf.getvalue()


def vpype_file(args: list[str]) -> bytes:
    """What the ``vpype`` command line writes for ``args`` (then ``write``, to stdout, without
    a date, so that the file is reproducible)."""
    vpype = Path(sys.executable).with_name("vpype")
    done = subprocess.run([str(vpype), *args, "write", "--dont-set-date", "--format",
                           "svg", "-"], check=True, capture_output=True)
    return done.stdout


def svgwrite_shapes() -> bytes:
    """Every svgwrite basic shape, a symbol placed twice with <use>, a group transform, two
    Inkscape layers."""
    import svgwrite

    dwg = svgwrite.Drawing(size=("80mm", "60mm"), viewBox="0 0 80 60", profile="full",
                           debug=False)
    symbol = dwg.symbol(id="star")
    symbol.add(dwg.polygon([(0, -4), (1, -1), (4, 0), (1, 1), (0, 4), (-1, 1), (-4, 0),
                            (-1, -1)], fill="none", stroke="black", stroke_width=0.3))
    dwg.defs.add(symbol)
    first = dwg.g(id="layer1", stroke="black", fill="none", stroke_width=0.3)
    first.attribs["inkscape:groupmode"] = "layer"
    first.attribs["inkscape:label"] = "1 outlines"
    first.add(dwg.rect((5, 5), (30, 20), rx=3, ry=3))
    first.add(dwg.circle((55, 15), r=10))
    first.add(dwg.ellipse((20, 45), r=(12, 6)))
    first.add(dwg.line((40, 35), (75, 55)))
    first.add(dwg.polyline([(40, 55), (50, 40), (60, 55)]))
    second = dwg.g(id="layer2", transform="translate(60 45) rotate(15)")
    second.attribs["inkscape:groupmode"] = "layer"
    second.attribs["inkscape:label"] = "2 stars"
    second.add(dwg.use("#star"))
    second.add(dwg.use("#star", insert=(10, 0)))
    dwg.add(first)
    dwg.add(second)
    dwg.attribs["xmlns:inkscape"] = "http://www.inkscape.org/namespaces/inkscape"
    return dwg.tostring().encode()


def drawsvg_shapes() -> bytes:
    """drawsvg shapes: a path with arcs and curves, a rounded rectangle, a circle, a group
    reused with <use>, text (skipped) and a hidden circle."""
    import drawsvg as draw

    d = draw.Drawing(100, 70, origin=(0, 0))
    d.set_render_size("100mm", "70mm")
    p = draw.Path(stroke="black", fill="none", stroke_width=0.5)
    p.M(10, 10).A(10, 10, 0, False, True, 30, 10).Q(40, 0, 50, 10).C(55, 20, 65, 0, 70, 10)
    d.append(p)
    d.append(draw.Rectangle(10, 30, 30, 15, rx=4, ry=4, stroke="black", fill="none"))
    d.append(draw.Circle(60, 40, 8, fill="#ddd", stroke="black"))
    group = draw.Group(id="tick", stroke="black")
    group.append(draw.Line(0, 0, 5, 5))
    group.append(draw.Line(0, 5, 5, 0))
    d.append(draw.Use(group, 80, 50))
    d.append(draw.Use("tick", 88, 50))
    d.append(draw.Text("plot me", 6, 10, 65))
    d.append(draw.Circle(85, 20, 5, stroke="black", fill="none", visibility="hidden"))
    return d.as_svg().encode()


MADE = {
    "matplotlib_text_paths.svg": lambda: matplotlib_figure("path"),
    "matplotlib_text_none.svg": lambda: matplotlib_figure("none"),
    "matplotlib_patches.svg": matplotlib_patches,
    "vpype_text.svg": lambda: vpype_file(
        ["text", "--size", "12", "--position", "10mm", "20mm", "inkarm", "pagesize", "a6"]),
    "vpype_shapes.svg": lambda: vpype_file(
        ["circle", "-l", "1", "30mm", "30mm", "15mm", "rect", "-l", "2", "--radii", "3mm", "3mm", "3mm", "3mm",
         "50mm", "15mm", "40mm", "30mm", "ellipse", "-l", "2", "40mm", "80mm", "25mm", "10mm",
         "line", "-l", "3", "10mm", "110mm", "90mm", "130mm", "linemerge", "pagesize", "a6"]),
    "svgwrite_shapes.svg": svgwrite_shapes,
    "drawsvg_shapes.svg": drawsvg_shapes,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 if a file would change")
    args = parser.parse_args(argv)
    changed = []
    for name, make in MADE.items():
        data = make()
        path = OUT / name
        if path.exists() and path.read_bytes() == data:
            continue
        changed.append(name)
        if not args.check:
            path.write_bytes(data)
    print(("would change: " if args.check else "written: ") + (", ".join(changed) or "none"))
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
