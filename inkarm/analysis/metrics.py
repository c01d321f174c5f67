"""Measures of a drawing run: how well the pen tracked, how close the ink is to the plan, how
hard the pen pressed, how near the joints came to their limits and how fast it simulated.

Pure NumPy/SciPy on plain arrays (no MuJoCo, no controller types). Time in [s], positions in
[mm] in the page frame, forces in [N], joint angles in [rad].

Conventions shared by the functions below: a run is N samples; ``drawing`` is a boolean mask
(N,) that is True where the controller's phase is "draw" (the pen is meant to be on the paper);
a maximal run of consecutive True samples is one planned stroke.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from inkarm.analysis.content_cache import ContentCache
from inkarm.analysis.medial_axis import medial_axis
from inkarm.errors import InputError

METRIC_KEYS = (
    "tracking_rms_mm",
    "tracking_max_mm",
    "ink_chamfer_mm",
    "gap_mm",
    "contact_force_mean_n",
    "contact_force_std_n",
    "force_p1_n",
    "force_p99_n",
    "joint_limit_margin_rad",
    "realtime_factor",
)


def _array(name: str, value, ndim: int, n: int | None = None) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != ndim:
        raise InputError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise InputError(f"{name}: expected {n} samples (rows), got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise InputError(f"{name}: non-finite value at index {bad}")
    return arr


def _mask(name: str, value, n: int) -> np.ndarray:
    mask = np.asarray(value)
    if mask.shape != (n,) or mask.dtype != bool:
        raise InputError(
            f"{name}: expected a boolean array of shape ({n},), got {mask.dtype} {mask.shape}"
        )
    return mask


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges [start, stop) of the maximal runs of True in ``mask``."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


@dataclass(frozen=True)
class TrackingError:
    """Distance in the page plane between the reference and the pen tip while drawing, in [mm]."""

    rms_mm: float
    max_mm: float


def tracking_error(reference_mm, tip_mm, drawing) -> TrackingError:
    """RMS and maximum of e_k = ||r_k - p_k|| over the drawing samples, where r_k and p_k are
    the (x, y) columns of the reference and the pen tip in [mm] (a z column is ignored: the
    height above the paper is the pen-up/down business of the controller)."""
    reference = _array("reference_mm", reference_mm, 2)
    tip = _array("tip_mm", tip_mm, 2, reference.shape[0])
    mask = _mask("drawing", drawing, reference.shape[0])
    if reference.shape[1] < 2 or tip.shape[1] < 2:
        raise InputError(
            f"tracking_error: need (x, y) columns, got reference {reference.shape}, tip {tip.shape}"
        )
    if not mask.any():
        raise InputError("tracking_error: the drawing mask selects no sample")
    error = np.linalg.norm(reference[mask, :2] - tip[mask, :2], axis=1)
    return TrackingError(float(np.sqrt(np.mean(error**2))), float(error.max()))


def resample_polyline(points_mm, spacing_mm: float) -> np.ndarray:
    """Points along the polyline ``points_mm`` (K, 2) at most ``spacing_mm`` apart, vertices
    included, in [mm]."""
    points = _array("polyline", points_mm, 2)
    if spacing_mm <= 0:
        raise InputError(f"resample_polyline: spacing_mm must be > 0, got {spacing_mm}")
    if len(points) < 2:
        return points.copy()
    pieces = [points[:1]]
    for a, b in itertools.pairwise(points):
        n = max(1, math.ceil(np.linalg.norm(b - a) / spacing_mm))
        s = np.arange(1, n + 1)[:, None] / n
        pieces.append(a + s * (b - a))
    return np.concatenate(pieces)


# Rows of a raster scanned at a time by ink_box (a few MB of boolean temporaries).
_SCAN_ROWS = 512
# The plans last resampled and their KD-trees (ink_chamfer_mm), by content: an ensemble's
# members share one plan.
_PLANS = ContentCache(4)

# How near [px] the ink's and the plan's nearest points are looked for first (ink_chamfer_mm:
# nearly all are within a pixel of the other side; a bounded query prunes more; a drawing far
# off its plan pays a second, unbounded query, about 1.4x one).
_NEAR_PX = 3.0

Box = tuple[int, int, int, int]


def ink_box(darkness, threshold: float, *, strict: bool = False, margin: int = 0,
            within: Box | None = None) -> Box | None:
    """The pixel box (r0, r1, c0, c1), half-open, of the pixels of the 2-D raster ``darkness``
    that are >= ``threshold`` (> it when ``strict``), grown by ``margin`` pixels on every side
    and clipped to the raster; None when there is no such pixel.

    ``within``: a box outside which the raster is 0 (:attr:`inkarm.ink.canvas.Canvas.
    inked_box`), the only part scanned (unless 0 itself passes the threshold); None: all of it.
    Scans :data:`_SCAN_ROWS` rows at a time: no page-sized temporary."""
    image = np.asarray(darkness)
    if image.ndim != 2:
        raise InputError(f"ink_box: darkness must be 2-D, got shape {image.shape}")
    n_rows, n_cols = image.shape
    zero_is_ink = 0.0 > threshold if strict else 0.0 >= threshold
    w0, w1, wc0, wc1 = (0, n_rows, 0, n_cols) if within is None or zero_is_ink else within
    part = image[w0:w1, wc0:wc1]
    row_any = np.zeros(part.shape[0], bool)
    col_any = np.zeros(part.shape[1], bool)
    for r0 in range(0, part.shape[0], _SCAN_ROWS):
        block = part[r0 : r0 + _SCAN_ROWS]
        ink = block > threshold if strict else block >= threshold
        row_any[r0 : r0 + len(block)] = ink.any(axis=1)
        col_any |= ink.any(axis=0)
    rows, cols = np.flatnonzero(row_any) + w0, np.flatnonzero(col_any) + wc0
    if rows.size == 0:
        return None
    return (max(0, int(rows[0]) - margin), min(n_rows, int(rows[-1]) + 1 + margin),
            max(0, int(cols[0]) - margin), min(n_cols, int(cols[-1]) + 1 + margin))


def ink_centreline_mm(darkness, px_per_mm: float, threshold: float = 0.5, *,
                      within: Box | None = None) -> np.ndarray:
    """Centres in [mm], shape (M, 2), of the pixels on the discrete medial axis of the ink.

    The ink is the set of pixels of ``darkness`` (rows, cols; row 0 at the top of the page, the
    :class:`inkarm.ink.canvas.Canvas` convention) that are >= ``threshold``; its medial axis is
    taken as the ink pixels whose Euclidean distance to the nearest blank pixel (the page's
    border counting as blank) is a maximum of their 3 x 3 neighbourhood (a ridge of the
    distance transform, :mod:`inkarm.analysis.medial_axis`). For a line of any width this lies
    within half a pixel of the line's centre. In row-major order.

    Work and memory follow the ink, not the page: the depths and the ridge are computed at the
    ink pixels only, in the ink's bounding box (:func:`ink_box`, scanning only ``within``
    where given), everything outside which is blank.
    """
    image = np.asarray(darkness)
    if image.ndim != 2:
        raise InputError(f"ink_centreline_mm: darkness must be 2-D, got shape {image.shape}")
    n_rows = image.shape[0]
    box = ink_box(image, threshold, within=within)
    if box is None:
        return np.empty((0, 2))
    r0, r1, c0, c1 = box
    rows, cols = medial_axis(image[r0:r1, c0:c1] >= threshold)
    rows, cols = rows + r0, cols + c0
    return np.column_stack(((cols + 0.5) / px_per_mm, (n_rows - rows - 0.5) / px_per_mm))


def chamfer_mm(points_a, points_b) -> float:
    """Symmetric chamfer distance in [mm] between point sets A (M, 2) and B (K, 2):

        d(A, B) = 1/2 ( mean_{a in A} min_{b in B} ||a - b|| + mean_{b in B} min_{a in A} ||a - b|| ).

    Returns inf when exactly one set is empty (nothing matches nothing)."""
    a = _array("points_a", points_a, 2)
    b = _array("points_b", points_b, 2)
    if len(a) == 0 and len(b) == 0:
        raise InputError("chamfer_mm: both point sets are empty")
    if len(a) == 0 or len(b) == 0:
        return math.inf
    return _chamfer(a, b, cKDTree(b))


def _chamfer(a: np.ndarray, b: np.ndarray, b_tree: cKDTree, near: float = math.inf) -> float:
    """:func:`chamfer_mm` of non-empty A and B, with B's KD-tree ``b_tree`` given; nearest
    points looked for within ``near`` [mm] first (:func:`_nearest`)."""
    a_to_b = _nearest(b_tree, a, near)
    # (a tree split at sliding midpoints, not medians: built faster, the same exact distances)
    b_to_a = _nearest(cKDTree(a, balanced_tree=False), b, near)
    return float(0.5 * (a_to_b.mean() + b_to_a.mean()))


def _nearest(tree: cKDTree, points: np.ndarray, near: float) -> np.ndarray:
    """The distance from each of ``points`` to its nearest point of ``tree``: looked for within
    ``near`` first (a bounded query prunes more of the tree), then without a bound for the
    points that have none so near. The same exact distances as one unbounded query."""
    distance, _ = tree.query(points, distance_upper_bound=near)
    far = np.isinf(distance)
    if far.any():
        distance[far], _ = tree.query(points[far])
    return distance


def _plan_points(plan_strokes, px_per_mm: float) -> tuple[np.ndarray, cKDTree]:
    """The plan's (x, y) in [mm] resampled at half a pixel (:func:`ink_chamfer_mm`), read-only,
    and its KD-tree: computed once per plan's content and ``px_per_mm`` (:data:`_PLANS`)."""
    strokes = [np.asarray(s, dtype=float) for s in plan_strokes]

    def compute() -> tuple[np.ndarray, cKDTree]:
        points = [resample_polyline(s, 0.5 / px_per_mm) for s in strokes]
        if not points or sum(len(p) for p in points) == 0:
            raise InputError("ink_chamfer_mm: the plan has no stroke")
        plan = np.concatenate([p[:, :2] for p in points])
        plan.flags.writeable = False
        return plan, cKDTree(plan)

    return _PLANS.get(strokes, compute, float(px_per_mm))


def half_darkest(darkness, within: Box | None = None) -> float | None:
    """Half the darkness of the darkest pixel of ``darkness`` (only ``within`` read, a box
    outside which it is 0: :func:`ink_within`), the core of a line whatever its ink; None
    where no pixel is dark (no ink)."""
    image = np.asarray(darkness)
    if within is not None:
        r0, r1, c0, c1 = within
        image = image[r0:r1, c0:c1]
    darkest = float(np.max(image)) if image.size else 0.0
    return 0.5 * darkest if darkest > 0.0 else None


def ink_within(canvas) -> Box | None:
    """The box outside which ``canvas`` holds no ink: its ``inked_box`` (an empty box on a
    blank page; :attr:`inkarm.ink.canvas.Canvas.inked_box`), or None (the whole page) for a
    raster that keeps none."""
    if not hasattr(canvas, "inked_box"):
        return None
    return canvas.inked_box or (0, 0, 0, 0)


def ink_chamfer_mm(darkness, px_per_mm: float, plan_strokes,
                   threshold: float | None = None, *, within: Box | None = None) -> float:
    """Ink-versus-plan distance in [mm]: the symmetric chamfer distance (:func:`chamfer_mm`)
    between the ink's centreline (:func:`ink_centreline_mm` of the raster ``darkness`` at
    ``px_per_mm``, ink = darkness >= ``threshold``) and the plan, each stroke of
    ``plan_strokes`` (a list of (K, 2) polylines in page [mm]) resampled at half a pixel.

    ``threshold`` defaults to half the darkest pixel's darkness: the core of a line, whatever
    the ink's own darkness (a pencil at 30% is measured like a marker at 100%).

    The centreline, not every inked pixel, is compared so that the line width does not count
    as error: with all pixels of a line of width w on its plan, the ink-to-plan term would be
    w/4. A drawing traced exactly scores below half a pixel; a drawing shifted by s scores s.
    Returns inf when there is no ink. ``within``: a box outside which ``darkness`` is 0, the
    only part read (:func:`ink_box`). The plan's side is computed once per plan
    (:func:`_plan_points`)."""
    plan, plan_tree = _plan_points(plan_strokes, px_per_mm)
    if threshold is None:
        threshold = half_darkest(darkness, within)
        if threshold is None:
            return float("inf")
    ink = ink_centreline_mm(darkness, px_per_mm, threshold, within=within)
    return _chamfer(ink, plan, plan_tree, _NEAR_PX / px_per_mm) if len(ink) else math.inf


@dataclass(frozen=True)
class Gaps:
    """Planned ink that the pen did not lay because it was off the paper, in [mm] of the
    reference path: the longest gap, their total and how many there were."""

    longest_mm: float
    total_mm: float
    count: int


def pen_gaps(reference_mm, force_n, drawing, contact_threshold_n: float = 0.05) -> Gaps:
    """Gaps in the ink along the reference path.

    A drawing sample k is off the paper when force_n[k] <= ``contact_threshold_n``. Each
    drawing sample owns the reference arc length w_k = (||r_{k+1} - r_k|| + ||r_k - r_{k-1}||)/2
    (trapezoidal weights; a neighbour outside the stroke contributes nothing), and a gap is a
    maximal run of consecutive off-paper drawing samples of length sum_k w_k. Only (x, y) of
    the reference count."""
    reference = _array("reference_mm", reference_mm, 2)
    n = reference.shape[0]
    force = _array("force_n", force_n, 1, n)
    mask = _mask("drawing", drawing, n)
    step = np.linalg.norm(np.diff(reference[:, :2], axis=0), axis=1)
    step[~(mask[:-1] & mask[1:])] = 0.0  # a step across a stroke boundary is not drawing
    weight = 0.5 * (np.concatenate(([0.0], step)) + np.concatenate((step, [0.0])))
    gaps = [weight[a:b].sum() for a, b in _runs(mask & (force <= contact_threshold_n))]
    return Gaps(float(max(gaps, default=0.0)), float(sum(gaps)), len(gaps))


def contact_force_stats(force_n, drawing, contact_threshold_n: float = 0.05) -> tuple[float, float]:
    """Mean and standard deviation in [N] of the normal force over the drawing samples in
    contact (force > ``contact_threshold_n``; gaps are :func:`pen_gaps`' business); NaN when
    the pen never touched while drawing."""
    force = _array("force_n", force_n, 1)
    mask = _mask("drawing", drawing, force.shape[0])
    touching = force[mask & (force > contact_threshold_n)]
    if touching.size == 0:
        return math.nan, math.nan
    return float(touching.mean()), float(touching.std())


def force_percentiles(force_n, drawing, percentiles=(1.0, 99.0)) -> tuple[float, ...]:
    """The ``percentiles`` [%] of the normal force in [N] over all the drawing samples, in
    contact or not (the band the force keeps while drawing; a gap pulls its low end to 0);
    NaN when no sample is drawing. NumPy's linear interpolation between order statistics."""
    force = _array("force_n", force_n, 1)
    mask = _mask("drawing", drawing, force.shape[0])
    if not mask.any():
        return tuple(math.nan for _ in percentiles)
    return tuple(float(v) for v in np.percentile(force[mask], percentiles))


def joint_limit_margin_rad(q, joint_range) -> float:
    """Smallest distance in [rad] of any joint to either of its limits over the run,

        min_k min_j min(q_kj - lo_j, hi_j - q_kj),

    negative when a limit was passed. ``q`` is (N, J), ``joint_range`` (J, 2) rows (lo, hi);
    give +-inf for an unlimited joint."""
    q = _array("q", q, 2)
    bounds = np.asarray(joint_range, dtype=float)
    if bounds.shape != (q.shape[1], 2):
        raise InputError(f"joint_range: expected shape ({q.shape[1]}, 2), got {bounds.shape}")
    if np.any(np.isnan(bounds)) or np.any(bounds[:, 0] >= bounds[:, 1]):
        j = int(np.argmax(np.isnan(bounds).any(axis=1) | (bounds[:, 0] >= bounds[:, 1])))
        raise InputError(
            f"joint_range[{j}] = {bounds[j].tolist()}: expected lo < hi (+-inf for no limit)"
        )
    return float(np.min(np.minimum(q - bounds[:, 0], bounds[:, 1] - q)))


def realtime_factor(times_s, wall_time_s: float) -> float:
    """Simulated time over wall-clock time, (t_N - t_1) / wall_time_s."""
    times = _array("times_s", times_s, 1)
    if not (wall_time_s > 0 and math.isfinite(wall_time_s)):
        raise InputError(f"realtime_factor: wall_time_s must be > 0, got {wall_time_s!r}")
    if times.size < 2:
        raise InputError(f"realtime_factor: need at least 2 times, got {times.size}")
    return float((times[-1] - times[0]) / wall_time_s)


def plan_strokes_from_reference(reference_mm, drawing) -> list[np.ndarray]:
    """The planned strokes: (x, y) of the reference over each maximal run of drawing samples."""
    reference = _array("reference_mm", reference_mm, 2)
    mask = _mask("drawing", drawing, reference.shape[0])
    return [reference[a:b, :2] for a, b in _runs(mask)]


def compute_metrics(
    *,
    times_s,
    reference_mm,
    tip_mm,
    force_n,
    drawing,
    q,
    joint_range,
    wall_time_s: float,
    canvas,
    plan_strokes=None,
    contact_threshold_n: float = 0.05,
    ink_threshold: float | None = None,
) -> dict[str, float]:
    """All metrics of a drawing run, keyed by :data:`METRIC_KEYS`: tracking RMS and max
    (:func:`tracking_error`), ink-versus-plan chamfer (:func:`ink_chamfer_mm`), the total
    length of the gaps (:func:`pen_gaps`, which also gives the longest), contact force mean
    and std (:func:`contact_force_stats`), the 1st and 99th percentiles of the force over the
    drawing samples (:func:`force_percentiles`), the smallest joint-limit margin
    (:func:`joint_limit_margin_rad`) and the real-time factor (:func:`realtime_factor`).

    Args:
        times_s: Sample times (N,) in [s].
        reference_mm: Pen reference (N, 2 or 3) in page [mm].
        tip_mm: Pen tip (N, 2 or 3) in page [mm].
        force_n: Pen-paper normal force (N,) in [N].
        drawing: Boolean (N,), True while the phase is "draw".
        q: Joint positions (N, J) in [rad].
        joint_range: Joint limits (J, 2) in [rad].
        wall_time_s: Wall-clock duration of the run in [s].
        canvas: The ink raster (anything with ``image`` and ``px_per_mm``, row 0 at the top;
            its ``inked_box``, where it has one, spares a scan of the whole page).
        plan_strokes: Planned strokes, (K, 2) polylines in page [mm]; by default the reference
            over each run of drawing samples.
        contact_threshold_n: Force in [N] at or below which the pen counts as off the paper.
        ink_threshold: Darkness at or above which a pixel counts as ink; None: half the
            darkest pixel (:func:`ink_chamfer_mm`).
    """
    times = _array("times_s", times_s, 1)
    n = times.size
    reference = _array("reference_mm", reference_mm, 2, n)
    _array("tip_mm", tip_mm, 2, n)
    _array("force_n", force_n, 1, n)
    _array("q", q, 2, n)
    mask = _mask("drawing", drawing, n)
    if plan_strokes is None:
        plan_strokes = plan_strokes_from_reference(reference, mask)
    # a run that never reached a drawing row (a fault before the first stroke, or a plotter's
    # reports that all fell outside its strokes): undefined tracking, which the judge fails
    tracking = (tracking_error(reference, tip_mm, mask) if mask.any()
                else TrackingError(math.nan, math.nan))
    gaps = pen_gaps(reference, force_n, mask, contact_threshold_n)
    force_mean, force_std = contact_force_stats(force_n, mask, contact_threshold_n)
    force_p1, force_p99 = force_percentiles(force_n, mask)
    image = canvas.image
    within = ink_within(canvas)  # (not the whole page, for each member of an ensemble)
    return {
        "tracking_rms_mm": tracking.rms_mm,
        "tracking_max_mm": tracking.max_mm,
        "ink_chamfer_mm": ink_chamfer_mm(image, canvas.px_per_mm, plan_strokes, ink_threshold,
                                         within=within),
        "gap_mm": gaps.total_mm,
        "contact_force_mean_n": force_mean,
        "contact_force_std_n": force_std,
        "force_p1_n": force_p1,
        "force_p99_n": force_p99,
        "joint_limit_margin_rad": joint_limit_margin_rad(q, joint_range),
        "realtime_factor": realtime_factor(times, wall_time_s),
    }
