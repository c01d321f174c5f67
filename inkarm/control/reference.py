"""Joint references for arms: the pen path by inverse kinematics, splined, with feed-forward.

Why inverse kinematics runs ahead of time, with feedback online
---------------------------------------------------------------
Seed 001's sensory-motor model inverts kinematics inside the loop, from the sensed state. Here
the kinematic inversion is solved once, before the run, on the controller's own kinematic model
(closed-loop IK on knots every ``ik_period_s`` along the whole reference,
:func:`inkarm.control.ik.track_path`, joined by a clamped cubic spline); the loop
(:mod:`inkarm.control.executor`) closes on the senses every control period. Reasons: (1) an
unreachable point, a joint limit or a joint speed above the robot's datasheet limit is found
before anything moves, naming the point or joint, which a real arm needs; (2) the per-period
cost drops to a PID and one bias evaluation, so a Python loop keeps a hardware period and the
simulation runs at >= 30x real time (``benchmarks/bench_draw.py``); (3) an online IK would only
re-solve the same equations from a state that differs from the plan by the tracking error, which
joint feedback already removes. What online IK would add, bending the path itself to sensed
surprises, is here limited to the pen-normal force loop.

Feed-forward terms planned here: the inertial M(q*) qdd*, the planned contact force carried
through J(q*)^T f with f = F* (mu u - n): the set-point force into the paper plus the nib's
Coulomb drag along the planned direction of motion u, and the joint direction J5^+ (-n) along
which the force loop moves the pen reference.

Pen poses. A drawing whose ``meta["pen_poses"]`` holds one :class:`inkarm.control.ik.PenPose`
(or None: upright) per stroke is drawn with each stroke's pen tilted and spun as asked (the pen
calibration's dots): the stroke's descent, draw and lift follow the line along the tilted pen
axis, p' = p + z (u - e_z) with u = -a / cos(theta) in the page frame (z: the planned height
above the paper), and the force loop presses along u too (J6^+ [-u; 0] with the orientation
held, J6 = [Jp; R^T Jr]): a tip that touches the paper sooner or later than planned (a pen of
another length) moves along the pen's own axis, into the paper, and does not slide on it (but
for the sheet's give, its sinking times tan(theta)); the travel to a stroke turns the pen from
the previous stroke's pose (slerp on the minimum-jerk profile; the spin is free unless both
strokes set one). Without the key nothing changes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.ik import (
    IKConfig,
    PathTracker,
    PenPose,
    solve_ik,
    track_path,
    track_poses,
)
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.relief_speed import slowed_over_relief
from inkarm.control.sequencing import PenPath, minimum_jerk, pen_depth_mm, sequence_pen, ticks
from inkarm.core.log import APPROACH, DRAW, HOME, PHASES, TRAVEL
from inkarm.core.spline import cubic_spline
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, UnreachableError
from inkarm.models.minjerk import PEAK_SPEED_RATIO
from inkarm.robots.kinematic import KinematicModel

# Spacing in [s] of the evaluations of the slowly varying terms (inertia matrix, normal direction
# in joint space, bias forces), linearly interpolated in between.
# (Gravity changes with the pose; the velocity forces of a 1 s joint move are a smooth profile.)
SLOW_TERMS_PERIOD_S = 0.04
# Speed in [mm/s] below which the nib-drag feed-forward fades out (u = v / sqrt(|v|^2 + v0^2)).
DRAG_SPEED_MM_S = 5.0


@dataclass(frozen=True, eq=False)
class JointReference:
    """The planned run, one row per control period (all SI but ``page_mm``).

    q, qd, qdd: joint reference [rad, rad/s, rad/s^2], (K, n); page_mm: planned tip in page
    [mm], (K, 3); phase, stroke: as in DrawLog; normal_q: J5^+ (-n), joint motion per metre of
    pen pressed into the paper, (K, n); contact_tau: J^T f, the joint torque that pushes the
    planned contact force f on the paper while pressing, (K, n); inertia: M(q) qdd
    feed-forward in [N m], (K, n); bias: c(q, qd), gravity and velocity forces along the plan
    [N m], (K, n); settle: rows after which the loop waits for the force to
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
    bias: np.ndarray
    settle: frozenset[int]

    def __len__(self) -> int:
        return self.q.shape[0]


class JointSpeedError(UnreachableError):
    """A planned joint speed above the robot's limit; ``joint`` names it and ``excess`` is the
    ratio of the planned speed to the limit (> 1); ``strokes_within``: whether the pen-down
    rows keep to every limit (only the moves between strokes are too fast)."""

    def __init__(self, message: str, joint: str = "", excess: float = 1.0,
                 strokes_within: bool = False, **context):
        super().__init__(message, **context)
        self.joint = joint
        self.excess = excess
        self.strokes_within = strokes_within


def check_reachable(
    drawing: Drawing,
    model: KinematicModel,
    config: LoopConfig | None = None,
    spacing_mm: float = 10.0,
    kin: ArmKinematics | None = None,
    ik: IKConfig | None = None,
) -> None:
    """Refuse, before any motion, a drawing that the arm cannot draw on its page.

    Checks that every stroke lies on the sheet and solves IK statically (pen perpendicular,
    pressed to the nominal compression) at the stroke ends and at points about ``spacing_mm``
    apart along each stroke, each solve warm-started from the previous one. Raises
    UnreachableError naming the stroke and the point in page [mm].
    """
    if not drawing.strokes:
        raise InputError("drawing: no strokes to draw")
    config = config or LoopConfig()
    ik = ik or IKConfig()
    kin = kin or ArmKinematics.of(model)
    placement = model.placement
    depth = pen_depth_mm(config, model.pen_stiffness_n_per_mm, model.pen_travel_mm,
                         model.pen_preload_n, model.paper_stiffness_n_per_mm)
    posture = model.home_q
    # Task-only steps (no posture pull) warm-started along the stroke: a cheap yes/no; each
    # solve starts from the last one's result (solve_ik's, from one PathTracker).
    cfg = dataclasses.replace(ik, posture_gain=0.0, tol_pos=1e-5, tol_tilt=1e-4, max_iter=200)
    tracker = PathTracker(kin, placement.pen_axis,
                          np.minimum(np.maximum(posture, kin.lower), kin.upper), posture, cfg)
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
        goals = placement.to_robot(np.column_stack([pos[picks], np.full(len(picks), -depth)]))
        for i, goal in zip(picks.tolist(), goals.tolist()):
            result = tracker.solve(goal)
            if not result.converged:
                raise UnreachableError(
                    f"stroke {k}, point ({pos[i, 0]:.1f}, {pos[i, 1]:.1f}) mm: out of reach "
                    f"with the pen perpendicular to the paper (closest tip "
                    f"{1000 * result.pos_error:.1f} mm away)"
                )


def plan_joint_reference(
    pen: PenPath,
    model: KinematicModel,
    config: LoopConfig,
    q_start: np.ndarray,
    dt: float,
    kin: ArmKinematics | None = None,
    ik: IKConfig | None = None,
    speed_limits: np.ndarray | None = None,
    poses: tuple[PenPose | None, ...] | None = None,
) -> JointReference:
    """The joint reference of the pen path ``pen`` (period ``dt`` [s]) for the arm of ``model``,
    from ``q_start``: a joint-space approach, the pen path by inverse kinematics, and home;
    ``poses``: one pen pose per stroke (module docstring), None: the pen upright throughout.

    Raises UnreachableError naming the stroke and point that the arm cannot reach, and
    :class:`JointSpeedError` naming the joint whose planned speed exceeds ``speed_limits``
    [rad/s] (n,)."""
    ik = ik or IKConfig()
    kin = kin or ArmKinematics.of(model)
    placement = model.placement
    page, phase, stroke = pen.page_mm, pen.phase, pen.stroke
    posture = model.home_q
    axis = placement.pen_axis
    if poses is not None:
        lean, axes, spins = _pose_rows(pen, poses, placement.rotation)
        page = page + page[:, 2:3] * (lean - np.array([0.0, 0.0, 1.0]))
        first = solve_ik(kin, placement.to_robot(page[0]), axes[0], posture, posture, ik,
                         spin_goal=None if np.isnan(spins[0]).any() else spins[0])
    else:
        first = solve_ik(kin, placement.to_robot(page[0]), axis, posture, posture, ik)
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

    ik_cfg = dataclasses.replace(ik, posture_gain=config.posture_rate * dt * stride,
                                 limit_gain=0.5)
    if poses is not None:
        q_knots = track_poses(kin, placement.to_robot(page[knots]), axes[knots], spins[knots],
                              first.q, posture, ik_cfg, label)
    else:
        q_knots = track_path(
            kin, placement.to_robot(page[knots]), axis, first.q, posture, ik_cfg, label
        )
    if len(knots) > 1:
        q_cart = cubic_spline(knots, q_knots, "clamped")(np.arange(len(page)))
    else:
        q_cart = q_knots.copy()

    peak = np.full(kin.n, config.joint_speed_rad_s)
    if speed_limits is not None:
        peak = np.minimum(peak, speed_limits)
    q_start = np.asarray(q_start, dtype=float)
    approach = _joint_move(q_start, q_cart[0], peak, dt)
    parts_q = [approach, q_cart]
    parts_phase = [np.full(len(approach), APPROACH, np.int8), phase]
    parts_stroke = [np.full(len(approach), -1, np.int32), stroke]
    if config.go_home:
        home = _joint_move(q_cart[-1], posture, peak, dt)
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
    if speed_limits is not None:
        _check_speeds(qd, speed_limits, kin.joint_names, dt,
                      np.concatenate(parts_phase) == DRAW)
    qdd = np.gradient(qd, dt, axis=0)
    # Slowly varying terms on knots SLOW_TERMS_PERIOD_S apart, linear in between: MuJoCo
    # evaluates each knot, the linear algebra runs on all knots at once.
    all_knots = _knots(len(q), max(1, round(SLOW_TERMS_PERIOD_S / dt)))
    n_k = len(all_knots)
    tip_k, rot_k = np.empty((n_k, 3)), np.empty((n_k, 3, 3))
    jac5_k, jac_r = np.empty((n_k, 5, kin.n)), np.empty((n_k, 3, kin.n))
    mass_k, bias_k = np.empty((n_k, kin.n, kin.n)), np.empty((n_k, kin.n))
    for j, q_j, qd_j in zip(range(n_k), q[all_knots], qd[all_knots]):
        tip_k[j], rot_k[j], jac5_k[j, :3], jac_r[j], mass_k[j], bias_k[j] = kin.plan_terms(
            q_j, qd_j)
    # pen_jacobian's tilt rows x_s^T Jr, y_s^T Jr of every knot in one product (its numbers)
    np.matmul(rot_k.transpose(0, 2, 1)[:, :2], jac_r, out=jac5_k[:, 3:])
    page_k = placement.to_page(tip_k)
    jac_k = jac5_k[:, :3].transpose(0, 2, 1).reshape(n_k, kin.n * 3)  # rows of Jp^T
    # J5^+ (-n): the joint motion that presses the pen along -n, tilt unchanged.
    normal = placement.normal
    press = np.concatenate([-normal, [0.0, 0.0]])
    JJt = jac5_k @ jac5_k.transpose(0, 2, 1)
    JJt += IKConfig().damping ** 2 * np.eye(5)
    y = np.linalg.solve(JJt, np.broadcast_to(press, (n_k, 5))[..., None])
    normal_q_k = (jac5_k.transpose(0, 2, 1) @ y)[..., 0]
    if poses is not None:  # a pen pose presses along its own axis (module docstring)
        spin_k = np.array([R[:, 2] @ Jr for R, Jr in zip(rot_k, jac_r)])  # z_s^T Jr
        cart = (all_knots >= len(approach)) & (all_knots < len(approach) + len(page))
        normal_q_k[cart] = _press_along(jac5_k[cart], spin_k[cart],
                                        lean[all_knots[cart] - len(approach)]
                                        @ placement.rotation.T)
    lerp = _Lerp(all_knots, len(q))
    mass = lerp(mass_k)
    jac_t = lerp(jac_k).reshape(len(q), kin.n, 3)
    page_all = lerp(page_k)
    offset = len(approach)
    page_all[offset : offset + len(page)] = page  # the exact plan where there is one

    # Contact feed-forward while pressing: hold F* against the paper's push F* n, and, while
    # drawing, the nib's Coulomb drag mu F* opposite the planned velocity (smoothed near rest).
    velocity = np.gradient(page_all[:, :2], dt, axis=0) @ placement.rotation[:, :2].T
    speed = np.linalg.norm(velocity, axis=1, keepdims=True)
    sliding = velocity / np.sqrt(speed**2 + DRAG_SPEED_MM_S**2)
    sliding[np.concatenate(parts_phase) != DRAW] = 0.0
    mu = config.nib_friction if config.nib_friction is not None else model.nib_friction
    contact_force = config.force_n * (mu * sliding - normal)  # what the arm must push with
    contact_tau = np.einsum("kij,kj->ki", jac_t, contact_force)
    return JointReference(
        q=q,
        qd=qd,
        qdd=qdd,
        page_mm=page_all,
        phase=np.concatenate(parts_phase),
        stroke=np.concatenate(parts_stroke),
        normal_q=lerp(normal_q_k),
        contact_tau=contact_tau,
        inertia=np.einsum("kij,kj->ki", mass, qdd),
        bias=lerp(bias_k),
        settle=frozenset(offset + r for r in pen.settle),
    )


def pen_poses(drawing: Drawing) -> tuple[PenPose | None, ...] | None:
    """The drawing's ``meta["pen_poses"]``, checked: one :class:`PenPose` or None per stroke;
    None without the key (or when every stroke's pen is upright with a free spin)."""
    raw = drawing.meta.get("pen_poses")
    if raw is None:
        return None
    poses = tuple(raw)
    if len(poses) != len(drawing.strokes) or not all(
            p is None or isinstance(p, PenPose) for p in poses):
        raise InputError(f"drawing meta['pen_poses']: expected one PenPose (or None) per stroke "
                         f"({len(drawing.strokes)}), got {len(poses)} items", key="pen_poses")
    upright = PenPose()
    return None if all(p is None or p == upright for p in poses) else poses


def _pose_rows(pen: PenPath, poses, rotation: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of ``pen``: the lean u = -a / cos(theta) (page frame, u_z = 1), and the pen
    axis a and spin goal x* (NaN: free) in the robot frame (module docstring)."""
    frames = [(p or PenPose()).page_axes() for p in poses]
    axes = np.array([a for a, _ in frames])
    spins = np.array([np.full(3, np.nan) if x is None else x for _, x in frames])
    k = pen.stroke
    row_axes, row_spins = axes[k].copy(), spins[k].copy()
    travel = pen.phase == TRAVEL
    starts = np.flatnonzero(travel & ~np.roll(travel, 1))
    for start in starts:
        end = start + int(np.argmin(travel[start:])) if not travel[start:].all() else len(k)
        to = int(k[start])
        s = minimum_jerk(end - start)[:, None]
        a = (1.0 - s) * axes[to - 1] + s * axes[to]
        row_axes[start:end] = a / np.linalg.norm(a, axis=1, keepdims=True)
        if np.isnan(spins[[to - 1, to]]).any():
            row_spins[start:end] = np.nan
            continue
        from scipy.spatial.transform import Rotation, Slerp  # (only where spins are set)

        ends = Rotation.from_matrix([np.column_stack([x, np.cross(a, x), a]) for a, x in
                                     ((axes[to - 1], spins[to - 1]), (axes[to], spins[to]))])
        turned = Slerp([0.0, 1.0], ends)(s[:, 0]).as_matrix()
        row_axes[start:end], row_spins[start:end] = turned[:, :, 2], turned[:, :, 0]
    lean = -row_axes / -row_axes[:, 2:3]
    return lean, row_axes @ rotation.T, row_spins @ rotation.T


def _press_along(jac5: np.ndarray, spin: np.ndarray, lean: np.ndarray) -> np.ndarray:
    """J6^+ [-u; 0] per knot: the joint motion that moves the pen by -u (robot frame, (m, 3))
    with its orientation held; ``jac5`` (m, 5, n) the pen task Jacobians, ``spin`` (m, n) the
    spin rows z_s^T Jr."""
    jac6 = np.concatenate([jac5, spin[:, None, :]], axis=1)
    press = np.concatenate([-lean, np.zeros((len(lean), 3))], axis=1)
    A = jac6 @ jac6.transpose(0, 2, 1) + IKConfig().damping ** 2 * np.eye(6)
    return (jac6.transpose(0, 2, 1) @ np.linalg.solve(A, press[..., None]))[..., 0]


def _knots(n: int, stride: int) -> np.ndarray:
    """Every ``stride``-th index of range(n), the last one always included."""
    knots = np.arange(0, n, stride)
    return knots if len(knots) and knots[-1] == n - 1 else np.append(knots, n - 1)


class _Lerp:
    """Rows given at the indices ``knots`` (increasing), linearly interpolated to range(n):
    v_i = v_k (1 - w) + v_{k+1} w, w = (i - i_k) / (i_{k+1} - i_k); the pieces and weights
    found once for every array of rows (called with ``values`` (len(knots), ...))."""

    def __init__(self, knots: np.ndarray, n: int):
        self.n, self.single = n, len(knots) == 1
        if not self.single:
            i = np.arange(n)
            k = np.clip(np.searchsorted(knots, i, side="right") - 1, 0, len(knots) - 2)
            self.k, self.k1 = k, k + 1
            self.w = (i - knots[k]) / (knots[k + 1] - knots[k])
            self.w0 = 1.0 - self.w

    def __call__(self, values: np.ndarray) -> np.ndarray:
        if self.single:
            return np.repeat(values, self.n, axis=0)
        shape = (-1,) + (1,) * (values.ndim - 1)
        rows, after = values[self.k], values[self.k1]  # (gathered copies, scaled in place)
        rows *= self.w0.reshape(shape)
        after *= self.w.reshape(shape)
        rows += after
        return rows


def _joint_move(q0: np.ndarray, q1: np.ndarray, peak_speed: np.ndarray, dt: float) -> np.ndarray:
    """Minimum-jerk joint path from q0 to q1 on which no joint j exceeds ``peak_speed[j]``."""
    duration = PEAK_SPEED_RATIO * float(np.max(np.abs(q1 - q0) / peak_speed))
    return q0 + minimum_jerk(ticks(duration, dt))[:, None] * (q1 - q0)


def _check_speeds(qd: np.ndarray, limits: np.ndarray, names, dt: float,
                  pen_down: np.ndarray) -> None:
    """Raise JointSpeedError for the joint whose planned speed most exceeds its limit, saying
    whether the ``pen_down`` rows keep to every limit."""
    ratio = np.abs(qd) / limits
    i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    if ratio[i, j] > 1.0:
        raise JointSpeedError(
            f"the reference drives joint {names[j]} at {np.rad2deg(abs(qd[i, j])):.1f} deg/s at "
            f"t = {i * dt:.3f} s, above its {np.rad2deg(limits[j]):.1f} deg/s limit "
            f"({ratio[i, j]:.2f} x)", joint=names[j], excess=float(ratio[i, j]),
            strokes_within=not (ratio[pen_down] > 1.0).any())


# Extra slowing on top of the measured excess when a reference is slowed to its speed limits.
SPEED_MARGIN = 1.05


def plan_within_speed_limits(
    drawing: Drawing,
    model: KinematicModel,
    config: LoopConfig,
    q_start: np.ndarray,
    dt: float,
    kin: ArmKinematics | None = None,
    ik: IKConfig | None = None,
    speed_limits: np.ndarray | None = None,
) -> tuple[JointReference, tuple[str, ...]]:
    """The joint reference of ``drawing``, and notes on what was changed to plan it.

    When a joint would exceed its speed limit [rad/s] and ``config.speed_limits`` is "slow",
    the descents, lifts and travel are stretched by the excess (times 1.05), and the drawing's
    own times too unless its strokes keep to the limits (a long pen-up move, such as a probe's,
    does not slow the strokes); the plan is made again, up to three times; "refuse" raises
    :class:`JointSpeedError`. The strokes' pen poses come from ``drawing.meta["pen_poses"]``
    (:func:`pen_poses`; module docstring)."""
    kin = kin or ArmKinematics.of(model)
    depth = pen_depth_mm(config, model.pen_stiffness_n_per_mm, model.pen_travel_mm,
                         model.pen_preload_n, model.paper_stiffness_n_per_mm)
    notes: list[str] = []
    if model.paper_map is not None and config.relief_accel_mm_s2 > 0:
        drawing, note = slowed_over_relief(drawing, model.paper_map, config.relief_accel_mm_s2)
        notes += [note] if note else []
    stretch = moves_stretch = 1.0
    poses = pen_poses(drawing)
    for attempt in range(4):
        pen = sequence_pen(drawing, config, depth, dt)
        try:
            return plan_joint_reference(pen, model, config, q_start, dt, kin, ik,
                                        speed_limits, poses), tuple(notes)
        except JointSpeedError as e:
            if config.speed_limits == "refuse" or attempt == 3:
                raise
            factor = SPEED_MARGIN * e.excess
            moves_stretch *= factor
            if e.strokes_within:
                notes.append(f"slowed the pen-up moves {moves_stretch:.2f} x: {e.message}")
            else:
                stretch *= factor
                notes.append(f"slowed {stretch:.2f} x: {e.message}")
                drawing = slowed(drawing, factor)
            config = dataclasses.replace(
                config, travel_speed_mm_s=config.travel_speed_mm_s / factor,
                descend_s=config.descend_s * factor, lift_s=config.lift_s * factor)
    raise AssertionError("unreachable")


def slowed(drawing: Drawing, factor: float) -> Drawing:
    """``drawing`` with every time (and so every pause) multiplied by ``factor``."""
    strokes = [Trajectory(t=s.t * factor, pos=s.pos,
                          vel=None if s.vel is None else s.vel / factor, pressure=s.pressure)
               for s in drawing.strokes]
    return Drawing(strokes, page_size=drawing.page_size)
