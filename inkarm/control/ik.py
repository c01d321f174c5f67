"""Damped-least-squares inverse kinematics of a pen held perpendicular to the paper.

The task is 5-D: the pen tip position (3) and the pen axis direction (2 tilts); the spin about
the pen axis is left free, so a 7-DOF arm keeps two redundant degrees of freedom, which a
null-space term spends on staying near a posture and away from joint limits.

With the site Jacobian J = [Jp; Jr] (mj_jacSite), the site axes x_s, y_s, z_s (z_s along the
pen, from flange to tip) and the desired pen direction a:

    e = [p* - p ; x_s . w ; y_s . w],   w = z_s x a           (position and tilt error)
    J5 = [Jp ; x_s^T Jr ; y_s^T Jr]                            (5 x n task Jacobian)
    dq = J5^T (J5 J5^T + lambda^2 I)^-1 e  +  (I - J5^+ J5) dq_0  (damped least squares)
    dq_0 = k_posture (q_posture - q) + k_limit * (push out of the margin zone near the limits)

and ``dq`` is scaled as a whole vector (direction kept) so that no joint moves more than its
step limit. Units: SI inside (m, rad), as in MuJoCo; callers in page millimetres go through
:mod:`inkarm.core.frames` first.

A stroke may ask for another pen orientation (:class:`PenPose`: the pen tilted from the normal,
its spin set; the pen calibration's marks, :mod:`inkarm.control.calibration.pen`). A set spin
adds a sixth row, the rotation about the pen axis that turns the site's x axis x_s onto the
goal x* (both across the pen):

    e_6 = z_s . (x_s x x*) = y_s . x*,    J_6 = z_s^T Jr

and the solve is the same with 6 rows (:func:`pose_task`). Without poses nothing changes.

:func:`pose_task`, :func:`dls_update` and :func:`task_error` state one step plainly, as above;
:class:`PathTracker`, which every solver here runs on, computes the same numbers in fewer NumPy
calls, and the tests hold it to the plain step (written out there) bit for bit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from inkarm.control.kinematics import ArmKinematics
from inkarm.errors import InputError, UnreachableError

_EYE5 = np.eye(5)


@dataclass(frozen=True)
class IKConfig:
    """Solver settings (SI).

    Attributes:
        damping: lambda of the damped least squares, in task units ([m] ~ [rad]).
        max_step: Largest joint step per iteration in [rad]; dq is scaled as a whole.
        posture_gain: k_posture, fraction of the posture error corrected per step in the null space.
        limit_margin: Width in [rad] of the zone near each joint limit that the null space
            pushes out of.
        limit_gain: k_limit, fraction of the intrusion into that zone removed per step.
        tol_pos: Convergence tolerance on the tip position in [m].
        tol_tilt: Convergence tolerance on the pen axis tilt in [rad].
        max_iter: Iteration cap of :func:`solve_ik`.
        position_weight: w_p, weight of the three tip-position rows.
        tilt_weight: w_t, weight of the two pen-tilt rows (0: the tilt is free).
    """

    damping: float = 1e-4
    max_step: float = 0.2
    posture_gain: float = 0.05
    limit_margin: float = np.deg2rad(10.0)
    limit_gain: float = 0.2
    tol_pos: float = 1e-6
    tol_tilt: float = 1e-5
    max_iter: int = 300
    position_weight: float = 1.0
    tilt_weight: float = 1.0

    def __post_init__(self) -> None:
        for name in ("damping", "max_step", "posture_gain", "limit_margin", "limit_gain",
                     "tol_pos", "tol_tilt", "position_weight", "tilt_weight"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"expected a finite number >= 0, got {value}", key=name,
                                 value=value)
        if self.position_weight == 0:
            raise InputError("the tip position is the task: its weight must be > 0",
                             key="position_weight", value=0.0)
        weights = [self.position_weight] * 3 + [self.tilt_weight] * 2
        object.__setattr__(self, "_row_weights",
                           None if weights == [1.0] * 5 else np.array(weights))
        object.__setattr__(self, "_ridge5", self.damping**2 * _EYE5)  # lambda^2 I, 5 rows

    def converged(self, pos_error: float, tilt_error: float) -> bool:
        """Whether a tip error [m] and tilt error [rad] are within tolerance (the tilt only
        counts when its rows do)."""
        return pos_error < self.tol_pos and (self.tilt_weight == 0 or tilt_error < self.tol_tilt)


@dataclass(frozen=True)
class IKResult:
    """Outcome of :func:`solve_ik`: joint angles [rad], tip error [m], tilt error [rad]."""

    q: np.ndarray
    converged: bool
    pos_error: float
    tilt_error: float
    iterations: int


@functools.cache
def _spd_solver():
    """LAPACK's dposv: (A, b) -> (factor, x of A x = b, info), A symmetric positive definite,
    by Cholesky; imported on first use (the planner imports without SciPy)."""
    from scipy.linalg.lapack import dposv

    return dposv


def pen_error(p: np.ndarray, R: np.ndarray, p_goal: np.ndarray,
              axis_goal: np.ndarray) -> np.ndarray:
    """The 5-D task error e = [p* - p ; x_s . w ; y_s . w] with w = z_s x a (module docstring).

    In a right-handed frame the triple products reduce to x_s . (z_s x a) = -y_s . a and
    y_s . (z_s x a) = x_s . a, so no cross product is needed."""
    xa, ya, _ = (R.T @ axis_goal).tolist()
    e = np.empty(5)
    e[:3] = p_goal - p
    e[3] = -ya
    e[4] = xa
    return e


def pen_jacobian(R: np.ndarray, Jp: np.ndarray, Jr: np.ndarray) -> np.ndarray:
    """The 5 x n task Jacobian J5 = [Jp ; x_s^T Jr ; y_s^T Jr] (module docstring)."""
    J5 = np.empty((5, Jp.shape[1]))
    J5[:3] = Jp
    np.dot(R.T[:2], Jr, out=J5[3:])
    return J5


def across(axis: np.ndarray, x_goal) -> np.ndarray:
    """``x_goal`` (3,) made a unit vector across the unit ``axis`` (its part along the axis
    removed): the spin goal x* of a 6-row task."""
    x = np.asarray(x_goal, float)
    x = x - (x @ axis) * axis
    norm = float(np.linalg.norm(x))
    if not norm > 1e-9:
        raise InputError("a spin goal must not point along the pen axis", key="spin_goal",
                         value=tuple(np.asarray(x_goal, float).tolist()))
    return x / norm


def pose_task(p: np.ndarray, R: np.ndarray, Jp: np.ndarray, Jr: np.ndarray, p_goal: np.ndarray,
              axis_goal: np.ndarray, spin_goal: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """The pen task's error e (5,) and Jacobian J5 (5, n) (:func:`pen_error`,
    :func:`pen_jacobian`), and with a ``spin_goal`` x* (unit, across ``axis_goal``) the sixth
    row of the module docstring: e_6 = y_s . x*, J_6 = z_s^T Jr."""
    e, J = pen_error(p, R, p_goal, axis_goal), pen_jacobian(R, Jp, Jr)
    if spin_goal is None:
        return e, J
    return np.append(e, R[:, 1] @ spin_goal), np.vstack([J, R[:, 2] @ Jr])


def dls_update(q: np.ndarray, e: np.ndarray, J: np.ndarray, dq0: np.ndarray | None,
               cfg: IKConfig, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """q + dq, the step of the module docstring from the pen-task error ``e`` (5,) and
    Jacobian ``J`` (5, n) at ``q`` (6 rows with a set spin: :func:`pose_task`; task only when
    ``dq0`` is None), scaled to ``cfg.max_step`` and clipped to the limits.

    The task and null-space terms share one solve, by linearity:
    J^T A^-1 e + (I - J^T A^-1 J) dq0 = J^T A^-1 (e - J dq0) + dq0 with A = J J^T + lambda^2 I,
    solved by Cholesky (A is symmetric positive definite)."""
    w = cfg._row_weights
    rows = e.shape[0]
    if w is not None:
        if rows != 5:  # the spin row (a pen pose's) weighs as the tilt rows do
            w = np.append(w, [cfg.tilt_weight] * (rows - 5))
        J = w[:, None] * J
        e = w * e
    # (ndarray.dot: the same BLAS calls as @, for a third of its overhead on these sizes)
    A = J.dot(J.T)
    A += cfg._ridge5 if rows == 5 else cfg.damping**2 * np.eye(rows)
    rhs = e if dq0 is None else e - J.dot(dq0)
    # A >= lambda^2 I, so the factorisation cannot fail on finite numbers (and non-finite ones
    # propagate to q, where the callers' error checks catch them).
    y = _spd_solver()(A, rhs)[1]
    dq = J.T.dot(y)
    if dq0 is not None:
        dq += dq0
    # (a max over a Python list: a numpy reduction costs more than the whole list on 7 numbers)
    biggest = max(map(abs, dq.tolist()))
    if biggest > cfg.max_step:
        dq *= cfg.max_step / biggest
    dq += q
    np.maximum(dq, lower, out=dq)
    return np.minimum(dq, upper, out=dq)


def task_error(e: np.ndarray) -> tuple[float, float]:
    """(position error [m], tilt error [rad]) of a pen-task error vector; the tilt error is
    |z_s x a|, the sine of the pen's tilt from the goal axis (with a spin row: the norm of the
    tilt and spin rows)."""
    ex, ey, ez, *turns = e.tolist()
    return math.sqrt(ex * ex + ey * ey + ez * ez), math.sqrt(sum(t * t for t in turns))


def _unit(axis) -> np.ndarray:
    """``axis`` (3,) over its norm (np.linalg.norm's sum, in one BLAS call)."""
    axis = np.ascontiguousarray(axis, float)
    return axis / math.sqrt(axis.dot(axis))


class PathTracker:
    """Closed-loop inverse kinematics along a path, one goal at a time (:func:`track_path`).

    :meth:`step` takes one null-space step towards the goal (the posture drift is then the same
    at every goal and the joint path stays smooth), then task-only steps until the tip is
    within tolerance (at most ``max_refine``). The Jacobian at the joint angles reached for
    one goal serves the first step towards the next, so each step costs one evaluation.

    :meth:`track` holds the one copy of the step, in few NumPy calls, on its parts: the task at
    the last evaluation (J5, or J6 with a ``spin_goal``, in its own buffer; the tip and tilt as
    floats) and the null-space motion with its limit bands made once.

    Args:
        kin: The controller's kinematics.
        axis_goal: Pen direction (3,) in the robot frame (normalised here unless ``unit``).
        q0: Starting joint angles [rad].
        q_posture: Posture the null space pulls towards [rad].
        cfg: Solver settings; pass posture and limit gains that are rates times the goal
            spacing.
        max_refine: Most task-only steps a goal of :meth:`step` takes.
        spin_goal: x* (3,), unit and across the axis (:func:`across`); None: the spin is free.
        unit: Whether ``axis_goal`` is unit already (taken as it is).
    """

    def __init__(self, kin: ArmKinematics, axis_goal, q0, q_posture, cfg: IKConfig = IKConfig(),
                 max_refine: int = 20, spin_goal: np.ndarray | None = None, unit: bool = False):
        self.kin, self.cfg, self.max_refine = kin, cfg, max(int(max_refine), 0)
        self.axis_goal = np.asarray(axis_goal, float) if unit else _unit(axis_goal)
        self.q_posture = np.asarray(q_posture, float)
        self.q = np.asarray(q0, float).copy()
        self._spin = spin_goal
        self._band = kin.lower + cfg.limit_margin, kin.upper - cfg.limit_margin
        self._J = np.empty((5 if spin_goal is None else 6, kin.n))
        self._JT = self._J.T
        self._rows = self._J[:3], self._J[3:5]
        self._R = self._tip = self._tilt = self._turn = None
        self._evaluate(self.q)

    def _evaluate(self, q: np.ndarray) -> None:
        p, R, Jp, Jr = self.kin.jacobian_views(q)
        if R is not self._R:  # (the same array at every evaluation: its views made once)
            self._R, self._RT, self._RT2 = R, R.T, R.T[:2]
        self._rows[0][...] = Jp  # pen_jacobian
        np.dot(self._RT2, Jr, out=self._rows[1])
        self._tip, self._tilt = p.tolist(), self._RT.dot(self.axis_goal).tolist()  # x_s . a, ..
        if self._spin is not None:  # pose_task's sixth row
            self._J[5] = R[:, 2] @ Jr
            self._turn = float(R[:, 1] @ self._spin)

    def _error(self, goal: list[float]) -> tuple[float, float, list[float]]:
        """(tip error [m], tilt error [rad], e) towards ``goal`` (3 floats, [m]) at the last
        evaluation: :func:`task_error` of :func:`pose_task`'s e."""
        (gx, gy, gz), (px, py, pz), (xa, ya, _) = goal, self._tip, self._tilt
        ex, ey, ez = gx - px, gy - py, gz - pz
        tilt = ya * ya + xa * xa
        e = [ex, ey, ez, -ya, xa]
        if self._turn is not None:
            tilt += self._turn * self._turn
            e.append(self._turn)
        return math.sqrt(ex * ex + ey * ey + ez * ez), math.sqrt(tilt), e

    def _dls(self, q: np.ndarray, e: list[float], null_space: bool) -> np.ndarray:
        """:func:`dls_update` from ``q`` with the error ``e`` of the last evaluation (there)."""
        cfg, (low, high) = self.cfg, self._band
        dq0 = None
        if null_space:  # dq_0 (module docstring), the limit push back into the band
            dq0 = cfg.posture_gain * (self.q_posture - q)
            dq0 += cfg.limit_gain * (np.minimum(np.maximum(q, low), high) - q)
        return dls_update(q, np.array(e), self._J, dq0, cfg, self.kin.lower, self.kin.upper)

    def solve(self, p_goal) -> IKResult:
        """:func:`solve_ik` from ``q`` (within the limits) towards ``p_goal`` (3,) [m], ``q``
        left at the result's joint angles: a chain of solves, each from the last one's result,
        evaluates each result once."""
        cfg, goal, q = self.cfg, np.asarray(p_goal, float).tolist(), self.q
        pos_err = tilt_err = 0.0
        for it in range(1, cfg.max_iter + 1):
            null_space = it <= cfg.max_iter // 2
            if it > 1:
                self._evaluate(q)
            pos_err, tilt_err, e = self._error(goal)
            converged = cfg.converged(pos_err, tilt_err)
            if converged and not null_space:
                break
            q_next = self._dls(q, e, null_space)
            if converged and max(map(abs, (q_next - q).tolist())) < 1e-4:  # (a list's max)
                break
            q = q_next
        else:
            self._evaluate(q)  # (the next solve's first evaluation)
            converged, it = False, cfg.max_iter
        self.q = q
        return IKResult(q, converged, pos_err, tilt_err, it)

    def step(self, p_goal: np.ndarray) -> tuple[float, float]:
        """Move ``q`` towards ``p_goal`` (3,) in [m]; returns (tip error [m], tilt error
        [rad]) at the new ``q``."""
        return self.track([np.asarray(p_goal, float).tolist()])[1][0]

    def track(self, goals: list[list[float]]
              ) -> tuple[list[np.ndarray], list[tuple[float, float]]]:
        """:meth:`step` towards each of ``goals`` (3 floats, [m]) in turn: the joint angles and
        (tip, tilt) errors reached; the one copy of the step, its parts written out in one loop."""
        kin, cfg, J, JT, dposv = self.kin, self.cfg, self._J, self._JT, _spd_solver()
        place, (Jp_rows, tilt_rows), dot = kin.jacobian_views, self._rows, np.dot
        R_held, RT, RT2, axis, spin = self._R, self._RT, self._RT2, self.axis_goal, self._spin
        maximum, minimum, array, sqrt = np.maximum, np.minimum, np.array, math.sqrt
        (low, high), lower, upper, qp = self._band, kin.lower, kin.upper, self.q_posture
        pg, lg, max_step = cfg.posture_gain, cfg.limit_gain, cfg.max_step
        w, n_rows = cfg._row_weights, J.shape[0]
        ridge = cfg._ridge5 if n_rows == 5 else cfg.damping**2 * np.eye(n_rows)
        if w is not None and n_rows != 5:  # (the spin row weighs as the tilt rows do)
            w = np.append(w, [cfg.tilt_weight] * (n_rows - 5))
        tol_pos, tol_tilt, tilt_free = cfg.tol_pos, cfg.tol_tilt, cfg.tilt_weight == 0
        q, refine, (px, py, pz), (xa, ya, za) = self.q, self.max_refine, self._tip, self._tilt
        turn, rows, errors = self._turn, [], []
        for gx, gy, gz in goals:
            dq0 = pg * (qp - q) + lg * (minimum(maximum(q, low), high) - q)  # (k = 0 only)
            e = [gx - px, gy - py, gz - pz, -ya, xa]
            if spin is not None:
                e.append(turn)
            for k in range(refine + 1):
                if w is None:
                    Jw, JwT, ew = J, JT, array(e)
                else:  # dls_update's weighted rows
                    Jw = w[:, None] * J
                    JwT, ew = Jw.T, w * array(e)
                A = Jw.dot(JwT)
                A += ridge
                rhs = ew - Jw.dot(dq0) if not k else ew
                dq = JwT.dot(dposv(A, rhs)[1])
                if not k:
                    dq += dq0
                biggest = max(map(abs, dq.tolist()))
                if biggest > max_step:
                    dq *= max_step / biggest
                dq += q
                q = minimum(maximum(dq, lower, out=dq), upper, out=dq)
                p, R, Jp, Jr = place(q)
                if R is not R_held:  # (kinematics may give R afresh: its views made again)
                    R_held, RT, RT2 = R, R.T, R.T[:2]
                Jp_rows[...] = Jp
                dot(RT2, Jr, out=tilt_rows)
                (px, py, pz), (xa, ya, za) = p.tolist(), RT.dot(axis).tolist()
                ex, ey, ez = gx - px, gy - py, gz - pz
                tilt = ya * ya + xa * xa
                if spin is not None:  # pose_task's sixth row
                    J[5] = R[:, 2] @ Jr
                    turn = float(R[:, 1] @ spin)
                    tilt += turn * turn
                pos_err, tilt_err = sqrt(ex * ex + ey * ey + ez * ez), sqrt(tilt)
                if pos_err < tol_pos and (tilt_free or tilt_err < tol_tilt):
                    break
                e = [ex, ey, ez, -ya, xa]
                if spin is not None:
                    e.append(turn)
            rows.append(q)
            errors.append((pos_err, tilt_err))
        self.q, self._tip, self._tilt, self._turn = q, [px, py, pz], [xa, ya, za], turn
        self._R, self._RT, self._RT2 = R_held, RT, RT2
        return rows, errors


def solve_ik(kin: ArmKinematics, p_goal, axis_goal, q0, q_posture=None,
             cfg: IKConfig = IKConfig(), spin_goal=None) -> IKResult:
    """Iterate the module docstring's step from ``q0`` until the tip is within tolerance of
    ``p_goal`` [m] and the pen points along ``axis_goal`` (unit, 3,) (and, given ``spin_goal``,
    the site's x axis along it: a :class:`PenPose`'s spin). Never raises on failure: check
    ``converged``. The null-space term acts during the first half of the iterations (until the
    posture has settled), task-only steps after (:meth:`PathTracker.solve`)."""
    q = np.minimum(np.maximum(np.asarray(q0, float), kin.lower), kin.upper)  # (np.clip's)
    axis = _unit(axis_goal)
    spin = None if spin_goal is None else across(axis, spin_goal)
    return PathTracker(kin, axis, q, q.copy() if q_posture is None else q_posture, cfg,
                       spin_goal=spin, unit=True).solve(p_goal)


def track_path(kin: ArmKinematics, points: np.ndarray, axis_goal, q0, q_posture,
               cfg: IKConfig = IKConfig(), label: Callable[[int], str] | None = None
               ) -> np.ndarray:
    """Joint path (N, n) [rad] through ``points`` (N, 3) [m], warm-started from ``q0``.

    Closed-loop inverse kinematics (:class:`PathTracker`): one null-space step per sample (so
    the posture drift is the same at every sample and the joint path stays smooth: pass a
    ``cfg`` whose posture and limit gains are rates times the sample period), then task-only
    steps until the tip is within tolerance. Raises UnreachableError naming the first sample
    (``label(i)`` when given) whose tip error stays above ``100 * tol_pos`` or which sits at a
    joint limit.
    """
    rows, errors = PathTracker(kin, axis_goal, q0, q_posture, cfg).track(
        np.asarray(points, float).tolist())
    return _checked(kin, cfg, rows, errors, label, "with the pen perpendicular")


def _checked(kin: ArmKinematics, cfg: IKConfig, rows: list[np.ndarray],
             errors: list[tuple[float, float]], label: Callable[[int], str] | None,
             how: str) -> np.ndarray:
    """The path of joint angles ``rows`` (N, n) [rad], or UnreachableError naming the first
    sample ``i`` (``label(i)`` when given) whose tip error [m] (``errors[i][0]``) stays above
    ``100 * tol_pos``, whose tilt error [rad] stays above ``100 * tol_tilt`` (when the tilt
    counts), or whose joint angles (clipped to the limits) sit at a joint limit; ``how``: the
    pen's pose, in words."""
    path, err = np.array(rows).reshape(-1, kin.n), np.array(errors).reshape(-1, 2)
    bad = (err[:, 0] > 100 * cfg.tol_pos) | ~(
        np.minimum(path - kin.lower, kin.upper - path).min(axis=1) > 1e-9)
    if cfg.tilt_weight > 0:
        bad |= err[:, 1] > 100 * cfg.tol_tilt
    if not bad.any():
        return path
    i = int(np.argmax(bad))
    q, (pos_err, tilt_err) = path[i], errors[i]
    at_limit = (q <= kin.lower + 1e-9) | (q >= kin.upper - 1e-9)
    where = label(i) if label is not None else f"sample {i}"
    why = (
        f"joint {kin.joint_names[int(np.argmax(at_limit))]} at its limit"
        if at_limit.any()
        else f"tip error {1000 * pos_err:.3f} mm, pen tilt {np.rad2deg(tilt_err):.3f} deg"
    )
    raise UnreachableError(f"{where}: out of reach {how} ({why})")


MAX_TILT_DEG = 60.0  # the largest pen tilt a stroke may ask for [deg]


@dataclass(frozen=True)
class PenPose:
    """An orientation of the pen against the paper that a stroke may ask for (the pen
    calibration's marks); the default is the drawing pen's: perpendicular, spin free.

    In the page frame (z out of the paper) the pen axis, from the flange to the tip, is

        a = (-sin(theta) cos(phi), -sin(theta) sin(phi), -cos(theta))

    (the pen's upper end leans toward the page direction ``phi``), and with a set spin ``psi``
    the flange's x axis is x* = Rot(k, theta) (cos(psi), sin(psi), 0): the upright pen's x axis
    at ``psi`` from page x, carried along by the tilt about k = (-sin(phi), cos(phi), 0)
    (Rodrigues: Rot(k, t) v = v cos t + (k x v) sin t + k (k . v)(1 - cos t)).

    Attributes:
        tilt_deg: theta, the pen axis's angle from the paper's normal [deg], in [0, 60].
        azimuth_deg: phi, the page direction the tilt leans toward, from page x [deg].
        spin_deg: psi [deg]; None: the spin about the pen axis is free (the IK's null space
            chooses it, as for drawing).
    """

    tilt_deg: float = 0.0
    azimuth_deg: float = 0.0
    spin_deg: float | None = None

    def __post_init__(self) -> None:
        for name in ("tilt_deg", "azimuth_deg", "spin_deg"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value)) and not (
                    value is None and name == "spin_deg"):
                raise InputError(f"expected a finite number of degrees, got {value!r}", key=name,
                                 value=value)
        if not 0.0 <= self.tilt_deg <= MAX_TILT_DEG:
            raise InputError(f"expected a tilt from the paper's normal in [0, {MAX_TILT_DEG:g}] "
                             f"deg, got {self.tilt_deg}", key="tilt_deg", value=self.tilt_deg)

    def page_axes(self) -> tuple[np.ndarray, np.ndarray | None]:
        """(a, x*) in the page frame (class docstring); x* is None with a free spin."""
        t, f = math.radians(self.tilt_deg), math.radians(self.azimuth_deg)
        axis = np.array([-math.sin(t) * math.cos(f), -math.sin(t) * math.sin(f), -math.cos(t)])
        if self.spin_deg is None:
            return axis, None
        s, k = math.radians(self.spin_deg), np.array([-math.sin(f), math.cos(f), 0.0])
        v = np.array([math.cos(s), math.sin(s), 0.0])
        x = v * math.cos(t) + np.cross(k, v) * math.sin(t) + k * (k @ v) * (1.0 - math.cos(t))
        return axis, x


def track_poses(kin: ArmKinematics, points: np.ndarray, axes: np.ndarray, spins: np.ndarray,
                q0, q_posture, cfg: IKConfig = IKConfig(),
                label: Callable[[int], str] | None = None) -> np.ndarray:
    """:func:`track_path` with a pen direction per sample: ``axes`` (N, 3) unit, and spin goals
    ``spins`` (N, 3) (a row of NaN: the spin is free there), robot frame. Each sample: one
    null-space step, then task-only steps until within tolerance (at most 20; the error is
    then the one at the joint angles reached); raises UnreachableError as :func:`track_path`
    does."""
    q, rows, errors = q0, [], []
    for goal, axis, spin in zip(np.asarray(points, float).tolist(), axes, spins, strict=True):
        tracker = PathTracker(kin, axis, q, q_posture, cfg, unit=True,  # (evaluated at its axis)
                              spin_goal=None if np.isnan(spin).any() else across(axis, spin))
        (q,), (error,) = tracker.track([goal])
        rows.append(q)
        errors.append(error)
    return _checked(kin, cfg, rows, errors, label, "with the pen's pose")
