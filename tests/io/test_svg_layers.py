"""Layers from top-level groups as vpype reads them (``vpype.io.read_multilayer_svg``), stored
in ``meta["layers"]``, and written back by :meth:`Drawing.to_svg` as vpype writes layers."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.io.trace import read_svg

LINE = '<line x1="{x}" y1="0" x2="{x}" y2="10" stroke="black"/>'
LAYERED = (
    '<g inkscape:label="Layer 7 red" id="g3">' + LINE.format(x=1) + "</g>"  # label digits
    + '<g inkscape:label="blue" id="pen4">' + LINE.format(x=2) + LINE.format(x=3) + "</g>"
    + LINE.format(x=4)  # top level, not a group: layer 1
    + '<g display="none">' + LINE.format(x=5) + "</g>"  # not drawn, takes no order number
    + '<g id="sketch">' + LINE.format(x=6) + "</g>"  # no digits: third group in order
    + '<g inkscape:label="0">' + LINE.format(x=7) + "</g>"  # 0 becomes 1
    + '<g><g transform="translate(1 0)">' + LINE.format(x=8) + "</g></g>"  # nested: 5th group
)


def write(tmp_path, body: str, name: str = "layers.svg"):
    path = tmp_path / name
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" '
                    'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
                    f'width="100mm" height="100mm" viewBox="0 0 100 100">{body}</svg>')
    return path


def test_top_level_groups_are_layers_by_label_id_or_order(tmp_path):
    drawing = read_svg(write(tmp_path, LAYERED))
    layers = drawing.meta["layers"]
    assert layers.dtype == np.int64
    assert layers.tolist() == [7, 4, 4, 1, 3, 1, 5]
    xs = [round(float(s.pos[0, 0])) for s in drawing.strokes]
    assert xs == [1, 2, 3, 4, 6, 7, 9]  # document order


def test_the_layers_are_vpypes(tmp_path):
    vpype = pytest.importorskip("vpype", reason="vpype compares layers (pip install vpype)")
    path = write(tmp_path, LAYERED)
    document = vpype.read_multilayer_svg(str(path), quantization=0.1)
    ours = Counter(read_svg(path).meta["layers"].tolist())
    assert ours == {lid: len(layer) for lid, layer in document.layers.items()}


def test_a_file_without_groups_has_no_layers(tmp_path):
    drawing = read_svg(write(tmp_path, LINE.format(x=1) + LINE.format(x=2)))
    assert "layers" not in drawing.meta


@pytest.mark.parametrize("digits", ["9" * 20, "7" * 10_000])
def test_a_layer_id_beyond_int64_is_refused(tmp_path, digits):
    body = f'<g id="L{digits}">' + LINE.format(x=1) + "</g>"
    with pytest.raises(InputError, match=rf"<g> id='L{digits[0]}+': layer id {digits[0]}+ "
                       r"\(from its label or id\) is larger than 9223372036854775807"):
        read_svg(write(tmp_path, body))
    leading_zeros = f'<g id="L{"0" * 30}12">' + LINE.format(x=1) + "</g>"
    assert read_svg(write(tmp_path, leading_zeros)).meta["layers"].tolist() == [12]


def test_to_svg_writes_vpype_layers_and_reading_back_keeps_them(tmp_path):
    first = read_svg(write(tmp_path, LAYERED))
    first.to_svg(tmp_path / "out.svg")
    text = (tmp_path / "out.svg").read_text()
    assert '<g inkscape:groupmode="layer" inkscape:label="7" id="layer7" ' in text
    assert text.count('inkscape:groupmode="layer"') == 5
    back = read_svg(tmp_path / "out.svg")
    order = np.argsort(first.meta["layers"], kind="stable")  # grouped by layer, ascending
    assert back.meta["layers"].tolist() == first.meta["layers"][order].tolist()
    for k, stroke in zip(order, back.strokes):
        np.testing.assert_allclose(stroke.pos[[0, -1]], first.strokes[k].pos[[0, -1]],
                                   atol=1e-3)
    again = tmp_path / "again.svg"
    back.to_svg(again)
    assert read_svg(again).meta["layers"].tolist() == back.meta["layers"].tolist()


def test_vpype_reads_the_layers_inkarm_writes(tmp_path):
    vpype = pytest.importorskip("vpype", reason="vpype reads inkarm's SVG (pip install vpype)")
    strokes = [Trajectory([0, 1], [[x, 10], [x, 20]]) for x in (10, 20, 30)]
    Drawing(strokes, meta={"layers": np.array([2, 5, 2])}).to_svg(tmp_path / "d.svg")
    document = vpype.read_multilayer_svg(str(tmp_path / "d.svg"), quantization=0.1)
    assert {lid: len(layer) for lid, layer in document.layers.items()} == {2: 2, 5: 1}


def test_to_svg_without_layers_writes_one_group_and_refuses_a_wrong_layer_list(tmp_path):
    strokes = [Trajectory([0, 1], [[0, 0], [1, 0]])] * 2
    Drawing(strokes).to_svg(tmp_path / "plain.svg")
    assert "groupmode" not in (tmp_path / "plain.svg").read_text()
    with pytest.raises(InputError, match=r"meta\['layers'\]: expected one integer layer id per "
                       r"stroke \(2\), got int64 of shape \(3,\)"):
        Drawing(strokes, meta={"layers": np.array([1, 2, 3])}).to_svg(tmp_path / "bad.svg")
