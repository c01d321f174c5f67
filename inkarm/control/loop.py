"""The sensory-motor loop: a Drawing in page millimetres -> pen-down strokes on a plant.

For each stroke the pen approaches above its first point, descends until the contact force
reaches its set point, tracks the stroke, lifts and travels (minimum jerk) to the next; the arm
goes home at the end. Phases: approach, descend, draw, lift, travel, home.

Why inverse kinematics runs ahead of time, with feedback online
---------------------------------------------------------------
Seed 001's sensory-motor model inverts kinematics inside the loop, from the sensed state. Here
the kinematic inversion is solved once, before the run, on the controller's own kinematic model
(closed-loop IK on knots every ``ik_period_s`` along the whole reference,
:func:`inkarm.control.ik.track_path`, joined by a clamped cubic spline), and the loop closes on
the senses every control period:

* the joint PID acts on the measured q, qd against the planned q*(t), qd*(t), with gravity and
  Coriolis compensation c(q, qd) evaluated at the *measured* state on the kinematic model, the
  inertial feed-forward M(q*) qdd*(t), and, while pressing, the planned contact force carried
  through J(q*)^T f with f = F* (mu u - n): the set-point force into the paper plus the nib's
  Coulomb drag along the planned direction of motion u (the measured force is not fed forward:
  with one period of delay, cancelling it exactly is a positive feedback on the contact);
* the pen force is regulated online: an integrator moves the pen reference along the paper
  normal, dz/dt = k_F (F* - F), mapped to joints through the planned direction J5^+ (-n). It
  learns where the paper really is, and each descent holds until F has settled at F*.

Reasons: (1) an unreachable point or a joint limit is found before anything moves, naming the
point, which a real arm needs; (2) the per-period cost drops to a PID and one bias evaluation,
which is what lets the simulation run at >= 30x real time on one core (40 to 50x measured for
a 60 mm script letter at the default 6 ms control period, planning included:
``benchmarks/bench_draw.py``) and a Python loop keep a hardware period; (3) the kinematic model is exact, so an online IK would only re-solve
the same equations from a state that differs from the plan by the tracking error, which joint
feedback already removes. What online IK would add, bending the path itself to sensed
surprises, is here limited to the pen-normal force loop.

Stroke samples are interpolated onto the control grid with a cubic spline (Hermite when the
stroke carries velocities), so the reference is as smooth as the curve the arm draws.

Units: page [mm] and [s] at this module's surface; the page-to-robot transform
(:class:`inkarm.core.frames.PagePlacement`) converts once to SI for the kinematics.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, fields

import mujoco
import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from inkarm.control.ik import ArmKinematics, IKConfig, pen_jacobian, solve_ik, track_path
from inkarm.control.pid import JointPID, PIDGains
from inkarm.core.frames import PagePlacement
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError, SimulationError, UnreachableError

PHASES = ("approach", "descend", "draw", "lift", "travel", "home")
# Spacing in [s] of the evaluations of the terms that vary with the pose only (inertia matrix,
# normal direction in joint space), linearly interpolated in between.
SLOW_TERMS_PERIOD_S = 0.04
# Speed in [mm/s] below which the nib-drag feed-forward fades out (u = v / sqrt(|v|^2 + v0^2)).
DRAG_SPEED_MM_S = 5.0
APPROACH, DESCEND, DRAW, LIFT, TRAVEL, HOME = range(len(PHASES))


@dataclass(frozen=True)
class LoopConfig:
    """Sequencing and force-control settings. Lengths in [mm], times in [s], forces in [N].

    Attributes:
        force_n: Contact force set point F*.
        pen_stiffness_n_per_mm: Pen spring rate; read from the kinematic model's ``pen_slide``
            joint when None.
        hover_mm: Pen height above the paper while travelling.
        descend_s: Duration of the descent from hover to the nominal pen compression.
        lift_s: Duration of the lift back to hover height.
        travel_speed_mm_s: Peak speed of the minimum-jerk travel between strokes.
        joint_speed_rad_s: Peak joint speed of the joint-space approach and home moves.
        nib_friction: Nib-paper friction coefficient of the drag feed-forward; read from the
            kinematic model's ``pen_tip`` and ``paper`` geoms when None.
        force_gain_mm_per_ns: k_F of the force integrator dz/dt = k_F (F* - F), in [mm/(N s)].
        correction_limit_mm: Bound of the force loop's correction along the normal.
        settle_tol_n: |F - F*| below which the descent counts as settled.
        settle_s: How long the force must stay settled before the stroke starts.
        settle_timeout_s: Longest wait at the end of a descent.
        contact_threshold_n: Force above which the pen counts as touching.
        posture_rate: Null-space pull towards the home posture, in [1/s].
        ik_period_s: Spacing of the IK solutions along the path; a cubic spline fills in.
        go_home: Return to the home pose at the end.
        command: "torque" (PID torques) or "position" (q goals with velocity feed-forward, for
            plants with their own servo loop).
    """

    force_n: float = 1.0
    pen_stiffness_n_per_mm: float | None = None
    hover_mm: float = 8.0
    descend_s: float = 0.3
    lift_s: float = 0.2
    travel_speed_mm_s: float = 150.0
    joint_speed_rad_s: float = 0.8
    nib_friction: float | None = None
    force_gain_mm_per_ns: float = 40.0
    correction_limit_mm: float = 3.0
    settle_tol_n: float = 0.05
    settle_s: float = 0.03
    settle_timeout_s: float = 0.6
    contact_threshold_n: float = 0.02
    posture_rate: float = 0.5
    ik_period_s: float = 0.012
    go_home: bool = True
    command: str = "torque"

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, float) and not np.isfinite(value):
                raise InputError(f"LoopConfig.{f.name}: expected a finite number, got {value}")
        for name in (
            "force_n",
            "hover_mm",
            "descend_s",
            "lift_s",
            "travel_speed_mm_s",
            "joint_speed_rad_s",
            "ik_period_s",
        ):
            if getattr(self, name) <= 0:
                raise InputError(f"LoopConfig.{name}: expected > 0, got {getattr(self, name)}")
        for name in (
            "force_gain_mm_per_ns",
            "correction_limit_mm",
            "settle_tol_n",
            "settle_s",
            "settle_timeout_s",
            "contact_threshold_n",
            "posture_rate",
        ):
            if getattr(self, name) < 0:
                raise InputError(f"LoopConfig.{name}: expected >= 0, got {getattr(self, name)}")
        if self.nib_friction is not None and not self.nib_friction >= 0:
            raise InputError(f"LoopConfig.nib_friction: expected >= 0, got {self.nib_friction}")
        if self.command not in ("torque", "position"):
            raise InputError(
                f"LoopConfig.command: expected 'torque' or 'position', got {self.command!r}"
            )


@dataclass
class DrawLog:
    """What happened, one row per control period.

    Attributes:
        time: Plant time in [s], (K,).
        q, qd, torque: Measured joint angles [rad], speeds [rad/s], commanded torques [N m], (K, n).
        tip: Pen tip in the page frame (x, y, z) in [mm], (K, 3): the plant's measurement when
            it has one, else forward kinematics of the measured q.
        force: Measured pen contact force in [N], (K,) (NaN when the plant cannot sense it).
        reference: Planned pen tip (x, y, z) in page [mm], (K, 3); z < 0 while pressing.
        phase: Index into :data:`PHASES`, (K,).
        stroke: Stroke index (during travel: the stroke travelled to), -1 during approach
            and home, (K,).
        wall_s: Wall-clock duration of the run in [s], planning included.
    """

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    torque: np.ndarray
    tip: np.ndarray
    force: np.ndarray
    reference: np.ndarray
    phase: np.ndarray
    stroke: np.ndarray
    wall_s: float = 0.0

    @staticmethod
    def empty(capacity: int, n: int) -> DrawLog:
        return DrawLog(
            time=np.zeros(capacity),
            q=np.zeros((capacity, n)),
            qd=np.zeros((capacity, n)),
            torque=np.zeros((capacity, n)),
            tip=np.zeros((capacity, 3)),
            force=np.zeros(capacity),
            reference=np.zeros((capacity, 3)),
            phase=np.zeros(capacity, dtype=np.int8),
            stroke=np.zeros(capacity, dtype=np.int32),
        )

    def truncated(self, k: int) -> DrawLog:
        """The first ``k`` rows."""
        return DrawLog(
            self.time[:k],
            self.q[:k],
            self.qd[:k],
            self.torque[:k],
            self.tip[:k],
            self.force[:k],
            self.reference[:k],
            self.phase[:k],
            self.stroke[:k],
            self.wall_s,
        )

    def __len__(self) -> int:
        return self.time.shape[0]

    @property
    def drawing(self) -> np.ndarray:
        """Boolean mask of the rows where a stroke is being tracked (phase draw)."""
        return self.phase == DRAW

    @property
    def realtime_factor(self) -> float:
        """Simulated time over wall-clock time."""
        span = float(self.time[-1] - self.time[0]) if len(self) > 1 else 0.0
        return span / self.wall_s if self.wall_s > 0 else float("inf")

    def tracking_error(self) -> np.ndarray:
        """In-plane distance |tip - reference| in [mm] on the draw rows."""
        mask = self.drawing
        return np.linalg.norm(self.tip[mask, :2] - self.reference[mask, :2], axis=1)

    def to_npz(self, path) -> None:
        np.savez(
            path, **{f.name: getattr(self, f.name) for f in fields(self)}, phases=np.array(PHASES)
        )


@dataclass
class Reference:
    """The planned run, one row per control period (all SI but ``page_mm``).

    q, qd, qdd: joint reference [rad, rad/s, rad/s^2], (K, n); page_mm: planned tip in page
    [mm], (K, 3); phase, stroke: as in DrawLog; normal_q: J5^+ (-n), joint motion per metre of
    pen pressed into the paper, (K, n); contact_tau: J^T f, the joint torque that pushes the
    planned contact force f on the paper while pressing, (K, n); inertia: M(q) qdd
    feed-forward in [N m], (K, n); settle: rows after which the loop waits for the force to
    settle (ends of descents).
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    page_mm: np.ndarray
    phase: np.ndarray
    stroke: np.ndarray
    normal_q: np.ndarray
    contact_tau: np.ndarray
    inertia: np.ndarray
    settle: frozenset[int]

    def __len__(self) -> int:
        return self.q.shape[0]


def minimum_jerk(n: int) -> np.ndarray:
    """Flash-Hogan profile s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 on n samples of [0, 1]."""
    tau = np.linspace(0.0, 1.0, max(n, 2))
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def _ticks(duration: float, dt: float) -> int:
    return max(2, int(np.ceil(duration / dt)) + 1)


def pen_depth_mm(kin_model: mujoco.MjModel, config: LoopConfig) -> float:
    """Nominal pen compression F* / k in [mm]: how far below the paper the pen reference goes.

    k is ``config.pen_stiffness_n_per_mm``, else the stiffness of the model's ``pen_slide``
    joint, whose travel must then leave room for the compression."""
    jid = mujoco.mj_name2id(kin_model, mujoco.mjtObj.mjOBJ_JOINT, "pen_slide")
    if config.pen_stiffness_n_per_mm is not None:
        stiffness = float(config.pen_stiffness_n_per_mm)
    elif jid >= 0 and kin_model.jnt_stiffness[jid] > 0:
        stiffness = float(kin_model.jnt_stiffness[jid]) / 1000.0
    else:
        raise InputError(
            "LoopConfig.pen_stiffness_n_per_mm: needed, the model has no sprung pen_slide"
        )
    if stiffness <= 0:
        raise InputError(f"LoopConfig.pen_stiffness_n_per_mm: expected > 0, got {stiffness}")
    depth = config.force_n / stiffness
    if jid >= 0 and kin_model.jnt_limited[jid]:
        travel = 1000.0 * float(np.ptp(kin_model.jnt_range[jid]))
        if depth > 0.8 * travel:
            raise InputError(
                f"LoopConfig.force_n: {config.force_n} N compresses the pen by {depth:.1f} mm, "
                f"more than 80% of its {travel:.1f} mm travel"
            )
    return depth


def nib_friction(kin_model: mujoco.MjModel, config: LoopConfig) -> float:
    """Nib-paper sliding friction coefficient: the configured one, else the kinematic model's
    (the larger of the ``pen_tip`` and ``paper`` geoms', as MuJoCo combines them), else 0."""
    if config.nib_friction is not None:
        return float(config.nib_friction)
    ids = [
        mujoco.mj_name2id(kin_model, mujoco.mjtObj.mjOBJ_GEOM, name)
        for name in ("pen_tip", "paper")
    ]
    return max((float(kin_model.geom_friction[g][0]) for g in ids if g >= 0), default=0.0)


def home_posture(kin: ArmKinematics) -> np.ndarray:
    """The model's ``home`` keyframe (arm joints), else its qpos0."""
    key = mujoco.mj_name2id(kin.model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = kin.model.key_qpos[key] if key >= 0 else kin.model.qpos0
    return np.asarray(qpos[kin.qpos_adr], dtype=float)


def _stroke_points(drawing: Drawing, k: int, dt: float) -> np.ndarray:
    """Stroke k resampled on the control grid, (N, 3) page [mm] with z height (0 if 2-D).

    A cubic spline through the samples (Hermite with the stroke's velocities when it has
    them): the arm draws smooth curves, and a piecewise-linear reference would differ from
    them by the chord sagitta, (v T)^2 / (8 R) for samples T apart on a curve of radius R.
    """
    s = drawing.strokes[k]
    if s.dim == 1:
        raise InputError(f"drawing stroke {k}: 1-D positions cannot be drawn on a page")
    # Whole periods covering the stroke, the last one clamped onto its end point.
    n = max(1, int(np.ceil(s.duration / dt - 1e-9)) + 1)
    t = np.minimum(s.t[0] + dt * np.arange(n), s.t[-1])
    pts = np.zeros((n, 3))
    if s.n >= 4 and s.vel is not None:
        pts[:, : s.dim] = CubicHermiteSpline(s.t, s.pos, s.vel, axis=0)(t)
    elif s.n >= 4:
        pts[:, : s.dim] = CubicSpline(s.t, s.pos, axis=0)(t)
    else:
        for c in range(s.dim):
            pts[:, c] = np.interp(t, s.t, s.pos[:, c])
    return pts


def check_reachable(
    drawing: Drawing,
    placement: PagePlacement,
    kin_model: mujoco.MjModel,
    config: LoopConfig = LoopConfig(),
    spacing_mm: float = 10.0,
    kin: ArmKinematics | None = None,
) -> None:
    """Refuse, before any simulation, a drawing that the arm cannot draw at ``placement``.

    Checks that every stroke lies on the sheet and solves IK statically (pen perpendicular,
    pressed to the nominal compression) at the stroke ends and at points about ``spacing_mm``
    apart along each stroke, each solve warm-started from the previous one. Raises
    UnreachableError naming the stroke and the point in page [mm].
    """
    if not drawing.strokes:
        raise InputError("drawing: no strokes to draw")
    kin = kin or ArmKinematics(kin_model)
    depth = pen_depth_mm(kin_model, config)
    posture = home_posture(kin)
    q = posture.copy()
    # Task-only steps (no posture pull) warm-started along the stroke: a cheap yes/no.
    cfg = IKConfig(posture_gain=0.0, tol_pos=1e-5, tol_tilt=1e-4, max_iter=200)
    for k, s in enumerate(drawing.strokes):
        pos = s.pos[:, :2]
        off = ~placement.contains(pos)
        if off.any():
            x, y = pos[int(np.argmax(off))]
            raise UnreachableError(
                f"stroke {k}, point ({x:.1f}, {y:.1f}) mm: off the {placement.size_mm[0]:.0f} x "
                f"{placement.size_mm[1]:.0f} mm sheet"
            )
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))])
        picks = np.unique(
            np.searchsorted(arc, np.arange(0.0, arc[-1], spacing_mm)).tolist() + [len(pos) - 1]
        )
        for i in picks:
            goal = placement.to_robot([pos[i, 0], pos[i, 1], -depth])
            result = solve_ik(kin, goal, placement.pen_axis, q, posture, cfg)
            if not result.converged:
                raise UnreachableError(
                    f"stroke {k}, point ({pos[i, 0]:.1f}, {pos[i, 1]:.1f}) mm: out of reach "
                    f"with the pen perpendicular to the paper (closest tip "
                    f"{1000 * result.pos_error:.1f} mm away)"
                )
            q = result.q


def plan_reference(
    drawing: Drawing,
    kin: ArmKinematics,
    placement: PagePlacement,
    config: LoopConfig,
    q_start: np.ndarray,
    dt: float,
) -> Reference:
    """The whole run on the control grid of period ``dt`` [s], joint references included."""
    depth = pen_depth_mm(kin.model, config)
    hover = config.hover_mm
    posture = home_posture(kin)
    segments: list[tuple[int, int, np.ndarray]] = []  # (phase, stroke, page points (N, 3))
    previous = None
    for k in range(len(drawing.strokes)):
        pts = _stroke_points(drawing, k, dt)
        pts[:, 2] -= depth
        start, end = pts[0], pts[-1]
        above = np.array([start[0], start[1], hover])
        if previous is not None:
            distance = float(np.linalg.norm(above[:2] - previous[:2]))
            # Minimum jerk peaks at 1.875 A / t_f (seed 002, eq. 3.1).
            n = _ticks(1.875 * distance / config.travel_speed_mm_s, dt)
            segments.append((TRAVEL, k, previous + minimum_jerk(n)[:, None] * (above - previous)))
        n = _ticks(config.descend_s, dt)
        segments.append((DESCEND, k, above + minimum_jerk(n)[:, None] * (start - above)))
        segments.append((DRAW, k, pts))
        lifted = np.array([end[0], end[1], hover])
        n = _ticks(config.lift_s, dt)
        segments.append((LIFT, k, end + minimum_jerk(n)[:, None] * (lifted - end)))
        previous = lifted

    page = np.vstack([seg[2] for seg in segments])
    phase = np.concatenate([np.full(len(seg[2]), seg[0], dtype=np.int8) for seg in segments])
    stroke = np.concatenate([np.full(len(seg[2]), seg[1], dtype=np.int32) for seg in segments])
    settle, row = set(), 0
    for ph, _, pts in segments:
        row += len(pts)
        if ph == DESCEND:
            settle.add(row - 1)

    axis = placement.pen_axis
    first = solve_ik(kin, placement.to_robot(page[0]), axis, posture, posture)
    if not first.converged:
        raise UnreachableError(
            f"stroke 0, point ({page[0, 0]:.1f}, {page[0, 1]:.1f}) mm: out of reach above the paper"
        )

    # IK on knots every ik_period_s, a clamped cubic spline in between (the Cartesian part
    # starts and ends at rest): the joint path is smooth, and the interpolation error is far
    # below the tracking error where the pen turns smoothly (about (omega h)^4 / 384 of the
    # radius of a curve); at cusps, where a script letter brakes hard, knots much further
    # apart than 12 ms round the corner off (0.7 mm more error at 40 ms on a 60 mm "a").
    stride = max(1, round(config.ik_period_s / dt))
    knots = _knots(len(page), stride)

    def label(j: int) -> str:
        i = knots[j]
        return (
            f"stroke {stroke[i]} ({PHASES[phase[i]]}), point ({page[i, 0]:.1f}, "
            f"{page[i, 1]:.1f}) mm"
        )

    ik_cfg = IKConfig(posture_gain=config.posture_rate * dt * stride, limit_gain=0.5)
    q_knots = track_path(
        kin, placement.to_robot(page[knots]), axis, first.q, posture, ik_cfg, label
    )
    if len(knots) > 1:
        q_cart = CubicSpline(knots, q_knots, axis=0, bc_type="clamped")(np.arange(len(page)))
    else:
        q_cart = q_knots.copy()

    q_start = np.asarray(q_start, dtype=float)
    approach = _joint_move(q_start, q_cart[0], config.joint_speed_rad_s, dt)
    parts_q = [approach, q_cart]
    parts_phase = [np.full(len(approach), APPROACH, np.int8), phase]
    parts_stroke = [np.full(len(approach), -1, np.int32), stroke]
    if config.go_home:
        home = _joint_move(q_cart[-1], posture, config.joint_speed_rad_s, dt)
        parts_q.append(home)
        parts_phase.append(np.full(len(home), HOME, np.int8))
        parts_stroke.append(np.full(len(home), -1, np.int32))
    q = np.vstack(parts_q)
    outside = (q < kin.lower) | (q > kin.upper)
    if outside.any():
        i = int(np.argmax(outside.any(axis=1)))
        j = int(np.argmax(outside[i]))
        raise UnreachableError(
            f"planned path leaves the range of {kin.joint_names[j]} at t = {i * dt:.3f} s "
            f"({np.rad2deg(q[i, j]):.1f} deg)"
        )
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)

    # Slowly varying terms on knots SLOW_TERMS_PERIOD_S apart, linear in between: MuJoCo
    # evaluates each knot, the linear algebra runs on all knots at once.
    all_knots = _knots(len(q), max(1, round(SLOW_TERMS_PERIOD_S / dt)))
    n_k = len(all_knots)
    tip_k = np.empty((n_k, 3))
    jac5_k = np.empty((n_k, 5, kin.n))
    mass_k = np.empty((n_k, kin.n * kin.n))
    for j, i in enumerate(all_knots):
        p, R, Jp, Jr = kin.jacobian_views(q[i])
        tip_k[j] = p
        jac5_k[j] = pen_jacobian(R, Jp, Jr)
        mass_k[j] = kin.mass(q[i]).ravel()
    page_k = placement.to_page(tip_k)
    jac_k = jac5_k[:, :3].transpose(0, 2, 1).reshape(n_k, kin.n * 3)  # rows of Jp^T
    # J5^+ (-n): the joint motion that presses the pen along -n, tilt unchanged.
    normal = placement.normal
    press = np.concatenate([-normal, [0.0, 0.0]])
    JJt = jac5_k @ jac5_k.transpose(0, 2, 1)
    JJt += IKConfig().damping ** 2 * np.eye(5)
    y = np.linalg.solve(JJt, np.broadcast_to(press, (n_k, 5))[..., None])
    normal_q_k = (jac5_k.transpose(0, 2, 1) @ y)[..., 0]
    mass = _lerp_rows(all_knots, mass_k, len(q)).reshape(len(q), kin.n, kin.n)
    jac_t = _lerp_rows(all_knots, jac_k, len(q)).reshape(len(q), kin.n, 3)
    page_all = _lerp_rows(all_knots, page_k, len(q))
    offset = len(approach)
    page_all[offset : offset + len(page)] = page  # the exact plan where there is one

    # Contact feed-forward while pressing: hold F* against the paper's push F* n, and, while
    # drawing, the nib's Coulomb drag mu F* opposite the planned velocity (smoothed near rest).
    velocity = np.gradient(page_all[:, :2], dt, axis=0) @ placement.rotation[:, :2].T
    speed = np.linalg.norm(velocity, axis=1, keepdims=True)
    sliding = velocity / np.sqrt(speed**2 + DRAG_SPEED_MM_S**2)
    sliding[np.concatenate(parts_phase) != DRAW] = 0.0
    mu = nib_friction(kin.model, config)
    contact_force = config.force_n * (mu * sliding - normal)  # what the arm must push with
    contact_tau = np.einsum("kij,kj->ki", jac_t, contact_force)
    return Reference(
        q=q,
        qd=qd,
        qdd=qdd,
        page_mm=page_all,
        phase=np.concatenate(parts_phase),
        stroke=np.concatenate(parts_stroke),
        normal_q=_lerp_rows(all_knots, normal_q_k, len(q)),
        contact_tau=contact_tau,
        inertia=np.einsum("kij,kj->ki", mass, qdd),
        settle=frozenset(offset + r for r in settle),
    )


def _knots(n: int, stride: int) -> np.ndarray:
    """Every ``stride``-th index of range(n), the last one always included."""
    return np.unique(np.append(np.arange(0, n, stride), n - 1))


def _lerp_rows(knots: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Rows ``values`` (len(knots), m) given at indices ``knots``, linearly interpolated to
    (n, m)."""
    if len(knots) == 1:
        return np.repeat(values, n, axis=0)
    i = np.arange(n)
    k = np.clip(np.searchsorted(knots, i, side="right") - 1, 0, len(knots) - 2)
    w = ((i - knots[k]) / (knots[k + 1] - knots[k]))[:, None]
    return values[k] * (1.0 - w) + values[k + 1] * w


def _joint_move(q0: np.ndarray, q1: np.ndarray, peak_speed: float, dt: float) -> np.ndarray:
    """Minimum-jerk joint path from q0 to q1 whose fastest joint peaks at ``peak_speed``."""
    span = float(np.max(np.abs(q1 - q0)))
    n = _ticks(1.875 * span / peak_speed, dt)
    return q0 + minimum_jerk(n)[:, None] * (q1 - q0)


def run_drawing(
    drawing: Drawing,
    plant,
    kin_model: mujoco.MjModel,
    gains: PIDGains,
    placement: PagePlacement,
    config: LoopConfig = LoopConfig(),
    progress: Callable[[float, str], None] | None = None,
) -> DrawLog:
    """Draw ``drawing`` (page [mm], [s]) with ``plant``; return the log of every control period.

    ``kin_model`` is the controller's own model (never the plant's): IK, the bias forces and the
    inertia come from it. Raises UnreachableError before moving when a point is out of reach,
    and SimulationError (with the log so far in its ``log`` attribute) when the plant diverges.
    ``progress(fraction, phase)`` is called about ten times per simulated second. The plant is
    left as it is at the end (the caller closes it).
    """
    wall0 = _time.perf_counter()
    kin = ArmKinematics(kin_model)
    if gains.n != kin.n:
        raise InputError(f"gains: {gains.n} joints, but the kinematic model has {kin.n}")
    check_reachable(drawing, placement, kin_model, config, kin=kin)
    dt = plant.dt
    state = plant.read()
    ref = plan_reference(drawing, kin, placement, config, state.q, dt)
    pid = JointPID(gains, dt)

    settle_ticks = round(config.settle_s / dt)
    timeout_ticks = round(config.settle_timeout_s / dt)
    log = DrawLog.empty(len(ref) + len(ref.settle) * timeout_ticks + 1, kin.n)
    k_force = config.force_gain_mm_per_ns / 1000.0 * dt  # [m/N] per period
    z_limit = config.correction_limit_mm / 1000.0
    f_star, threshold, settle_tol = config.force_n, config.contact_threshold_n, config.settle_tol_n
    torque_mode = config.command == "torque"
    report_every = max(1, round(0.1 / dt))
    senses_force = getattr(state, "pen_force", None) is not None
    senses_tip = getattr(state, "tip_mm", None) is not None
    # Local names and Python lists: this loop runs once per control period and its Python cost
    # is the budget. The plan's columns of the log are filled from ``ref_row`` afterwards.
    q_ref, qd_ref, inertia, normal_q = ref.q, ref.qd, ref.inertia, ref.normal_q
    contact_tau = ref.contact_tau
    phases = ref.phase.tolist()
    hold_at = [False] * len(ref)  # rows where a descent waits for the force (if sensed)
    for r in ref.settle:
        hold_at[r] = senses_force
    bias, update = kin.bias, pid.update
    read, command, step = plant.read, plant.command, plant.step
    log_time, log_q, log_qd, log_torque = log.time, log.q, log.qd, log.torque
    log_tip, log_force = log.tip, log.force
    ref_row = np.zeros(len(log), dtype=np.intp)
    nan_torque = np.full(kin.n, np.nan)

    z_corr = 0.0  # force-loop correction along the normal, [m] (positive = deeper)
    row, i, waited, settled_for = 0, 0, 0, 0
    n_ref = len(ref)
    try:
        while i < n_ref:
            state = read()
            force = state.pen_force if senses_force else np.nan
            phase = phases[i]
            holding = hold_at[i]
            pressing = phase == DRAW or (holding and waited > 0)
            if pressing and force > threshold:
                z_corr = min(max(z_corr + k_force * (f_star - force), -z_limit), z_limit)
            q_goal = q_ref[i] + z_corr * normal_q[i]
            if torque_mode:
                feedforward = bias(state.q, state.qd) + inertia[i]
                if pressing:
                    feedforward += contact_tau[i]
                tau = update(q_goal, state.q, state.qd, qd_ref[i], feedforward)
                command(torque=tau)
            else:
                tau = nan_torque
                command(q_goal=q_goal, qd_ff=qd_ref[i])
            log_time[row] = state.time
            log_q[row] = state.q
            log_qd[row] = state.qd
            log_torque[row] = tau
            log_tip[row] = state.tip_mm if senses_tip else placement.to_page(kin.fk(state.q)[0])
            log_force[row] = force
            ref_row[row] = i
            row += 1
            step()
            if progress is not None and row % report_every == 0:
                progress(i / n_ref, PHASES[phase])
            # Hold the end of a descent until the force has settled at its set point.
            if holding and waited < timeout_ticks:
                waited += 1
                settled_for = settled_for + 1 if abs(force - f_star) < settle_tol else 0
                if settled_for < settle_ticks:
                    continue
            waited, settled_for = 0, 0
            i += 1
    except SimulationError as err:
        partial = _with_plan_columns(log, ref, ref_row, row)
        partial.wall_s = _time.perf_counter() - wall0
        err.log = partial
        raise
    result = _with_plan_columns(log, ref, ref_row, row)
    result.wall_s = _time.perf_counter() - wall0
    if progress is not None:
        progress(1.0, PHASES[phases[-1]])
    return result


def _with_plan_columns(log: DrawLog, ref: Reference, ref_row: np.ndarray, k: int) -> DrawLog:
    """The first ``k`` rows of ``log``, with the reference, phase and stroke of the plan rows
    ``ref_row`` filled in."""
    rows = ref_row[:k]
    log.reference[:k] = ref.page_mm[rows]
    log.phase[:k] = ref.phase[rows]
    log.stroke[:k] = ref.stroke[rows]
    return log.truncated(k)


__all__ = [
    "PHASES",
    "DrawLog",
    "LoopConfig",
    "Reference",
    "check_reachable",
    "home_posture",
    "minimum_jerk",
    "nib_friction",
    "pen_depth_mm",
    "plan_reference",
    "run_drawing",
]
