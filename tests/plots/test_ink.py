"""The ink figure (inkarm.plots.drawing.plot_ink): one collection of one compound path per
line width, however many strokes, holding every segment once at its speed's width (rounded
to one of WIDTH_LEVELS steps); and plot_text adds one collection for the font and one for
the ink."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.path import Path

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.plots.drawing import WIDTH_LEVELS, plot_ink


def _drawing(n_strokes=40, seed=0):
    rng = np.random.default_rng(seed)
    strokes, t0 = [], 0.0
    for _ in range(n_strokes):
        n = int(rng.integers(1, 60))
        t = t0 + 0.01 * np.arange(n)
        pos = np.cumsum(rng.normal(size=(n, 2)) * rng.uniform(0.01, 1.0, (n, 1)), axis=0)
        strokes.append(Trajectory(t, pos + rng.uniform(0, 100, 2)))
        t0 = t[-1] + 0.2
    return Drawing(strokes)


def _segments(path: Path) -> list[tuple[float, ...]]:
    out = []
    for a, b, code in zip(path.vertices[:-1], path.vertices[1:], path.codes[1:]):
        if code == Path.LINETO:
            out.append((*a, *b))
    return out


def test_one_collection_one_path_per_width_every_segment_once_at_its_width():
    drawing = _drawing()
    width = (0.6, 2.2)
    ax = Figure().add_subplot()
    plot_ink(drawing, ax, width=width)
    assert len(ax.collections) == 1
    ink = ax.collections[0]
    paths, widths = ink.get_paths(), ink.get_linewidths()
    assert 1 <= len(paths) <= WIDTH_LEVELS + 1 and len(widths) == len(paths)
    speeds = [s.speed() for s in drawing.strokes]
    top = max(float(np.percentile(np.concatenate(speeds), 95)), 1e-9)
    want = {}
    for s, v in zip(drawing.strokes, speeds):
        w = width[0] + (width[1] - width[0]) * (1 - np.clip(0.5 * (v[:-1] + v[1:]) / top, 0, 1))
        for a, b, wk in zip(s.pos[:-1], s.pos[1:], w):
            want.setdefault((*a, *b), []).append(wk)
    got = {}
    for path, lw in zip(paths, widths):
        for seg in _segments(path):
            got.setdefault(seg, []).append(lw)
    assert sorted(got) == sorted(want) and all(len(got[k]) == len(want[k]) for k in want)
    step = (width[1] - width[0]) / WIDTH_LEVELS
    for k, exact in want.items():
        assert max(abs(a - b) for a, b in zip(sorted(got[k]), sorted(exact))) <= step / 2 + 1e-12


def test_the_ink_is_one_collection_whatever_the_number_of_strokes():
    for n in (1, 5, 200):
        ax = Figure().add_subplot()
        plot_ink(_drawing(n, seed=n), ax)
        assert len(ax.collections) == 1
        assert len(ax.collections[0].get_paths()) <= WIDTH_LEVELS + 1
    drawn = np.vstack([s.pos for s in _drawing(200, seed=200).strokes if s.n > 1])
    np.testing.assert_array_equal(ax.dataLim.get_points(), [drawn.min(0), drawn.max(0)])


def test_plot_text_adds_one_collection_for_the_font_and_one_for_the_ink():
    from inkarm.plans.text import write_text
    from inkarm.plots.text import plot_text

    tp, drawing = write_text("minimum wage quaff", "cursive", height=4.0)
    assert len(drawing.strokes) >= 3
    fig = plot_text(tp, drawing)
    ax = fig.axes[0]
    assert len(ax.collections) == 2
    font = ax.collections[0].get_paths()
    assert len(font) == 1
    n_font = sum(len(s) for g in tp.glyphs for s in g.strokes)
    assert len(font[0].vertices) == n_font
