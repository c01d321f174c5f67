"""How far a written text is from its font, in [mm], both ways (seed 000 sec. 4.1 figures).

:func:`outline_deviation` measures drawing -> font (ink where the font has none),
:func:`font_deviation` font -> drawing (font the ink misses: cut corners, skipped parts,
dropped junction targets), :func:`text_fidelity` both. Each sample of the drawing belongs to
the letter whose target is active at its time: targets are held stepwise for
``segment_time`` each (seed 000 sec. 3.3).

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.text`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Drawing, Trajectory

if TYPE_CHECKING:
    from inkarm.plans.text import TextPlan


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


def outline_deviation(tp: TextPlan, drawing: Drawing) -> dict[int, float]:
    """Largest distance in [mm] of the written path from the font, per letter (text index).

    A sample belongs to the letter of the target active at its time and is compared with the
    path the plan prescribes around that target i: the font outlines of the letters of
    targets i - 1, i and i + 1 (the smooth pen anticipates the next target and lags the
    last), plus the straight connector chords into targets i and i + 1 (ligatures are not
    part of any letter's outline).
    """
    outlines = {g.index: g.strokes for g in tp.glyphs}
    worst: dict[int, float] = {}
    for plan, traj in zip(tp.plan.strokes, drawing.strokes):
        letters = np.asarray(plan.meta["letters"])
        connectors = np.asarray(plan.meta["connectors"])
        means = plan.means
        m = len(letters)
        active = _active_targets(plan, traj)
        for i, lo, hi in _runs(active):  # the samples lo:hi, drawn while target i is active
            neighbours = {max(i - 1, 0), i, min(i + 1, m - 1)}
            polylines = [s for j in neighbours for s in outlines[letters[j]]]
            polylines += [means[[j - 1, j]] for j in (i, i + 1) if 0 < j < m and connectors[j]]
            d = _distance_to_polylines(traj.pos[lo:hi, :2], polylines)
            worst[int(letters[i])] = max(worst.get(int(letters[i]), 0.0), float(d.max()))
    return worst


def _runs(values: np.ndarray) -> list[tuple[int, int, int]]:
    """(value, start, stop) of each run of equal consecutive entries of ``values`` (N,)."""
    if not len(values):
        return []
    starts = np.flatnonzero(np.diff(values)) + 1
    lo = np.concatenate([[0], starts])
    hi = np.concatenate([starts, [len(values)]])
    return [(int(values[a]), int(a), int(b)) for a, b in zip(lo, hi)]


def _distance_to_polylines(points: np.ndarray, polylines: list[np.ndarray]) -> np.ndarray:
    """Distance in [mm] of each point (k, 2) to the nearest of the polylines' segments."""
    a = np.vstack([p[:-1] if len(p) > 1 else p for p in polylines])
    b = np.vstack([p[1:] if len(p) > 1 else p for p in polylines])
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    ap = points[:, None, :] - a[None]
    u = np.clip(np.einsum("kij,ij->ki", ap, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    nearest = a[None] + u[..., None] * ab[None]
    return np.min(np.linalg.norm(points[:, None, :] - nearest, axis=2), axis=1)


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
    """
    pieces: dict[int, list[np.ndarray]] = {}
    strokes = []
    for plan, traj in zip(tp.plan.strokes, drawing.strokes):
        letters = np.asarray(plan.meta["letters"])[_active_targets(plan, traj)]
        pos = traj.pos[:, :2]
        strokes.append(pos)
        for letter, runs in _letter_neighbourhoods(letters).items():
            for lo, hi in runs:
                hi = min(hi + 1, len(pos))  # the step out of the run too
                pieces.setdefault(letter, []).append(pos[lo:hi])
    spacing = _FONT_SPACING * tp.font.height
    everything = None  # all the ink, for a letter none of whose targets was drawn
    worst: dict[int, float] = {}
    for glyph in tp.glyphs:
        near = [p for k in (-1, 0, 1) for p in pieces.get(glyph.index + k, [])]
        if near:
            ink = cKDTree(np.vstack([_densify(p, spacing) for p in near]))
        else:
            if everything is None:
                everything = cKDTree(np.vstack([_densify(p, spacing) for p in strokes]))
            ink = everything
        font = np.vstack([_densify(s, spacing) for s in glyph.strokes])
        worst[glyph.index] = float(ink.query(font)[0].max())
    return worst


def _letter_neighbourhoods(letters: np.ndarray) -> dict[int, list[tuple[int, int]]]:
    """For each letter drawn in a stroke (``letters``: the letter per sample, (N,)), the
    sample ranges (start, stop) where it or a neighbour of it in the text is drawn, in
    O(N): each run of one letter is visited for itself and its two neighbours."""
    runs = _runs(letters)
    by_letter: dict[int, list[int]] = {}
    for r, (letter, _, _) in enumerate(runs):
        by_letter.setdefault(letter, []).append(r)
    out: dict[int, list[tuple[int, int]]] = {}
    for letter in by_letter:
        indices = sorted(r for k in (-1, 0, 1) for r in by_letter.get(letter + k, []))
        ranges: list[tuple[int, int]] = []
        for r in indices:
            _, lo, hi = runs[r]
            if ranges and ranges[-1][1] == lo:
                ranges[-1] = (ranges[-1][0], hi)  # runs next to each other: one range
            else:
                ranges.append((lo, hi))
        out[letter] = ranges
    return out


def _densify(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline (n, 2) with points inserted so no edge is longer than ``spacing`` [mm]."""
    if len(points) < 2:
        return points
    counts = np.maximum(1, np.ceil(np.linalg.norm(np.diff(points, axis=0), axis=1) / spacing))
    counts = counts.astype(int)
    edge = np.repeat(np.arange(len(counts)), counts)
    frac = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[edge]
    inner = points[edge] + frac[:, None] * (points[edge + 1] - points[edge])
    return np.vstack([inner, points[-1:]])
