"""``<use>`` stays bounded: svgelements expands it recursively without a guard, so cycles are
dropped and counted, and exponential expansion ("<use> bombs") and deep nesting through
``<use>`` are refused before svgelements sees the file."""

from __future__ import annotations

import pytest

from inkarm.errors import InputError
from inkarm.io.svgtree import MAX_CYCLES, MAX_DEPTH, MAX_ELEMENTS
from inkarm.io.trace import load_trace, read_svg

LINE = '<line x1="0" y1="0" x2="10" y2="0" stroke="black"/>'


def write(tmp_path, body: str, root: str = "", name: str = "u.svg"):
    path = tmp_path / name
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {root}>{body}</svg>')
    return path


def groups(levels: int, fan: int) -> str:
    """``levels`` groups b0, b1, ..., each of ``fan`` <use> of the one below."""
    body = f'<g id="b0">{LINE}</g>'
    for k in range(1, levels):
        body += f'<g id="b{k}">' + f'<use href="#b{k - 1}"/>' * fan + "</g>"
    return body


def bomb(levels: int, fan: int) -> str:
    """The top group of :func:`groups` drawn once: fan ** (levels - 1) lines."""
    return f'<defs>{groups(levels, fan)}</defs><use href="#b{levels - 1}"/>'


def test_a_use_bomb_is_refused_before_it_expands(tmp_path):
    path = write(tmp_path, bomb(levels=12, fan=10), name="bomb.svg")  # 10**11 lines
    with pytest.raises(InputError, match=rf"bomb\.svg: <g> id='b\d+': the drawing expands to "
                       rf"more than {MAX_ELEMENTS} elements \(<use> elements naming groups"):
        load_trace(path)


def test_a_small_fan_of_uses_is_drawn_in_full(tmp_path):
    drawing = read_svg(write(tmp_path, bomb(levels=4, fan=3)), rate=20.0)
    assert len(drawing.strokes) == 27


@pytest.mark.parametrize(
    ("body", "root"),
    [
        (f'<g id="a">{LINE}<use href="#a"/></g>', ""),  # itself
        (f'<g id="a"><use href="#b"/></g><g id="b"><use href="#a"/></g>{LINE}', ""),  # a pair
        (f'{LINE}<use href="#root"/>', 'id="root"'),  # the document
        (f'<defs><g id="a"><use href="#a"/></g></defs><use href="#a"/>{LINE}', ""),
    ],
)
def test_a_circular_use_is_dropped_and_counted(tmp_path, body, root):
    drawing = read_svg(write(tmp_path, body, root))
    assert len(drawing.strokes) == 1
    assert drawing.meta["svg_skipped"] == {"circular <use>": 1}


def test_many_circular_uses_are_refused(tmp_path):
    body = "".join(f'<g id="c{k}"><use href="#c{k}"/></g>' for k in range(MAX_CYCLES + 1))
    with pytest.raises(InputError, match=rf"more than {MAX_CYCLES} <use> elements name an "
                       "element containing them"):
        read_svg(write(tmp_path, body + LINE))


def test_nesting_through_use_counts_against_max_depth(tmp_path):
    half = MAX_DEPTH // 2 + 5
    deep = '<g id="deep">' + "<g>" * half + LINE + "</g>" * half + "</g>"
    body = f"<defs>{deep}</defs>" + "<g>" * half + '<use href="#deep"/>' + "</g>" * half
    with pytest.raises(InputError, match=rf"nested more than {MAX_DEPTH} deep \(counting what "
                       r"<use> expands"):
        read_svg(write(tmp_path, body))
    shallow = f"<defs>{deep}</defs>" + '<use href="#deep"/>'
    assert len(read_svg(write(tmp_path, shallow)).strokes) == 1


def test_unused_definitions_are_not_read(tmp_path):
    body = f'<defs><path id="broken" d="M0 0 L"/>{groups(levels=12, fan=10)}</defs>{LINE}'
    assert len(read_svg(write(tmp_path, body)).strokes) == 1
