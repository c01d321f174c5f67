"""The vpype plug-in ``inkarm-style`` (inkarm.vpype_plugin) and the vpype <-> Drawing seam
(inkarm.io.vpype_doc): a pipeline read -> inkarm-style -> write keeps every layer, its line
count, its metadata and the page, and moves no line far from where it was."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

vpype = pytest.importorskip("vpype", reason="vpype not installed: pip install inkarm[vpype]")
vpype_cli = pytest.importorskip("vpype_cli", reason="vpype not installed: pip install inkarm[vpype]")
click = pytest.importorskip("click")

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.io.vpype_doc import (
    MM_PER_PX,
    document_to_drawing,
    drawing_to_document,
    lines_to_drawing,
)
from inkarm.plans.handstyles import PRESETS

# Three layers as Inkscape writes them: letters (a branching path, a closed bowl, a zigzag),
# shapes (a circle and a rectangle: closed), bits (a 0.4 mm dash and a 40 mm straight line).
SVG = """<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="120mm" height="80mm" viewBox="0 0 120 80">
  <g inkscape:groupmode="layer" inkscape:label="letters" id="layer1" stroke="black" fill="none">
    <path d="M 10 60 L 10 20 M 10 40 C 15 30 25 30 25 40 L 25 60"/>
    <path d="M 35 45 C 35 35 50 35 50 45 C 50 55 35 55 35 45 Z"/>
    <polyline points="60,60 65,20 70,60 75,20 80,60"/>
  </g>
  <g inkscape:groupmode="layer" inkscape:label="shapes" id="layer2" stroke="red" fill="none">
    <circle cx="95" cy="30" r="12"/>
    <rect x="85" y="50" width="25" height="20"/>
  </g>
  <g inkscape:groupmode="layer" inkscape:label="bits" id="layer3" stroke="blue" fill="none">
    <line x1="10" y1="70" x2="10.4" y2="70"/>
    <line x1="20" y1="72" x2="60" y2="72"/>
  </g>
</svg>
"""
# The LQT is linear in its targets, so how far it cuts a corner or falls short of an end
# scales with the spacing of the targets: with the defaults (samples 0.25 mm apart, compression
# 0.8, (1 - 0.8) x 2/3 targets a sample) a target every 1.9 mm. Measured on SVG, largest
# Hausdorff distance of a line to its input: hurried 0.79 mm (the rectangle's corners), italic
# 0.58, graffiti 0.41, loose 0.25, cursive 0.25, faithful 0.21. Bound: half a target spacing.
MAX_HAUSDORFF_MM = 0.5 * 0.25 / ((1 - 0.8) * 2 / 3)


def _svg(tmp_path: Path) -> Path:
    path = tmp_path / "in.svg"
    path.write_text(SVG)
    return path


def _dense_mm(line: np.ndarray, step_px: float = 0.25) -> np.ndarray:
    """A vpype line [px] as points [mm] at most ``step_px`` apart along it (its segments
    sampled, so that a distance to it is a distance to the polyline, not to its vertices)."""
    parts = [line[:1]]
    for p, q in itertools.pairwise(line):
        n = max(1, int(np.ceil(abs(q - p) / step_px)))
        parts.append(p + (q - p) * np.arange(1, n + 1) / n)
    z = np.concatenate(parts) * MM_PER_PX
    return np.column_stack([z.real, z.imag])


def _hausdorff_mm(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.spatial import cKDTree

    pa, pb = _dense_mm(a), _dense_mm(b)
    return float(max(cKDTree(pb).query(pa)[0].max(), cKDTree(pa).query(pb)[0].max()))


def _check_restyled(before, after, *, layers=None, through_file=False) -> list[float]:
    """Same layers, line counts, metadata and page; each line's Hausdorff distance [mm]."""
    assert list(after.layers) == list(before.layers)
    assert after.page_size == pytest.approx(before.page_size)
    distances = []
    for lid, lc in before.layers.items():
        assert len(after.layers[lid]) == len(lc), f"layer {lid}"
        if through_file:  # vpype's writer spells some properties its own way
            for prop in ("vp_name", "vp_color"):
                assert after.layers[lid].property(prop) == lc.property(prop)
        else:
            assert after.layers[lid].metadata == lc.metadata
        restyled = layers is None or lid in layers
        for a, b in zip(lc, after.layers[lid]):
            if restyled:
                distances.append(_hausdorff_mm(a, b))
            else:
                np.testing.assert_array_equal(a, b)
    return distances


@pytest.mark.parametrize("style", sorted(PRESETS))
def test_pipeline_restyles_every_line_in_its_layer_near_its_input(tmp_path, style):
    out = tmp_path / "out.svg"
    before = vpype_cli.execute(f"read {_svg(tmp_path)}")
    assert {lid: len(lc) for lid, lc in before.layers.items()} == {1: 4, 2: 2, 3: 2}
    vpype_cli.execute(f"read {_svg(tmp_path)} inkarm-style --style {style} write {out}")
    after = vpype_cli.execute(f"read {out}")
    distances = _check_restyled(before, after, through_file=True)
    assert max(distances) <= MAX_HAUSDORFF_MM
    assert max(distances) > 0.05  # restyled, not copied


def test_inkarm_restyle_of_a_layered_svg_keeps_its_layers(tmp_path):
    from inkarm.cli import main

    assert main(["restyle", str(_svg(tmp_path)), "--out", str(tmp_path / "o"),
                 "--compression", "0.8"]) == 0
    before = vpype_cli.execute(f"read {_svg(tmp_path)}")
    after = vpype_cli.execute(f"read {tmp_path / 'o' / 'in_restyled.svg'}")
    assert {lid: len(lc) for lid, lc in after.layers.items()} == {1: 4, 2: 2, 3: 2}
    assert after.page_size == pytest.approx(before.page_size)


@pytest.mark.slow  # a fresh interpreter loading vpype: about 1 s idle, 5 s on a busy machine
def test_installed_vpype_executable_loads_the_entry_point(tmp_path):
    exe = shutil.which("vpype", path=str(Path(sys.executable).parent)) or shutil.which("vpype")
    if exe is None:
        pytest.skip("no vpype executable on PATH")
    out = tmp_path / "out.svg"
    done = subprocess.run([exe, "read", str(_svg(tmp_path)), "inkarm-style", "--style",
                           "cursive", "write", str(out)], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    # vpype replaces a plug-in that fails to load by a command that only says so: the lines
    # must have moved
    before = vpype_cli.execute(f"read {_svg(tmp_path)}")
    distances = _check_restyled(before, vpype_cli.execute(f"read {out}"), through_file=True)
    assert 0.05 < max(distances) <= MAX_HAUSDORFF_MM


def test_layer_option_restyles_only_the_chosen_layer(tmp_path):
    before = vpype_cli.execute(f"read {_svg(tmp_path)}")
    after = vpype_cli.execute("inkarm-style --layer 2", before)
    assert max(_check_restyled(before, after, layers={2})) > 0.05


def test_a_dot_is_kept_and_a_short_dash_restyled():
    dot = np.array([5 + 5j, 5 + 5j])
    dash = np.array([10 + 10j, 11 + 10j])  # 0.26 mm: two vertices, resampled to 3 samples
    before = vpype.Document(vpype.LineCollection([dot, dash]), page_size=(100.0, 100.0))
    after = vpype_cli.execute("inkarm-style -s loose", before)
    assert len(after.layers[1]) == 2
    np.testing.assert_allclose(after.layers[1][0], dot, rtol=0, atol=1e-12)
    restyled = after.layers[1][1]
    assert len(restyled) > 2
    assert restyled[0] == pytest.approx(dash[0])
    assert abs(restyled[-1] - dash[-1]) < 0.2  # [px]: the pen reaches the end (MIN_TARGETS)


@pytest.mark.parametrize("style", ["cursive", "graffiti"])
def test_a_closed_circle_stays_nearly_closed(style):
    # vpype's circle: one closed line of 50 px radius (13.2 mm); measured gap between the
    # restyled ends: cursive 0.20 mm, graffiti 0.09 mm (the LQT ends near, not on, its start)
    before = vpype_cli.execute("circle 100 100 50")
    line = vpype_cli.execute(f"inkarm-style -s {style}", before).layers[1][0]
    assert line[0] == before.layers[1][0][0]
    assert abs(line[-1] - line[0]) * MM_PER_PX < 0.3
    assert _hausdorff_mm(before.layers[1][0], line) <= MAX_HAUSDORFF_MM


def test_seed_changes_only_a_style_with_magnitude_noise(tmp_path):
    doc = vpype_cli.execute(f"read {_svg(tmp_path)}")

    def lines(pipeline):
        out = vpype_cli.execute(pipeline, doc)
        return np.concatenate([line for lc in out.layers.values() for line in lc])

    assert PRESETS["hurried"].rho > 0 and PRESETS["cursive"].rho == 0
    assert not np.allclose(lines("inkarm-style -s hurried --seed 1"),
                           lines("inkarm-style -s hurried --seed 2"))
    np.testing.assert_array_equal(lines("inkarm-style -s cursive --seed 1"),
                                  lines("inkarm-style -s cursive --seed 2"))


def test_a_bad_style_name_lists_the_valid_ones_and_the_closest():
    with pytest.raises(click.BadParameter) as e:
        vpype_cli.execute('text "x" inkarm-style --style cursiv')
    message = e.value.format_message()
    assert "unknown handstyle 'cursiv'" in message
    assert "expected one of " + ", ".join(sorted(PRESETS)) in message
    assert "Did you mean 'cursive'?" in message
    assert e.value.param_hint == "'--style'"


def test_a_styles_file_adds_styles_and_its_errors_name_it(tmp_path):
    good = tmp_path / "mine.toml"
    good.write_text('[styles.wobbly]\nbase = "loose"\nh = 2.0\n')
    vpype_cli.execute(f'text "x" inkarm-style --styles {good} --style wobbly')
    bad = tmp_path / "bad.toml"
    bad.write_text("[styles.x]\nhh = 2.0\n")
    with pytest.raises(click.BadParameter) as e:
        vpype_cli.execute(f'text "x" inkarm-style --styles {bad} --style x')
    assert "unknown key 'hh'" in e.value.format_message()
    assert e.value.param_hint == "'--styles'"


@pytest.mark.parametrize("option, hint", [("--compression 1.5", "--compression"),
                                          ("--spacing 0", "--spacing")])
def test_bad_numbers_name_the_option(option, hint):
    with pytest.raises(click.BadParameter) as e:
        vpype_cli.execute(f'text "x" inkarm-style {option}')
    assert e.value.param_hint == f"'{hint}'"


def test_over_the_step_budget_says_what_to_change(monkeypatch):
    monkeypatch.setenv("INKARM_MAX_STEPS", "10")
    with pytest.raises(click.ClickException) as e:
        vpype_cli.execute('text "hello" inkarm-style')
    message = e.value.format_message()
    assert "INKARM_MAX_STEPS" in message and "--compression" in message


# -- the seam: vpype Document <-> Drawing ---------------------------------------------------


def _timed(points, speed=50.0) -> Trajectory:
    pos = np.asarray(points, dtype=float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))])
    return Trajectory(t=s / speed, pos=pos)


def test_drawing_document_drawing_round_trip():
    drawing = Drawing(
        [_timed([[10.0, 20.0], [30.5, 20.25], [31.0, 287.0]]), _timed([[1.0, 1.0], [2.0, 3.0]]),
         _timed([[100.0, 0.0], [0.0, 297.0], [210.0, 0.0]])],
        page_size=(210.0, 297.0), meta={"layers": np.array([2, 5, 2], dtype=np.int64)},
    )
    document = drawing_to_document(drawing)
    assert {lid: len(lc) for lid, lc in document.layers.items()} == {2: 2, 5: 1}
    assert document.page_size == pytest.approx((210 / 25.4 * 96, 297 / 25.4 * 96), rel=1e-15)
    back = document_to_drawing(document, speed=50.0)
    assert back.page_size == pytest.approx(drawing.page_size, rel=1e-15)
    # strokes come back grouped by layer (2, 2, 5): the layer convention's order
    order = [0, 2, 1]
    np.testing.assert_array_equal(back.meta["layers"], [2, 2, 5])
    assert back.meta["layers"].dtype == np.int64
    for got, i in zip(back.strokes, order):
        np.testing.assert_allclose(got.pos, drawing.strokes[i].pos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.t, drawing.strokes[i].t, rtol=1e-14, atol=1e-15)


def test_document_to_drawing_flips_y_and_converts_px_to_mm():
    document = vpype.Document(vpype.LineCollection([np.array([0j, 96 + 48j])]),
                              page_size=(192.0, 96.0))  # 2 x 1 inch
    drawing = document_to_drawing(document, speed=25.4)
    assert drawing.page_size == pytest.approx((50.8, 25.4))
    np.testing.assert_allclose(drawing.strokes[0].pos, [[0.0, 25.4], [25.4, 12.7]], atol=1e-12)
    np.testing.assert_allclose(drawing.strokes[0].t, [0.0, np.hypot(25.4, 12.7) / 25.4])
    assert "layers" not in drawing.meta  # all in layer 1


def test_a_document_without_page_size_gets_none_back():
    document = vpype.Document(vpype.LineCollection([np.array([0j, 10 + 20j, 10 + 20j, 30j])]))
    drawing = document_to_drawing(document)
    assert drawing.meta["page_from_content"] is True
    assert drawing.page_size == pytest.approx((10 * MM_PER_PX, 30 * MM_PER_PX))
    assert drawing.strokes[0].n == 3  # the repeated point (a pause) dropped
    back = drawing_to_document(drawing)
    assert back.page_size is None
    np.testing.assert_allclose(back.layers[1][0], [0j, 10 + 20j, 30j], atol=1e-12)


@pytest.mark.parametrize("layers, speed, message", [
    ({0: [np.array([0j, 1j])]}, 50.0, "vpype layer id must be an integer >= 1, got 0"),
    ({1: [np.array([0j, np.nan])]}, 50.0, "vpype layer 1 line 0: coordinates must be finite"),
    ({1: [np.array([0j, 1j])]}, 0.0, "speed must be a positive number of mm/s, got 0.0"),
])
def test_lines_to_drawing_errors(layers, speed, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        lines_to_drawing(layers, None, speed)


def test_drawing_to_document_refuses_bad_layers():
    drawing = Drawing([_timed([[0.0, 0.0], [1.0, 1.0]])], meta={"layers": np.array([0])})
    with pytest.raises(InputError, match=r"expected one integer layer id >= 1 per stroke \(1\)"):
        drawing_to_document(drawing)


def test_importing_inkarm_and_the_seam_does_not_load_vpype():
    code = ("import sys, inkarm, inkarm.io.vpype_doc, inkarm.plans.restyle; "
            "print(sorted(m for m in ('vpype', 'vpype_cli', 'click') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, check=True)
    assert done.stdout.strip() == "[]"
