"""The Human Line Algorithm path (seed 002, ch. 3): a pencil line between two points.

1. Minimum-jerk control points (seed 002 eq. 3.1) on the segment, taken every Delta t of the
   thesis's normalised clock t in [0, 2]; Delta t shrinks as the line grows (Table 3.1), so
   longer lines get more control points and more room to wander.
2. Squiggle: each interior control point moves normal to the segment by an independent
   D ~ U[-squiggle, +squiggle] (sec. 3.2.1, [-5, 5] px by default).
3. A uniform Catmull-Rom spline interpolates the displaced control points (sec. 3.2, end
   points repeated as phantom neighbours).

Choices where the thesis is loose, stated here once:

- Pixels. Table 3.1 and the squiggle range are in pixels of the thesis's images, which were
  300 dpi scans (ch. 6), so one pixel is ``DEFAULT_PX_MM`` = 25.4/300 mm: the thresholds of
  Table 3.1 fall at about 17 mm and 34 mm and the default squiggle is +-0.42 mm. Pass ``px_mm``
  to use another resolution (a 96 dpi screen would be 25.4/96).
- Eq. 3.1 adds D to both x and y, but the text applies it "normal to the Catmull-Rom spline";
  we follow the text, and leave the two end points undisplaced so the line keeps its ends.
- t runs over [0, 2] but Delta t = 0.3 does not divide 2; we use n = round(2 / Delta t)
  equal intervals (4, 7 or 10 of them).
- Time: the thesis only renders paths. We time the pen along the spline with the
  minimum-jerk profile itself: the arc length covered at t is L s(t / duration), L the
  spline's length, so the speed is one smooth bell, zero at both ends, peaking at
  1.875 L / duration. (Timing the control points at equal steps of t instead leaves ripples
  in the speed, because a cubic spline through samples of a quintic is not that quintic.)

Units: positions in [mm], times in [s]; squiggle in pixels of size ``px_mm``.

Ranges: points within +-1e6 mm (as the LQT's means, :mod:`inkarm.models.lqt.config`),
duration up to 3600 s, squiggle up to 1e6 px, px_mm in [1e-6, 1] mm. A line has
ceil(duration / dt) + 1 samples, a polyline of m points (m - 1) ceil(duration / dt) + 1
(:func:`step_count`); its work, those plus 641 arc-length samples per line
(:func:`sample_count`), is checked against INKARM_MAX_STEPS (:mod:`inkarm.core.budget`)
before anything is computed.
"""

from __future__ import annotations

import numpy as np

from inkarm.core import budget
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.lqt.config import MAX_TIME, coordinate_error, expected_in
from inkarm.models.minjerk import minimum_jerk_profile

THESIS_CLOCK = 2.0  # seed 002 sec. 3.2: t in [0, 2]
DEFAULT_PX_MM = 25.4 / 300.0  # one pixel of a 300 dpi scan, in [mm]
DEFAULT_SQUIGGLE_PX = 5.0  # seed 002 sec. 3.2.1: D in [-5, 5]
ARC_SAMPLES_PER_SEGMENT = 64  # resolution of the arc-length table of the spline
MAX_SQUIGGLE_PX = 1e6
PX_MM_RANGE = (1e-6, 1.0)  # [mm]: 25400 dpi .. 25.4 dpi

# seed 002 Table 3.1: (upper bound of the line length in px, time step Delta t)
TIME_STEP_TABLE = ((200.0, 0.5), (400.0, 0.3), (np.inf, 0.2))


def time_step_for_length(length_px: float) -> float:
    """Delta t of seed 002 Table 3.1 for a line of ``length_px`` pixels."""
    for upper, step in TIME_STEP_TABLE:
        if length_px <= upper:
            return step
    raise InputError(
        f"expected a finite number of pixels, got {length_px}", key="length_px", value=length_px
    )


def _rng(rng) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def _check_params(squiggle: float, px_mm: float, duration: float, dt: float) -> None:
    for name, value, low_ok, high, unit in (
        ("squiggle", squiggle, True, MAX_SQUIGGLE_PX, "px"),
        ("px_mm", px_mm, False, PX_MM_RANGE[1], "mm"),
        ("duration", duration, False, MAX_TIME, "s"),
        ("dt", dt, False, MAX_TIME, "s"),
    ):
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = np.nan
        if not np.isfinite(v) or v < 0 or (v == 0 and not low_ok):
            kind = "non-negative" if low_ok else "positive"
            raise InputError(f"must be a {kind} number, got {value}", key=name, value=value)
        low = PX_MM_RANGE[0] if name == "px_mm" else 0.0
        if not low <= v <= high:
            raise InputError(f"{expected_in(low, high, unit, 'a number')}, got {v:g}", key=name,
                             value=value)


def step_count(lines: int, duration: float, dt: float) -> int:
    """Samples of a polyline of ``lines`` lines of ``duration`` [s] sampled every ``dt`` [s]:
    lines ceil(duration / dt) + 1 (consecutive lines share their joint)."""
    return int(lines) * max(int(np.ceil(duration / dt - 1e-9)), 1) + 1


ARC_TABLE = ARC_SAMPLES_PER_SEGMENT * round(THESIS_CLOCK / TIME_STEP_TABLE[-1][1]) + 1


def sample_count(lines: int, duration: float, dt: float) -> int:
    """Spline evaluations of a polyline, the measure of its work that is checked against
    INKARM_MAX_STEPS: per line its ceil(duration / dt) + 1 time steps plus at most
    :data:`ARC_TABLE` (641) samples of its arc-length table. (About 1 ms per line of a few
    hundred steps, so that the budget also bounds polylines of many short lines.)"""
    return int(lines) * (max(int(np.ceil(duration / dt - 1e-9)), 1) + 1 + ARC_TABLE)


def check_polyline(lines: int, squiggle: float, px_mm: float, duration: float,
                   dt: float) -> None:
    """Check the settings of a polyline of ``lines`` lines against their ranges and its work
    (:func:`sample_count`) against INKARM_MAX_STEPS, before anything is computed."""
    _check_params(squiggle, px_mm, duration, dt)
    _require_steps(lines, duration, dt)


def _require_steps(lines: int, duration: float, dt: float) -> None:
    budget.require(
        sample_count(lines, duration, dt),
        budget.STEPS,
        f"time steps of the human line ({lines} line{'' if lines == 1 else 's'} x (duration "
        f"{duration:g} s / dt {dt:g} s + {ARC_TABLE} arc-length samples))",
        key="dt",
        value=dt,
    )


def _normal(direction: np.ndarray) -> np.ndarray:
    """Unit normal to ``direction`` in the page (x, y) plane; zero for a purely vertical move."""
    n = np.zeros_like(direction)
    n[0], n[1] = -direction[1], direction[0]
    norm = np.linalg.norm(n)
    return n / norm if norm > 0 else n


def control_points(
    start,
    end,
    rng=None,
    squiggle: float = DEFAULT_SQUIGGLE_PX,
    px_mm: float = DEFAULT_PX_MM,
) -> tuple[np.ndarray, np.ndarray]:
    """The HLA control points of a line: (tau (n+1,), points (n+1, D) in [mm]).

    tau in [0, 1] is the normalised time of each point; the points are the minimum-jerk
    positions at tau (seed 002 eq. 3.1), interior ones displaced normal to the segment by
    D * px_mm with D ~ U[-squiggle, squiggle] px drawn from ``rng``.
    """
    p0 = np.asarray(start, dtype=float)
    p1 = np.asarray(end, dtype=float)
    if p0.ndim != 1 or p0.shape != p1.shape or p0.shape[0] not in (2, 3):
        raise InputError(
            f"expected 2-D or 3-D points of the same shape as start, got {p0.shape} and "
            f"{p1.shape}",
            key="end",
            value=end,
        )
    for name, p, value in (("start", p0, start), ("end", p1, end)):
        if not np.all(np.isfinite(p)):
            raise InputError(f"NaN or inf in {p.tolist()}", key=name, value=value)
        message = coordinate_error(p)
        if message:
            raise InputError(message, key=name, value=value)
    _check_params(squiggle, px_mm, 1.0, 1.0)
    length_px = float(np.linalg.norm(p1 - p0)) / px_mm
    n = round(THESIS_CLOCK / time_step_for_length(length_px))
    tau = np.linspace(0.0, 1.0, n + 1)
    s = minimum_jerk_profile(tau)
    points = p0 + np.outer(s, p1 - p0)  # seed 002 eq. 3.1
    offsets = _rng(rng).uniform(-squiggle, squiggle, size=n - 1) * px_mm  # seed 002 sec. 3.2.1
    points[1:-1] += np.outer(offsets, _normal(p1 - p0))
    return tau, points


def catmull_rom(points, u) -> tuple[np.ndarray, np.ndarray]:
    """Uniform Catmull-Rom spline through ``points`` (m, D) at parameters ``u`` in [0, m - 1].

    Returns (positions (len(u), D), derivatives d/du (len(u), D)). The spline passes through
    points[k] at u = k; the end points are repeated as phantom neighbours.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[0] < 2:
        raise InputError(
            f"expected points of shape (m >= 2, D), got {p.shape}", key="points", value=points
        )
    u = np.clip(np.asarray(u, dtype=float), 0.0, p.shape[0] - 1)
    padded = np.vstack([p[:1], p, p[-1:]])
    k = np.minimum(np.floor(u).astype(int), p.shape[0] - 2)
    s = (u - k)[:, None]
    a, b, c, d = padded[k], padded[k + 1], padded[k + 2], padded[k + 3]
    c1 = 0.5 * (c - a)
    c2 = 0.5 * (2 * a - 5 * b + 4 * c - d)
    c3 = 0.5 * (-a + 3 * b - 3 * c + d)
    pos = b + c1 * s + c2 * s**2 + c3 * s**3
    deriv = c1 + 2 * c2 * s + 3 * c3 * s**2
    return pos, deriv


def human_line(
    start,
    end,
    rng=None,
    squiggle: float = DEFAULT_SQUIGGLE_PX,
    px_mm: float = DEFAULT_PX_MM,
    duration: float = THESIS_CLOCK,
    dt: float = 0.01,
) -> Trajectory:
    """A human-like pencil line from ``start`` to ``end`` [mm] lasting ``duration`` [s].

    ``rng`` is a numpy Generator or a seed: the same seed gives the same line. Sampled every
    ``dt`` [s] (the last step may be shorter) with the spline's exact velocity.
    """
    check_polyline(1, squiggle, px_mm, duration, dt)
    _, points = control_points(start, end, rng, squiggle, px_mm)
    steps = max(int(np.ceil(duration / dt - 1e-9)), 1)
    t = np.minimum(np.arange(steps + 1) * dt, duration)
    t[-1] = duration
    # arc length of the spline on a fine grid of its parameter u, then invert it
    u_fine = np.linspace(
        0.0, points.shape[0] - 1, ARC_SAMPLES_PER_SEGMENT * (points.shape[0] - 1) + 1
    )
    fine, _ = catmull_rom(points, u_fine)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(fine, axis=0), axis=1))])
    s = minimum_jerk_profile(t / duration)
    ds = minimum_jerk_profile(t / duration, 1)
    u = np.interp(s * arc[-1], arc, u_fine)
    pos, tangent = catmull_rom(points, u)
    norm = np.linalg.norm(tangent, axis=1, keepdims=True)
    unit = np.divide(tangent, norm, out=np.zeros_like(tangent), where=norm > 0)
    vel = unit * (arc[-1] * ds / duration)[:, None]
    pos[0], pos[-1] = points[0], points[-1]
    return Trajectory(t=t, pos=pos, vel=vel)


def human_polyline(
    points,
    rng=None,
    squiggle: float = DEFAULT_SQUIGGLE_PX,
    px_mm: float = DEFAULT_PX_MM,
    duration: float = THESIS_CLOCK,
    dt: float = 0.01,
) -> Trajectory:
    """Human lines through consecutive ``points`` (m >= 2, D) [mm], drawn one after the other
    without lifting the pen; each line lasts ``duration`` [s]."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[0] < 2:
        raise InputError(
            f"expected points of shape (m >= 2, D), got {p.shape}", key="points", value=points
        )
    check_polyline(p.shape[0] - 1, squiggle, px_mm, duration, dt)
    gen = _rng(rng)
    ts, poss, vels = [], [], []
    for k in range(p.shape[0] - 1):
        line = human_line(p[k], p[k + 1], gen, squiggle, px_mm, duration, dt)
        skip = 0 if k == 0 else 1  # the joint is the previous line's last sample
        ts.append(line.t[skip:] + k * duration)
        poss.append(line.pos[skip:])
        vels.append(line.vel[skip:])
    return Trajectory(t=np.concatenate(ts), pos=np.vstack(poss), vel=np.vstack(vels))
