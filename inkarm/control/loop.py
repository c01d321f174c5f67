"""The online executor: a Drawing in page millimetres -> pen-down strokes on a plant.

Before moving, the drawing is checked against the arm's reach and planned as a pen path
(:mod:`inkarm.control.sequencing`) and a joint reference (:mod:`inkarm.control.reference`);
then, every control period, the loop reads the plant, computes its command and steps the plant
(which, on hardware, waits for the period to pass):

* torque mode: the joint PID acts on the measured q, qd against the planned q*(t), qd*(t),
  with gravity and Coriolis compensation c(q, qd) evaluated at the *measured* state on the
  kinematic model, the inertial feed-forward M(q*) qdd*(t) and, while pressing, the planned
  contact force J(q*)^T f (the measured force is not fed forward: with one period of delay,
  cancelling it exactly is a positive feedback on the contact);
* position mode (plants with their own servo loop): joint goals with velocity and
  acceleration feed-forward;
* where the plant senses the pen force, it is regulated online: an integrator moves the pen
  reference along the paper normal, dz/dt = k_F (F* - F), mapped to joints through the planned
  direction J5^+ (-n). It learns where the paper really is, and each descent holds until F has
  settled at F*.

Units: page [mm] and [s] at this module's surface; the page-to-robot transform
(:class:`inkarm.core.frames.PagePlacement`) converts once to SI for the kinematics.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time as _time
from collections.abc import Callable

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.friction import FrictionCompensation
from inkarm.control.ik import IKConfig
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.pid import JointPID, PIDGains
from inkarm.control.probe import first_drawing_row, probe_note, with_probes, without_probes
from inkarm.control.reference import (
    JointReference,
    JointSpeedError,
    check_reachable,
    plan_joint_reference,
)
from inkarm.control.sequencing import pen_depth_mm, sequence_pen
from inkarm.control.surface import SurfaceEstimate
from inkarm.control.watchdog import Watchdog
from inkarm.core.log import APPROACH, DESCEND, DRAW, HOME, LIFT, PHASES, DrawLog
from inkarm.core.plant import Plant, PositionCommand, TorqueCommand
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, RunFault, SimulationError
from inkarm.models.minjerk import minimum_jerk_profile
from inkarm.robots.kinematic import KinematicModel

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
    :class:`JointSpeedError`."""
    kin = kin or ArmKinematics.of(model)
    depth = pen_depth_mm(config, model.pen_stiffness_n_per_mm, model.pen_travel_mm,
                         model.pen_preload_n, model.paper_stiffness_n_per_mm)
    notes: list[str] = []
    stretch = moves_stretch = 1.0
    for attempt in range(4):
        pen = sequence_pen(drawing, config, depth, dt)
        try:
            return plan_joint_reference(pen, model, config, q_start, dt, kin, ik,
                                        speed_limits), tuple(notes)
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


def run_drawing(
    drawing: Drawing,
    plant: Plant,
    model: KinematicModel,
    gains: PIDGains,
    config: LoopConfig | None = None,
    progress: Callable[[float, str], None] | None = None,
    ik: IKConfig | None = None,
    speed_limits: np.ndarray | None = None,
) -> DrawLog:
    """Draw ``drawing`` (page [mm], [s]) with ``plant``; return the log of every control period.

    ``model`` is the controller's own kinematic model (never the plant's): IK, the bias forces
    and the inertia come from it. Raises UnreachableError before moving when a point is out of
    reach (or a joint would exceed ``speed_limits`` [rad/s] with ``config.speed_limits =
    "refuse"``), and SimulationError (with the log so far in its ``log`` attribute) when the
    plant diverges; a KeyboardInterrupt carries the log so far the same way. With
    ``config.probe_paper`` the paper is probed first (:mod:`inkarm.control.probe`; the log is the
    drawing's, its notes say what the probe found). ``progress(fraction, phase)`` is called
    about ten times per simulated second. The plant is left as it is at the end (the caller
    closes it).
    """
    config = config or LoopConfig()
    # the paper's height along the normal, learnt while drawing (and probing)
    surface = SurfaceEstimate()
    wall0 = _time.perf_counter()
    kin = ArmKinematics.of(model)
    placement = model.placement
    if gains.n != kin.n:
        raise InputError(f"{gains.n} joints, but the kinematic model has {kin.n}", key="gains")
    check_reachable(drawing, model, config, kin=kin, ik=ik)
    probes = 0  # the probe's dots come first in the plan (inkarm.control.probe)
    if config.probe_paper:
        drawing, probes = with_probes(drawing)
    dt = plant.dt
    state = plant.read()
    ref, notes = plan_within_speed_limits(drawing, model, config, state.q, dt, kin, ik,
                                          speed_limits)
    drawing_starts = first_drawing_row(ref.stroke, probes)
    probing, probe_wall, probed = bool(probes), 0.0, ()
    pid = JointPID(gains, dt)
    watchdog = Watchdog(config, dt, kin.joint_names, gains.torque_limit, speed_limits,
                        np.column_stack([kin.lower, kin.upper]))

    settle_ticks = round(config.settle_s / dt)
    timeout_ticks = round(config.settle_timeout_s / dt)
    stop_ticks = max(1, round(config.stop_s / dt))
    log = DrawLog.empty(len(ref) + len(ref.settle) * timeout_ticks + 2 * stop_ticks + 2, kin.n)
    k_force = config.force_gain_mm_per_ns / 1000.0 * dt  # [m/N] per period
    search_step = config.search_speed_mm_s / 1000.0 * dt  # [m] per period
    z_limit = config.correction_limit_mm / 1000.0
    f_star, threshold, settle_tol = config.force_n, config.contact_threshold_n, config.settle_tol_n
    smoothing = dt / (config.force_filter_s + dt)
    torque_mode = config.command == "torque"
    if config.command not in plant.commands:
        raise InputError(f"the plant takes {', '.join(sorted(plant.commands))} commands, not "
                         f"{config.command!r}", key="command", value=config.command,
                         choices=tuple(plant.commands))
    report_every = max(1, round(0.1 / dt))
    senses_force = "force" in plant.senses
    senses_tip = "tip" in plant.senses
    # Local names and Python lists: this loop runs once per control period and its Python cost
    # is the budget. The plan's columns of the log are filled from ``ref_row`` afterwards.
    q_ref, qd_ref, qdd_ref, inertia, normal_q = ref.q, ref.qd, ref.qdd, ref.inertia, ref.normal_q
    contact_tau, page_ref, plan_bias = ref.contact_tau, ref.page_mm, ref.bias
    phases = ref.phase.tolist()
    hold_at = [False] * len(ref)  # rows where a descent waits for the force (if sensed)
    for r in ref.settle:
        hold_at[r] = senses_force
    bias, update, check = kin.bias, pid.update, watchdog.check
    read, command, step = plant.read, plant.command, plant.step
    log_time, log_q, log_qd, log_torque = log.time, log.q, log.qd, log.torque
    log_tip, log_force = log.tip, log.force
    ref_row = [0] * len(log)  # (Python lists: cheaper per period than numpy's items)
    nan_torque = np.full(kin.n, np.nan)
    friction = FrictionCompensation(kin.model.dof_frictionloss[kin.dof_adr], dt,
                                    config.friction_adaptation)
    adapt_friction = bool(friction.rate)
    # What depends on the plan row only, computed for all rows at once (the same bits as row by
    # row): the friction's direction, the feed-forward's bias and inertia terms.
    friction_direction = friction.direction(qd_ref)
    planned_torque = plan_bias + inertia

    z_corr = 0.0  # force integrator's correction along the normal, [m] (positive = deeper)
    force_f = 0.0  # low-passed sensed force [N]
    lookahead_rows, lookahead_frac = divmod(config.lookahead_s / dt, 1.0)
    lookahead_rows = int(lookahead_rows)
    lookahead_step = lookahead_frac * (q_ref[1:] - q_ref[:-1])  # goal's share of the next row
    commanded = [0] * len(log)  # reference row commanded at each log row
    ref_blend = [0.0] * len(log)  # fraction of the way to the next commanded row
    page_x, page_y = page_ref[:, 0].tolist(), page_ref[:, 1].tolist()
    row, i, waited, settled_for = 0, 0, 0, 0
    n_ref = len(ref)
    state = None
    # The time of the first period: the plant's clock where it has one (a reading may be
    # older: a plant used before has delayed readings from the start), else the first reading's.
    now = getattr(plant, "now", None)
    t_first = now() if now is not None else None
    loop_wall0 = _time.perf_counter()
    try:
        while i < n_ref:
            state = read()
            if t_first is None:
                t_first = state.time
            if probing and i >= drawing_starts:  # the pen leaves the last probe dot
                probing, probe_wall = False, _time.perf_counter() - loop_wall0
                probed = (probe_note(probes, surface.describe()),)
            phase = phases[i]
            holding = hold_at[i]
            tip = state.tip_mm if senses_tip else placement.to_page(kin.fk(state.q)[0])
            # A reading is as old as the plant's sensing delay: compare it with the plan row
            # that was current when it was taken (and the fraction of the way to the next).
            commanded[row] = i
            lag = max(0.0, (t_first + row * dt - state.time) / dt)
            back, frac = int(lag), lag - int(lag)
            seen = commanded[max(row - back - (frac > 0), 0)]
            ref_blend[row] = blend = 1.0 - frac if frac > 0 else 0.0
            if senses_force:
                force = state.force
                force_f += smoothing * (force - force_f)
                # Press with the force loop while drawing and at the end of a descent; once
                # touching, during the whole descent (the paper may be higher than believed).
                if phase == DRAW or (holding and waited > 0) or (phase == DESCEND
                                                                 and force_f > threshold):
                    if force_f > threshold:
                        z_corr = max(z_corr + k_force * (f_star - force_f), -z_limit)
                    else:  # guarded search: no paper where the model puts it; go deeper
                        z_corr += search_step
                        if z_corr >= z_limit:
                            raise RunFault(
                                f"paper_not_found: no contact within "
                                f"{config.correction_limit_mm:g} mm beyond where the model puts "
                                f"the paper, at t = {state.time:.3f} s",
                                watchdog="paper_not_found", time_s=state.time)
                    if (phase == DRAW or holding) and abs(force_f - f_star) < settle_tol:
                        x, y = page_x[i] / 1000.0, page_y[i] / 1000.0
                        before = surface.height(x, y)
                        surface.add(x, y, before + z_corr)
                        z_corr -= surface.height(x, y) - before  # the same depth, shared anew
            else:
                force = np.nan
            # The command leads the plan by the actuation latency the user stated (the goal
            # interpolated between plan rows; the feed-forward of the nearer row).
            c = min(i + lookahead_rows, n_ref - 1)
            pressing = phase == DRAW or (holding and waited > 0)
            x, y = page_x[c], page_y[c]
            depth = z_corr + surface.height(x / 1000.0, y / 1000.0)
            q_goal = q_planned = q_ref[c] + depth * normal_q[c]
            if lookahead_frac and c + 1 < n_ref:
                q_goal = q_planned + lookahead_step[c]
            if torque_mode:
                feedforward = bias(state.q, state.qd) + inertia[c]
                if pressing:
                    feedforward += contact_tau[c]
                tau = update(q_goal, state.q, state.qd, qd_ref[c], feedforward)
                command(TorqueCommand(tau))
            else:
                error = None
                if adapt_friction:  # the joint error the friction estimate learns from
                    q_then = q_planned if seen == c else q_ref[seen] + depth * normal_q[seen]
                    if blend:
                        q_then = q_then + blend * (q_ref[min(seen + 1, n_ref - 1)] - q_ref[seen])
                    error = q_then - state.q
                feedforward = planned_torque[c] + friction.torque(friction_direction[c], error)
                if pressing:
                    feedforward += contact_tau[c]
                tau = state.torque if state.torque is not None else nan_torque
                command(PositionCommand(q_goal, qd_ref[c], qdd_ref[c], feedforward))
            log_time[row] = state.time
            log_q[row] = state.q
            log_qd[row] = state.qd
            log_torque[row] = tau
            log_tip[row] = tip
            log_force[row] = force
            ref_row[row] = seen
            row += 1
            # Joint-space moves (approach, home) run far above the sheet: their path is not gated.
            error = 0.0 if phase in (APPROACH, HOME) else math.hypot(tip[0] - page_x[seen],
                                                                     tip[1] - page_y[seen])
            check(state.time, state.q, state.qd, state.torque, force_f, error)
            step()
            if progress is not None and row % report_every == 0:
                progress(i / n_ref, PHASES[phase])
            # Hold the end of a descent until the force has settled at its set point.
            if holding and waited < timeout_ticks:
                waited += 1
                settled_for = settled_for + 1 if abs(force_f - f_star) < settle_tol else 0
                if settled_for < settle_ticks:
                    continue
            waited, settled_for = 0, 0
            i += 1
    except (RunFault, KeyboardInterrupt) as err:  # make the arm safe; keep what happened
        stop_from = row
        if state is not None and not isinstance(err, SimulationError):
            with contextlib.suppress(SimulationError):
                    row = _safe_stop(plant, log, ref_row, row, min(i, n_ref - 1), state, normal_q,
                                 config, stop_ticks, torque_mode, update, bias, placement, kin,
                                 senses_tip, torque_saturated=getattr(err, "watchdog", "")
                                 in ("torque_saturated", "joint_speed"),
                                 travel_mm=model.pen_travel_mm)
        _brake(plant)
        partial = _with_plan_columns(log, ref, ref_row, row, ref_blend)
        partial.phase[stop_from:] = LIFT
        partial = without_probes(partial, probes)
        partial.wall_s = _time.perf_counter() - wall0 - probe_wall
        partial.notes = probed + notes
        err.log = partial
        raise
    result = without_probes(_with_plan_columns(log, ref, ref_row, row, ref_blend), probes)
    result.wall_s = _time.perf_counter() - wall0 - probe_wall
    result.notes = probed + notes
    if progress is not None:
        progress(1.0, PHASES[phases[-1]])
    return result


def _safe_stop(plant, log, ref_row, row, i, state, normal_q, config, ticks, torque_mode,
               update, bias, placement, kin, senses_tip, torque_saturated,
               travel_mm: float) -> int:
    """After a fault: lift the pen by ``hover_mm`` plus its travel along the paper normal from
    where the arm is, over ``stop_s``, and hold there for half as long again (commands may be
    late); logged as a lift. An arm whose torques saturated is braked at once. Returns the next
    log row."""
    if torque_saturated:
        return row
    q0 = np.asarray(state.q, dtype=float)
    lift = -(config.hover_mm + travel_mm) / 1000.0 * normal_q[i]
    zero = np.zeros_like(q0)
    for k in range(1, ticks + ticks // 2 + 1):
        goal = q0 + float(minimum_jerk_profile(k / ticks)) * lift
        state = plant.read()
        if torque_mode:
            plant.command(TorqueCommand(update(goal, state.q, state.qd, zero,
                                               bias(state.q, state.qd))))
        else:
            plant.command(PositionCommand(goal, zero, zero, bias(goal, zero).copy()))
        if row < len(log.time):
            log.time[row], log.q[row], log.qd[row] = state.time, state.q, state.qd
            log.torque[row] = state.torque if state.torque is not None else np.nan
            log.tip[row] = state.tip_mm if senses_tip else placement.to_page(kin.fk(state.q)[0])
            log.force[row] = state.force if state.force is not None else np.nan
            ref_row[row] = i
            row += 1
        plant.step()
    return row


def _brake(plant) -> None:
    """Hold the arm where it is: the plant's brakes where it has them."""
    brake = getattr(plant, "brake", None)
    if brake is not None:
        brake()


def _with_plan_columns(log: DrawLog, ref: JointReference, ref_row: list[int], k: int,
                       blend: list[float] | None = None) -> DrawLog:
    """The first ``k`` rows of ``log``, with the reference, phase and stroke of the plan rows
    ``ref_row`` filled in; the reference ``blend`` of the way to the next plan row."""
    rows = np.asarray(ref_row[:k], dtype=np.intp)
    log.reference[:k] = ref.page_mm[rows]
    w = None if blend is None else np.asarray(blend[:k])[:, None]
    if w is not None and w.any():
        after = np.minimum(rows + 1, len(ref) - 1)
        log.reference[:k] += w * (ref.page_mm[after] - ref.page_mm[rows])
    log.phase[:k] = ref.phase[rows]
    log.stroke[:k] = ref.stroke[rows]
    return log.truncated(k)


__all__ = ["LoopConfig", "plan_within_speed_limits", "run_drawing", "slowed"]
