"""How far a written text is from its font, in [mm], both ways (seed 000 sec. 4.1 figures).

:func:`outline_deviation` measures drawing -> font (ink where the font has none),
:func:`font_deviation` font -> drawing (font the ink misses: cut corners, skipped parts,
dropped junction targets), :func:`text_fidelity` both. Each sample of the drawing belongs to
the letter whose target is active at its time: targets are held stepwise for
``segment_time`` each (seed 000 sec. 3.3).

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Drawing, Trajectory
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



def kd_tree(points: np.ndarray):
    """A ``scipy.spatial.cKDTree`` of ``points`` (SciPy is imported when a text's fidelity is
    measured, not when the module is: a command that only writes needs none)."""
    from scipy.spatial import cKDTree

    return cKDTree(points, balanced_tree=False, compact_nodes=False)

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


def _samples(tp: TextPlan, drawing: Drawing) -> _Samples | None:
    """The samples of ``drawing`` with the targets of ``tp`` active at them (as
    :func:`_active_targets`, for all strokes at once); None for no strokes."""
    pairs = list(zip(tp.plan.strokes, drawing.strokes))
    if not pairs:
        return None
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


def outline_deviation(tp: TextPlan, drawing: Drawing) -> dict[int, float]:
    """Largest distance in [mm] of the written path from the font, per letter (text index).

    A sample belongs to the letter of the target active at its time and is compared with the
    path the plan prescribes around that target i: the font outlines of the letters of
    targets i - 1, i and i + 1 (the smooth pen anticipates the next target and lags the
    last), plus the straight connector chords into targets i and i + 1 (ligatures are not
    part of any letter's outline).

    All samples are measured at once, each against the segments of its own (at most three)
    letters, in chunks of at most ``_PAIRS`` sample-segment pairs: time and memory grow
    linearly with the drawing, a long word included.
    """
    smp = _samples(tp, drawing)
    if smp is None:
        return {}
    i, letters, means = smp.target, smp.letters, smp.means
    before = np.maximum(i - 1, smp.first_target)
    after = np.minimum(i + 1, smp.last_target)
    near = np.stack([letters[before], letters[i], letters[after]], axis=1)
    px, py = np.ascontiguousarray(smp.pos.T)
    ax, ay, bx, by, first, count = _outline_segments(tp.glyphs, int(near.max()) + 1)
    d2 = _letters_distance2(px, py, near, ax, ay, bx, by, first, count)
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
    dist = np.sqrt(d2)  # sqrt is monotonic: the nearest in squares is the nearest
    own = letters[i]
    worst = np.zeros(int(own.max()) + 1)
    np.maximum.at(worst, own, dist)
    drawn, at = np.unique(own, return_index=True)
    return {int(k): float(worst[k]) for k in drawn[np.argsort(at)]}  # in writing order


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
    One k-d tree of all the ink answers; where the ink nearest an outline point is other ink
    (a letter of the line above, say), a tree of the letter's own ink answers that point
    again. The distance is 1-Lipschitz along the outline, so only every ``_COARSE``-th
    outline point is asked first, then the points between that could exceed the largest
    distance found: the maxima are exactly those of asking every point.
    """
    smp = _samples(tp, drawing)
    glyphs = tp.glyphs
    outlines = [s for glyph in glyphs for s in glyph.strokes]
    spacing = _FONT_SPACING * tp.font.height
    font, _, font_vertex = _densify_all(outlines, spacing)
    per_glyph = np.array([sum(len(s) for s in g.strokes) for g in glyphs], dtype=np.int64)
    vertex_glyph = np.repeat(np.arange(len(glyphs)), per_glyph)
    point_glyph = vertex_glyph[font_vertex]  # the glyph (position in glyphs) of each point
    if smp is None:
        return {g.index: float("inf") for g in glyphs}
    ink, ink_at, ink_sample = _densify_all(_split_at(smp.pos, smp.first), spacing)
    own = _OwnInk(smp, ink_at, ink_sample, np.array([g.index for g in glyphs]), ink)
    # every _COARSE-th point of each outline polyline, and the last
    vertex_poly = np.repeat(np.arange(len(outlines)), [len(s) for s in outlines])
    point_poly = vertex_poly[font_vertex]
    start = np.flatnonzero(np.diff(point_poly, prepend=-1))  # each polyline's first point
    local = np.arange(len(font)) - np.repeat(start, np.diff(np.append(start, len(font))))
    coarse = local % _COARSE == 0
    coarse[np.append(start[1:] - 1, len(font) - 1)] = True
    c = np.flatnonzero(coarse)
    dist = np.full(len(font), np.nan)
    dist[c] = own.query(font[c], point_glyph[c])
    worst = np.full(len(glyphs), -np.inf)
    np.maximum.at(worst, point_glyph[c], dist[c])
    # a bound for the points between: the distance at a coarse neighbour plus the way to it
    prev_c = c[np.searchsorted(c, np.arange(len(font)), side="right") - 1]
    next_c = c[np.minimum(np.searchsorted(c, np.arange(len(font))), len(c) - 1)]
    bound = np.minimum(
        dist[prev_c] + np.linalg.norm(font - font[prev_c], axis=1),
        dist[next_c] + np.linalg.norm(font - font[next_c], axis=1),
    )
    slack = 1e-9 * max(1.0, float(np.abs(font).max(initial=0.0)))  # rounding of distances
    ask = np.flatnonzero(~coarse & (bound >= worst[point_glyph] - slack))
    if len(ask):
        dist[ask] = own.query(font[ask], point_glyph[ask])
        np.maximum.at(worst, point_glyph[ask], dist[ask])
    return {g.index: float(w) for g, w in zip(glyphs, worst)}


_COARSE = 8
"""Outline points asked first by :func:`font_deviation`: every this many along a polyline."""


class _OwnInk:
    """The ink each letter is compared with in :func:`font_deviation`, asked through one k-d
    tree of all the ink and, where that tree's answer is other ink, a tree of the letter's
    own."""

    def __init__(
        self, smp: _Samples, at: np.ndarray, sample: np.ndarray, index: np.ndarray, ink: np.ndarray
    ) -> None:
        self.ink, self.at, self.sample, self.index = ink, at, sample, index
        self.first = smp.first
        self.letter = smp.letters[smp.target]  # the letter drawn at each sample
        top = int(max(self.letter.max(), index.max())) + 3
        self.top = top
        # (stroke, letter) pairs drawn, as stroke * top + letter, sorted
        self.drawn = np.unique(self.first * top + self.letter)
        drawn_at = np.zeros(top + 3, dtype=bool)  # letter L drawn somewhere: drawn_at[L + 1]
        drawn_at[self.letter + 1] = True
        self.any_near = drawn_at[index[:, None] + np.arange(3)].any(axis=1)  # g - 1 .. g + 1
        self.by_letter = np.argsort(self.letter, kind="stable")  # samples, sorted by letter
        self.sorted_letters = self.letter[self.by_letter]
        self.tree = kd_tree(ink)
        self.own_trees: dict = {}  # (scipy.spatial.cKDTree per stroke)

    def _in_stroke(self, sample: np.ndarray, letter: np.ndarray) -> np.ndarray:
        key = self.first[sample] * self.top + letter
        j = np.minimum(np.searchsorted(self.drawn, key), len(self.drawn) - 1)
        return self.drawn[j] == key

    def _includes(self, sample: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Whether the run holding each sample is part of the ink of letter g (text index)."""
        d = self.letter[sample] - g
        ok = np.abs(d) <= 1
        two = np.abs(d) == 2
        ok[two] = self._in_stroke(sample[two], g[two] + d[two] // 2)
        return ok

    def allowed(self, j: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Whether the ink points ``j`` are among the ink of letters ``g`` (text indices)."""
        e = self.sample[j]
        ok = self._includes(e, g)
        step_out = ~ok & (j == self.at[e]) & (e > self.first[e])  # a run's sample after it
        ok[step_out] = self._includes(e[step_out] - 1, g[step_out])
        return ok

    def own_tree(self, k: int):
        """The tree of the ink of glyph k (position in the glyphs)."""
        if k not in self.own_trees:
            g = int(self.index[k])
            lo, hi = np.searchsorted(self.sorted_letters, [g - 2, g + 3])
            samples = np.sort(self.by_letter[lo:hi])  # those of letters g - 2 .. g + 2
            counts = np.diff(np.append(self.at, len(self.ink)))[samples]
            j = np.repeat(self.at[samples] - (np.cumsum(counts) - counts), counts)
            j += np.arange(len(j))  # their ink points
            after = samples[samples + 1 < len(self.first)] + 1
            after = after[self.first[after] == self.first[after - 1]]  # the samples after them
            j = np.unique(np.concatenate([j, self.at[after]]))
            j = j[self.allowed(j, np.full(len(j), g))]
            self.own_trees[k] = kd_tree(self.ink[j])
        return self.own_trees[k]

    def query(self, points: np.ndarray, glyph: np.ndarray) -> np.ndarray:
        """Distance of each point (k, 2) to the ink of its glyph (positions in the glyphs)."""
        dist, nearest = self.tree.query(points, workers=-1)
        check = self.any_near[glyph]
        other = np.zeros(len(points), dtype=bool)
        other[check] = ~self.allowed(nearest[check], self.index[glyph[check]])
        for k in np.unique(glyph[other]):
            mine = np.flatnonzero(other & (glyph == k))
            dist[mine] = self.own_tree(int(k)).query(points[mine], workers=-1)[0]
        return dist


def _split_at(pos: np.ndarray, first: np.ndarray) -> list[np.ndarray]:
    """``pos`` (N, 2) cut into strokes; ``first`` (N,): the first sample of each sample's stroke."""
    starts = np.unique(first)
    return np.split(pos, starts[1:])


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
