"""The pen's tool-centre point from dot marks made at several pen orientations.

The IK holds the pen perpendicular to the paper with its spin free, so with the pen upright a
longer pen is a higher sheet, and a tip off the holder's axis moves each mark by the offset
turned with the spin. Marks made with the pen spun about its axis (the offset draws a circle)
and tilted from the normal (the length shows as a sideways shift L sin(theta)) tell them apart:
the dots of :func:`pen_pattern`, each a stroke with its :class:`inkarm.control.ik.PenPose`.

The fit (:func:`fit_tip_offset`). Unknowns: the tip offset p = (px, py, pz) [mm] in the flange
frame (the tip site's: z along the pen, from the flange to the tip), optionally a page offset b
(2,) [mm] common to every mark (the sheet or the marks' frame shifted against the belief), and,
with contact heights, the sheet's height h [mm]. For mark i, from the controller's own forward
kinematics at the joint readings while the pen rested on the dot: the believed tip site's
position t_i [mm] and orientation R_i (columns: the site's axes), both in the page frame, and
the pen's compression c_i [mm] into its holder (from the sensed force, (F - P) / k). The real
tip is

    r_i = t_i + R_i (p - c_i e_z)

and its mark lies at m_i = (r_i)_xy + b. Stacked, two rows per mark:

    [R_i[:2, :]  I_2] [p; b] = m_i - (t_i)_xy + c_i R_i[:2, 2]

and, with the sheet's believed surface s_i where the tip rests (its sinking, -F_i / k_paper
[mm]), one more, weighted by ``height_weight``:

    [R_i[2, :]  0  -1] [p; b; h] = s_i - (t_i)_z + c_i R_i[2, 2]

solved by linear least squares (SVD). pz's column is the pen axis's tilt, R_i[:2, 2] =
sin(theta_i) (-cos(phi_i), -sin(phi_i)): without tilts it is zero; px and py's columns turn with
the spin, so with a free page offset they need spins that differ. A design whose smallest
singular value is below ``MIN_SINGULAR`` of its largest is refused, naming the orientations
that are missing. Units: [mm] and [deg] throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.control.ik import IKConfig, PenPose, solve_ik
from inkarm.control.kinematics import ArmKinematics
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.robots.kinematic import KinematicModel

MIN_SINGULAR = 0.05  # the smallest singular value of the design over its largest, at least
TILT_DEG = 25.0  # the pattern's tilt of the pen from the normal [deg]
SPINS_DEG = (-120.0, -60.0, 0.0, 60.0, 120.0)  # the pattern's upright spins, from the natural one
# the pattern's tilt directions (page frame): eight, whose marks' small slides on the sheet's
# give (its sinking times tan(theta)) average out of the length (at most 0.014 mm off in the
# simulated cell, against 0.056 mm with four)
AZIMUTHS_DEG = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
DWELL_S = 0.3  # how long the pen rests on each dot [s]


@dataclass(frozen=True, eq=False)
class PenFit:
    """What :func:`fit_tip_offset` found.

    Attributes:
        tip_offset_mm: p, the real tip minus the believed one in the flange frame [mm] (3,).
        page_offset_mm: b, the marks' common shift [mm] (2,); zeros when not fitted.
        sheet_height_mm: h [mm] when contact heights were fitted, else None.
        residuals_mm: (k, 2) measured minus fitted mark positions [mm].
        singular_values: Of the design matrix, largest first.
        std_mm: One standard error of each unknown (p, then b, then h) from the residuals'
            scatter [mm]; zeros with as many equations as unknowns.
        length: Whether pz was fitted (else held at 0).
    """

    tip_offset_mm: np.ndarray
    page_offset_mm: np.ndarray
    sheet_height_mm: float | None
    residuals_mm: np.ndarray
    singular_values: np.ndarray
    std_mm: np.ndarray
    length: bool = True

    @property
    def residual_rms_mm(self) -> float:
        """RMS distance of the marks from where the fit puts them [mm]."""
        return float(np.sqrt(np.mean(np.sum(self.residuals_mm**2, axis=1))))

    def summary(self) -> str:
        """The fit in words."""
        p, s = self.tip_offset_mm, self.std_mm
        text = (f"pen tip offset ({p[0]:+.3f}, {p[1]:+.3f}, {p[2]:+.3f}) mm (flange x, y, along "
                f"the pen; +- {s[0]:.3f}, {s[1]:.3f}, {s[2]:.3f}); {len(self.residuals_mm)} "
                f"marks, RMS residual {self.residual_rms_mm:.4f} mm")
        if not self.length:
            text += "; the length not measured (held)"
        if self.page_offset_mm.any():
            b = self.page_offset_mm
            text += f"; marks shifted ({b[0]:+.3f}, {b[1]:+.3f}) mm on the page"
        if self.sheet_height_mm is not None:
            text += f"; sheet at {self.sheet_height_mm:+.3f} mm"
        return text


def fit_tip_offset(
    rotations,
    tips_mm,
    marks_mm,
    compression_mm=None,
    page_offset: bool = True,
    surface_mm=None,
    height_weight: float = 1.0,
    length: bool = True,
) -> PenFit:
    """The tip offset p (and b, h) of the module docstring by linear least squares.

    Args:
        rotations: (k, 3, 3) orientations R_i of the believed tip site in the page frame.
        tips_mm: (k, 3) believed tip site positions t_i in the page frame [mm].
        marks_mm: (k, 2) measured mark positions m_i [mm].
        compression_mm: (k,) c_i, the pen's compression [mm]; None: 0.
        page_offset: Fit the common page offset b (needs marks at several spins).
        surface_mm: (k,) s_i, the sheet's believed surface where each tip rested [mm]: adds
            the height rows and the unknown h; None: marks only.
        height_weight: Weight of the height rows against the mark rows.
        length: Fit pz; False: hold it at 0 (a pen whose compression is not known, pressed
            without a force sensor: only its upright marks tell, and they tell px, py).

    Raises InputError when the arrays disagree in shape, are not finite, or the marks' pen
    orientations cannot tell the unknowns apart (the message says which are needed).
    """
    R = np.asarray(rotations, dtype=float)
    t = np.asarray(tips_mm, dtype=float)
    m = np.asarray(marks_mm, dtype=float)
    k = R.shape[0] if R.ndim == 3 else -1
    c = np.zeros(max(k, 0)) if compression_mm is None else np.asarray(compression_mm, float)
    shapes = {"rotations": (R.shape, (k, 3, 3)), "tips_mm": (t.shape, (k, 3)),
              "marks_mm": (m.shape, (k, 2)), "compression_mm": (c.shape, (k,))}
    if surface_mm is not None:
        shapes["surface_mm"] = (np.shape(surface_mm), (k,))
    for name, (got, want) in shapes.items():
        if k < 1 or got != want:
            raise InputError(f"pen fit: expected {name} of shape {want if k >= 1 else '(k, ...)'}"
                             f" for k >= 1 marks, got {got}", key=name, value=got)
    for name, a in (("rotations", R), ("tips_mm", t), ("marks_mm", m), ("compression_mm", c)):
        if not np.all(np.isfinite(a)):
            raise InputError(f"pen fit: {name} has non-finite values", key=name)
    names = ["tip x", "tip y", "tip length"] + (["page x", "page y"] if page_offset else [])
    rows = R[:, :2, :]  # [R_i[:2, :]  I_2] per mark (module docstring)
    if page_offset:
        rows = np.concatenate([rows, np.broadcast_to(np.eye(2), (k, 2, 2))], axis=2)
    A = rows.reshape(2 * k, -1)
    y = (m - t[:, :2] + c[:, None] * R[:, :2, 2]).reshape(-1)
    if surface_mm is not None:
        s = np.asarray(surface_mm, dtype=float)
        w = float(height_weight)
        if not (np.all(np.isfinite(s)) and math.isfinite(w) and w > 0):
            raise InputError("pen fit: expected finite surface heights and a height_weight > 0",
                             key="surface_mm")
        A = np.hstack([A, np.zeros((2 * k, 1))])
        height = np.hstack([R[:, 2, :], np.zeros((k, A.shape[1] - 4)), -np.ones((k, 1))])
        A = np.vstack([A, w * height])
        y = np.concatenate([y, w * (s - t[:, 2] + c * R[:, 2, 2])])
        names.append("sheet height")
    if not length:
        A = np.delete(A, 2, axis=1)
        del names[2]
    _require_identifiable(A, names, k)
    x, *_ = np.linalg.lstsq(A, y, rcond=None)
    if not length:
        x = np.insert(x, 2, 0.0)
    sv = np.linalg.svd(A, compute_uv=False)
    dof = A.shape[0] - A.shape[1]
    fitted = A @ (x if length else np.delete(x, 2))
    std = np.zeros(A.shape[1])
    if dof > 0:
        sigma2 = float(np.sum((y - fitted) ** 2)) / dof
        std = np.sqrt(sigma2 * np.diag(np.linalg.inv(A.T @ A)))
    if not length:
        std = np.insert(std, 2, 0.0)
    residuals = (y - fitted)[: 2 * k].reshape(k, 2)
    return PenFit(
        tip_offset_mm=x[:3].copy(),
        page_offset_mm=x[3:5].copy() if page_offset else np.zeros(2),
        sheet_height_mm=float(x[-1]) if surface_mm is not None else None,
        residuals_mm=residuals,
        singular_values=sv,
        std_mm=std,
        length=length,
    )


def _require_identifiable(A: np.ndarray, names: list[str], k: int) -> None:
    """Refuse a design A that cannot tell its unknowns ``names`` apart, saying which pen
    orientations would (module docstring)."""
    unknowns = A.shape[1]
    if A.shape[0] < unknowns:
        raise InputError(f"pen fit: {k} marks give {A.shape[0]} equations for {unknowns} "
                         f"unknowns ({', '.join(names)}); mark more dots: upright at several "
                         "spins and tilted toward several directions", key="marks", value=k)
    _, sv, vt = np.linalg.svd(A, full_matrices=False)
    if sv[-1] >= MIN_SINGULAR * sv[0]:
        return
    v = np.abs(vt[-1])
    lost = [names[i] for i in np.flatnonzero(v > 0.3)]
    if "tip length" in lost or "sheet height" in lost:
        need = ("marks with the pen tilted from the normal (tilt_deg > 0), toward at least two "
                "directions")
    else:
        need = "marks with the pen spun to at least two different spins about its axis"
    raise InputError(f"pen fit: the marks do not determine {', '.join(lost)} (smallest singular "
                     f"value {sv[-1]:.3g} of {sv[0]:.3g}); needed: {need}", key="marks",
                     value=k)


def tip_poses(model: KinematicModel, q, kin: ArmKinematics | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """The believed tip site at joint readings ``q`` (k, n) [rad]: orientations (k, 3, 3) and
    positions (k, 3) [mm], page frame (the controller's own forward kinematics)."""
    kin = kin or ArmKinematics.of(model)
    placement = model.placement
    rot = placement.rotation
    q = np.atleast_2d(np.asarray(q, dtype=float))
    rotations, tips = np.empty((len(q), 3, 3)), np.empty((len(q), 3))
    for i, qi in enumerate(q):
        p, R = kin.fk(qi)
        rotations[i] = rot.T @ R
        tips[i] = placement.to_page(p)
    return rotations, tips


def natural_spin_deg(model: KinematicModel, point_mm, kin: ArmKinematics | None = None) -> float:
    """The spin [deg, from page x] of the flange's x axis that the IK chooses for the upright
    pen at page ``point_mm`` (x, y) from the home posture: the pattern's spins are set around
    it, so that they stay within the wrist's range."""
    kin = kin or ArmKinematics.of(model)
    placement = model.placement
    goal = placement.to_robot([float(point_mm[0]), float(point_mm[1]), 0.0])
    result = solve_ik(kin, goal, placement.pen_axis, model.home_q, model.home_q, IKConfig())
    if not result.converged:
        raise InputError(f"pen pattern: the point ({point_mm[0]:.1f}, {point_mm[1]:.1f}) mm is "
                         "out of reach with the pen upright", key="centre_mm",
                         value=tuple(point_mm))
    _, R = kin.fk(result.q)
    x = placement.rotation.T @ R[:, 0]
    return math.degrees(math.atan2(x[1], x[0]))


def pen_pattern(model: KinematicModel, centre_mm=None, spacing_mm: float = 12.0,
                tilt_deg: float = TILT_DEG, spins_deg=SPINS_DEG, azimuths_deg=AZIMUTHS_DEG,
                dwell_s: float = DWELL_S) -> Drawing:
    """The calibration's dots: the pen upright at the spins ``spins_deg`` (around the natural
    one, :func:`natural_spin_deg`), then tilted by ``tilt_deg`` toward each of
    ``azimuths_deg`` (at the natural spin), on a grid ``spacing_mm`` apart around ``centre_mm``
    (default: the sheet's centre), serpentine; each dot rests ``dwell_s`` [s]. The poses are
    the drawing's ``meta["pen_poses"]`` (:func:`inkarm.control.reference.pen_poses`)."""
    w, h = model.placement.size_mm
    centre = np.array((w / 2, h / 2) if centre_mm is None else centre_mm, dtype=float)
    if not (spacing_mm > 0 and dwell_s > 0):
        raise InputError(f"pen pattern: expected spacing_mm > 0 and dwell_s > 0, got "
                         f"{spacing_mm} and {dwell_s}", key="spacing_mm", value=spacing_mm)
    spin0 = natural_spin_deg(model, centre)
    poses = [PenPose(0.0, 0.0, spin0 + s) for s in spins_deg]
    poses += [PenPose(tilt_deg, a, spin0) for a in azimuths_deg]
    columns = math.ceil(math.sqrt(len(poses)))
    rows = math.ceil(len(poses) / columns)
    points = []
    for r in range(rows):
        cols = range(columns) if r % 2 == 0 else range(columns - 1, -1, -1)
        points += [centre + spacing_mm * np.array([c - (columns - 1) / 2, r - (rows - 1) / 2])
                   for c in cols]
    points = points[: len(poses)]
    inside = model.placement.contains(np.array(points))
    if not inside.all():
        x, y = points[int(np.argmin(inside))]
        raise InputError(f"pen pattern: dot ({x:.1f}, {y:.1f}) mm is off the sheet; move "
                         "centre_mm or shrink spacing_mm", key="centre_mm", value=tuple(centre))
    dots = [Trajectory(t=np.array([0.0, dwell_s]), pos=np.array([p, p])) for p in points]
    return Drawing(dots, page_size=(w, h), meta={"pen_poses": tuple(poses)})


__all__ = ["AZIMUTHS_DEG", "DWELL_S", "MIN_SINGULAR", "SPINS_DEG", "TILT_DEG", "PenFit",
           "fit_tip_offset", "natural_spin_deg", "pen_pattern", "tip_poses"]
