"""Synthesis of a pencil line's texture from a profile (seed 002, Al-Meraj, ch. 4.2).

The texture is made in a straightened strip, the line running along the rows (as the scans
were turned upright for extraction), one row per pixel of arc length and one column per pixel
across; :mod:`inkarm.ink.pencil` bends it onto the page. Three steps, as in the thesis's
Table 4.1:

1. Grey fill (:func:`initial_fill`), the "bell-shaped fall-off" of Figs. 4.2-4.3: the pixel on
   the line's centre draws its grey level from the mid-line histogram (range [min_mid,
   max_mid]); a pixel at distance n from the centre, in a line of width w, draws from the dark
   band [min_range, max_mid] of the full histogram with probability exp(-n^2 / (2 (w/4)^2))
   and from the light band [max_mid, max_range] otherwise. The thesis's "flat, uniform" draw
   over each range is weighted here by the full histogram within it, so that the fill starts
   from the scan's own grey levels. (The thesis gives two bands, near and far, without a
   boundary; the Gaussian weight is that boundary made smooth.)
2. Co-occurrence repair (:func:`repair`), sec. 4.2: every pixel's 3x3 neighbourhood is
   compared with the profile's co-occurrence matrices (eq. 4.1; one per neighbour direction,
   see :data:`inkarm.ink.pencil_profile.OFFSETS`). Where a pair of levels "does not exist" in
   the model, the pixel is replaced with a value that exists next to its neighbours: the
   thesis's C(i, j) = 0, read here as "among the model's rarest pairs that together hold
   ``rare_mass`` of its occurrences" (a scan's single counts are noise). Candidates are drawn
   from the model's distribution of a level next to a random neighbour's level; of them, the
   one that most lowers the squared error between the strip's pair counts H and the model's,
   sum (H - N T)^2 (N pairs, T the model's probabilities), is kept if it lowers it at all:
   the criterion of Gagalowicz and Ma (1985), whose strategy the thesis follows (sec. 2.3.1).
   Pixels four-coloured by (row mod 2, column mod 2) are updated a colour at a time, so no two
   neighbours change together. Sweeps repeat "until the amount of pixel changes reach a
   minimum": here until fewer than ``tol`` of the line's pixels changed in a sweep, or
   ``max_sweeps``.
3. One 3x3 Gaussian blur (Fig. 4.6, "a 3x3 single-pass Gaussian filter", "to reduce tone
   differences"), made to keep what step 2 repaired (:func:`smooth`). The plain blur of the
   repaired strip, with the binomial kernel G = [1 2 1]^T [1 2 1] / 16
   (:func:`gaussian_blur3`), undoes the repair: the profile's matrices are those of the scan's
   own pixels, which already hold whatever blur the pencil, the paper and the scanner put
   there, so a second blur pulls every pair towards the diagonal (L1 distance to the profile,
   measured at the scan's resolution on the grades shipped before issue 25: 0.77-1.15 after
   it, 0.11-0.45 after the repair, 0.58-1.06 after the random fill). Here the blur's value b = G * (d m) / G * m (d the darkness, m the line's
   mask: the paper does not lighten the edge) is the target of every line pixel; a colour at a
   time (as in step 2), a pixel takes b where b stays in its level (no co-occurrence matrix sees
   that), and where b's level lowers, or keeps, the L1 distance between the strip's pair counts
   and the model's (to first order: each of its pairs moves a count from one cell to another);
   else it keeps its grey. A colour whose moves together raised the distance
   (:func:`glcm_distance`, measured) keeps only the best half of them, then the best quarter,
   ...: the distance after step 3 is at most the one after step 2, by construction. The page's
   own aliasing (a curved stroke resampled onto pixels) is the canvas's anti-aliased edge
   (:mod:`inkarm.ink.pencil`).

Grey levels g in [0, 255] become darkness 1 - g / 255 (paper white).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from inkarm.errors import InputError
from inkarm.ink.pencil_extract import line_glcm
from inkarm.ink.pencil_profile import OFFSETS, PencilProfile

# 3x3 binomial approximation of a Gaussian (sigma about 0.85 px), normalised.
GAUSS3 = np.outer([1.0, 2.0, 1.0], [1.0, 2.0, 1.0]) / 16.0
# Every neighbour of a 3x3 neighbourhood: (row, column) step and the index of its offset.
_NEIGHBOURS = tuple((s * dr, s * dc, k) for k, (dr, dc) in enumerate(OFFSETS) for s in (1, -1))
_NEIGHBOUR_OFFSET = np.array([k for _, _, k in _NEIGHBOURS])  # each neighbour's offset index
_TINY = 1e-12


@dataclass(frozen=True)
class RepairConfig:
    """How the co-occurrence repair (step 2) runs.

    Attributes:
        candidates: Values drawn per replaced pixel, besides its current one.
        max_sweeps: Most sweeps over the line.
        tol: Stop once a sweep changes fewer than this share of the line's pixels.
        rare_mass: A pair of levels "does not exist" when it is among the model's rarest
            pairs that together make up this share of its occurrences (0: the thesis's
            C(i, j) = 0 exactly; a little more ignores the single counts of a finite scan).
    """

    candidates: int = 4
    max_sweeps: int = 8
    tol: float = 0.05
    rare_mass: float = 0.05

    def __post_init__(self) -> None:
        if not (isinstance(self.candidates, int) and 1 <= self.candidates <= 64):
            raise InputError(f"expected 1 to 64 candidates, got {self.candidates!r}",
                             key="candidates", value=self.candidates)
        if not (isinstance(self.max_sweeps, int) and 0 <= self.max_sweeps <= 1000):
            raise InputError(f"expected 0 to 1000 sweeps, got {self.max_sweeps!r}",
                             key="max_sweeps", value=self.max_sweeps)
        for key in ("tol", "rare_mass"):
            value = getattr(self, key)
            if not 0.0 <= value <= (1.0 if key == "tol" else 0.5):
                raise InputError(f"expected a share in [0, {1.0 if key == 'tol' else 0.5:g}], "
                                 f"got {value!r}", key=key, value=value)


@dataclass(frozen=True, eq=False)
class LineTexture:
    """A synthesized line in its strip (rows along the line, columns across).

    Attributes:
        filled: (N, W) uint8 grey levels after step 1 (the random fill).
        repaired: (N, W) uint8 grey levels after step 2.
        darkness: (N, W) float darkness in [0, 1] after step 3 (the smoothing), 0 off the
            line (grey g = 255 (1 - darkness) exactly: the smoothing keeps whole grey
            levels).
        mask: (N, W) bool, the line's pixels.
        changes: Pixels changed by each repair sweep.
    """

    filled: np.ndarray
    repaired: np.ndarray
    darkness: np.ndarray
    mask: np.ndarray
    changes: tuple[int, ...] = field(default=())


def strip_mask(widths_px: np.ndarray) -> np.ndarray:
    """(N, W) mask of a strip whose row k holds a line of width ``widths_px[k]`` [px] centred
    on the middle column (W odd, wide enough for the widest row; the centre pixel of a row of
    positive width is always in)."""
    widths = np.asarray(widths_px, dtype=float)
    if widths.ndim != 1 or not np.all(np.isfinite(widths)) or np.any(widths < 0):
        raise InputError("expected a 1-D array of finite widths >= 0 [px]", key="widths_px")
    half = int(np.ceil(widths.max(initial=1.0) / 2.0))
    offsets = np.arange(-half, half + 1, dtype=float)
    inked = widths[:, None] > 0
    return inked & ((np.abs(offsets)[None, :] <= widths[:, None] / 2.0)
                    | (offsets == 0)[None, :])


def initial_fill(profile: PencilProfile, widths_px: np.ndarray,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Step 1: grey levels (N, W) uint8 (255 off the line) and the line's mask (see the module
    docstring)."""
    mask = strip_mask(widths_px)
    widths = np.asarray(widths_px, dtype=float)
    n_rows, n_cols = mask.shape
    offsets = np.abs(np.arange(n_cols) - (n_cols - 1) / 2.0)[None, :].repeat(n_rows, axis=0)
    min_mid, max_mid = profile.mid_range
    min_range, max_range = profile.full_range
    sigma = np.maximum(widths / 4.0, 0.25)[:, None]
    near = rng.random(mask.shape) < np.exp(-0.5 * (offsets / sigma) ** 2)
    centre = offsets == 0
    grey = np.full(mask.shape, 255, np.uint8)
    draws = (
        (mask & centre, profile.mid_hist, min_mid, max_mid),
        (mask & ~centre & near, profile.full_hist, min(min_range, max_mid), max_mid),
        (mask & ~centre & ~near, profile.full_hist, max_mid, max(max_range, max_mid)),
    )
    for where, hist, lo, hi in draws:
        grey[where] = _draw_grey(hist, lo, hi, int(where.sum()), rng)
    return grey, mask


def repair(grey: np.ndarray, mask: np.ndarray, profile: PencilProfile,
           rng: np.random.Generator,
           config: RepairConfig = RepairConfig()) -> tuple[np.ndarray, tuple[int, ...]]:
    """Step 2: the grey levels after the co-occurrence repair, and the pixels changed per
    sweep (see the module docstring)."""
    levels = profile.levels
    grey = np.array(grey, dtype=np.uint8)
    level = (grey.astype(np.intp) * levels // 256)
    exists = existing_pairs(profile.glcm, config.rare_mass)
    cond_cdf = np.cumsum(profile.glcm / np.maximum(profile.glcm.sum(axis=2, keepdims=True),
                                                   _TINY), axis=2)
    marginal_cdf = np.cumsum(_level_marginal(profile.full_hist, levels))
    grey_table, grey_cdf = _greys_per_level(profile.full_hist, levels)
    offset_of = _NEIGHBOUR_OFFSET[:, None]
    n_line = int(mask.sum())
    colours = _colours(mask)  # fixed over sweeps
    changes: list[int] = []
    for _ in range(config.max_sweeps):
        changed = 0
        for r, c, ni in colours:
            nl = _neighbour_levels(level, r, c)
            current = level[r, c]
            bad = (~exists[offset_of, current[None, :], nl] & ni).any(axis=0)
            if not np.any(bad):
                continue
            r, c, current, nl, ni = r[bad], c[bad], current[bad], nl[:, bad], ni[:, bad]
            counts = pair_counts(level, mask, levels)
            excess = counts - profile.glcm * counts.sum(axis=(1, 2), keepdims=True)
            n_pairs = ni.sum(axis=0)
            best, best_gain = current, np.zeros(current.size)
            for _ in range(config.candidates):
                cand = _draw_candidate(nl, ni, cond_cdf, marginal_cdf, rng)
                # change of sum((H - N T)^2) when the pixel's pairs move from its current
                # level to cand (each symmetric pair: two cells, +-1 each), to first order
                # plus the constant second-order term
                delta = 4.0 * np.where(ni, excess[offset_of, cand[None, :], nl]
                                       - excess[offset_of, current[None, :], nl], 0.0).sum(axis=0)
                delta += 4.0 * n_pairs * (cand != current)
                better = delta < best_gain
                best = np.where(better, cand, best)
                best_gain = np.where(better, delta, best_gain)
            moved = best != current
            if np.any(moved):
                r, c, new = r[moved], c[moved], best[moved]
                level[r, c] = new
                u = rng.random(new.size)[:, None]
                pick = np.minimum((grey_cdf[new] < u).sum(axis=1), grey_table.shape[1] - 1)
                grey[r, c] = grey_table[new, pick]
                changed += int(moved.sum())
        changes.append(changed)
        if changed <= config.tol * n_line:
            break
    return grey, tuple(changes)


def _colours(mask: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The line's pixels in four colours by (row mod 2, column mod 2), no two of a colour
    neighbours: per colour its rows, columns and (8, M) which of their neighbours
    (:data:`_NEIGHBOURS`) lie on the line."""
    padded_mask = np.pad(mask, 1)
    rows, cols = np.indices(mask.shape)
    colours = []
    for a in (0, 1):
        for b in (0, 1):
            r, c = np.nonzero(mask & (rows % 2 == a) & (cols % 2 == b))
            if r.size:
                colours.append((r, c, np.stack([padded_mask[r + 1 + dr, c + 1 + dc]
                                                for dr, dc, _ in _NEIGHBOURS])))
    return colours


def _neighbour_levels(level: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(8, M) the levels of the neighbours (:data:`_NEIGHBOURS`) of pixels (r, c), 0 off the
    strip."""
    padded = np.pad(level, 1)
    return np.stack([padded[r + 1 + dr, c + 1 + dc] for dr, dc, _ in _NEIGHBOURS])


def pair_counts(level: np.ndarray, mask: np.ndarray, levels: int) -> np.ndarray:
    """(4, L, L) symmetric counts of the pairs of levels (0..L-1) of the pixels in ``mask`` at
    OFFSETS (eq. 4.1, unnormalised): what :func:`inkarm.ink.pencil_extract.pair_counts`
    (scikit-image's ``graycomatrix``) counts, by ``np.bincount`` on shifted views, which the
    repair calls after every colour of every sweep without importing scikit-image's feature
    module into a drawing run."""
    n_rows, n_cols = level.shape
    out = np.empty((len(OFFSETS), levels, levels))
    for k, (dr, dc) in enumerate(OFFSETS):
        c0, c1 = max(0, -dc), n_cols - max(0, dc)
        a = (slice(0, n_rows - dr), slice(c0, c1))
        b = (slice(dr, n_rows), slice(c0 + dc, c1 + dc))
        both = mask[a] & mask[b]
        index = level[a][both] * levels + level[b][both]
        counts = np.bincount(index, minlength=levels * levels).reshape(levels, levels)
        out[k] = counts + counts.T
    return out


def existing_pairs(prob: np.ndarray, rare_mass: float) -> np.ndarray:
    """(4, L, L) bool: the pairs of levels that exist in the model, per offset: all but the
    rarest ones that together hold at most ``rare_mass`` of its probability (0: every pair of
    positive probability)."""
    exists = prob > 0
    if rare_mass <= 0:
        return exists
    for k, matrix in enumerate(prob):
        values = np.sort(matrix.ravel())
        below = np.cumsum(values) <= rare_mass
        if np.any(below):
            exists[k] &= matrix > values[np.flatnonzero(below)[-1]]
    return exists


def smooth(grey: np.ndarray, mask: np.ndarray, profile: PencilProfile) -> np.ndarray:
    """Step 3: the thesis's 3x3 Gaussian blur made to keep the repaired statistics: grey
    levels (N, W) uint8, 255 off the line (see the module docstring)."""
    levels = profile.levels
    grey = np.array(grey, dtype=np.uint8)
    weight = gaussian_blur3(mask.astype(float))
    blurred = gaussian_blur3(np.where(mask, 1.0 - grey / 255.0, 0.0)) / np.maximum(weight,
                                                                                   _TINY)
    target = np.clip(np.round(255.0 * (1.0 - blurred)), 0, 255).astype(np.intp)
    level = grey.astype(np.intp) * levels // 256
    target_level = target * levels // 256
    # b where it stays in the pixel's level: no co-occurrence matrix sees the change
    grey = np.where(mask, np.where(target_level == level, target, grey), 255).astype(np.uint8)
    offset_of = _NEIGHBOUR_OFFSET[:, None]
    distance = _level_distance(level, mask, profile)
    for r, c, ni in _colours(mask):
        move = target_level[r, c] != level[r, c]
        r, c, ni = r[move], c[move], ni[:, move]
        if r.size == 0:
            continue
        counts = pair_counts(level, mask, levels)
        n_pairs = np.maximum(counts.sum(axis=(1, 2)), 1.0)
        excess = counts - profile.glcm * n_pairs[:, None, None]
        nl, old, new = _neighbour_levels(level, r, c), level[r, c], target_level[r, c]
        # L1 change of the normalised matrices when this pixel alone moves (each pair: two
        # symmetric cells leave (old, l), two enter (new, l))
        leave = np.abs(excess[offset_of, old[None, :], nl] - 1.0) \
            - np.abs(excess[offset_of, old[None, :], nl])
        enter = np.abs(excess[offset_of, new[None, :], nl] + 1.0) \
            - np.abs(excess[offset_of, new[None, :], nl])
        gain = np.where(ni, 2.0 * (leave + enter) / n_pairs[offset_of], 0.0).sum(axis=0)
        order = np.flatnonzero(gain <= 0.0)
        order = order[np.argsort(gain[order], kind="stable")]
        keep = order.size
        while keep:  # the colour's moves together: halved until the distance does not grow
            rr, cc = r[order[:keep]], c[order[:keep]]
            level[rr, cc] = new[order[:keep]]
            after = _level_distance(level, mask, profile)
            if after <= distance:
                grey[rr, cc] = target[rr, cc]
                distance = after
                break
            level[rr, cc] = old[order[:keep]]
            keep //= 2
    return grey


def _level_distance(level: np.ndarray, mask: np.ndarray, profile: PencilProfile) -> float:
    """:func:`glcm_distance` of the strip's levels to the profile (offsets without a pair
    counted as all zero, as :func:`strip_glcm` does)."""
    counts = pair_counts(level, mask, profile.levels)
    return glcm_distance(counts / np.maximum(counts.sum(axis=(1, 2), keepdims=True), 1.0),
                         profile.glcm)


def gaussian_blur3(darkness: np.ndarray) -> np.ndarray:
    """One pass of the 3x3 Gaussian :data:`GAUSS3` (zero beyond the edges): the blur of step 3,
    before :func:`smooth` keeps it to the moves the statistics allow."""
    from scipy.ndimage import convolve

    return convolve(np.asarray(darkness, dtype=float), GAUSS3, mode="constant", cval=0.0)


def synthesize_line(profile: PencilProfile, widths_px: np.ndarray, rng: np.random.Generator,
                    config: RepairConfig = RepairConfig()) -> LineTexture:
    """The three steps for a straight strip with one row per entry of ``widths_px`` [px]."""
    filled, mask = initial_fill(profile, widths_px, rng)
    repaired, changes = repair(filled, mask, profile, rng, config)
    smoothed = smooth(repaired, mask, profile)
    return LineTexture(filled, repaired, np.where(mask, 1.0 - smoothed / 255.0, 0.0), mask,
                       changes)


def strip_glcm(grey: np.ndarray, mask: np.ndarray, levels: int) -> np.ndarray:
    """The co-occurrence probabilities (4, L, L) of a strip's line pixels, as extraction
    computes them (:func:`inkarm.ink.pencil_extract.line_glcm`); all zero at an offset where
    a line one pixel wide has no pair."""
    return line_glcm(grey, mask, levels, require_pairs=False)


def glcm_distance(a: np.ndarray, b: np.ndarray) -> float:
    """L1 distance between two sets of co-occurrence probabilities (4, L, L), averaged over
    the offsets: 0 for equal matrices, 2 for disjoint ones (the sum form of Copeland et al.'s
    average co-occurrence error, seed 002 sec. 2.3.2)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        raise InputError(f"co-occurrence matrices of different shapes {a.shape} and {b.shape}")
    return float(np.abs(a - b).sum(axis=(-2, -1)).mean())


def _draw_grey(hist: np.ndarray, lo: int, hi: int, n: int,
               rng: np.random.Generator) -> np.ndarray:
    """``n`` grey levels drawn from ``hist`` restricted to [lo, hi] (uniform over the range
    where the histogram has no mass there)."""
    if n == 0:
        return np.empty(0, np.uint8)
    weights = np.asarray(hist, float)[lo : hi + 1]
    if weights.sum() <= 0:
        weights = np.ones(hi - lo + 1)
    return (lo + rng.choice(weights.size, size=n, p=weights / weights.sum())).astype(np.uint8)


def _level_marginal(full_hist: np.ndarray, levels: int) -> np.ndarray:
    marginal = np.bincount(np.arange(256) * levels // 256, weights=full_hist, minlength=levels)
    return marginal / marginal.sum()


def _greys_per_level(full_hist: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """For each level, its grey levels (padded by repeating the last) and their cumulative
    probabilities under the full histogram (uniform where the level has no mass)."""
    bins = np.arange(256) * levels // 256
    width = int(np.bincount(bins).max())
    table = np.zeros((levels, width), np.uint8)
    cdf = np.ones((levels, width))
    for lv in range(levels):
        greys = np.flatnonzero(bins == lv)
        weights = full_hist[greys] if full_hist[greys].sum() > 0 else np.ones(greys.size)
        table[lv, : greys.size] = greys
        table[lv, greys.size :] = greys[-1]
        cdf[lv, : greys.size] = np.cumsum(weights) / weights.sum()
    return table, cdf


def _draw_candidate(neighbour_levels: np.ndarray, neighbour_in: np.ndarray,
                    cond_cdf: np.ndarray, marginal_cdf: np.ndarray,
                    rng: np.random.Generator) -> np.ndarray:
    """One candidate level per pixel: drawn from the model's distribution of a level next to a
    randomly chosen neighbour (that neighbour's level, its offset), or from the line's level
    marginal where that neighbour is off the line."""
    m = neighbour_levels.shape[1]
    which = rng.integers(0, len(_NEIGHBOURS), size=m)
    cols = np.arange(m)
    offset = _NEIGHBOUR_OFFSET[which]
    inside = neighbour_in[which, cols]
    cdf = np.where(inside[:, None], cond_cdf[offset, neighbour_levels[which, cols]],
                   marginal_cdf[None, :])
    u = rng.random(m)[:, None]
    return np.minimum((cdf < u).sum(axis=1), marginal_cdf.size - 1)
