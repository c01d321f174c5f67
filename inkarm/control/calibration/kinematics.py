"""Kinematic calibration from drawn marks: the pattern of dots, and the least-squares fit of link
lengths and joint offsets to where the dots landed.

The arm draws dots (:func:`dot_pattern`) with the controller's own model; each dot's joint
readings ``q_k`` (the median of its pressed rows) are logged, and its mark is found on the sheet
(:mod:`inkarm.control.calibration.marks`) at ``m_k`` [mm]. The parameters

    p = (dl_1 .. dl_{n-1} [mm], d_0 .. d_{n-1} [deg])

(the link-length changes of joints 1..n-1 and the joint offsets of
:class:`inkarm.robots.geometry.GeometryErrors`) minimise

    sum_k |f_xy(q_k; p) - m_k|^2 + w^2 |N^T (p / s)|^2

with ``f_xy(q; p)`` the page x, y [mm] of the believed model's pen tip with ``p`` applied
(:func:`inkarm.robots.geometry.apply_geometry` on a copy; the pen compressed along its axis by
the controller's own estimate ``max(F - P, 0) / k`` of the logged force), ``s`` the parameters'
scales (1 mm a link, 0.1 deg an offset: either moves the tip of an arm 0.6 m long by about 1 mm),
and ``N`` the unidentifiable directions: the right singular vectors of the scaled identification
Jacobian ``J = d f / d(p / s)`` (2k x (2n - 1)) whose singular values fall below
``10 mark_noise_mm`` (the mark noise would move them by more than a tenth of a scale unit). The
small ridge ``w`` (1 mm per scale unit) holds what no mark can tell at 0 and shrinks the weak
directions towards it by ``s_i^2 / (s_i^2 + w^2)`` (a direction of singular value ``s_i``);
solved by :func:`scipy.optimize.least_squares` (Levenberg-Marquardt).

What a pen perpendicular to a flat sheet cannot tell apart (the Jacobian's null space for the
iiwa14; :func:`identification` computes it for any arm): the shoulder's height (``link joint2``
moves the tip along the pen), the last link and the flange's roll (along and about the pen), and
how a length splits between two links joined by a joint that turns about their common axis (only
the upper arm's and the forearm's sums show): 5 of 13. Of the other 8, three are weak from one
home posture (the sums with the shoulder's pitch, the page being at one height); the swivelled
homes of :func:`swivel_postures` raise them 10 to 20 times. The fit leaves what no mark tells
at 0; none of it moves the tip in the drawing's postures either, which is what the correction
is for.

The marks are where the pen inked, not where it rested: landing, the pen slides a few tenths of
a mm while the arm takes up the force (0.2 to 0.3 mm on the iiwa14 at 1 N). :func:`dot_readings`
renders each dot's contact path as the controller's model puts it and takes the mark's offset
from the resting point off the measured mark (without it, the fit absorbs the slide as a
0.2 mm shift of the whole drawing: tracking 0.25 instead of 0.05 mm after calibration).

Only what a real cell offers is used: joint readings, the sensed force, the marks and the
controller's own model. Never the plant's truth.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import mujoco
import numpy as np

from inkarm.control.calibration.dots import settled_rows
from inkarm.core.log import DrawLog
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.robots.geometry import GeometryErrors, apply_geometry
from inkarm.robots.kinematic import KinematicModel

LINK_SCALE_MM = 1.0
OFFSET_SCALE_DEG = 0.1
NO_ERRORS = GeometryErrors()
RIDGE_MM = 1.0  # the ridge's weight [mm per scale unit] on the unidentifiable directions
DWELL_S = 0.15  # how long the pen rests on each dot [s]


def dot_pattern(page_size_mm: tuple[float, float], columns: int = 5, rows: int = 6,
                margin_mm: float = 20.0, dwell_s: float = DWELL_S,
                shift_mm: tuple[float, float] = (0.0, 0.0)) -> Drawing:
    """A grid of ``columns`` x ``rows`` dots over the sheet, ``margin_mm`` from its edges and
    then moved by ``shift_mm`` [mm] (so that patterns of several postures share one sheet), in
    a serpentine order (row by row, alternating direction: short travels), each a stroke that
    rests ``dwell_s`` [s] at one page point [mm].

    The evidence (the iiwa14, :func:`identification`'s singular values): they grow as the
    square root of the number of dots (3 x 3, 5 x 6, 8 x 10 from one home: the 5th 0.07, 0.12,
    0.18 mm per unit); dots gathered in the middle 60 mm of the sheet lose 2.5 to 3 times on the
    weak ones; postures count most: 3 x 3 dots from each of three homes
    (:func:`swivel_postures`) raise the 5th to 1.0 and the 8th from 0.01 to 0.1 mm per unit,
    5 x 6 from each to 1.6 and 0.15. Hence the default: 5 x 6 over the sheet from three
    homes."""
    w, h = (float(v) for v in page_size_mm)
    if columns < 2 or rows < 2:
        raise InputError(f"dot_pattern: expected at least 2 columns and 2 rows, got {columns} x "
                         f"{rows}", key="columns", value=(columns, rows))
    if not (0 <= margin_mm < 0.5 * min(w, h)):
        raise InputError(f"dot_pattern: expected a margin in [0, {0.5 * min(w, h):g}) mm, got "
                         f"{margin_mm}", key="margin_mm", value=margin_mm)
    if not dwell_s > 0:
        raise InputError(f"dot_pattern: expected dwell_s > 0, got {dwell_s}", key="dwell_s",
                         value=dwell_s)
    sx, sy = (float(v) for v in shift_mm)
    if max(abs(sx), abs(sy)) > margin_mm:
        raise InputError(f"dot_pattern: a shift {shift_mm} mm beyond the margin {margin_mm} mm "
                         "would leave the sheet", key="shift_mm", value=shift_mm)
    xs = np.linspace(margin_mm, w - margin_mm, columns) + sx
    ys = np.linspace(margin_mm, h - margin_mm, rows) + sy
    points = [(x, y) for r, y in enumerate(ys) for x in (xs if r % 2 == 0 else xs[::-1])]
    dots = [Trajectory(t=np.array([0.0, dwell_s]), pos=np.array([p, p])) for p in points]
    return Drawing(dots, page_size=(w, h))


def swivel_postures(model: KinematicModel, angle_deg: float = 45.0) -> tuple[np.ndarray, ...]:
    """Home postures [rad] (n,) turned by +-``angle_deg`` along the null space of the flange's
    whole pose at ``model.home_q`` (for a 7-joint arm: the elbow's swivel about the shoulder-
    wrist line, which leaves the pen where it is); () for an arm without one (n <= 6).

    Dots drawn from these homes reach the same page points in other postures (the
    controller's inverse kinematics pulls towards its home): for the iiwa14 the 3 x 30 dots of
    homes at 0 and +-45 deg raise the weak singular values 10 to 20 times over 30 dots from one
    home (+-30 deg: a little less, +-60 deg: a little more, nearer the joints' limits).
    Each posture's step is scaled down where it would leave a joint's range."""
    from inkarm.control.kinematics import ArmKinematics

    arm = ArmKinematics.of(model)
    home = np.asarray(model.home_q, dtype=float)
    _, _, jp, jr = arm.jacobian(home)
    _, sv, vt = np.linalg.svd(np.vstack([jp, jr]))
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    if rank >= model.n:
        return ()
    v = vt[rank]
    v = v / np.max(np.abs(v)) * np.deg2rad(angle_deg)
    out = []
    for step in (v, -v):
        room = np.where(step > 0, arm.upper - home, home - arm.lower) / np.maximum(
            np.abs(step), 1e-12)
        out.append(home + step * min(1.0, 0.9 * float(np.min(room))))
    return tuple(out)


def dot_points(drawing: Drawing) -> np.ndarray:
    """The (k, 2) page points [mm] of a drawing of dots (each stroke's first point)."""
    return np.array([s.pos[0, :2] for s in drawing.strokes])


def parameter_names(joint_names) -> tuple[str, ...]:
    """Names of the entries of p: ``link <joint> [mm]`` for joints 1..n-1, then ``offset
    <joint> [deg]`` for joints 0..n-1."""
    names = tuple(joint_names)
    return (*(f"link {j} [mm]" for j in names[1:]), *(f"offset {j} [deg]" for j in names))


def parameter_scales(n: int) -> np.ndarray:
    """The scales s (2n - 1,) of p: [mm] for the links, [deg] for the offsets."""
    return np.r_[np.full(n - 1, LINK_SCALE_MM), np.full(n, OFFSET_SCALE_DEG)]


def geometry_of(params, n: int, tip_offset_mm=(0.0, 0.0, 0.0)) -> GeometryErrors:
    """The :class:`GeometryErrors` of a parameter vector p (2n - 1,), with ``tip_offset_mm``."""
    p = np.asarray(params, dtype=float)
    if p.shape != (2 * n - 1,):
        raise InputError(f"expected {2 * n - 1} parameters for {n} joints, got {p.shape}",
                         key="params", value=p.tolist())
    return GeometryErrors(link_length_mm=(0.0, *p[: n - 1].tolist()),
                          joint_offset_deg=tuple(p[n - 1:].tolist()),
                          tip_offset_mm=tuple(float(v) for v in tip_offset_mm))


def params_of(geometry: GeometryErrors, n: int) -> np.ndarray:
    """The parameter vector p (2n - 1,) of ``geometry`` (its tip offset left out)."""
    links = np.zeros(n) if not geometry.link_length_mm else np.asarray(geometry.link_length_mm)
    offsets = np.zeros(n) if not geometry.joint_offset_deg else \
        np.asarray(geometry.joint_offset_deg)
    if links.shape != (n,) or offsets.shape != (n,):
        raise InputError(f"expected {n} link lengths and joint offsets, got {len(links)} and "
                         f"{len(offsets)}", key="geometry")
    return np.r_[links[1:], offsets].astype(float)


class TipModel:
    """Page x, y [mm] of the pen tip of ``model`` at joint readings, with parameters p applied on
    top of ``base`` (the controller's current geometry; its tip offset kept)."""

    def __init__(self, model: KinematicModel, base: GeometryErrors = NO_ERRORS):
        self.model = model
        self.base = base
        self.n = model.n
        self._joints = [mujoco.mj_name2id(model.model, mujoco.mjtObj.mjOBJ_JOINT, j)
                        for j in model.joint_names]
        if min(self._joints) < 0:
            raise InputError(f"kinematic model: lacks one of the joints {model.joint_names}")
        self._site = mujoco.mj_name2id(model.model, mujoco.mjtObj.mjOBJ_SITE, model.tip_site)
        self._qadr = [int(model.model.jnt_qposadr[j]) for j in self._joints]
        self._base_p = params_of(base, self.n)

    def tips(self, q: np.ndarray, params, compression_mm: np.ndarray | None = None) -> np.ndarray:
        """(k, 2) page x, y [mm] of :meth:`page`."""
        return self.page(q, params, compression_mm)[:, :2]

    def page(self, q: np.ndarray, params, compression_mm: np.ndarray | None = None) -> np.ndarray:
        """(k, 3) page [mm] at readings ``q`` (k, n) [rad] with p = ``params`` applied (on top of
        the base geometry); the pen pushed into its holder by ``compression_mm`` (k,)."""
        m = copy.deepcopy(self.model.model)
        apply_geometry(m, self.model.joint_names,
                       geometry_of(self._base_p + np.asarray(params, float), self.n,
                                   self.base.tip_offset_mm), self.model.tip_site)
        d = mujoco.MjData(m)
        q = np.atleast_2d(q)
        c = np.zeros(len(q)) if compression_mm is None else np.asarray(compression_mm, float)
        out = np.zeros((len(q), 3))
        for k, qk in enumerate(q):
            d.qpos[self._qadr] = qk
            mujoco.mj_kinematics(m, d)
            axis = d.site_xmat[self._site].reshape(3, 3)[:, 2]  # the flange's z: along the pen
            out[k] = d.site_xpos[self._site] - c[k] / 1000.0 * axis
        return self.model.placement.to_page(out)

    def jacobian(self, q: np.ndarray, params=None, compression_mm=None,
                 step: float = 1e-3) -> np.ndarray:
        """d tips / d(p / s): (2k, 2n - 1) [mm per scale unit], central differences of
        ``step`` scale units."""
        s = parameter_scales(self.n)
        p0 = np.zeros(2 * self.n - 1) if params is None else np.asarray(params, float)
        cols = []
        for i in range(len(p0)):
            e = np.zeros_like(p0)
            e[i] = step * s[i]
            cols.append((self.tips(q, p0 + e, compression_mm)
                         - self.tips(q, p0 - e, compression_mm)).ravel() / (2 * step))
        return np.column_stack(cols)


@dataclass(frozen=True)
class DotReadings:
    """Per dot of a pattern run: joint readings ``q`` (k, n) [rad], the pen's compression
    (k,) [mm] and the mark's expected offset from the tip at ``q`` (k, 2) [mm]."""

    q: np.ndarray
    compression_mm: np.ndarray
    offset_mm: np.ndarray


def pen_compression_mm(force_n, model: KinematicModel) -> np.ndarray:
    """The pen's compression ``clip((F - P) / k, 0, travel)`` [mm] under ``force_n`` [N] (the
    controller's spring: rate k, preload P)."""
    f = np.asarray(force_n, dtype=float)
    return np.clip((f - model.pen_preload_n) / model.pen_stiffness_n_per_mm, 0.0,
                   model.pen_travel_mm)


def dot_readings(log: DrawLog, dots: int, force_n: float, tip: TipModel, ink=None,
                 px_per_mm: float = 10.0) -> DotReadings:
    """What a pattern run's ``log`` says of each dot (stroke 0..dots-1):

    * ``q``: the median joint readings over the last half of its pressed rows (phase draw;
      with a sensed force, above half ``force_n`` [N]): where the pen rested;
    * the pen's compression there (:func:`pen_compression_mm` of the median force; 0 without
      a sensed force);
    * the mark's offset from the tip at ``q``: its contact rows (the rows around the resting
      ones while the sensed force stays above a tenth of ``force_n``: noise while the pen is in
      the air does not count) as ``tip``
      (the controller's model) puts them, inked with ``ink`` at ``px_per_mm``
      (:func:`inkarm.control.calibration.marks.rendered_mark`), minus the tip at ``q``. The pen
      slides a few tenths of a mm while it lands and lifts; this offset barely depends on the
      small corrections fitted, so it is taken once, with the model's current geometry.
      Without a sensed force (a servo arm), the contact rows are those where the model puts
      the tip at or below the sheet, inked at ``force_n``. Zero without ``ink``.

    Raises InputError naming a dot that was never pressed."""
    from inkarm.control.calibration.marks import rendered_mark

    sensed = bool(len(log)) and bool(np.isfinite(log.force).any())
    model = tip.model
    q = np.zeros((dots, log.q.shape[1]))
    compression = np.zeros(dots)
    offset = np.zeros((dots, 2))
    zero = np.zeros(2 * tip.n - 1)
    for k in range(dots):
        mine = settled_rows(log, k, force_n if sensed else None)
        if len(mine) == 0:
            raise InputError(f"dot {k} of the pattern was never pressed on the paper (no logged "
                             "contact): is the sheet where the model believes it?", key="dots",
                             value=k)
        q[k] = np.median(log.q[mine], axis=0)
        if sensed:
            compression[k] = float(pen_compression_mm(np.median(log.force[mine]), model))
        if ink is None:
            continue
        if sensed:
            touching = _contact_rows((log.stroke == k) & (log.force > 0.1 * force_n), mine[-1])
            force = log.force[touching]
        else:  # the pen touches where the model puts it at or below the sheet, at F*
            below = np.zeros(len(log), dtype=bool)
            own = np.flatnonzero(log.stroke == k)
            below[own] = tip.page(log.q[own], zero)[:, 2] <= 0.0
            below[mine] = True
            touching = _contact_rows(below, mine[-1])
            force = np.full(len(touching), float(force_n))
        path = tip.tips(log.q[touching], zero, pen_compression_mm(force, model) if sensed
                        else None)
        rest = tip.tips(q[k], zero, compression[k:k + 1])[0]
        offset[k] = rendered_mark(path, force, log.time[touching], ink, px_per_mm) - rest
    return DotReadings(q, compression, offset)


def _contact_rows(pressed: np.ndarray, resting: int) -> np.ndarray:
    """The rows around row ``resting`` while ``pressed`` (a boolean per row) holds."""
    start = resting
    while start > 0 and pressed[start - 1]:
        start -= 1
    stop = resting + 1
    while stop < len(pressed) and pressed[stop]:
        stop += 1
    return np.arange(start, stop)


@dataclass(frozen=True)
class Identification:
    """What a set of postures can tell: the scaled identification Jacobian's singular values
    (descending) [mm per scale unit], its right singular vectors (rows, in scaled parameters),
    and how many of them are identifiable (the first ``rank``)."""

    singular_values: np.ndarray
    directions: np.ndarray
    rank: int

    @property
    def null(self) -> np.ndarray:
        """The unidentifiable directions (rows, scaled parameters)."""
        return self.directions[self.rank:]

    def projector(self) -> np.ndarray:
        """Projector onto the identifiable directions, in scaled parameters."""
        v = self.directions[: self.rank]
        return v.T @ v

    def identifiable_sums(self, links: int, tol: float = 0.05) -> list[tuple[int, int]]:
        """Pairs (i, i + 1) of the first ``links`` parameters (the link lengths) of which only
        the sum is identifiable: their difference lies outside the identifiable directions, their
        sum inside (two links joined by a joint that turns about their common axis)."""
        inside = self.projector()
        pairs = []
        for i in range(links - 1):
            d, s = np.zeros(len(inside)), np.zeros(len(inside))
            d[[i, i + 1]], s[[i, i + 1]] = (1.0, -1.0), (1.0, 1.0)
            d, s = d / np.sqrt(2.0), s / np.sqrt(2.0)
            if np.linalg.norm(inside @ d) < tol and np.linalg.norm(s - inside @ s) < tol:
                pairs.append((i, i + 1))
        return pairs

    def identifiable_parameters(self, tol: float = 0.05) -> np.ndarray:
        """Indices of the single parameters that lie in the identifiable subspace (their unit
        vector's component outside it below ``tol``)."""
        eye = np.eye(self.directions.shape[1])
        outside = np.linalg.norm(eye - eye @ self.projector(), axis=1)
        return np.flatnonzero(outside < tol)


def identification(tip: TipModel, q: np.ndarray, compression_mm=None,
                   mark_noise_mm: float = 0.05) -> Identification:
    """The identification of p from marks at readings ``q`` (k, n): a direction is identifiable
    when its singular value is at least ``10 mark_noise_mm`` (module docstring)."""
    if not mark_noise_mm > 0:
        raise InputError(f"expected mark_noise_mm > 0, got {mark_noise_mm}",
                         key="mark_noise_mm", value=mark_noise_mm)
    _, sv, vt = np.linalg.svd(tip.jacobian(q, compression_mm=compression_mm))
    rank = int(np.sum(sv >= 10.0 * mark_noise_mm))
    return Identification(sv, vt, rank)


@dataclass(frozen=True)
class KinematicFit:
    """A fitted correction.

    Attributes:
        params: p (2n - 1,): link changes [mm] of joints 1..n-1, offsets [deg] of joints 0..n-1.
        names: Their names (:func:`parameter_names`).
        geometry: p as :class:`GeometryErrors` on top of the base (its tip offset kept).
        residual_before_mm, residual_after_mm: RMS distance of marks from the predicted tips
            [mm], with the base geometry and with the fit.
        identification: The Jacobian's evidence at the fit's postures.
        marks_mm: (k, 2) the marks fitted; residuals_mm: (k, 2) after the fit.
    """

    params: np.ndarray
    names: tuple[str, ...]
    geometry: GeometryErrors
    residual_before_mm: float
    residual_after_mm: float
    identification: Identification
    marks_mm: np.ndarray
    residuals_mm: np.ndarray

    def report(self) -> str:
        """The fit in words: residuals, then each parameter (marking the unidentifiable)."""
        ident = self.identification
        inside = set(ident.identifiable_parameters().tolist())
        lines = [(f"{len(self.marks_mm)} marks: residual RMS {self.residual_before_mm:.3f} mm "
                  f"before, {self.residual_after_mm:.3f} mm after the fit"),
                 f"identifiable directions: {ident.rank} of {len(self.params)} (singular values "
                 + ", ".join(f"{s:.3g}" for s in ident.singular_values) + " mm per unit)"]
        for i, (name, value) in enumerate(zip(self.names, self.params, strict=True)):
            tag = "" if i in inside else "   (not identifiable alone)"
            lines.append(f"  {name:<28} {value:+.4f}{tag}")
        for i, j in ident.identifiable_sums(self.identification.directions.shape[1] // 2):
            label = f"{self.names[i].split(' [')[0]} + {self.names[j].split(' ', 1)[1]}"
            lines.append(f"  {label:<28} {self.params[i] + self.params[j]:+.4f}   "
                         "(identifiable: only the sum shows)")
        return "\n".join(lines)


def fit_kinematics(model: KinematicModel, q: np.ndarray, marks_mm: np.ndarray,
                   compression_mm: np.ndarray | None = None,
                   base: GeometryErrors = NO_ERRORS,
                   mark_noise_mm: float = 0.05) -> KinematicFit:
    """Fit p to the marks ``marks_mm`` (k, 2) [mm] drawn at joint readings ``q`` (k, n) [rad]
    by the arm of ``model`` (the controller's; ``base``: the geometry it already has), the pen
    compressed by ``compression_mm`` (k,) [mm] (module docstring)."""
    from scipy.optimize import least_squares

    q = np.atleast_2d(np.asarray(q, dtype=float))
    marks = np.asarray(marks_mm, dtype=float).reshape(-1, 2)
    n = model.n
    if q.shape != (len(marks), n):
        raise InputError(f"expected joint readings (k, {n}) for k = {len(marks)} marks, got "
                         f"{q.shape}", key="q", value=q.shape)
    if len(marks) * 2 < 2 * n - 1:
        raise InputError(f"{len(marks)} marks cannot fit {2 * n - 1} parameters; draw at "
                         f"least {n} dots", key="marks", value=len(marks))
    tip = TipModel(model, base)
    scale = parameter_scales(n)
    ident = identification(tip, q, compression_mm, mark_noise_mm)
    null = ident.null

    def residuals(x: np.ndarray) -> np.ndarray:
        fit = (tip.tips(q, x * scale, compression_mm) - marks).ravel()
        return np.r_[fit, RIDGE_MM * (null @ x)]

    before = tip.tips(q, np.zeros(2 * n - 1), compression_mm) - marks
    solution = least_squares(residuals, np.zeros(2 * n - 1), method="lm", xtol=1e-12,
                             ftol=1e-12, gtol=1e-12)
    params = solution.x * scale
    after = tip.tips(q, params, compression_mm) - marks
    total = params_of(base, n) + params
    return KinematicFit(
        params=total,
        names=parameter_names(model.joint_names),
        geometry=geometry_of(total, n, base.tip_offset_mm),
        residual_before_mm=_rms(before),
        residual_after_mm=_rms(after),
        identification=ident,
        marks_mm=marks,
        residuals_mm=after,
    )


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1)))) if len(d) else 0.0


__all__ = ["DWELL_S", "DotReadings", "Identification", "KinematicFit", "TipModel", "dot_pattern",
           "dot_points", "dot_readings", "fit_kinematics", "geometry_of", "identification",
           "parameter_names", "parameter_scales", "params_of", "pen_compression_mm",
           "swivel_postures"]
