"""The fidelity measures (inkarm.plans.fidelity), computed for all samples at once, against
the per-run reference they replace: the same values (to 1e-9 mm; in practice bit for bit)
on several texts, styles and line spacings, on drawings shifted off their letters (where the
ink nearest a letter's outline is often another letter's), and with a bounded number of
array passes however many strokes there are."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from inkarm.core.trajectory import Drawing
from inkarm.plans import fidelity, ownink
from inkarm.plans.handstyles import PRESETS
from inkarm.plans.layout import PageLayout
from inkarm.plans.text import write_text

# -- the reference: one run of samples (one active target) at a time --------------------------


def _active(plan, traj):
    t = traj.t - traj.t[0]
    return np.minimum((t / plan.segment_time + 1e-9).astype(int), len(plan.targets) - 1)


def _runs(values):
    starts = np.flatnonzero(np.diff(values)) + 1
    lo = np.concatenate([[0], starts])
    hi = np.concatenate([starts, [len(values)]])
    return [(int(values[a]), int(a), int(b)) for a, b in zip(lo, hi)]


def _distance_to_polylines(points, polylines):
    a = np.vstack([p[:-1] if len(p) > 1 else p for p in polylines])
    b = np.vstack([p[1:] if len(p) > 1 else p for p in polylines])
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    ap = points[:, None, :] - a[None]
    u = np.clip(np.einsum("kij,ij->ki", ap, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    nearest = a[None] + u[..., None] * ab[None]
    return np.min(np.linalg.norm(points[:, None, :] - nearest, axis=2), axis=1)


def reference_outline_deviation(tp, drawing):
    outlines = {g.index: g.strokes for g in tp.glyphs}
    worst = {}
    for plan, traj in zip(tp.plan.strokes, drawing.strokes):
        letters = np.asarray(plan.meta["letters"])
        connectors = np.asarray(plan.meta["connectors"])
        means = plan.means
        m = len(letters)
        for i, lo, hi in _runs(_active(plan, traj)):
            neighbours = {max(i - 1, 0), i, min(i + 1, m - 1)}
            polylines = [s for j in neighbours for s in outlines[letters[j]]]
            polylines += [means[[j - 1, j]] for j in (i, i + 1) if 0 < j < m and connectors[j]]
            d = _distance_to_polylines(traj.pos[lo:hi, :2], polylines)
            worst[int(letters[i])] = max(worst.get(int(letters[i]), 0.0), float(d.max()))
    return worst


def _neighbourhoods(letters):
    runs = _runs(letters)
    by_letter = {}
    for r, (letter, _, _) in enumerate(runs):
        by_letter.setdefault(letter, []).append(r)
    out = {}
    for letter in by_letter:
        ranges = []
        for r in sorted(r for k in (-1, 0, 1) for r in by_letter.get(letter + k, [])):
            _, lo, hi = runs[r]
            if ranges and ranges[-1][1] == lo:
                ranges[-1] = (ranges[-1][0], hi)
            else:
                ranges.append((lo, hi))
        out[letter] = ranges
    return out


def _densify(points, spacing):
    if len(points) < 2:
        return points
    counts = np.maximum(1, np.ceil(np.linalg.norm(np.diff(points, axis=0), axis=1) / spacing))
    counts = counts.astype(int)
    edge = np.repeat(np.arange(len(counts)), counts)
    frac = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[edge]
    inner = points[edge] + frac[:, None] * (points[edge + 1] - points[edge])
    return np.vstack([inner, points[-1:]])


def reference_font_deviation(tp, drawing):
    pieces, strokes = {}, []
    for plan, traj in zip(tp.plan.strokes, drawing.strokes):
        letters = np.asarray(plan.meta["letters"])[_active(plan, traj)]
        pos = traj.pos[:, :2]
        strokes.append(pos)
        for letter, runs in _neighbourhoods(letters).items():
            for lo, hi in runs:
                pieces.setdefault(letter, []).append(pos[lo : min(hi + 1, len(pos))])
    spacing = 0.01 * tp.font.height
    worst = {}
    for glyph in tp.glyphs:
        near = [p for k in (-1, 0, 1) for p in pieces.get(glyph.index + k, [])]
        ink = cKDTree(np.vstack([_densify(p, spacing) for p in (near or strokes)]))
        font = np.vstack([_densify(s, spacing) for s in glyph.strokes])
        worst[glyph.index] = float(ink.query(font)[0].max())
    return worst


# -- the cases ---------------------------------------------------------------------------------

WORDS = [
    "minimum",
    "wage",
    "jiggly",
    "quaff",
    "lorem",
    "ipsum",
    "dolor",
    "sit",
    "amet",
    "inkarm",
    "zebra",
    "Hello,",
    "World!",
    "42",
]


def _cases():
    rng = np.random.default_rng(5)
    for k, style in enumerate(sorted(PRESETS)):
        text = " ".join(rng.choice(WORDS, 6))
        line_height = [None, 5.5, 8.0][k % 3]  # 5.5 mm at 5 mm letters: lines overlap
        layout = PageLayout(margins=(20.0, 130.0, 20.0, 20.0), line_height=line_height)
        tp, drawing = write_text(text, PRESETS[style], height=5.0, layout=layout, seed=k)
        shifted = Drawing([s.shifted(dpos=rng.normal(0.0, 1.5, 2)) for s in drawing.strokes])
        yield style, tp, drawing, shifted


CASES = list(_cases())


@pytest.mark.parametrize("style, tp, drawing, shifted", CASES, ids=[c[0] for c in CASES])
def test_both_directions_match_the_reference(style, tp, drawing, shifted):
    for d in (drawing, shifted):
        for fast, slow in (
            (fidelity.outline_deviation, reference_outline_deviation),
            (fidelity.font_deviation, reference_font_deviation),
        ):
            want, got = slow(tp, d), fast(tp, d)
            assert list(got) == list(want)  # the same letters, in the same order
            np.testing.assert_allclose(list(got.values()), list(want.values()), rtol=0, atol=1e-9)


def test_a_letters_own_ink_answers_where_other_ink_is_nearer(monkeypatch):
    """On drawings shifted off their letters, the tree of all the ink often finds another
    letter's ink first: each such letter gets a tree of its own ink, and the result is the
    reference's all the same (checked above)."""
    built = []
    own_tree = ownink.OwnInk.own_tree
    monkeypatch.setattr(
        ownink.OwnInk, "own_tree", lambda s, k: built.append(k) or own_tree(s, k)
    )
    for _, tp, _, shifted in CASES:
        fidelity.font_deviation(tp, shifted)
    assert built


def test_measures_take_a_bounded_number_of_passes_however_many_strokes(monkeypatch):
    """Work is done on arrays of many samples, not stroke by stroke or run by run: in one
    block (given memory for it), the point-segment distances in one pass, one tree of the
    ink, two rounds of queries (every 8th outline point, then the points between that may
    exceed it)."""
    distance_calls, trees, queries = [], [], []
    distance = fidelity._segment_distance2
    monkeypatch.setattr(
        fidelity, "_segment_distance2", lambda *a: distance_calls.append(1) or distance(*a)
    )
    query = ownink.OwnInk.query
    monkeypatch.setattr(
        ownink.OwnInk, "query", lambda s, p, g: queries.append(len(p)) or query(s, p, g)
    )
    tree = ownink.kd_tree
    monkeypatch.setattr(ownink, "kd_tree", lambda *a, **k: trees.append(1) or tree(*a, **k))
    _, tp, drawing, _ = CASES[0]
    assert len(drawing.strokes) >= 5
    for name in ("_PAIRS", "_BLOCK_SAMPLES", "_BLOCK_VERTICES"):
        monkeypatch.setattr(fidelity, name, 1 << 40)  # one chunk, one block
    fidelity.outline_deviation(tp, drawing)
    assert len(distance_calls) == 3  # the letters' outlines, the chords into i and i + 1
    fidelity.font_deviation(tp, drawing)
    assert len(queries) == 2 and len(trees) <= 1 + len(tp.glyphs) // 4
    outline_points = sum(len(fidelity._densify(s, 0.05)) for g in tp.glyphs for s in g.strokes)
    assert queries[0] < outline_points / 4  # the coarse round: every 8th point and the ends


def test_densify_all_is_densify_of_each():
    rng = np.random.default_rng(0)
    polylines = [rng.normal(size=(int(n), 2)) for n in rng.integers(1, 8, 50)]
    dense, at, vertex = fidelity._densify_all(polylines, 0.3)
    starts = np.cumsum([len(p) for p in polylines]) - [len(p) for p in polylines]
    ends = np.append(at[starts[1:]], len(dense))
    for p, a, b in zip(polylines, at[starts], ends):
        np.testing.assert_array_equal(dense[a:b], _densify(p, 0.3))
    np.testing.assert_array_equal(np.vstack(polylines)[vertex[at]], np.vstack(polylines))


@pytest.mark.parametrize("case", [0, 3])
def test_blocks_of_strokes_and_glyphs_give_the_numbers_of_one_block(monkeypatch, case):
    """Measured a few strokes and glyphs at a time (the memory of a page of text stays a few
    MB), the fidelity is that of one block bit for bit: also where the drawing leaves letters
    without ink (compared with all the ink) and where it is shifted off its letters."""
    _, tp, drawing, shifted = CASES[case]
    partial = Drawing(drawing.strokes[: len(drawing.strokes) // 2])
    for d in (drawing, shifted, partial):
        monkeypatch.setattr(fidelity, "_BLOCK_SAMPLES", 1 << 40)
        monkeypatch.setattr(fidelity, "_BLOCK_VERTICES", 1 << 40)
        whole = fidelity.outline_deviation(tp, d), fidelity.font_deviation(tp, d)
        monkeypatch.setattr(fidelity, "_BLOCK_SAMPLES", 50)
        monkeypatch.setattr(fidelity, "_BLOCK_VERTICES", 40)
        blocks = fidelity.outline_deviation(tp, d), fidelity.font_deviation(tp, d)
        for a, b in zip(whole, blocks):
            assert list(a) == list(b)
            np.testing.assert_array_equal(list(a.values()), list(b.values()))
        want = reference_font_deviation(tp, d)
        np.testing.assert_allclose(list(blocks[1].values()), list(want.values()), rtol=0, atol=1e-9)
