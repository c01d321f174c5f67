"""The one executor: a Drawing in page millimetres -> pen-down strokes on N >= 1 plants.

Before moving, the drawing is checked against the arm's reach and planned once, on the
controller's nominal model, as a pen path (:mod:`inkarm.control.sequencing`) and a joint
reference (:mod:`inkarm.control.reference`); every member shares that plan. Then, every control
period, each member runs the same steps:

1. read its plant;
2. shape the reference (:class:`inkarm.control.force.ForceLoop`): where the plant senses the
   pen force, the force loop moves the pen reference along the paper normal, dz/dt =
   k_F (F* - F), mapped to joints through the planned direction J5^+ (-n), with a guarded
   search when no contact is found, and the settled depths feed the paper's surface estimate;
   each descent holds until F has settled at F*; the goal leads the plan by the actuation
   latency;
3. ask its control law for the command (:mod:`inkarm.control.laws`: the executor never knows
   which law it runs);
4. check its watchdogs (:mod:`inkarm.control.watchdogs`) and log the period;

and the members are stepped together (:class:`inkarm.control.members.Members`: on hardware the
step waits for the period to pass). A member whose watchdog fires is lifted along the normal and
stops; the others go on. Each member is a generator that yields once per period, so its state
stays in local variables (this loop's Python cost per period is the budget of a hardware period)
and a member of a batch computes exactly, bit for bit, what it computes alone.

Where steps 2-4 are the built-in ones (the ``position`` law, the force loop without a learnt
field or calibrated map, no probing), they run in one C call per period
(:mod:`inkarm.control.member_lane`); where, besides, the plant is stepped alone and offers its
period in C (``compiled_port``: the simulated arm on its default path), whole periods run in C,
the plant's step included, a tenth of a simulated second at a time (one yield each: the
progress, Ctrl-C); where the members are a batch's (N, ...) arrays, one C call takes every such
member's period after its first (:mod:`inkarm.control.batch_lanes`). Every path gives the same
bits (tests/control/test_member_lane.py, test_batch_lanes.py); ``INKARM_COMPILED=0`` takes the
Python steps throughout.

Units: page [mm] and [s] at this module's surface; the page-to-robot transform
(:class:`inkarm.core.frames.PagePlacement`) converts once to SI for the kinematics.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Callable, Generator

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.force import ForceLoop
from inkarm.control.ik import IKConfig
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.laws import Controller, LawContext, LawSpec, Setpoint
from inkarm.control.member_lane import lane_for, port_of
from inkarm.control.members import Board, Members, Progress, Solo, as_members, lockstep
from inkarm.control.probe import first_drawing_row, probe_note, with_probes, without_probes
from inkarm.control.reference import JointReference, check_reachable, plan_within_speed_limits
from inkarm.control.stopping import brake, fallback_law, law_error, safe_stop
from inkarm.control.watchdogs import WatchContext, Watchdogs, WatchdogSpec
from inkarm.core.log import APPROACH, DRAW, HOME, LIFT, DrawLog
from inkarm.core.plant import Plant, TorqueCommand
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError, RunFault, SimulationError
from inkarm.robots.gains import PIDGains
from inkarm.robots.kinematic import KinematicModel


@dataclasses.dataclass(frozen=True, eq=False)
class _Shared:
    """What every member of one execution shares: the plan and what was derived from it."""

    ref: JointReference
    law_context: LawContext  # (the model, its kinematics, the config and the period)
    watch_context: WatchContext
    watchdogs: tuple[WatchdogSpec, ...]
    probes: int
    drawing_starts: int
    notes: tuple[str, ...]
    wall0: float
    # The plan's columns as each period reads them (Python lists: cheaper per period than numpy's
    # items), made once for every member.
    phases: list[int]
    hold_at: list[bool]  # rows where a descent waits for the force (if sensed)
    page_x: list[float]
    page_y: list[float]
    lookahead_rows: int
    lookahead_frac: float
    # the goal's share of the next row, only read with a fraction of a period to look ahead
    lookahead_step: np.ndarray | None
    senses_force: bool


def _plan_columns(ref: JointReference, config: LoopConfig, dt: float,
                  senses_force: bool) -> dict:
    """What every member's periods read of the plan (the :class:`_Shared` fields above)."""
    hold_at = [False] * len(ref)
    for r in ref.settle:
        hold_at[r] = senses_force
    rows, frac = divmod(config.lookahead_s / dt, 1.0)
    q_ref = ref.q
    return {"phases": ref.phase.tolist(), "hold_at": hold_at,
            "page_x": ref.page_mm[:, 0].tolist(), "page_y": ref.page_mm[:, 1].tolist(),
            "lookahead_rows": int(rows), "lookahead_frac": frac,
            "lookahead_step": frac * (q_ref[1:] - q_ref[:-1]) if frac else None,
            "senses_force": senses_force}


def execute(
    drawing: Drawing,
    plants: Plant | Members,
    model: KinematicModel,
    gains: PIDGains,
    config: LoopConfig | None = None,
    law: LawSpec | None = None,
    watchdogs: tuple[WatchdogSpec, ...] = (),
    progress: Progress = None,
    ik: IKConfig | None = None,
    speed_limits: np.ndarray | None = None,
) -> list[DrawLog | RunFault]:
    """Draw ``drawing`` (page [mm], [s]) with every member of ``plants`` (one plant, or
    :class:`Members`); return per member its :class:`DrawLog`, or the :class:`RunFault` that
    stopped it (its ``log`` attribute holds the log to the safe stop).

    ``model`` is the controller's own kinematic model (never the plant's). ``law`` (default:
    ``position``) makes one law instance per member; ``watchdogs`` are added to the built-ins.
    Raises before moving: InputError for a law whose commands the plant does not take, or
    members that do not start at one pose; UnreachableError when a point is out of reach (or a
    joint would exceed ``speed_limits`` [rad/s] with ``config.speed_limits = "refuse"``). With
    ``config.probe_paper`` the paper is probed first (:mod:`inkarm.control.probe`; the log is
    the drawing's, its notes say what the probe found). ``progress(fraction, phase)`` is called
    about ten times per simulated second, for the member furthest behind. Ctrl-C lifts every
    member's pen and raises KeyboardInterrupt with the logs so far (``logs``; ``log``: the
    first member's). The plants are left as they are at the end (the caller closes them).
    """
    wall0 = _time.perf_counter()
    config = config or LoopConfig()
    law = law or LawSpec()
    members = as_members(plants)
    plants_ = members.plants
    kin = ArmKinematics.of(model)
    if gains.n != kin.n:
        raise InputError(f"{gains.n} joints, but the kinematic model has {kin.n}", key="gains")
    first = plants_[0]
    missing = law.commands - first.commands
    if missing:
        raise InputError(f"law {law.name!r} sends {', '.join(sorted(law.commands))} commands; "
                         f"the plant takes {', '.join(sorted(first.commands))}",
                         key="controller.law", value=law.name, choices=tuple(first.commands))
    check_reachable(drawing, model, config, kin=kin, ik=ik)
    probes = 0  # the probe's dots come first in the shared plan (inkarm.control.probe)
    if config.probe_paper:
        drawing, probes = with_probes(drawing)
    states = [plant.read() for plant in plants_]
    q_start = states[0].q
    if any(not np.array_equal(s.q, q_start) for s in states[1:]):
        raise InputError("the members of an execution must start at the same pose (they "
                         "share one plan)", key="plants")
    dt = members.dt
    ref, notes = plan_within_speed_limits(drawing, model, config, q_start, dt, kin, ik,
                                          speed_limits)
    senses = frozenset(first.senses)
    shared = _Shared(
        ref=ref,
        law_context=LawContext(ref, kin, model, gains, config, dt, senses),
        watch_context=WatchContext(config, dt, tuple(kin.joint_names), gains.torque_limit,
                                   speed_limits, np.column_stack([kin.lower, kin.upper])),
        watchdogs=tuple(watchdogs), probes=probes,
        drawing_starts=first_drawing_row(ref.stroke, probes), notes=notes, wall0=wall0,
        **_plan_columns(ref, config, dt, "force" in senses))
    laws = [law.make() for _ in plants_]
    board = Board(len(plants_))
    t_first = members.now()
    # A plant stepped alone may take whole periods in C from a compiled member (Lane.run).
    ports = [port_of(plant) if type(members) is Solo else None for plant in plants_]
    runs = [_member(shared, plant, law_, m, board, t_first, port) for m, (plant, law_, port) in
            enumerate(zip(plants_, laws, ports))]
    results = lockstep(runs, members, board, len(ref), ref.phase, progress)
    if len(runs) > 1:  # the members ran at once: each one's share of the wall time
        wall = (_time.perf_counter() - wall0) / len(runs)
        for result in results:
            log = getattr(result, "log", result)
            if log is not None:
                log.wall_s = wall
    return results


def run_drawing(
    drawing: Drawing,
    plant: Plant,
    model: KinematicModel,
    gains: PIDGains,
    config: LoopConfig | None = None,
    progress: Progress = None,
    ik: IKConfig | None = None,
    speed_limits: np.ndarray | None = None,
    law: LawSpec | None = None,
    watchdogs: tuple[WatchdogSpec, ...] = (),
) -> DrawLog:
    """:func:`execute` on one plant: its :class:`DrawLog`; the :class:`RunFault` that stopped
    it is raised (with the log so far in its ``log`` attribute), and so is Ctrl-C."""
    [result] = execute(drawing, plant, model, gains, config, law, watchdogs, progress, ik,
                       speed_limits)
    if isinstance(result, RunFault):
        raise result
    return result


def _send(command: Callable, order, time: float) -> None:
    """``command(order)``: a command the plant does not take is the law's fault at ``time``
    [s] (:func:`law_error`), as a watchdog's, not a crash."""
    try:
        command(order)
    except RunFault:
        raise
    except Exception as e:
        raise law_error(e, time) from e


def _member(shared: _Shared, plant: Plant, law: Controller, member: int, board: Board,
            t_first: float | None, port=None) -> Generator[None, None, DrawLog]:
    """One member's periods (module docstring); yields after each command, returns its log or
    raises the fault that stopped it, with the log to the safe stop."""
    context = shared.law_context
    ref, kin, config = shared.ref, context.kinematics, context.config
    placement = context.model.placement
    dt = context.dt
    law.start(context)
    watchdog = Watchdogs(shared.watch_context, shared.watchdogs)
    force_loop = ForceLoop.of_model(config, dt, context.model)  # and the paper's surface
    shape, depth_at, surface = force_loop.shape, force_loop.depth, force_loop.surface
    probes, drawing_starts = shared.probes, shared.drawing_starts
    probing, probe_wall, probed = bool(probes), 0.0, ()

    settle_ticks = round(config.settle_s / dt)
    timeout_ticks = round(config.settle_timeout_s / dt)
    stop_ticks = max(1, round(config.stop_s / dt))
    log = DrawLog.empty(len(ref) + len(ref.settle) * timeout_ticks + 2 * stop_ticks + 2, kin.n)
    f_star, settle_tol = config.force_n, config.settle_tol_n
    senses_force = "force" in plant.senses
    senses_tip = "tip" in plant.senses
    # Local names and Python lists: this loop runs once per control period and its Python cost
    # is the budget. The plan's columns of the log are filled from ``ref_row`` afterwards.
    q_ref, qd_ref, qdd_ref, normal_q = ref.q, ref.qd, ref.qdd, ref.normal_q
    phases, hold_at, page_x, page_y = shared.phases, shared.hold_at, shared.page_x, shared.page_y
    if senses_force != shared.senses_force:  # (a member that senses otherwise than the first)
        hold_at = _plan_columns(ref, config, dt, senses_force)["hold_at"]
    lookahead_rows, lookahead_frac = shared.lookahead_rows, shared.lookahead_frac
    lookahead_step = shared.lookahead_step
    check, read, command, to_law = watchdog.check, plant.read, plant.command, law.command
    log_time, log_q, log_qd, log_torque = log.time, log.q, log.qd, log.torque
    log_tip, log_force = log.tip, log.force
    ref_row = [0] * len(log)  # (Python lists: cheaper per period than numpy's items)
    nan_torque = np.full(kin.n, np.nan)

    force_f = 0.0  # low-passed sensed force [N] (0 where not sensed)
    commanded = [0] * len(log)  # reference row commanded at each log row
    ref_blend = [0.0] * len(log)  # fraction of the way to the next commanded row
    row, i, waited, settled_for = 0, 0, 0, 0
    n_ref = len(ref)
    state, fresh, logged = None, False, False  # fresh: read and not commanded yet; logged
    rows = board.rows
    # Steps 2-4 compiled, where they are all the C period's (the same bits): the lane
    # writes the log and these three columns itself.
    lane = lane_for(law=law, force_loop=force_loop, watchdogs=watchdog, plan=ref, log=log,
                    plan_columns=shared.__dict__, hold_at=hold_at, senses_force=senses_force,
                    senses_tip=senses_tip, probes=probes, settle_ticks=settle_ticks,
                    timeout_ticks=timeout_ticks, dt=dt, t_first=t_first, port=port)
    chunk = 0  # whole periods in C between two of this loop's (the plant alone: Lane.run)
    if lane is not None:
        commanded, ref_row, ref_blend = lane.commanded, lane.ref_row, lane.ref_blend
        kernel = lane.kernel
        lane_period, lane_advance = kernel.period, kernel.advance
        chunk = max(1, round(0.1 / dt)) if port is not None else 0
        if board.lanes is not None and not chunk:  # (offered: a batch's C call may take it)
            board.lanes.offered[member] = kernel
    loop_wall0 = _time.perf_counter()
    try:
        while i < n_ref:
            if chunk:  # whole periods in C, the plant's step included
                ran = lane.run(chunk)
                if ran:  # (the last one's step taken: lockstep does not step the plant)
                    board.ran = ran
                    i = lane.kernel.i
                    yield
                    rows[member] = i
                    i = lane_advance()
                    continue
            state, fresh, logged = read(), True, False
            if lane is not None:  # steps 2-4 in one call (the watchdogs' faults raised)
                try:
                    order = lane_period(state)
                except lane.not_for_lane:  # (a reading it cannot take: Python from here on)
                    taken = lane.hand_over(force_loop)
                    i, row, waited, settled_for, force_f, t_first = (taken[k] for k in (
                        "i", "row", "waited", "settled_for", "force_f", "t_first"))
                    commanded, ref_row, ref_blend = (taken[k] for k in (
                        "commanded", "ref_row", "ref_blend"))
                    lane, chunk = None, 0
                    if board.lanes is not None:
                        board.lanes.offered.pop(member, None)
                else:
                    logged = True
                    _send(command, order, state.time)
                    fresh = False
                    yield
                    rows[member] = kernel.i  # (i, or where the batch's C periods left it)
                    i = lane_advance()  # (the descent's hold included)
                    continue
            # The time of the first period: the plants' clock where they have one (a reading may
            # be older: a plant used before has delayed readings from the start), else the
            # first reading's.
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
            lag = (t_first + row * dt - state.time) / dt
            whole = round(lag)
            if abs(lag - whole) < 1e-6:  # whole periods, up to the clock's rounding
                lag = float(whole)
            if lag > 0.0:
                back, frac = int(lag), lag - int(lag)
                seen = commanded[max(row - back - (frac > 0), 0)]
                blend = 1.0 - frac if frac > 0 else 0.0
            else:  # (a reading of this period's state: the common case)
                seen, blend = i, 0.0
            ref_blend[row] = blend
            pressing = phase == DRAW or (holding and waited > 0)
            if senses_force:
                force = state.force
                force_f = shape(force, state.time, phase, holding, pressing, page_x[i], page_y[i])
            else:
                force = np.nan
            # The command leads the plan by the actuation latency the user stated (the goal
            # interpolated between plan rows; the feed-forward of the nearer row).
            c = min(i + lookahead_rows, n_ref - 1)
            depth = depth_at(page_x[c], page_y[c])
            q_goal = q_row = q_ref[c] + depth * normal_q[c]
            if lookahead_frac and c + 1 < n_ref:
                q_goal = q_row + lookahead_step[c]
            try:
                order = to_law(state, Setpoint(c, q_goal, qd_ref[c], qdd_ref[c], q_row, pressing,
                                               depth, seen, blend))
            except RunFault:
                raise
            except Exception as e:  # a law's bug is a fault like a watchdog's, not a crash
                raise law_error(e, state.time) from e
            log_time[row] = state.time
            log_q[row] = state.q
            log_qd[row] = state.qd
            log_torque[row] = (order.torque if type(order) is TorqueCommand else
                               state.torque if state.torque is not None else nan_torque)
            log_tip[row] = tip
            log_force[row] = force
            ref_row[row] = seen
            row += 1
            logged = True
            # Joint-space moves (approach, home) run far above the sheet: their path is not gated.
            if phase in (APPROACH, HOME):
                error = 0.0
            elif blend:  # (the reference between two plan rows, as the log has it)
                after = min(seen + 1, n_ref - 1)
                error = math.hypot(tip[0] - page_x[seen] - blend * (page_x[after] - page_x[seen]),
                                   tip[1] - page_y[seen] - blend * (page_y[after] - page_y[seen]))
            else:
                error = math.hypot(tip[0] - page_x[seen], tip[1] - page_y[seen])
            # (watched before the command goes out: a fault's first command is the safe stop's)
            check(state.time, state.q, state.qd, state.torque, force_f, error)
            _send(command, order, state.time)
            fresh = False
            yield
            rows[member] = i
            # Hold the end of a descent until the force has settled at its set point.
            if holding and waited < timeout_ticks:
                waited += 1
                settled_for = settled_for + 1 if abs(force_f - f_star) < settle_tol else 0
                if settled_for < settle_ticks:
                    continue
            waited, settled_for = 0, 0
            i += 1
    except (RunFault, KeyboardInterrupt) as err:  # make the arm safe; keep what happened
        if lane is not None:  # (where it is, what it logged, before its fault)
            row, logged, i = lane.kernel.row, lane.kernel.logged, lane.kernel.i
            # (a reading the C took itself, run() or a batch's periods(), and did not command)
            if lane.kernel.fresh:
                fresh, state = True, plant.read()
            if state is None:  # (every period so far ran in C: a plant drawn on again)
                state = plant.read()
        board.stopping[member] = True
        if isinstance(err, KeyboardInterrupt):
            board.interrupted = True
        stop_from = row
        if state is not None and not isinstance(err, SimulationError):
            saturated = getattr(err, "watchdog", "") in ("torque_saturated", "joint_speed")
            if not saturated:  # a saturated arm is braked at once
                stopper = law if getattr(err, "watchdog", "") != "law_error" else \
                    fallback_law(plant, context)
                row, interrupted = yield from safe_stop(
                    plant, stopper, context, log, ref_row, row, min(i, n_ref - 1),
                    state if fresh else None, fresh and logged, ref, config, stop_ticks,
                    placement, kin, senses_tip, context.model.pen_travel_mm)
                if interrupted and not isinstance(err, KeyboardInterrupt):
                    board.interrupted = True  # (Ctrl-C during the stop: the others stop too)
        brake(plant)
        partial = _with_plan_columns(log, ref, ref_row, row, ref_blend)
        partial.phase[stop_from:] = LIFT
        partial = without_probes(partial, probes)
        partial.wall_s = _time.perf_counter() - shared.wall0 - probe_wall
        partial.notes = probed + shared.notes
        err.log = partial
        raise
    if lane is not None:
        row = lane.kernel.row
    result = without_probes(_with_plan_columns(log, ref, ref_row, row, ref_blend), probes)
    result.wall_s = _time.perf_counter() - shared.wall0 - probe_wall
    result.notes = probed + shared.notes
    return result


def _with_plan_columns(log: DrawLog, ref: JointReference, ref_row: list[int], k: int,
                       blend: list[float]) -> DrawLog:
    """The first ``k`` rows of ``log``, with the reference, phase and stroke of the plan rows
    ``ref_row`` filled in; the reference ``blend`` of the way to the next plan row."""
    rows = np.asarray(ref_row[:k], dtype=np.intp)
    log.reference[:k] = ref.page_mm[rows]
    w = np.asarray(blend[:k])[:, None]
    if w.any():
        after = np.minimum(rows + 1, len(ref) - 1)
        log.reference[:k] += w * (ref.page_mm[after] - ref.page_mm[rows])
    log.phase[:k] = ref.phase[rows]
    log.stroke[:k] = ref.stroke[rows]
    return log.truncated(k)


__all__ = ["execute", "run_drawing"]
