"""The ink a letter's font outline is compared with (:func:`inkarm.plans.fidelity.font_deviation`):
the drawn path sampled every ``spacing`` [mm], addressed point by point and asked through k-d
trees of the ink near a block of letters, or of one letter's own.

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


def kd_tree(points: np.ndarray):
    """A ``scipy.spatial.cKDTree`` of ``points`` (SciPy is imported when a text's fidelity is
    measured, not when the module is: a command that only writes needs none)."""
    from scipy.spatial import cKDTree

    return cKDTree(points, balanced_tree=False, compact_nodes=False)


class InkSamples(NamedTuple):
    """Every sample of a written text, strokes one after the other (N of them).

    Attributes:
        pos: (N, 2) pen positions in [mm].
        first: (N,) the first sample of the sample's stroke.
        letter: (N,) the letter (text index) drawn at the sample.
        last: (N,) whether the sample is its stroke's last.
        count: (N,) the ink points from the sample to the next: max(1, ceil(l / spacing))
            for an edge of length l [mm], 1 for a stroke's last sample.
        drawn: the (stroke, letter) pairs drawn, as first * top + letter, ascending.
        top: a number above every letter (text index), + 3.
    """

    pos: np.ndarray
    first: np.ndarray
    letter: np.ndarray
    last: np.ndarray
    count: np.ndarray
    drawn: np.ndarray
    top: int


class OwnInk:
    """The ink each letter is compared with (:func:`inkarm.plans.fidelity.font_deviation`),
    asked through a k-d tree of the ink near a block of glyphs and, where that tree's answer
    is other ink, a tree of the letter's own.

    The ink is the drawn path sampled as :func:`inkarm.plans.fidelity._densify_all` samples
    it, its points computed where asked, never all at once: point j lies on the edge from
    sample e to e + 1 of its stroke, (j - at[e]) / count[e] of the way (a stroke's last
    sample is one point)."""

    def __init__(self, samples: InkSamples, index: np.ndarray) -> None:
        self.pos, self.first, self.letter = samples.pos, samples.first, samples.letter
        self.last, self.count, self.drawn, self.top = (
            samples.last, samples.count, samples.drawn, samples.top)
        self.at = np.cumsum(self.count, dtype=np.int64) - self.count
        self.index = index
        drawn_at = np.zeros(self.top + 3, dtype=bool)  # letter L drawn somewhere: [L + 1]
        drawn_at[self.letter + 1] = True
        self.any_near = drawn_at[index[:, None] + np.arange(3)].any(axis=1)  # g - 1 .. g + 1
        self.by_letter = np.argsort(self.letter, kind="stable").astype(np.int32)  # by letter
        self.sorted_letters = self.letter[self.by_letter]
        self.tree = self.all_ink = None
        self.own_trees: dict = {}  # (scipy.spatial.cKDTree per glyph of the block)

    def points(self, j: np.ndarray, e: np.ndarray) -> np.ndarray:
        """The ink points ``j`` (k,) on the edges from samples ``e`` (k,), (k, 2) in [mm]: as
        ``_densify_all`` computes them, operation for operation."""
        frac = (j - self.at[e]) / self.count[e]
        pos = self.pos[e]
        step = self.pos[np.minimum(e + 1, len(self.pos) - 1)] - pos
        step[self.last[e]] = 0.0
        return np.column_stack([pos[:, 0] + frac * step[:, 0], pos[:, 1] + frac * step[:, 1]])

    def near(self, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
        """(j, e) of the ink of the samples of letters (text indices) lo - 2 .. hi + 2 and the
        first point of the sample after each in its stroke, j ascending: all the ink that
        any letter lo .. hi is compared with, and some more."""
        a, b = np.searchsorted(self.sorted_letters, [lo - 2, hi + 3])
        samples = np.sort(self.by_letter[a:b])
        counts = self.count[samples]
        j = np.repeat(self.at[samples] - (np.cumsum(counts) - counts), counts)
        j += np.arange(len(j))  # their ink points
        after = samples[samples + 1 < len(self.first)] + 1
        after = after[self.first[after] == self.first[after - 1]]  # the samples after them
        j, keep = np.unique(np.concatenate([j, self.at[after]]), return_index=True)
        return j, np.concatenate([np.repeat(samples, counts), after])[keep]

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

    def allowed(self, j: np.ndarray, e: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Whether the ink points ``j`` (on the edges from samples ``e``) are among the ink of
        letters ``g`` (text indices)."""
        ok = self._includes(e, g)
        step_out = ~ok & (j == self.at[e]) & (e > self.first[e])  # a run's sample after it
        ok[step_out] = self._includes(e[step_out] - 1, g[step_out])
        return ok

    def block(self, lo: int, hi: int) -> None:
        """Answer for the glyphs ``lo:hi`` (positions in the glyphs) from now on: a tree of
        the ink near their letters (:meth:`near`)."""
        self.own_trees, self.tree = {}, None
        letters = self.index[lo:hi][self.any_near[lo:hi]]
        if len(letters):
            self.j, self.e = self.near(int(letters.min()), int(letters.max()))
            self.tree = kd_tree(self.points(self.j, self.e))

    def own_tree(self, k: int):
        """The tree of the ink of glyph k (position in the glyphs)."""
        if k not in self.own_trees:
            g = int(self.index[k])
            j, e = self.near(g, g)
            keep = self.allowed(j, e, np.full(len(j), g))
            self.own_trees[k] = kd_tree(self.points(j[keep], e[keep]))
        return self.own_trees[k]

    def query(self, points: np.ndarray, glyph: np.ndarray) -> np.ndarray:
        """Distance of each point (k, 2) to the ink of its glyph (positions in the glyphs, in
        the block)."""
        dist = np.empty(len(points))
        check = self.any_near[glyph]
        if not check.all():  # no ink near the letter: all the ink
            if self.all_ink is None:
                j = np.arange(int(self.count.sum()))
                self.all_ink = kd_tree(self.points(j, np.repeat(np.arange(len(self.pos)),
                                                                self.count)))
            dist[~check] = self.all_ink.query(points[~check], workers=-1)[0]
        c = np.flatnonzero(check)
        if len(c):
            dist[c], nearest = self.tree.query(points[c], workers=-1)
            other = ~self.allowed(self.j[nearest], self.e[nearest], self.index[glyph[c]])
            for k in np.unique(glyph[c[other]]):
                mine = c[other & (glyph[c] == k)]
                dist[mine] = self.own_tree(int(k)).query(points[mine], workers=-1)[0]
        return dist
