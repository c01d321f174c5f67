"""The SVG corpus (tests/data/svg/, files from independent writers): inkarm's stroke count and
what it skips, against vpype's path count (``vpype.read_multilayer_svg``, as ``vpype read``),
every difference listed with its reason here and in the corpus README."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from inkarm.io.trace import read_svg

CORPUS = Path(__file__).resolve().parents[1] / "data" / "svg"

TOP_LEVEL_USE = "vpype draws no top-level <use>"
EXPECTED = {
    # file: (inkarm strokes, vpype paths, inkarm's skipped counts, why the counts differ)
    "adwaita_parental_controls.svg": (7, 8, {}, ("vpype crops to the page: one outline "
                                                 "crosses the page edge and is cut in two")),
    "adwaita_select_all.svg": (16, 16, {}, ""),
    "drawsvg_shapes.svg": (7, 3, {"hidden": 1, "text": 1},
                           f"{TOP_LEVEL_USE} (2 <use> of 2 lines each)"),
    "graphviz_rust_book.svg": (23, 24, {"text": 20, "white on white": 1},
                               "vpype draws the white background polygon"),
    "hand_arcs.svg": (10, 10, {}, ""),
    "hand_groups_transforms.svg": (7, 7, {}, ""),
    "hand_hidden.svg": (1, 8, {"hidden": 6, "no stroke or fill": 3, "white on white": 2,
                               "text": 1, "image": 1},
                        ("vpype draws the 3 unpainted paths, the 2 white shapes and the "
                         "opacity-0 path, and crops the page-size white rectangle in two")),
    "hand_nested_units.svg": (5, 5, {}, ""),
    "hand_use_symbol.svg": (12, 5, {}, (f"{TOP_LEVEL_USE} (8 strokes); vpype draws the "
                                        "circle of a <symbol> outside <defs>, which SVG never "
                                        "renders")),
    "matplotlib_icon_home.svg": (2, 3, {"hidden": 1},
                                 "vpype draws the opacity-0 background rectangle"),
    "matplotlib_patches.svg": (5, 6, {"white on white": 1},
                               "vpype draws the white figure background"),
    "matplotlib_text_none.svg": (11, 13, {"text": 7, "white on white": 2},
                                 "vpype draws the white figure and axes backgrounds"),
    "matplotlib_text_paths.svg": (29, 31, {"white on white": 2},
                                  "vpype draws the white figure and axes backgrounds"),
    "sodipodi_hand.svg": (2, 2, {}, ""),
    "svgwrite_shapes.svg": (7, 7, {}, ""),
    "vpype_shapes.svg": (4, 4, {}, ""),
    "vpype_text.svg": (14, 14, {}, ""),
}
FILES = sorted(EXPECTED)


def test_the_corpus_is_the_listed_files_from_at_least_ten_writers():
    assert sorted(p.name for p in CORPUS.glob("*.svg")) == FILES
    writers = {name.split("_")[0] for name in FILES}
    assert len(FILES) >= 10 and len(writers) >= 8
    assert all((CORPUS / name).stat().st_size < 32_000 for name in FILES)


def test_the_readme_table_lists_every_file_with_these_counts():
    rows = {}
    for line in (CORPUS / "README.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[0].startswith("`") and cells[0].endswith(".svg`"):
            rows[cells[0].strip("`")] = (int(cells[4]), int(cells[5]), cells[6].replace("`", ""))
    assert sorted(rows) == FILES
    for name, (strokes, paths, _, why) in EXPECTED.items():
        assert rows[name][:2] == (strokes, paths), name
        assert (rows[name][2] == "-") == (strokes == paths), name
        assert not why or why.split(":")[0].split(" (")[0] in rows[name][2], name


@pytest.mark.parametrize("name", FILES)
def test_inkarm_reads_every_corpus_file(name):
    strokes, _, skipped, _ = EXPECTED[name]
    drawing = read_svg(CORPUS / name)
    assert len(drawing.strokes) == strokes
    assert drawing.meta["svg_skipped"] == skipped


def test_nothing_invisible_is_drawn():
    """hand_hidden.svg has one visible element, a 20 mm square at (10, 10) on a 100 mm page."""
    (square,) = read_svg(CORPUS / "hand_hidden.svg").strokes
    lo, hi = square.pos.min(axis=0), square.pos.max(axis=0)
    np.testing.assert_allclose([*lo, *hi], [10, 70, 30, 90], atol=1e-9)


@pytest.fixture(scope="module")
def vpype():
    return pytest.importorskip("vpype", reason="the corpus is compared with vpype's reading "
                                               "(pip install vpype)")


@pytest.mark.parametrize("name", FILES)
def test_vpype_counts_and_the_strokes_both_draw_start_and_end_together(vpype, name):
    paths = EXPECTED[name][1]
    document = vpype.read_multilayer_svg(str(CORPUS / name), quantization=0.1)
    assert sum(len(layer) for layer in document.layers.values()) == paths
    if TOP_LEVEL_USE in EXPECTED[name][3]:
        return  # inkarm draws more than vpype
    uncut = vpype.read_multilayer_svg(str(CORPUS / name), quantization=0.1, crop=False)
    drawing = read_svg(CORPUS / name)
    width_mm, height_mm = drawing.page_size
    scale = width_mm / uncut.page_size[0]  # [mm] per vpype unit (px)
    theirs = np.array([[line[0], line[-1]] for layer in uncut.layers.values()
                       for line in layer])
    theirs = np.stack([theirs.real * scale, height_mm - theirs.imag * scale], axis=-1)
    for stroke in drawing.strokes:
        ends = stroke.pos[[0, -1], :2]
        gap = np.linalg.norm(theirs - ends, axis=-1).max(axis=1).min()
        assert gap < 1e-3, (name, ends)


def test_layers_agree_with_vpype(vpype):
    for name in ("hand_groups_transforms.svg", "svgwrite_shapes.svg", "vpype_shapes.svg",
                 "adwaita_parental_controls.svg"):
        document = vpype.read_multilayer_svg(str(CORPUS / name), quantization=0.1, crop=False)
        layers = read_svg(CORPUS / name).meta["layers"]
        ours = {int(lid): int(np.sum(layers == lid)) for lid in np.unique(layers)}
        assert ours == {lid: len(layer) for lid, layer in document.layers.items()}, name


def test_the_script_makes_every_file_of_the_python_writers():
    script = (CORPUS.parents[2] / "scripts" / "make_svg_corpus.py").read_text()
    made = set(re.findall(r'"(\w+\.svg)": ', script))
    python_writers = {n for n in FILES if n.split("_")[0] in ("matplotlib", "vpype", "svgwrite",
                                                             "drawsvg")}
    assert made == python_writers - {"matplotlib_icon_home.svg"}  # copied from matplotlib
