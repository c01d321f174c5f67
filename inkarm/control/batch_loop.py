"""The online executor of :mod:`inkarm.control.loop`, vectorised over an ensemble of plants.

N plants that differ only in their truth draw the same drawing with the same controller. The
controller's model is nominal, so the plan (:func:`plan_within_speed_limits`) and every
feed-forward term that depends only on the plan (the bias c(q*, qd*) at the reference, M(q*)
qdd*, J^T f) are computed once and shared; what depends on the measurements runs for all members
as (N, n) arrays each control period, in position mode (the default, :class:`LoopConfig`
``command = "position"``):

* the force loop dz/dt = k_F (F* - F) with its guarded search, and the settling wait at the end
  of each descent, per member (members reach the end of a descent at different times, so each
  member has its own plan row i);
* the surface estimate (:class:`SurfaceEstimate`'s ridge plane, N 3 x 3 systems at once);
* the Coulomb friction feed-forward and its adaptation (:class:`FrictionCompensation`);
* the watchdogs (:class:`Watchdog`: a member whose check fires is lifted and stops; the others go
  on).

Each member's log, fault and arithmetic are those of :func:`run_drawing` on its own plant; the
plant is any object with ``dt``, ``n_members``, ``senses``, ``read() -> state`` of (N, ...) arrays
(``time``, ``q``, ``qd``, ``torque``, ``force``, ``tip_mm``), ``command(ids, q, qd, tau_ff)`` and
``step(ids) -> {member: SimulationError}`` (:class:`inkarm.sim.batch.BatchPlant`).

Units: page [mm] and [s] at this module's surface, SI in the joint arrays.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.friction import FrictionCompensation
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.loop import _with_plan_columns, plan_within_speed_limits
from inkarm.control.probe import first_drawing_row, probe_note, with_probes, without_probes
from inkarm.control.reference import check_reachable
from inkarm.control.surface import describe_plane
from inkarm.control.watchdog import SATURATION, SPEED_TOLERANCE, Watchdog
from inkarm.core.log import APPROACH, DESCEND, DRAW, HOME, LIFT, PHASES, DrawLog
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError, RunFault
from inkarm.models.minjerk import minimum_jerk_profile
from inkarm.robots.gains import PIDGains
from inkarm.robots.kinematic import KinematicModel

RUNNING, STOPPING, DONE = 0, 1, 2


class _Surfaces:
    """N :class:`SurfaceEstimate` planes, updated together (the same arithmetic per member)."""

    def __init__(self, n: int, prior: float = 1e-3, refit_every: int = 10):
        self.normal = np.zeros((n, 3, 3))
        self.rhs = np.zeros((n, 3))
        self.ridge = np.diag([0.0, prior, prior]) + 0.0
        self.refit_every = refit_every
        self.count = np.zeros(n, dtype=np.int64)
        self.coef = np.zeros((n, 3))
        self.origin = np.zeros((n, 2))

    def height(self, x: np.ndarray, y: np.ndarray, who=slice(None)) -> np.ndarray:
        """Each member's plane (or members ``who``'s) at its (x, y) [m]; 0 before a sample."""
        a, b, c = self.coef[who].T
        origin = self.origin[who]
        h = a + b * (x - origin[:, 0]) + c * (y - origin[:, 1])
        return np.where(self.count[who] > 0, h, 0.0)

    def describe(self, m: int) -> str:
        """Member ``m``'s plane in words (:func:`describe_plane`)."""
        return describe_plane(tuple(self.coef[m].tolist()), int(self.count[m]))

    def add(self, who: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
        first = self.count[who] == 0
        self.origin[who[first], 0], self.origin[who[first], 1] = x[first], y[first]
        row = np.stack([np.ones(len(who)), x - self.origin[who, 0], y - self.origin[who, 1]], 1)
        self.normal[who] += row[:, :, None] * row[:, None, :]
        self.rhs[who] += z[:, None] * row
        self.count[who] += 1
        count = self.count[who]
        refit = who[(count == 1) | (count % self.refit_every == 0)]
        if len(refit):
            a = self.normal[refit] + self.ridge + 1e-12 * np.eye(3)
            self.coef[refit] = np.linalg.solve(a, self.rhs[refit][:, :, None])[:, :, 0]


def run_drawings(drawing: Drawing, plant, model: KinematicModel, gains: PIDGains,
                 config: LoopConfig | None = None, speed_limits: np.ndarray | None = None,
                 progress: Callable[[float, str], None] | None = None,
                 ) -> list[DrawLog | RunFault]:
    """Draw ``drawing`` (page [mm], [s]) with every member of the batched ``plant``; return
    per member its :class:`DrawLog`, or the :class:`RunFault` that stopped it (its ``log``
    attribute holds the log to the safe stop), as :func:`run_drawing` would have.

    Raises UnreachableError before moving, and InputError for a torque-mode ``config``
    (position mode only). With ``config.probe_paper`` every member probes the paper first, as
    :func:`run_drawing` does (the probe's dots lead the shared plan). ``progress(fraction,
    phase)`` is called about ten times per simulated second with the plan fraction and phase of
    the member furthest behind."""
    wall0 = _time.perf_counter()
    config = config or LoopConfig()
    if config.command != "position":
        raise InputError(f"the batched ensemble runs position commands only, not "
                         f"{config.command!r}", key="command", value=config.command,
                         choices=("position",))
    kin = ArmKinematics.of(model)
    if gains.n != kin.n:
        raise InputError(f"{gains.n} joints, but the kinematic model has {kin.n}", key="gains")
    check_reachable(drawing, model, config, kin=kin)
    probes = 0  # as in run_drawing: the probe's dots come first in the shared plan
    if config.probe_paper:
        drawing, probes = with_probes(drawing)
    N, n, dt = plant.n_members, kin.n, plant.dt
    state = plant.read()
    q_start = state.q[0]
    if not np.all(state.q == q_start):
        raise InputError("the batched ensemble needs every member at the same start pose")
    ref, notes = plan_within_speed_limits(drawing, model, config, q_start, dt, kin, None,
                                          speed_limits)
    n_ref = len(ref)
    drawing_starts = first_drawing_row(ref.stroke, probes)
    probed = [""] * N  # what each member's probe found, when it leaves its last dot
    watchdogs = [Watchdog(config, dt, kin.joint_names, gains.torque_limit, speed_limits,
                          np.column_stack([kin.lower, kin.upper])) for _ in range(N)]
    settle_ticks = round(config.settle_s / dt)
    timeout_ticks = round(config.settle_timeout_s / dt)
    stop_ticks = max(1, round(config.stop_s / dt))
    capacity = n_ref + len(ref.settle) * timeout_ticks + 2 * stop_ticks + 2
    log_time, log_force = np.zeros((N, capacity)), np.zeros((N, capacity))
    log_q, log_qd, log_torque = (np.zeros((N, capacity, n)) for _ in range(3))
    log_tip = np.zeros((N, capacity, 3))
    ref_rows = np.zeros((N, capacity), dtype=np.intp)
    ref_blend = np.zeros((N, capacity))
    k_force = config.force_gain_mm_per_ns / 1000.0 * dt
    search_step = config.search_speed_mm_s / 1000.0 * dt
    z_limit = config.correction_limit_mm / 1000.0
    f_star, threshold, settle_tol = config.force_n, config.contact_threshold_n, config.settle_tol_n
    smoothing = dt / (config.force_filter_s + dt)
    senses_force = "force" in plant.senses
    if "tip" not in plant.senses:
        raise InputError("the batched ensemble needs plants that sense the pen tip")
    q_ref, qd_ref, inertia, normal_q = ref.q, ref.qd, ref.inertia, ref.normal_q
    contact_tau, page_ref, phases = ref.contact_tau, ref.page_mm, ref.phase
    hold_at = np.zeros(n_ref, dtype=bool)
    hold_at[list(ref.settle)] = senses_force
    # The controller's model is nominal: c(q*, qd*) is the same for every member.
    bias_ref = ref.bias
    friction_estimate = np.tile(kin.model.dof_frictionloss[kin.dof_adr].astype(float), (N, 1))
    friction_ceiling = 4.0 * friction_estimate + 2.0
    friction_rate = config.friction_adaptation * dt
    travel = model.pen_travel_mm
    lookahead_rows, lookahead_frac = divmod(config.lookahead_s / dt, 1.0)
    lookahead_rows = int(lookahead_rows)
    report_every = max(1, round(0.1 / dt))

    mode = np.full(N, RUNNING)
    faults: dict[int, RunFault] = {}
    stop_from = np.zeros(N, dtype=np.intp)
    stop_k = np.zeros(N, dtype=np.intp)
    stop_q0 = np.zeros((N, n))
    stop_lift = np.zeros((N, n))
    i = np.zeros(N, dtype=np.intp)
    row = np.zeros(N, dtype=np.intp)
    waited = np.zeros(N, dtype=np.intp)
    settled_for = np.zeros(N, dtype=np.intp)
    z_corr, force_f = np.zeros(N), np.zeros(N)
    surfaces = _Surfaces(N)
    commanded: list[np.ndarray] = []  # plan row of each member at each period
    far, fast = np.zeros(N, dtype=np.intp), np.zeros(N, dtype=np.intp)
    saturated = np.zeros((N, n), dtype=np.intp)
    now = getattr(plant, "now", None)  # as in run_drawing
    t_first = now() if now is not None else None
    period = 0
    members = np.arange(N)

    def fault(m: int, err: RunFault, st, at_row: int) -> None:
        faults[m] = err
        stop_from[m] = at_row
        saturated_stop = err.watchdog in ("torque_saturated", "joint_speed")
        if saturated_stop or err.watchdog == "diverged":
            mode[m] = DONE
            return
        mode[m] = STOPPING
        stop_q0[m] = st.q[m]
        stop_lift[m] = -(config.hover_mm + travel) / 1000.0 * normal_q[min(i[m], n_ref - 1)]

    def log_rows(who: np.ndarray, st, seen: np.ndarray) -> None:
        """One log row for each of members ``who`` (while it has room)."""
        who = who[row[who] < capacity]
        r = row[who]
        log_time[who, r], log_q[who, r], log_qd[who, r] = st.time, st.q[who], st.qd[who]
        log_torque[who, r], log_tip[who, r] = st.torque[who], st.tip_mm[who]
        log_force[who, r] = st.force[who]
        ref_rows[who, r] = seen[who]
        row[who] = r + 1

    while (mode != DONE).any():
        state = plant.read()
        if t_first is None:
            t_first = state.time
        run = mode == RUNNING
        ii = np.minimum(i, n_ref - 1)
        phase = phases[ii]
        holding = hold_at[ii] & run
        commanded.append(i.copy())
        lag = max(0.0, (t_first + period * dt - state.time) / dt)
        back, frac = int(lag), lag - int(lag)
        seen = commanded[max(period - back - (frac > 0), 0)]
        seen = np.minimum(seen, n_ref - 1)
        blend = 1.0 - frac if frac > 0 else 0.0
        if senses_force:
            force = state.force
            force_f = np.where(run, force_f + smoothing * (force - force_f), force_f)
            press = run & ((phase == DRAW) | (holding & (waited > 0))
                           | ((phase == DESCEND) & (force_f > threshold)))
            touching = force_f > threshold
            z_corr = np.where(press & touching,
                              np.maximum(z_corr + k_force * (f_star - force_f), -z_limit), z_corr)
            search = press & ~touching
            z_corr = np.where(search, z_corr + search_step, z_corr)
            for m in np.flatnonzero(search & (z_corr >= z_limit)):
                fault(int(m), RunFault(
                    f"paper_not_found: no contact within {config.correction_limit_mm:g} mm "
                    f"beyond where the model puts the paper, at t = {state.time:.3f} s",
                    watchdog="paper_not_found", time_s=state.time), state, int(row[m]))
            run = mode == RUNNING
            settle = press & run & ((phase == DRAW) | holding) & \
                (np.abs(force_f - f_star) < settle_tol)
            who = np.flatnonzero(settle)
            if len(who):
                x, y = page_ref[ii[who], 0] / 1000.0, page_ref[ii[who], 1] / 1000.0
                before = surfaces.height(x, y, who)
                surfaces.add(who, x, y, before + z_corr[who])
                z_corr[who] -= surfaces.height(x, y, who) - before
        # commands of the running members
        c = np.minimum(i + lookahead_rows, n_ref - 1)
        pressing = (phase == DRAW) | (holding & (waited > 0))
        x, y = page_ref[c, 0], page_ref[c, 1]
        depth = z_corr + surfaces.height(x / 1000.0, y / 1000.0)
        q_goal = q_ref[c] + depth[:, None] * normal_q[c]
        if lookahead_frac:
            c1 = np.minimum(c + 1, n_ref - 1)
            ahead = q_goal + lookahead_frac * (q_ref[c1] - q_ref[c])
            q_goal = np.where((c + 1 < n_ref)[:, None], ahead, q_goal)
        q_then = q_ref[seen] + depth[:, None] * normal_q[seen]
        if blend:
            q_then = q_then + blend * (q_ref[np.minimum(seen + 1, n_ref - 1)] - q_ref[seen])
        direction = FrictionCompensation.direction(qd_ref[c])
        if friction_rate:
            adapted = np.clip(friction_estimate + friction_rate * (q_then - state.q) * direction,
                              0.0, friction_ceiling)
            friction_estimate = np.where(run[:, None], adapted, friction_estimate)
        feedforward = bias_ref[c] + inertia[c] + friction_estimate * direction
        feedforward = np.where(pressing[:, None], feedforward + contact_tau[c], feedforward)
        qd_goal, tau_goal = qd_ref[c].copy(), feedforward
        p = page_ref[seen]
        error = np.where((phase == APPROACH) | (phase == HOME), 0.0,
                         np.hypot(state.tip_mm[:, 0] - p[:, 0], state.tip_mm[:, 1] - p[:, 1]))
        running = np.flatnonzero(run)
        log_rows(running, state, seen)
        ref_blend[running, row[running] - 1] = blend
        # the watchdogs, vectorised; a member whose check fires gets its own Watchdog's fault
        cfg = config
        far = np.where(run & (error > cfg.tracking_limit_mm), far + 1, 0)
        candidates = run & ((force_f > cfg.force_limit_n) | (far >= watchdogs[0].patience))
        if watchdogs[0].lower is not None:
            lower, upper = watchdogs[0].lower, watchdogs[0].upper
            candidates |= run & ((state.q < lower) | (state.q > upper)).any(axis=1)
        if speed_limits is not None:
            over = (np.abs(state.qd) > SPEED_TOLERANCE * np.asarray(speed_limits)).any(axis=1)
            fast = np.where(run & over, fast + 1, 0)
            candidates |= run & (fast >= watchdogs[0].patience)
        if gains.torque_limit is not None:
            at_limit = np.abs(state.torque) >= SATURATION * np.asarray(gains.torque_limit)
            saturated = np.where(at_limit & run[:, None], saturated + 1, 0)
            candidates |= run & (saturated.max(axis=1) >= watchdogs[0].saturation_patience)
        for m in np.flatnonzero(candidates):
            wd = watchdogs[m]
            wd.far, wd.fast = int(far[m]) - 1 if far[m] else 0, max(int(fast[m]) - 1, 0)
            wd.saturated = np.maximum(saturated[m] - 1, 0)
            try:
                wd.check(state.time, state.q[m], state.qd[m], state.torque[m], force_f[m],
                         float(error[m]))
            except RunFault as err:
                fault(int(m), err, state, int(row[m]))
        # the safe stops: lift along the normal over stop_s, hold half as long again
        stopping = np.flatnonzero(mode == STOPPING)
        zero = np.zeros(n)
        for m in stopping:
            stop_k[m] += 1
            goal = stop_q0[m] + float(minimum_jerk_profile(stop_k[m] / stop_ticks)) * stop_lift[m]
            q_goal[m], qd_goal[m], tau_goal[m] = goal, zero, kin.bias(goal, zero)
            log_rows(np.array([m]), state, np.minimum(i, n_ref - 1))
        active = np.flatnonzero(mode != DONE)
        if not len(active):
            break
        plant.command(active, q_goal[active], qd_goal[active], tau_goal[active])
        diverged = plant.step(active)
        for m, err in diverged.items():
            if mode[m] == RUNNING:
                fault(m, err, state, int(row[m]))
            mode[m] = DONE
        period += 1
        for m in stopping:
            if stop_k[m] >= stop_ticks + stop_ticks // 2:
                mode[m] = DONE
        # advance the plan rows of the running members (holding at the ends of descents)
        run = mode == RUNNING
        wait = run & holding & (waited < timeout_ticks)
        waited = np.where(wait, waited + 1, waited)
        settled_for = np.where(wait, np.where(np.abs(force_f - f_star) < settle_tol,
                                              settled_for + 1, 0), settled_for)
        stay = wait & (settled_for < settle_ticks)
        advance = run & ~stay
        waited = np.where(advance, 0, waited)
        settled_for = np.where(advance, 0, settled_for)
        i = np.where(advance, i + 1, i)
        if probes:
            for m in np.flatnonzero(advance & (i == drawing_starts)):
                probed[m] = probe_note(probes, surfaces.describe(int(m)))
        mode[run & (i >= n_ref)] = DONE
        if progress is not None and period % report_every == 0 and (mode == RUNNING).any():
            last = int(i[mode == RUNNING].min())
            progress(last / n_ref, PHASES[phases[last]])
    plant.close()
    if progress is not None:
        progress(1.0, PHASES[phases[-1]])
    wall = (_time.perf_counter() - wall0) / N
    out: list[DrawLog | RunFault] = []
    for m in members:
        log = DrawLog.empty(capacity, n)
        log.time[:], log.q[:], log.qd[:], log.torque[:] = (log_time[m], log_q[m], log_qd[m],
                                                           log_torque[m])
        log.tip[:], log.force[:] = log_tip[m], log_force[m]
        result = _with_plan_columns(log, ref, ref_rows[m], int(row[m]), ref_blend[m])
        if m in faults:
            result.phase[stop_from[m]:] = LIFT
        result = without_probes(result, probes)
        result.wall_s = wall
        result.notes = (probed[m],) + notes if probed[m] else notes
        if m in faults:
            faults[m].log = result
            out.append(faults[m])
        else:
            out.append(result)
    return out


__all__ = ["run_drawings"]
