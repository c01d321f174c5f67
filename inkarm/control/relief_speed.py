"""Slower over steep relief: a speed limit from the calibrated sheet.

The pen's depth follows its reference some 30 ms late (the drive, the pen's spring and the
underlay); the force loop reads the calibrated height map that far ahead along the plan, which
undoes a pure delay but not the lag's smoothing. What is left grows with how fast the height
under the pen changes its rate: along a stroke p(t) over a map m, the height h(t) = m(p(t)) has

    h''(t) = v^T H(m) v + grad(m) . p''(t)          (v = p'(t); H the map's Hessian)

and under the time stretch t -> k t every term scales as 1 / k^2. So a stroke whose largest
|h''| exceeds the force loop's reach a_max is slowed uniformly by

    k = sqrt(max_t |h''(t)| / a_max)   (k >= 1),

its shape and the proportions of its speed profile kept. Issue 23's calibrated mix: the letter's
diagonal crosses an 8 mm bump of 1 mm at 280 mm/s (|h''| about 6.8 m/s^2) and the force leaves
1 +- 0.1 N. The default a_max of 0.5 m/s^2 (``LoopConfig.relief_accel_mm_s2``) was chosen on
that mix: at 2 m/s^2 55 of 64 plants around it were ok, at 0.8 m/s^2 the four worst of them
and at 0.6 the tag (its force 0.87..1.17 N at 2 m/s^2, 0.935..1.100 at 0.6, 0.949..1.085 at
0.45); a calibrated flat sheet's map is smooth enough to slow nothing. h'' is taken from the map along the stroke
resampled every :data:`STEP_S`, smoothed by a Gaussian of :data:`SMOOTH_S` (the map is bilinear
between grid points: its raw second differences spike at the cell edges).
"""

from __future__ import annotations

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory

STEP_S = 0.002  # the resampling step of a stroke [s]
SMOOTH_S = 0.004  # sigma of the Gaussian smoothing of h(t) before differencing [s]


def height_acceleration(stroke: Trajectory, height_map) -> np.ndarray:
    """|h''(t)| [mm/s^2] of the map's height along ``stroke`` (page [mm], ``height_map.height``
    in mm), on a grid of :data:`STEP_S`; empty for a stroke shorter than the smoothing's
    window (a dot, a tick)."""
    half = int(np.ceil(3 * SMOOTH_S / STEP_S))
    t = np.arange(stroke.t[0], stroke.t[-1], STEP_S)
    if len(t) < 2 * half + 3:
        return np.zeros(0)
    x = np.interp(t, stroke.t, stroke.pos[:, 0])
    y = np.interp(t, stroke.t, stroke.pos[:, 1])
    h = np.asarray(height_map.height(x, y), dtype=float)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) * STEP_S / SMOOTH_S) ** 2)
    kernel /= kernel.sum()
    # (an odd reflection continues the slope at the ends: no kink for the differences to see)
    smooth = np.convolve(np.pad(h, half, mode="reflect", reflect_type="odd"), kernel,
                         mode="valid")
    return np.abs(np.diff(smooth, 2)) / STEP_S**2


def relief_factors(drawing: Drawing, height_map, max_accel_mm_s2: float) -> np.ndarray:
    """Per stroke, the factor k >= 1 (module docstring) that keeps |h''| <= ``max_accel_mm_s2``."""
    factors = np.ones(len(drawing.strokes))
    for i, stroke in enumerate(drawing.strokes):
        accel = height_acceleration(stroke, height_map)
        if accel.size and accel.max() > max_accel_mm_s2:
            factors[i] = float(np.sqrt(accel.max() / max_accel_mm_s2))
    return factors


def stretched(drawing: Drawing, factors: np.ndarray) -> Drawing:
    """``drawing`` with stroke i's duration times ``factors[i]`` (its times from its start,
    velocities divided) and every later stroke moved later by what the earlier ones gained."""
    strokes, shift = [], 0.0
    for stroke, k in zip(drawing.strokes, factors):
        t0 = float(stroke.t[0])
        strokes.append(Trajectory(
            t=t0 + shift + (stroke.t - t0) * k, pos=stroke.pos,
            vel=None if stroke.vel is None else stroke.vel / k, pressure=stroke.pressure))
        shift += (float(stroke.t[-1]) - t0) * (k - 1.0)
    return Drawing(strokes, page_size=drawing.page_size, meta=dict(drawing.meta))


def slowed_over_relief(drawing: Drawing, height_map, max_accel_mm_s2: float
                       ) -> tuple[Drawing, str | None]:
    """``drawing`` with the strokes that cross relief too fast slowed (:func:`relief_factors`),
    and a note saying how much (None when none was)."""
    factors = relief_factors(drawing, height_map, max_accel_mm_s2)
    if not (factors > 1.0).any():
        return drawing, None
    slow = factors > 1.0
    return stretched(drawing, factors), (
        f"slowed {int(slow.sum())} of {len(factors)} strokes up to {factors.max():.2f} x over "
        f"the calibrated sheet's relief (the height under the pen changing its rate by at most "
        f"{max_accel_mm_s2 / 1000.0:g} m/s^2: relief_accel_mm_s2)")


__all__ = ["SMOOTH_S", "STEP_S", "height_acceleration", "relief_factors", "slowed_over_relief",
           "stretched"]
