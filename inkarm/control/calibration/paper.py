"""The real sheet's height map from probe touches (``inkarm calibrate paper``).

The pen touches the sheet at dots along the drawing's own path (where the drawing lays ink
anyway, so the probe leaves no mark of its own) or on a grid over it
(:func:`inkarm.control.probe.probe_drawing`), each dot held once the force loop has settled
at F*. A settled dot is a sample of the sheet's height above the model's sheet
(:func:`contact_heights`), from what any arm with a force sensor knows: its joint readings q,
the sensed force F and its own model of the cell (never the simulated plant's truth)::

    h = z_fk(q) - D(F)                            [mm], along the page normal

- ``z_fk(q)``: the tip as the controller's model puts it at the measured q, pen spring at rest
  (its page z: 0 on the model's unloaded sheet);
- ``D(F)``: where the model's own tip (spring at rest) sits relative to its own sheet when it
  presses with F (negative: below): the pen slid into its holder (spring past its preload, the
  cartridge's weight), the underlay sunk and the soft contact's depth, together.
  :func:`touch_curve` finds it by letting the believed MuJoCo model settle, the arm held at a
  probe pose, on its own sheet raised by a few known amounts, and interpolates F -> D. (A
  hand formula, ``(F - F_0 - m g) / k_pen + F / k_paper``, misses the soft contact's depth:
  0.85 mm of bias on the default cell, where this reads 0.00.)

On the model's own flat sheet h is 0 wherever the pen stays perpendicular to it; a sheet 1.5 mm
higher reads 1.5.

An arm without a force sensor (a Dynamixel arm: its position-mode servos hold a tick of error
with about 1 N at the pen, 4 mm of height through the pen's spring) reads the sheet from ink
instead (:class:`RampDashes`, :func:`dash_contacts`): short dashes drawn while the pen's aimed
height ramps down through the range where the sheet may be; where a dash's ink starts, its
resting tip met the sheet less :func:`onset_depth_mm`, the model's own contact at the ink's
threshold force. On the wx250s, a sheet 3.5 mm higher than believed (1.5 raised, a pen 2 mm
longer) reads 3.37 +- 0.05 mm (mean +- SD of 18 dashes) in the simulation, the nominal sheet
-0.11 +- 0.06 (the servos' goals step in encoder ticks, 0.3 mm of the pen's height), and
through the Dynamixel emulator 3.34 +- 0.13; with the realistic mix (backlash, bus delay) each
dash to about 0.2 mm RMS.

:func:`fit_height_map` turns the samples into a :class:`~inkarm.robots.calibration.HeightMap`:
a thin-plate smoothing spline with a linear part (:class:`scipy.interpolate.RBFInterpolator`),

    h(p) = a + b . p + sum_i w_i phi(|p - p_i|),   phi(r) = r^2 log r

minimising sum_i (h(p_i) - h_i)^2 + lambda * (bending energy), evaluated on a grid of a quarter
of the probe spacing over the samples' bounding box padded by one spacing. A plane is
reproduced exactly (it has no bending); smooth relief between samples as the sampling allows
(tests/control/test_calibration_paper.py states the tolerances: a 1 mm wave of 30 mm within
0.08 mm from samples every 5 mm, 0.35 every 10 mm; a bump needs samples every third of its
width). Samples along one line (a straight stroke) leave the map constant across the line;
one sample gives a flat map at its height.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.control.calibration.dots import settled_rows
from inkarm.core.log import DRAW, LIFT, DrawLog
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.robots.calibration import HeightMap
from inkarm.robots.kinematic import KinematicModel

MAX_GRID = 400  # grid lines per axis of a fitted map (a 400 mm drawing at 1 mm)


@dataclass(frozen=True)
class Touches:
    """The settled touches of a probe run.

    Attributes:
        points_mm: (k, 3) page x, y and the sheet's height h above the model's sheet [mm].
        dots: (k,) the index of the dot each row comes from.
        missed: The dots that never settled (no contact at F* +- the tolerance).
    """

    points_mm: np.ndarray
    dots: np.ndarray
    missed: tuple[int, ...]


def contact_heights(log: DrawLog, believed: KinematicModel, dots: int,
                    force_n: float, settle_tol_n: float) -> Touches:
    """The sheet's height at each settled dot of a probe run's ``log`` (module docstring):
    per dot (stroke index), the median of h over the last half of its drawing rows whose
    sensed force is within ``settle_tol_n`` of ``force_n``; x, y from the same model's tip.
    Raises InputError when the log has no force (the backend senses none)."""
    from inkarm.control.kinematics import ArmKinematics

    if len(log) and not np.isfinite(log.force).any():
        raise InputError("the run senses no pen force: probing the paper needs a force "
                         "sensor (the simulated arm has one; a Dynamixel arm has not)",
                         key="--backend")
    arm = ArmKinematics.of(believed)
    placement = believed.placement
    rows, index, missed = [], [], []
    curve = None
    for k in range(dots):
        mine = settled_rows(log, k)
        force = log.force[mine]
        mine = mine[np.abs(force - force_n) < settle_tol_n]
        if len(mine) == 0:
            missed.append(k)
            continue
        page = np.array([placement.to_page(arm.fk(log.q[r])[0]) for r in mine])
        if curve is None:
            curve = touch_curve(believed, log.q[mine[-1]], force_n)
        h = page[:, 2] - np.interp(log.force[mine], *curve)
        rows.append((float(np.median(page[:, 0])), float(np.median(page[:, 1])),
                     float(np.median(h))))
        index.append(k)
    return Touches(np.array(rows, dtype=float).reshape(-1, 3), np.array(index, dtype=int),
                   tuple(missed))


def touch_curve(believed: KinematicModel, q: np.ndarray, force_n: float,
                settle_s: float = 0.6, points: int = 7,
                depths_mm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(F, D)``: the model's settled tip force [N] (increasing) and its tip depth D [mm]
    (page z of the tip at rest, relative to the model's sheet) when its arm is held at ``q``
    [rad] over its own sheet raised by ``points`` amounts chosen so that F spans about
    0.5..2 ``force_n`` (module docstring). A copy of the believed MuJoCo model is simulated
    for ``settle_s`` [s] per amount, the arm joints held (reset each step, their inertia made
    huge); nothing else moves but the pen's slide and the sheet's underlay. ``depths_mm``: the
    depths D to try instead (then the forces are returned as found, in the order given, zeros
    and ties included)."""
    import copy

    import mujoco

    from inkarm.control.kinematics import ArmKinematics

    model = copy.deepcopy(believed.model)
    arm = ArmKinematics(model, believed.tip_site, believed.joint_names)
    tip_geom, sheet_geom = _touching_geoms(model, arm.site_id)
    sheet = int(model.geom_bodyid[sheet_geom])
    if model.body_parentid[sheet] != 0:
        raise InputError("the model's sheet is not a body of the world; cannot raise it",
                         key="believed")
    model.dof_armature[arm.dof_adr] = 1e6
    z0 = float(believed.placement.to_page(arm.fk(q)[0])[2])  # [mm]
    normal = believed.placement.normal
    base = model.body_pos[sheet].copy()
    data = mujoco.MjData(model)
    contact = np.zeros(6)
    # stiffness along the normal: the pen spring in series with the underlay (guesses that only
    # set the raises tried; the simulation gives the forces)
    k = believed.pen_stiffness_n_per_mm
    if believed.paper_stiffness_n_per_mm > 0:
        k = 1.0 / (1.0 / k + 1.0 / believed.paper_stiffness_n_per_mm)
    steps = max(1, round(settle_s / model.opt.timestep))
    forces, depths = [], []
    slide = _slide_address(model, int(model.site_bodyid[arm.site_id]))
    tries = (-np.maximum(np.linspace(0.5, 2.0, points) * force_n - believed.pen_preload_n, 0.0)
             / k - 0.05 if depths_mm is None else np.asarray(depths_mm, dtype=float))  # [mm]
    for depth in tries:
        model.body_pos[sheet] = base + normal * (z0 - depth) / 1000.0
        mujoco.mj_resetData(model, data)
        data.qpos[arm.qpos_adr] = q
        if slide is not None:  # (the tip starts on the sheet, not inside it)
            data.qpos[slide] = min(-depth, believed.pen_travel_mm) / 1000.0
        force = 0.0
        for step in range(steps):
            data.qpos[arm.qpos_adr] = q
            data.qvel[arm.dof_adr] = 0.0
            mujoco.mj_step(model, data)
            if 3 * step >= 2 * steps:  # the mean over the last third (the pen rings a little)
                for i in range(data.ncon):
                    if tip_geom in data.contact.geom[i] and sheet_geom in data.contact.geom[i]:
                        mujoco.mj_contactForce(model, data, i, contact)
                        force += contact[0]
        forces.append(force / (steps - (2 * steps + 2) // 3))
        depths.append(float(depth))
    f, d = np.array(forces), np.array(depths)
    if depths_mm is not None:
        return f, d
    order = np.argsort(f)
    f, d = f[order], d[order]
    if not np.all(np.diff(f) > 0) or f[0] <= 0:
        raise InputError(f"the model's own touch did not settle to increasing forces "
                         f"({np.round(f, 3).tolist()} N); cannot read heights from forces",
                         key="believed")
    return f, d


def onset_depth_mm(believed: KinematicModel, q: np.ndarray, force_n: float,
                   span_mm: tuple[float, float] = (-1.0, 2.0), points: int = 13) -> float:
    """D_0 [mm]: where the model's own resting tip sits relative to its own sheet (negative:
    below) when it first presses with ``force_n`` (a marker's ink threshold, below the pen's
    preload: the pen does not give, only the underlay and the soft contact do), the arm held at
    ``q`` [rad]: :func:`touch_curve` at ``points`` depths over ``span_mm``, interpolated
    between the last depth that presses less and the first that presses more. On the wx250s's
    and the iiwa's cells 0.08 N reads +0.59 and +0.61 mm (the soft contact reaches above the
    sheet's top), where the underlay alone (0.08 N over 2 N/mm) would say -0.04.
    Raises InputError when no depth of the span reaches ``force_n``."""
    f, d = touch_curve(believed, q, force_n, depths_mm=np.linspace(*span_mm, points)[::-1])
    above = np.flatnonzero(f >= force_n)
    if len(above) == 0 or above[0] == 0:
        raise InputError(f"the model's own tip does not reach {force_n} N first within "
                         f"{span_mm} mm of its sheet (forces {np.round(f, 3).tolist()} N)",
                         key="believed")
    k = above[0]
    return float(np.interp(force_n, [f[k - 1], f[k]], [d[k - 1], d[k]]))


def _slide_address(model, body: int) -> int | None:
    """qpos address of the pen's slide: the one slide joint of the tip's body, if any."""
    import mujoco

    start, count = model.body_jntadr[body], model.body_jntnum[body]
    slides = [j for j in range(start, start + count)
              if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE]
    return int(model.jnt_qposadr[slides[0]]) if len(slides) == 1 else None


def _touching_geoms(model, site: int) -> tuple[int, int]:
    """The geom at the tip (on the tip site's body, colliding with something) and the one
    geom it can collide with (the sheet), by MuJoCo's contype/conaffinity rule."""
    body = model.site_bodyid[site]
    tips = [g for g in range(model.ngeom)
            if model.geom_bodyid[g] == body and (model.geom_contype[g] or
                                                 model.geom_conaffinity[g])]
    for tip in tips:
        others = [g for g in range(model.ngeom) if g != tip and model.geom_bodyid[g] != body
                  and (model.geom_contype[g] & model.geom_conaffinity[tip]
                       or model.geom_conaffinity[g] & model.geom_contype[tip])]
        if len(others) == 1:
            return tip, others[0]
    raise InputError("the model's pen tip does not touch exactly one geom (the sheet)",
                     key="believed")


def image_ink_mm(image, corners_px, page_size_mm: tuple[float, float],
                 threshold: float = 0.25) -> np.ndarray:
    """The inked points (M, 2) of a scanned or photographed sheet [mm]: pixels darker than the
    image's median by more than ``threshold``, their centres mapped to the page by the sheet's
    corners ``corners_px`` (lower-left, lower-right, upper-right, upper-left, in (u right,
    v down) pixels; :func:`inkarm.control.calibration.marks.sheet_homography`), those that
    land on the page kept."""
    from inkarm.control.calibration.marks import apply_homography, read_darkness, sheet_homography

    darkness = read_darkness(image) if isinstance(image, str | Path) else np.asarray(
        image, dtype=float)
    if darkness.ndim != 2 or not np.all(np.isfinite(darkness)):
        raise InputError(f"expected a finite 2-D darkness raster, got shape {darkness.shape}",
                         key="image")
    rows, cols = np.nonzero(darkness - float(np.median(darkness)) > threshold)
    if len(rows) == 0:
        return np.zeros((0, 2))
    page = apply_homography(sheet_homography(corners_px, page_size_mm),
                            np.column_stack([cols, rows]) + 0.5)
    w, h = page_size_mm
    return page[(page[:, 0] >= 0) & (page[:, 0] <= w) & (page[:, 1] >= 0) & (page[:, 1] <= h)]


def fit_height_map(points_mm: np.ndarray, spacing_mm: float,
                   smoothing: float = 1e-3, pad_mm: float | None = None) -> HeightMap:
    """A :class:`HeightMap` through samples ``points_mm`` (k, 3) of page x, y and height
    [mm] (module docstring); ``spacing_mm``: the samples' spacing (the grid is a quarter of
    it, padded by ``pad_mm`` around the samples, default one spacing; beyond the grid the map
    holds its edge); ``smoothing``: lambda of the thin-plate spline (0: through every
    sample)."""
    from scipy.interpolate import RBFInterpolator

    p = np.asarray(points_mm, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"expected (k, 3) samples of x, y, height [mm], got shape {p.shape}",
                         key="points_mm")
    if not np.all(np.isfinite(p)):
        raise InputError("expected finite samples", key="points_mm")
    if not spacing_mm > 0 or not np.isfinite(spacing_mm):
        raise InputError(f"expected a spacing > 0 mm, got {spacing_mm}", key="spacing_mm",
                         value=spacing_mm)
    if not smoothing >= 0 or not np.isfinite(smoothing):
        raise InputError(f"expected a smoothing >= 0, got {smoothing}", key="smoothing",
                         value=smoothing)
    if len(p) == 0:
        raise InputError("no samples to fit", key="points_mm")
    if len(p) == 1:  # one touch: the sheet at that height
        return HeightMap([p[0, 0]], [p[0, 1]], [[p[0, 2]]])
    p = _across_a_line(p, spacing_mm)
    xy = p[:, :2]
    pad = spacing_mm if pad_mm is None else max(float(pad_mm), 0.0)
    lo, hi = xy.min(axis=0) - pad, xy.max(axis=0) + pad
    step = max(spacing_mm / 4.0, float(np.max(hi - lo)) / (MAX_GRID - 1))
    gx = _grid(lo[0], hi[0], step)
    gy = _grid(lo[1], hi[1], step)
    spline = RBFInterpolator(xy, p[:, 2], kernel="thin_plate_spline", smoothing=smoothing,
                             degree=1)
    mx, my = np.meshgrid(gx, gy)
    z = spline(np.column_stack([mx.ravel(), my.ravel()])).reshape(mx.shape)
    return HeightMap(gx, gy, z)


@dataclass(frozen=True)
class RampDashes:
    """A paper probe for an arm that senses no pen force (a Dynamixel arm): short dashes along
    page +x, each drawn while the pen's aimed height ramps down through the range where the
    sheet may be, so that the ink starts where the pen met the sheet (module docstring of
    :func:`dash_contacts`).

    Attributes:
        starts_mm: (k, 2) page x, y where each dash starts [mm].
        length_mm: Each dash's length [mm].
        top_mm, bottom_mm: The pen tip's aimed height (spring at rest) above the model's sheet
            at a dash's start and end [mm] (the sheet's height must lie between; the pen is
            compressed by at most ``top_mm - bottom_mm`` at a dash's end).
        speed_mm_s: Drawing speed along a dash [mm/s].
    """

    starts_mm: np.ndarray
    length_mm: float
    top_mm: float
    bottom_mm: float
    speed_mm_s: float

    @staticmethod
    def over(lo_mm, hi_mm, spacing_mm: float = 10.0, length_mm: float = 12.0,
             range_mm: tuple[float, float] = (-0.5, 5.0),
             speed_mm_s: float = 10.0) -> RampDashes:
        """Dashes over the box ``lo_mm``..``hi_mm`` (page x, y [mm]): rows ``spacing_mm`` apart,
        in columns of ``length_mm`` dashes with a gap of a third of a dash, centred on the box,
        each row shifted by a third of the columns' pitch from the last (-1, 0, +1 thirds in
        turn: a dash meets the sheet near the same point of itself wherever the sheet is about
        as high, so unshifted rows would sample a relief along x at two or three places only);
        the sheet expected within ``range_mm`` (low, high) of the model's [mm]."""
        lo, hi = np.asarray(lo_mm, dtype=float)[:2], np.asarray(hi_mm, dtype=float)[:2]
        for key, value in (("spacing_mm", spacing_mm), ("length_mm", length_mm),
                           ("speed_mm_s", speed_mm_s)):
            if not (value > 0 and np.isfinite(value)):
                raise InputError(f"expected > 0, got {value}", key=key, value=value)
        low, high = (float(v) for v in range_mm)
        if not high > low:
            raise InputError(f"expected (low, high) with high > low [mm], got {range_mm}",
                             key="range_mm", value=str(range_mm))
        pitch = length_mm * 4.0 / 3.0
        columns = max(1, int(np.ceil((hi[0] - lo[0] + pitch - length_mm) / pitch)))
        rows = max(1, int(np.floor((hi[1] - lo[1]) / spacing_mm)) + 1)
        x0 = 0.5 * (lo[0] + hi[0]) - 0.5 * (columns * pitch - (pitch - length_mm))
        y0 = 0.5 * (lo[1] + hi[1]) - 0.5 * (rows - 1) * spacing_mm
        starts = np.array([(x0 + c * pitch + (r % 3 - 1) * pitch / 3.0, y0 + r * spacing_mm)
                           for r in range(rows) for c in range(columns)])
        return RampDashes(starts, float(length_mm), high, low, float(speed_mm_s))

    def drawing(self, page_size_mm) -> Drawing:
        """The dashes as page strokes, each ``length_mm`` along +x at ``speed_mm_s``."""
        from inkarm.core.trajectory import Trajectory

        t = np.array([0.0, self.length_mm / self.speed_mm_s])
        strokes = [Trajectory(t=t, pos=np.array([s, s + (self.length_mm, 0.0)]))
                   for s in self.starts_mm]
        return Drawing(strokes, page_size=tuple(page_size_mm))

    def aim_map(self, depth_mm: float) -> HeightMap:
        """The height map that, believed by the controller, makes a pen pressing ``depth_mm``
        below the sheet it believes (the plan's depth) aim its tip at ``top_mm`` over a dash's
        start falling linearly to ``bottom_mm`` at its end: ``aim + depth_mm``, along each row
        of dashes, rising back between dashes (where the pen travels in the air), over a band
        of 0.6 row spacings around the row (between the bands the pen only travels). Exact
        under bilinear interpolation (x nodes at every dash's start and end)."""
        rows = np.unique(self.starts_mm[:, 1])
        ends = self.starts_mm[:, 0] + self.length_mm
        nodes = np.unique(np.concatenate([self.starts_mm[:, 0], ends]))
        band = 0.3 * (float(np.min(np.diff(rows))) if len(rows) > 1 else self.length_mm)
        y, z = [], []
        for row in rows:
            mine = np.sort(self.starts_mm[self.starts_mm[:, 1] == row, 0])
            xp = np.column_stack([mine, mine + self.length_mm]).ravel()
            fp = np.tile([self.top_mm, self.bottom_mm], len(mine))
            aim = np.interp(nodes, xp, fp) + depth_mm
            y += [row - band, row + band]
            z += [aim, aim]
        return HeightMap(nodes, np.array(y), np.vstack(z))


def dash_contacts(ink_mm: np.ndarray, log: DrawLog, believed: KinematicModel,
                  dashes: RampDashes, start_radius_mm: float, onset_depth_mm: float,
                  corridor_mm: float = 2.5) -> Touches:
    """Where each dash of a :class:`RampDashes` probe met the sheet, from its ink and the arm's
    joint readings (what a servo arm without a force sensor offers; a scanned sheet's ink on a
    real arm, the canvas in simulation)::

        s_c = s_end(fk) - [(x_last - r_end) - (x_first + r_0)]         along the dash [mm]
        h   = z_fk(q at s_c) - D_0                                     [mm]

    - ``x_first``, ``x_last``: the dash's first and last ink along +x (pixels within
      ``corridor_mm`` of its line); ``r_0`` = ``start_radius_mm``, the ink's half width where it
      begins (the marker's width at its threshold force); ``r_end``: half the ink's width over
      its last 2 mm (measured);
    - ``s_end(fk)``: the believed tip (forward kinematics of the measured q) where the dash
      ends, the furthest along +x over its drawing and lifting rows (the pen stops there and
      lifts straight up): the ink's length back from its end
      puts the contact on the believed path, so the pen tip's lateral offset, the same at both
      ends, drops out;
    - ``z_fk``: the believed tip's page z (pen spring at rest) at the row where it passed
      ``s_c`` (interpolated), the arm's lag included (the readings, not the reference);
    - ``D_0`` = ``onset_depth_mm``: where the resting tip is relative to the sheet when the
      ink starts (the model's own contact at the ink's threshold force,
      :func:`onset_depth_mm`; the pen gives in its holder only past its preload, far above a
      marker's threshold).

    The resolution is the ink's along the dash (a pixel, 0.1 mm at 10 px/mm, and the stamp's
    width law) times the ramp's slope (``(top - bottom) / length``: 0.42 at 5 mm over 12 mm):
    about 0.05 mm, against 3.9 mm per newton of force through the pen's spring (0.26 N/mm in
    series with the underlay) that a servo's Present Current would have to resolve: an
    XM430's position loop holds a tick (0.088 deg) with 0.14 N m, about 1 N at the pen. A dash
    without ink (the sheet below ``bottom_mm``) or inked from its start (above ``top_mm``) is
    missed."""
    from inkarm.control.kinematics import ArmKinematics

    ink = np.asarray(ink_mm, dtype=float).reshape(-1, 2)
    arm = ArmKinematics.of(believed)
    placement = believed.placement
    rows, index, missed = [], [], []
    for k, (x0, y0) in enumerate(dashes.starts_mm):
        near = ink[(np.abs(ink[:, 1] - y0) < corridor_mm) & (ink[:, 0] > x0 - corridor_mm)
                   & (ink[:, 0] < x0 + dashes.length_mm + corridor_mm)]
        mine = np.flatnonzero((log.stroke == k) & (log.phase == DRAW))
        if len(near) == 0 or len(mine) < 2:
            missed.append(k)
            continue
        first, last = near[:, 0].min(), near[:, 0].max()
        tail = near[near[:, 0] > last - 2.0, 1]
        r_end = 0.5 * (tail.max() - tail.min())
        inked = (last - r_end) - (first + start_radius_mm)
        page = np.array([placement.to_page(arm.fk(log.q[r])[0]) for r in mine])
        lifted = np.flatnonzero((log.stroke == k) & (log.phase == LIFT))
        end = max([page[-1, 0]] + [placement.to_page(arm.fk(log.q[r])[0])[0] for r in lifted])
        s_c = end - inked
        if not page[0, 0] + 0.05 * dashes.length_mm < s_c:  # inked from its start: above range
            missed.append(k)
            continue
        order = np.argsort(page[:, 0])
        z = float(np.interp(s_c, page[order, 0], page[order, 2]))
        y = float(np.interp(s_c, page[order, 0], page[order, 1]))
        rows.append((float(s_c), y, z - onset_depth_mm))
        index.append(k)
    return Touches(np.array(rows, dtype=float).reshape(-1, 3), np.array(index, dtype=int),
                   tuple(missed))


def residual_rms_mm(height_map: HeightMap, points_mm: np.ndarray) -> float:
    """RMS [mm] of the map's height at the samples minus theirs."""
    p = np.asarray(points_mm, dtype=float)
    return float(np.sqrt(np.mean((height_map.height(p[:, 0], p[:, 1]) - p[:, 2]) ** 2)))


def _grid(lo: float, hi: float, step: float) -> np.ndarray:
    count = int(np.ceil((hi - lo) / step)) + 1
    return lo + step * np.arange(count)


def _across_a_line(p: np.ndarray, spacing_mm: float) -> np.ndarray:
    """Samples along (nearly) one line say nothing across it: there the map is held constant,
    the samples copied one spacing to either side of the line (RMS distance from it below a
    quarter spacing); others are returned as they are."""
    xy = p[:, :2]
    _, s, vt = np.linalg.svd(xy - xy.mean(axis=0), full_matrices=False)
    if s[-1] / np.sqrt(len(p)) >= 0.25 * spacing_mm:
        return p
    across = np.append(vt[-1] * spacing_mm, 0.0)
    return np.vstack([p, p + across, p - across])


__all__ = ["RampDashes", "Touches", "contact_heights", "dash_contacts", "fit_height_map",
           "image_ink_mm", "onset_depth_mm", "residual_rms_mm", "touch_curve"]
