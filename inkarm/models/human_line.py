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

Many polylines (the samples of a plan's stroke) are computed together by
:func:`human_polylines`, the same numbers as one by one but 5-10x faster (0.15-0.3 ms
instead of 1.5-3 ms for a polyline of 3 one-second lines at dt = 0.01 s); their time,
:func:`polylines_seconds`, is checked against INKARM_MAX_COMPUTE_S. Its constants, measured
on the 2-core development machine under load: :data:`POLYLINE_S` per polyline (its generator
and squiggles), :data:`ARC_SAMPLE_S` per arc-length sample (measured 24-34 ns),
:data:`STEP_S` per time step (~120 ns) and :data:`BLOCK_S` per line and block of polylines
(the NumPy calls); whole runs took 0.7x to 1.4x of the estimate.
"""

from __future__ import annotations

import numpy as np

from inkarm.core import budget
from inkarm.core.ranges import expected_in
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.lqt.config import MAX_TIME, coordinate_error
from inkarm.models.minjerk import minimum_jerk_profile

THESIS_CLOCK = 2.0  # seed 002 sec. 3.2: t in [0, 2]
DEFAULT_PX_MM = 25.4 / 300.0  # one pixel of a 300 dpi scan, in [mm]
DEFAULT_SQUIGGLE_PX = 5.0  # seed 002 sec. 3.2.1: D in [-5, 5]
ARC_SAMPLES_PER_SEGMENT = 64  # resolution of the arc-length table of the spline
MAX_SQUIGGLE_PX = 1e6
PX_MM_RANGE = (1e-6, 1.0)  # [mm]: 25400 dpi .. 25.4 dpi
_BLOCK = 1 << 17  # spline evaluations per NumPy call: ~1 MB per (block, D) temporary

# seed 002 Table 3.1: (upper bound of the line length in px, time step Delta t)
TIME_STEP_TABLE = ((200.0, 0.5), (400.0, 0.3), (np.inf, 0.2))



def _intervals(duration: float, dt: float) -> int:
    """Time steps of a line of ``duration`` [s] sampled every ``dt`` [s] (at least one)."""
    return max(int(np.ceil(duration / dt - 1e-9)), 1)

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
    return int(lines) * _intervals(duration, dt) + 1


ARC_TABLE = ARC_SAMPLES_PER_SEGMENT * round(THESIS_CLOCK / TIME_STEP_TABLE[-1][1]) + 1


def sample_count(lines: int, duration: float, dt: float) -> int:
    """Spline evaluations of a polyline, the measure of its work that is checked against
    INKARM_MAX_STEPS: per line its ceil(duration / dt) + 1 time steps plus at most
    :data:`ARC_TABLE` (641) samples of its arc-length table. (About 1 ms per line of a few
    hundred steps, so that the budget also bounds polylines of many short lines.)"""
    return int(lines) * (_intervals(duration, dt) + 1 + ARC_TABLE)


POLYLINE_S = 50e-6  # [s] per polyline: its generator and squiggles
ARC_SAMPLE_S = 30e-9  # [s] per sample of a line's arc-length table
STEP_S = 120e-9  # [s] per time step of a line (inversion of the arc length, spline, velocity)
BLOCK_S = 1e-3  # [s] per line and block of polylines: NumPy calls


def polylines_seconds(count: int, lines: int, duration: float, dt: float) -> float:
    """Estimated seconds of :func:`human_polylines`: ``count`` polylines of ``lines`` lines,
    each line ceil(duration / dt) + 1 time steps and :data:`ARC_TABLE` arc-length samples,
    computed for blocks of polylines."""
    steps = _intervals(duration, dt) + 1
    blocks = -(-int(count) // max(1, _BLOCK // max(ARC_TABLE, steps)))
    per_line = ARC_TABLE * ARC_SAMPLE_S + steps * STEP_S
    return float(count) * (POLYLINE_S + int(lines) * per_line) + int(lines) * blocks * BLOCK_S


def check_polylines(count: int, lines: int, duration: float, dt: float) -> None:
    """Check the time of ``count`` polylines (:func:`polylines_seconds`) against
    INKARM_MAX_COMPUTE_S; the error names ``rngs`` (one generator or seed per polyline)."""
    budget.require(
        polylines_seconds(count, lines, duration, dt), budget.COMPUTE_S,
        f"time of {count} human polylines of {lines} line{'' if lines == 1 else 's'} "
        f"(duration {duration:g} s / dt {dt:g} s)", key="rngs", value=count,
    )


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


def _line_geometry(start, end, squiggle: float, px_mm: float):
    """The undisplaced control points of a line and its normal: (tau (n+1,), points (n+1, D)
    in [mm], unit normal (D,)); ``start`` and ``end`` checked (errors name them)."""
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
    return tau, points, _normal(p1 - p0)


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
    tau, points, normal = _line_geometry(start, end, squiggle, px_mm)
    n = tau.shape[0] - 1
    offsets = _rng(rng).uniform(-squiggle, squiggle, size=n - 1) * px_mm  # seed 002 sec. 3.2.1
    points[1:-1] += np.outer(offsets, normal)
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
    steps = _intervals(duration, dt)
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
    without lifting the pen; each line lasts ``duration`` [s].

    The lines are those of :func:`human_line` with one generator drawn from in turn (the
    joint is the previous line's last sample); computed by :func:`human_polylines`."""
    t, pos, vel = human_polylines(points, [rng], squiggle, px_mm, duration, dt)
    return Trajectory(t=t, pos=pos[0], vel=vel[0])


def human_polylines(
    points,
    rngs,
    squiggle: float = DEFAULT_SQUIGGLE_PX,
    px_mm: float = DEFAULT_PX_MM,
    duration: float = THESIS_CLOCK,
    dt: float = 0.01,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One :func:`human_polyline` through ``points`` per generator (or seed) of ``rngs``, all
    at once: (t (N,) in [s], pos (P, N, D) in [mm], vel (P, N, D) in [mm/s]), P = len(rngs).

    The same numbers, bit for bit, as P calls of :func:`human_polyline` (and as its lines one
    by one through :func:`human_line`): each generator draws the squiggles of all its lines
    in one call (the same stream as line by line), the geometry of each line is shared, and
    the splines and arc lengths are evaluated for a block of polylines per NumPy call. The
    time, :func:`polylines_seconds`, is checked against INKARM_MAX_COMPUTE_S first (the error
    names ``rngs``, the number of polylines).
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[0] < 2:
        raise InputError(
            f"expected points of shape (m >= 2, D), got {p.shape}", key="points", value=points
        )
    lines = p.shape[0] - 1
    check_polyline(lines, squiggle, px_mm, duration, dt)
    rngs = list(rngs)
    check_polylines(len(rngs), lines, duration, dt)
    geometry = [_line_geometry(p[k], p[k + 1], squiggle, px_mm) for k in range(lines)]
    gens = [_rng(r) for r in rngs]
    count, dim = len(gens), p.shape[1]
    sizes = [tau.shape[0] - 2 for tau, _, _ in geometry]  # interior control points per line
    starts = np.concatenate([[0], np.cumsum(sizes)])
    offsets = np.empty((count, int(starts[-1])))
    for i, gen in enumerate(gens):  # seed 002 sec. 3.2.1, line after line
        offsets[i] = gen.uniform(-squiggle, squiggle, size=offsets.shape[1]) * px_mm
    steps = _intervals(duration, dt)
    t = np.minimum(np.arange(steps + 1) * dt, duration)
    t[-1] = duration
    s = minimum_jerk_profile(t / duration)
    ds = minimum_jerk_profile(t / duration, 1)
    n_out = lines * steps + 1
    t_out = np.empty(n_out)
    pos_out = np.empty((count, n_out, dim))
    vel_out = np.empty((count, n_out, dim))
    for k, (_, base, normal) in enumerate(geometry):
        skip = 0 if k == 0 else 1  # the joint is the previous line's last sample
        cols = slice(k * steps + skip, (k + 1) * steps + 1)
        t_out[cols] = t[skip:] + k * duration
        n = base.shape[0] - 1
        u_fine = np.linspace(0.0, n, ARC_SAMPLES_PER_SEGMENT * n + 1)
        block = max(1, _BLOCK // max(u_fine.shape[0], steps + 1))
        for r0 in range(0, count, block):
            rows = slice(r0, min(r0 + block, count))
            ctrl = np.repeat(base[None], rows.stop - rows.start, axis=0)
            ctrl[:, 1:-1] += offsets[rows, starts[k] : starts[k + 1], None] * normal
            pos, vel = _timed_lines(ctrl, u_fine, s, ds, duration)
            pos_out[rows, cols] = pos[:, :, skip:].transpose(0, 2, 1)
            vel_out[rows, cols] = vel[:, :, skip:].transpose(0, 2, 1)
    return t_out, pos_out, vel_out


def _timed_lines(ctrl: np.ndarray, u_fine: np.ndarray, s: np.ndarray, ds: np.ndarray,
                 duration: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`human_line`'s timing for R lines at once: control points (R, n+1, D), the
    arc-length grid ``u_fine``, the minimum-jerk profile s and s' at the time steps; returns
    positions and velocities (R, D, T) (coordinates first: long inner loops)."""
    fine, _ = _catmull_rom_rows(ctrl, u_fine[None], derivative=False)
    arc = np.zeros((fine.shape[0], fine.shape[2]))
    np.cumsum(_norms(np.diff(fine, axis=2)), axis=1, out=arc[:, 1:])
    length = arc[:, -1:]
    target = s * length
    u = np.empty(target.shape)
    for i in range(u.shape[0]):  # np.interp per line: cheap beside the splines
        u[i] = np.interp(target[i], arc[i], u_fine)
    pos, tangent = _catmull_rom_rows(ctrl, u)
    norm = _norms(tangent)[:, None]
    unit = np.divide(tangent, norm, out=np.zeros_like(tangent), where=norm > 0)
    vel = unit * (length * ds / duration)[:, None]
    pos[:, :, 0], pos[:, :, -1] = ctrl[:, 0], ctrl[:, -1]
    return pos, vel


def _norms(x: np.ndarray) -> np.ndarray:
    """``np.linalg.norm`` over the D = 2 or 3 coordinates of x (R, D, Q), with its arithmetic
    (squares summed in order): (R, Q)."""
    sq = x * x
    total = sq[:, 0] + sq[:, 1]
    for j in range(2, x.shape[1]):
        total += sq[:, j]
    return np.sqrt(total)


def _catmull_rom_rows(points: np.ndarray, u: np.ndarray, derivative: bool = True):
    """:func:`catmull_rom` for R splines at once: points (R, m, D), parameters u (R or 1, Q);
    (positions, derivatives or None) as (R, D, Q), with the same arithmetic (the coefficients
    of each segment computed once, then gathered)."""
    m = points.shape[1]
    u = np.clip(u, 0.0, m - 1)
    padded = np.concatenate([points[:, :1], points, points[:, -1:]], axis=1).transpose(0, 2, 1)
    a, b, c, d = (padded[:, :, j : j + m - 1] for j in range(4))  # (R, D, m - 1) per segment
    c1 = 0.5 * (c - a)
    c2 = 0.5 * (2 * a - 5 * b + 4 * c - d)
    c3 = 0.5 * (-a + 3 * b - 3 * c + d)
    k = np.minimum(np.floor(u).astype(int), m - 2)
    s = (u - k)[:, None]
    if k.shape[0] == 1 and np.all(np.diff(k[0]) >= 0):  # shared, sorted: repeat segments
        counts = np.bincount(k[0], minlength=m - 1)
        b, c1, c2, c3 = (np.repeat(x, counts, axis=2) for x in (b, c1, c2, c3))
    else:  # gather each row's segments from the flattened coefficients
        rows, dims = points.shape[0], points.shape[2]
        k = np.broadcast_to(k, (rows, k.shape[1]))
        flat = np.arange(rows * dims).reshape(rows, dims, 1) * (m - 1) + k[:, None]
        b, c1, c2, c3 = (np.take(np.ascontiguousarray(x), flat) for x in (b, c1, c2, c3))
    s2 = s**2
    pos = b + c1 * s + c2 * s2 + c3 * s**3
    if not derivative:
        return pos, None
    return pos, c1 + 2 * c2 * s + 3 * c3 * s2
