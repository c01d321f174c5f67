"""How far a written text is from its font, in [mm], both ways (seed 000 sec. 4.1 figures).

:func:`outline_deviation` measures drawing -> font (ink where the font has none),
:func:`font_deviation` font -> drawing (font the ink misses: cut corners, skipped parts,
dropped junction targets), :func:`text_fidelity` both. Each sample of the drawing belongs to
the letter whose target is active at its time: targets are held stepwise for
``segment_time`` each (seed 000 sec. 3.3). Both are measured a block of strokes or glyphs at
a time, so a page of text (a million samples, two million outline points) costs a few tens
of MB; the ink a font outline is compared with is :class:`inkarm.plans.ownink.OwnInk`.

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.plans.ownink import InkSamples, OwnInk
from inkarm.plans.textplan import TextPlan


def _active_targets(plan: StrokePlan, traj: Trajectory) -> np.ndarray:
    """Index of the target tracked at each sample: targets are held stepwise for
    ``segment_time`` each (seed 000 sec. 3.3), so at time t from the stroke's start it is
    floor(t / T_s)."""
    t = traj.t - traj.t[0]
    return np.minimum((t / plan.segment_time + 1e-9).astype(int), len(plan.targets) - 1)


def sample_letters(plan: StrokePlan, traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Per sample of ``traj``: the index of the letter being drawn, and whether the pen is on
    that letter's outline (False while it heads for a target along a connector), both (N,)."""
    active = _active_targets(plan, traj)
    return np.asarray(plan.meta["letters"])[active], ~np.asarray(plan.meta["connectors"])[active]



class _Samples(NamedTuple):
    """Every sample of a written text, strokes one after the other, with its active target.

    Attributes:
        pos: (N, 2) pen positions in [mm].
        first: (N,) index of the first sample of the sample's stroke.
        target: (N,) the active target, counted over all strokes' targets.
        first_target, last_target: (N,) the first and last target of the sample's stroke.
        letters: (T,) the letter (text index) of each target.
        connectors: (T,) whether the path into each target is a connector.
        means: (T, 2) the targets' means in [mm].
    """

    pos: np.ndarray
    first: np.ndarray
    target: np.ndarray
    first_target: np.ndarray
    last_target: np.ndarray
    letters: np.ndarray
    connectors: np.ndarray
    means: np.ndarray


def _samples(pairs: list[tuple[StrokePlan, Trajectory]]) -> _Samples:
    """The samples of the strokes ``pairs`` (plan, trajectory) with the targets active at them
    (as :func:`_active_targets`, for all strokes at once), counted from the first pair's."""
    n = np.array([traj.n for _, traj in pairs])
    m = np.array([len(plan.targets) for plan, _ in pairs])
    t = np.concatenate([traj.t for _, traj in pairs])
    t0 = np.repeat([traj.t[0] for _, traj in pairs], n)
    step = np.repeat([plan.segment_time for plan, _ in pairs], n)
    active = np.minimum(((t - t0) / step + 1e-9).astype(int), np.repeat(m - 1, n))
    first_target = np.repeat(np.cumsum(m) - m, n)
    return _Samples(
        pos=np.concatenate([traj.pos[:, :2] for _, traj in pairs]),
        first=np.repeat(np.cumsum(n) - n, n),
        target=first_target + active,
        first_target=first_target,
        last_target=first_target + np.repeat(m - 1, n),
        letters=np.concatenate([np.asarray(plan.meta["letters"]) for plan, _ in pairs]),
        connectors=np.concatenate(
            [np.asarray(plan.meta["connectors"], dtype=bool) for plan, _ in pairs]
        ),
        means=np.concatenate([plan.means[:, :2] for plan, _ in pairs]),
    )


_BLOCK_SAMPLES = 1 << 16
"""Samples measured at once: whole strokes, about this many (a few MB of temporaries a
block, whatever the text's length)."""
_BLOCK_VERTICES = 1 << 12
"""Font outline vertices measured at once by :func:`font_deviation`: whole glyphs."""


def _blocks(sizes: list[int], limit: int):
    """(lo, hi) of runs of consecutive items whose ``sizes`` sum to at most ``limit`` (an
    item larger than that alone), in order."""
    lo = 0
    while lo < len(sizes):
        hi, count = lo + 1, sizes[lo]
        while hi < len(sizes) and count + sizes[hi] <= limit:
            count += sizes[hi]
            hi += 1
        yield lo, hi
        lo = hi


def _stroke_blocks(tp: TextPlan, drawing: Drawing):
    """(first sample, the (plan, trajectory) pairs) of consecutive strokes, about
    :data:`_BLOCK_SAMPLES` samples a block."""
    pairs = list(zip(tp.plan.strokes, drawing.strokes))
    first = np.cumsum([0] + [traj.n for _, traj in pairs])
    for lo, hi in _blocks([traj.n for _, traj in pairs], _BLOCK_SAMPLES):
        yield int(first[lo]), pairs[lo:hi]


def outline_deviation(tp: TextPlan, drawing: Drawing) -> dict[int, float]:
    """Largest distance in [mm] of the written path from the font, per letter (text index).

    A sample belongs to the letter of the target active at its time and is compared with the
    path the plan prescribes around that target i: the font outlines of the letters of
    targets i - 1, i and i + 1 (the smooth pen anticipates the next target and lags the
    last), plus the straight connector chords into targets i and i + 1 (ligatures are not
    part of any letter's outline).

    Strokes are measured a block at a time (:data:`_BLOCK_SAMPLES`), each sample against the
    segments of its own (at most three) letters, in chunks of at most ``_PAIRS``
    sample-segment pairs: time and memory grow linearly with the drawing, a long word
    included, and the temporaries stay a few MB.
    """
    top = 1 + max((max(p.meta["letters"]) for p in tp.plan.strokes), default=-1)
    segments = _outline_segments(tp.glyphs, top)
    worst = np.zeros(top)
    order = []  # the letters, as first drawn
    seen = np.zeros(top, dtype=bool)
    for _, pairs in _stroke_blocks(tp, drawing):
        own, dist = _outline_block(_samples(pairs), segments)
        np.maximum.at(worst, own, dist)
        drawn, at = np.unique(own, return_index=True)
        new = drawn[np.argsort(at)]
        order.extend(new[~seen[new]].tolist())
        seen[new] = True
    return {k: float(worst[k]) for k in order}  # in writing order


def _outline_block(smp: _Samples, segments) -> tuple[np.ndarray, np.ndarray]:
    """The letter of each sample of ``smp`` and its distance in [mm] to the path the plan
    prescribes around it (:func:`outline_deviation`); ``segments``: :func:`_outline_segments`."""
    i, letters, means = smp.target, smp.letters, smp.means
    before = np.maximum(i - 1, smp.first_target)
    after = np.minimum(i + 1, smp.last_target)
    near = np.stack([letters[before], letters[i], letters[after]], axis=1)
    px, py = np.ascontiguousarray(smp.pos.T)
    d2 = _letters_distance2(px, py, near, *segments)
    into = smp.connectors.copy()  # a connector leads into the target (not a stroke's first)
    into[np.unique(smp.first_target)] = False
    for has, a, b in (
        (into[i], before, i),  # the chord into target i
        (into[after] & (after > i), i, after),  # the chord into target i + 1
    ):
        k = np.flatnonzero(has)
        d2[k] = np.minimum(
            d2[k],
            _segment_distance2(
                px[k], py[k], means[a[k], 0], means[a[k], 1], means[b[k], 0], means[b[k], 1]
            ),
        )
    return letters[i], np.sqrt(d2)  # sqrt is monotonic: the nearest in squares is the nearest


def _outline_segments(glyphs, n: int):
    """The segments of the font outline of every letter of text index below ``n``: the x and
    y of their starts and ends (S,) each, and per text index (n,) its first segment and their
    number (a one-point polyline is one segment of length 0)."""
    starts, ends = [np.zeros((0, 2))], [np.zeros((0, 2))]
    first = np.zeros(n, dtype=np.int64)
    count = np.zeros(n, dtype=np.int64)
    total = 0
    for g in glyphs:
        if g.index >= n:
            continue
        first[g.index] = total
        for p in g.strokes:
            starts.append(p[:-1] if len(p) > 1 else p)
            ends.append(p[1:] if len(p) > 1 else p)
            total += len(ends[-1])
        count[g.index] = total - first[g.index]
    (ax, ay), (bx, by) = (np.ascontiguousarray(np.vstack(e).T) for e in (starts, ends))
    return ax, ay, bx, by, first, count


_PAIRS = 1 << 15
"""Sample-segment pairs measured at once by :func:`_letters_distance2`: a few MB, in cache."""


def _letters_distance2(px, py, near, ax, ay, bx, by, first, count) -> np.ndarray:
    """Squared distance of each point (px, py) (N,) to the nearest segment of the outlines of
    its letters ``near`` (N, 3; a letter named twice counts once): segments a-b, the
    letter's ``first[letter]`` on, ``count[letter]`` of them. Inf for a point whose letters
    have no segment."""
    n = len(px)
    distinct = np.ones(near.shape, dtype=bool)
    distinct[:, 1] = near[:, 1] != near[:, 0]
    distinct[:, 2] = (near[:, 2] != near[:, 0]) & (near[:, 2] != near[:, 1])
    pair_point = np.broadcast_to(np.arange(n)[:, None], near.shape)[distinct]  # ascending
    pair_first = first[near[distinct]]
    pair_count = count[near[distinct]]
    point_pairs = np.cumsum(np.bincount(pair_point, minlength=n))  # pairs of points :k + 1
    point_count = np.bincount(pair_point, weights=pair_count, minlength=n).astype(np.int64)
    point_total = np.cumsum(point_count)  # segments of points :k + 1
    out = np.full(n, np.inf)
    lo = 0
    while lo < n:  # the points lo:hi, their pairs p0:p1
        done = int(point_total[lo - 1]) if lo else 0
        hi = max(int(np.searchsorted(point_total, done + _PAIRS, "right")), lo + 1)
        p0, p1 = (int(point_pairs[lo - 1]) if lo else 0), int(point_pairs[hi - 1])
        counts = pair_count[p0:p1]
        seg = np.repeat(pair_first[p0:p1] - (np.cumsum(counts) - counts), counts)
        seg += np.arange(len(seg))  # each pair's segments, one after the other
        point = np.repeat(pair_point[p0:p1], counts)
        d2 = _segment_distance2(
            px.take(point), py.take(point), ax.take(seg), ay.take(seg), bx.take(seg), by.take(seg)
        )
        sizes = point_count[lo:hi]
        some = sizes > 0
        if some.any():
            block = out[lo:hi]
            block[some] = np.minimum.reduceat(d2, (np.cumsum(sizes) - sizes)[some])
        lo = hi
    return out


def _segment_distance2(px, py, ax, ay, bx, by) -> np.ndarray:
    """Squared distance of each point (px, py) to its segment from (ax, ay) to (bx, by), all
    (k,): to the point of the segment nearest it, a + u (b - a) with u clipped to [0, 1]."""
    abx, aby = bx - ax, by - ay
    u = (px - ax) * abx
    u += (py - ay) * aby
    length2 = abx * abx
    length2 += aby * aby
    u /= np.maximum(length2, 1e-300)
    u = np.minimum(np.maximum(u, 0.0), 1.0)
    dx = px - (ax + u * abx)
    dy = py - (ay + u * aby)
    dx *= dx
    dy *= dy
    dx += dy
    return dx


# -- fidelity to the font, both ways --------------------------------------------------------

_FONT_SPACING = 0.01
"""Font outlines are sampled every this fraction of the letter height for font->drawing."""


@dataclass(frozen=True)
class TextFidelity:
    """How far a written text is from its font, in [mm], in both directions.

    Attributes:
        drawing_to_font: Largest distance of the drawn path from the font outlines, over all
            letters (:func:`outline_deviation`): ink where the font has none.
        font_to_drawing: Largest distance of the font outlines from the drawn path, over all
            letters (:func:`font_deviation`): font the ink misses (cut corners, skipped
            parts, dropped junction targets).
    """

    drawing_to_font: float
    font_to_drawing: float

    @property
    def symmetric(self) -> float:
        """The larger of the two directions in [mm] (a Hausdorff distance per letter)."""
        return max(self.drawing_to_font, self.font_to_drawing)

    def summary(self) -> str:
        """Both directions and the symmetric figure in one line, e.g. ``drawing->font 0.11 mm,
        font->drawing 0.44 mm, symmetric 0.44 mm``."""
        return (
            f"drawing->font {self.drawing_to_font:.2f} mm, "
            f"font->drawing {self.font_to_drawing:.2f} mm, symmetric {self.symmetric:.2f} mm"
        )


def text_fidelity(tp: TextPlan, drawing: Drawing) -> TextFidelity:
    """Both directions of the distance between the written ``drawing`` and the font of ``tp``."""
    return TextFidelity(
        drawing_to_font=max(outline_deviation(tp, drawing).values(), default=0.0),
        font_to_drawing=max(font_deviation(tp, drawing).values(), default=0.0),
    )


def font_deviation(tp: TextPlan, drawing: Drawing) -> dict[int, float]:
    """Largest distance in [mm] of each letter's font outline from the written path, per
    letter (text index): the converse of :func:`outline_deviation`.

    A letter's outline is compared with the ink drawn while a target of that letter or of its
    neighbours in the text was active (the pen anticipates the next letter and lags the
    last), or with all the ink if there is none. Both are sampled every 0.01 letter heights
    (0.1 mm at 10 mm), which bounds the error of the distance by that spacing.

    The ink a letter g is compared with: in every stroke, the runs of samples of the letters
    next to a letter of g - 1, g, g + 1 drawn in that stroke (so g - 1 .. g + 1, and g - 2
    or g + 2 where g - 1 or g + 1 is in the stroke too), each with the sample after it.
    Glyphs are measured a block at a time (:data:`_BLOCK_VERTICES` outline vertices): one k-d
    tree of the ink of the block's letters and their neighbours answers; where the ink
    nearest an outline point is other ink (a letter's neighbour's neighbour, say), a tree of
    the letter's own ink answers that point again. The distance is 1-Lipschitz along the
    outline, so only every ``_COARSE``-th outline point is asked first, then the points
    between that could exceed the largest distance found: the maxima are exactly those of
    asking every point.
    """
    glyphs = tp.glyphs
    if not drawing.strokes:
        return {g.index: float("inf") for g in glyphs}
    spacing = _FONT_SPACING * tp.font.height
    index = np.array([g.index for g in glyphs], dtype=np.int64)
    own = OwnInk(_ink_samples(tp, drawing, spacing, int(index.max(initial=0))), index)
    size = max((float(np.abs(s).max()) for g in glyphs for s in g.strokes if len(s)), default=0)
    slack = 1e-9 * max(1.0, size)  # rounding of distances
    worst = np.full(len(glyphs), -np.inf)
    vertices = [sum(len(s) for s in g.strokes) for g in glyphs]
    for lo, hi in _blocks(vertices, _BLOCK_VERTICES):
        own.block(lo, hi)
        _font_block(glyphs, lo, hi, spacing, slack, own, worst)
    return {g.index: float(w) for g, w in zip(glyphs, worst)}


def _font_block(glyphs, lo: int, hi: int, spacing: float, slack: float, own, worst) -> None:
    """Raise ``worst`` (per glyph) to the distances of the outline points of the glyphs
    ``lo:hi`` (positions in ``glyphs``) from their ink ``own`` (:func:`font_deviation`)."""
    outlines = [s for glyph in glyphs[lo:hi] for s in glyph.strokes]
    if not outlines:
        return
    font, _, font_vertex = _densify_all(outlines, spacing)
    per_glyph = [sum(len(s) for s in g.strokes) for g in glyphs[lo:hi]]
    point_glyph = np.repeat(np.arange(lo, hi), per_glyph)[font_vertex]  # position in glyphs
    # every _COARSE-th point of each outline polyline, and the last
    point_poly = np.repeat(np.arange(len(outlines)), [len(s) for s in outlines])[font_vertex]
    start = np.flatnonzero(np.diff(point_poly, prepend=-1))  # each polyline's first point
    local = np.arange(len(font)) - np.repeat(start, np.diff(np.append(start, len(font))))
    coarse = local % _COARSE == 0
    coarse[np.append(start[1:] - 1, len(font) - 1)] = True
    c = np.flatnonzero(coarse)
    dist = np.full(len(font), np.nan)
    dist[c] = own.query(font[c], point_glyph[c])
    np.maximum.at(worst, point_glyph[c], dist[c])
    # a bound for the points between: the distance at a coarse neighbour plus the way to it
    prev_c = c[np.searchsorted(c, np.arange(len(font)), side="right") - 1]
    next_c = c[np.minimum(np.searchsorted(c, np.arange(len(font))), len(c) - 1)]
    bound = np.minimum(
        dist[prev_c] + np.linalg.norm(font - font[prev_c], axis=1),
        dist[next_c] + np.linalg.norm(font - font[next_c], axis=1),
    )
    ask = np.flatnonzero(~coarse & (bound >= worst[point_glyph] - slack))
    if len(ask):
        dist[ask] = own.query(font[ask], point_glyph[ask])
        np.maximum.at(worst, point_glyph[ask], dist[ask])


_COARSE = 8
"""Outline points asked first by :func:`font_deviation`: every this many along a polyline."""


def _ink_samples(tp: TextPlan, drawing: Drawing, spacing: float, top_glyph: int) -> InkSamples:
    """The samples of ``drawing`` with the letter drawn at each and the ink points from each
    to the next, sampled every ``spacing`` [mm] as :func:`_densify_all` samples a stroke,
    gathered a block of strokes at a time; ``top_glyph``: the largest text index of a glyph."""
    n = sum(traj.n for _, traj in zip(tp.plan.strokes, drawing.strokes))
    top = 3 + max(top_glyph, *(max(plan.meta["letters"]) for plan in tp.plan.strokes))
    pos, first = np.empty((n, 2)), np.empty(n, dtype=np.int64)
    letter, last, count = np.empty(n, np.int32), np.empty(n, bool), np.empty(n, np.int32)
    drawn = []
    for done, pairs in _stroke_blocks(tp, drawing):  # blocks of whole strokes
        smp = _samples(pairs)
        k = slice(done, done + len(smp.pos))
        pos[k], first[k] = smp.pos, smp.first + done
        letter[k] = smp.letters[smp.target]
        last[k] = end = np.append(smp.first[1:] != smp.first[:-1], True)
        step = np.zeros_like(smp.pos)
        step[:-1] = np.diff(smp.pos, axis=0)
        step[end] = 0.0
        count[k] = np.where(end, 1, np.maximum(1, np.ceil(np.linalg.norm(step, axis=1) / spacing)))
        drawn.append(np.unique(first[k] * top + letter[k]))
    return InkSamples(pos, first, letter, last, count, np.concatenate(drawn), top)


def _densify(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline (n, 2) with points inserted so no edge is longer than ``spacing`` [mm]."""
    if len(points) < 2:
        return points
    return _densify_all([points], spacing)[0]


def _densify_all(
    polylines: list[np.ndarray], spacing: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every polyline (n_j, 2) with points inserted so no edge is longer than ``spacing``
    [mm], all in one array (M, 2), polyline after polyline; where each vertex of the
    polylines (counted over all of them) lies in it, (V,); and the vertex each point comes
    from, (M,). An edge of length l gets max(1, ceil(l / spacing)) evenly spaced points
    from its start; a polyline's last vertex is itself."""
    if not polylines:
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    points = np.vstack(polylines)
    v = len(points)
    last = np.cumsum([len(p) for p in polylines]) - 1
    last = last[last >= 0]  # the last vertex of each polyline: no edge starts there
    step = np.zeros_like(points)
    step[:-1] = np.diff(points, axis=0)
    step[last] = 0.0
    counts = np.maximum(1, np.ceil(np.linalg.norm(step, axis=1) / spacing)).astype(np.int64)
    counts[last] = 1
    at = np.cumsum(counts) - counts
    edge = np.repeat(np.arange(v), counts)
    frac = (np.arange(int(counts.sum())) - np.repeat(at, counts)) / counts[edge]
    x = points[:, 0].take(edge) + frac * step[:, 0].take(edge)
    y = points[:, 1].take(edge) + frac * step[:, 1].take(edge)
    return np.column_stack([x, y]), at, edge
