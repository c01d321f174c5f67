"""A batched plant: an ensemble of drawing cells that differ in model parameters, stepped as one
:class:`mujoco.batch.Batch` (MuJoCo 4), with the joint drives and senses vectorised over members.

Member k runs on its own compiled model (:func:`member_model`: the cell with the member's
:class:`PlantTruth` applied, as :func:`inkarm.sim.perturb.plant_model` does, plus a contact sensor
on the pen tip) through ``Batch.set_models``; the batch steps all of them on a thread pool in C,
bit for bit as a loop of ``mj_step`` over one MjData each would (``persistent=True``: one MjData
per member, so ``mjSTAGE_VEL`` after each step is ``mj_step1`` of the next, as in MujocoPlant).
Everything that :class:`inkarm.sim.plant.MujocoPlant` does per physics step in Python runs here
once for all members as (N, n) arrays: the drive law (one :class:`inkarm.sim.drive.JointDrive`,
whose arithmetic is elementwise, on (N, n) arrays)

    tau = tau_ff + K_p e + clip(I + K_i h e) + K_d (qd* - v),   e = q* + qd* (t - t_cmd) - q_m,

the encoder (quantisation, noise: each member's stream drawn from its own seed, in MujocoPlant's
order), velocity from differences or in servo units, force-sensor noise and bias, sensing delay
(a ring of the last ``d + 1`` readings) and actuation delay (commands queued for whole physics
steps). The pen force is the sum of the normal components reported by the contact
sensor (the forces of the step just taken, at the state it left: MujocoPlant's
``mj_contactForce`` after ``mj_step2``); the touches (force, tip position of that state) are
kept per member and fed to its canvas afterwards (:meth:`BatchPlant.feed`).

Stiction (:mod:`inkarm.sim.stiction`) switches each member's joint friction in its own model
after each physics step (the batch reads the caller's models at every step), as MujocoPlant
does; read-out jitter draws each member's reading ages from its own seed, as its MujocoPlant
would (:mod:`inkarm.sim.senses`).

The physics steps of a control period run in C where the extension is built
(:mod:`inkarm.sim.batch_substeps`: the same bits as the NumPy step here; stiction keeps NumPy's).

Supported truths: every model-level field, and at run time ``encoder_ticks_per_rev``,
``q_noise_rad``, ``velocity`` (all three modes), ``force_noise_n``, ``force_bias_n``,
``sensing_delay_ms``, ``readout_jitter_ms``, ``stiction_nm`` and ``actuation_delay_ms``, equal
in every member (only model-level fields may be drawn at random per member). Series elasticity
and backlash (a transmission per joint, with its own sub-stepping) are refused:
:func:`check_batchable` names the field.

Units: SI inside (MuJoCo), page [mm] for tips as in MujocoPlant.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from inkarm.errors import InputError, SimulationError
from inkarm.robots.gains import PIDGains
from inkarm.sim import perturb
from inkarm.sim.actuators import affine_drives, native_drive
from inkarm.sim.batch_substeps import substeps_for
from inkarm.sim.batch_touches import Touches
from inkarm.sim.cell import HOME_KEY, PAPER_ORIGIN, PEN_TIP, Cell
from inkarm.sim.divergence import divergence_error, route_mujoco_warnings
from inkarm.sim.drive import JointDrive
from inkarm.sim.imperfections import SERVO_VELOCITY_UNIT, PlantTruth
from inkarm.sim.lookups import address_index as _index
from inkarm.sim.relief import has_relief
from inkarm.sim.senses import JITTER_BLOCK, history_length, jitter_generator
from inkarm.sim.stiction import Stiction, stuck_window

# Run-time truths the batched plant reproduces (all members alike); the rest are refused.
RUNTIME_SUPPORTED = ("encoder_ticks_per_rev", "q_noise_rad", "velocity", "force_noise_n",
                     "force_bias_n", "sensing_delay_ms", "actuation_delay_ms",
                     "readout_jitter_ms", "stiction_nm")
RUNTIME_REFUSED = ("elasticity_nm_per_rad", "backlash_deg")
CONTACT_SLOTS = 4  # pen-tip contacts the sensor reports (a sphere on a box makes one)
_DIVERGENCE_WARNINGS = [int(w) for w in (mujoco.mjtWarning.mjWARN_BADQPOS,
                                         mujoco.mjtWarning.mjWARN_BADQVEL,
                                         mujoco.mjtWarning.mjWARN_BADQACC)]


def check_batchable(truths: list[PlantTruth], key_prefix: str = "plant") -> None:
    """Refuse truths the batched plant cannot reproduce, naming the field: series elasticity or
    backlash, or run-time fields that differ between members."""
    for truth in truths:
        for name in RUNTIME_REFUSED:
            if np.any(np.asarray(getattr(truth, name), dtype=float) != 0.0):
                raise InputError(
                    f"the batched ensemble does not simulate {name} (a transmission per joint); "
                    f"run these members one by one (inkarm.jobs.run.run)",
                    key=f"{key_prefix}.{name}", value=getattr(truth, name))
        if has_relief(truth):  # (its patch moves between a step's dynamics and collisions)
            raise InputError("the batched ensemble does not simulate paper relief; run these "
                             "members one by one (inkarm.jobs.run.run)", key=f"{key_prefix}.relief")
    first = truths[0]
    for truth in truths[1:]:
        for name in RUNTIME_SUPPORTED:
            if getattr(truth, name) != getattr(first, name):
                raise InputError(
                    f"the batched ensemble needs one {name} for every member (only model-level "
                    f"fields may differ); got {getattr(first, name)!r} and "
                    f"{getattr(truth, name)!r}", key=f"{key_prefix}.{name}",
                    value=getattr(truth, name))


def member_model(cell: Cell, truth: PlantTruth) -> mujoco.MjModel:
    """The plant's model of one member: :func:`inkarm.sim.perturb.plant_model`'s steps, with a
    contact sensor on the pen tip added before compiling (it changes no dynamics)."""
    def add_contact_sensor(spec: mujoco.MjSpec) -> None:
        spec.add_sensor(name="inkarm_pen_contact", type=mujoco.mjtSensor.mjSENS_CONTACT,
                        objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=PEN_TIP,
                        intprm=[2, 0, CONTACT_SLOTS])  # data "force", reduce "none"

    return perturb.plant_model(cell, truth, edit_spec=add_contact_sensor)


@dataclass
class BatchState:
    """What every member's devices report, (N, ...) arrays; ``time`` is shared [s], unless
    ``times`` (N,) gives each member's (read-out jitter: each reading has its own age)."""

    time: float
    q: np.ndarray
    qd: np.ndarray
    torque: np.ndarray
    force: np.ndarray
    tip_mm: np.ndarray
    times: np.ndarray | None = None


class BatchPlant:
    """N drawing cells stepped together; position commands to the joint drives only.

    Args:
        models: One model per member, all from :func:`member_model` of one cell.
        cell: The nominal cell (joint names).
        truth: The run-time truth, shared by all members (its model-level fields are ignored).
        seeds: The members' truth seeds (their measurement noise is drawn from them, as each
            member's MujocoPlant would).
        substeps: Physics steps per control period.
        drive_gains: The joint drives' gains.
        nthread: Threads of the batch (0: all CPUs).
        max_joint_speed: [rad/s] above which a member counts as diverged.
    """

    senses = frozenset({"force", "tip", "torque"})
    commands = frozenset({"position"})

    def __init__(self, models: list[mujoco.MjModel], cell: Cell, truth: PlantTruth,
                 seeds: list[int], substeps: int = 3,
                 drive_gains: PIDGains | None = None, nthread: int = 0,
                 max_joint_speed: float = 50.0):
        route_mujoco_warnings()
        check_batchable([truth])
        self.n_members = N = len(models)
        m0 = models[0]
        drive_gains = drive_gains or cell.robot.drive
        # The drives as affine actuators where MujocoPlant runs them so (on from the first
        # step: the members are commanded before they step, with no actuation delay).
        self.native = native_drive(True, truth, False)
        for m in models:
            m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.substeps = int(substeps)
        self.h = float(m0.opt.timestep)
        names = cell.robot.joint_names
        self.n = n = len(names)
        joints = [mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_JOINT, j) for j in names]
        # (slices where the addresses are consecutive: views, not copies, every step)
        self._qpos_adr = _index([m0.jnt_qposadr[j] for j in joints])
        self._dof_adr = _index([m0.jnt_dofadr[j] for j in joints])
        dof_of_actuator = {int(m0.jnt_dofadr[m0.actuator_trnid[a, 0]]): a for a in range(m0.nu)}
        dofs = np.arange(m0.nv)[self._dof_adr]
        self._arm_ctrl = _index([dof_of_actuator[int(d)] for d in dofs])
        self._limit = np.stack([m.actuator_ctrlrange[self._arm_ctrl, 1] for m in models])
        self._floor = -self._limit
        if self.native:
            for m, limit in zip(models, self._limit):
                affine_drives(m, self._arm_ctrl, drive_gains, limit)
        sensor = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_SENSOR, "inkarm_pen_contact")
        if sensor < 0:
            raise InputError("BatchPlant: the models need the pen contact sensor "
                             "(build them with inkarm.sim.batch.member_model)")
        adr = int(m0.sensor_adr[sensor])
        self._normals = slice(adr, adr + 3 * CONTACT_SLOTS, 3)
        if not nthread:
            nthread = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
                else (os.cpu_count() or 1)
        self.batch = b = mjbatch.Batch(m0, N, nthread=min(nthread, N), persistent=True)
        try:
            b.set_models(models)
        except mujoco.FatalError as e:  # e.g. a rigid sheet (stiffness 0) beside a soft one
            raise InputError(f"the members' models differ in structure, not only in parameters "
                             f"({e}); a batch needs one layout", key="plant") from None
        self._models = models
        # outputs bound before the first call (a field bound later is zero until the next)
        self._sensordata = b.bind("sensordata")
        self._actuator_force = b.bind("actuator_force")
        site_xpos, site_xmat = b.bind("site_xpos"), b.bind("site_xmat")
        b.reset(keyframe=mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY))
        self._qpos, self._qvel, self._ctrl = b.bind("qpos"), b.bind("qvel"), b.bind("ctrl")
        tip_site = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_SITE, PEN_TIP)
        origin = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
        self._tip_xpos = site_xpos[:, tip_site]
        to_page = 1000.0 * site_xmat[:, origin].reshape(N, 3, 3)
        self._to_page = to_page.copy()
        self._page_offset = np.einsum("ki,kij->kj", site_xpos[:, origin], to_page)
        self._touches = Touches(N)
        self.max_joint_speed = float(max_joint_speed)
        self._warnings = self._warning_counts()
        # The drive law is elementwise: one JointDrive runs every member's drive on (N, n)
        # arrays (members are commanded together, so the time since the set point is shared).
        self.drive = JointDrive(drive_gains, self.h)
        self._u = self._du = None
        self.drive.integral = np.zeros((N, n))
        self.drive.v = np.zeros((N, n))
        self._goal = [np.zeros((N, n)) for _ in range(3)]  # q, qd, tau_ff of the set points
        self.motor = np.zeros((N, n))
        ticks = truth.encoder_ticks_per_rev
        self.tick = 2.0 * np.pi / ticks if ticks > 0 else 0.0
        self.q_noise, self.force_noise, self.force_bias = (truth.q_noise_rad, truth.force_noise_n,
                                                           truth.force_bias_n)
        self.differences = truth.velocity == "differences"
        self.servo_units = truth.velocity == "servo"
        self.exact_q = self.tick == 0.0 and self.q_noise == 0.0
        self.sense_delay = round(truth.sensing_delay_ms / 1000.0 / self.h)
        self.jitter_steps = truth.readout_jitter_ms / 1000.0 / self.h
        self.ideal = (self.exact_q and truth.velocity == "exact" and self.force_noise == 0.0
                      and self.force_bias == 0.0 and self.sense_delay == 0
                      and self.jitter_steps == 0.0)
        self.act_delay = round(truth.actuation_delay_ms / 1000.0 / self.h)
        self._rngs = [np.random.default_rng([int(s), 0x5E45]) for s in seeds]
        self._draws, self._drawn = np.zeros((N, 0)), 0  # (blocks; the columns used so far)
        self._age_rngs = [jitter_generator(s) for s in seeds]
        self._uniforms = np.zeros((N, 0))
        self._aged: tuple[int, BatchState] | None = None
        self._queue: list = []
        self.steps = 0
        self.time = 0.0
        self.pen_force = np.zeros(N)
        self._tip_prev = self._tip_xpos.copy()
        self._sq_prev: np.ndarray | None = None
        ring = history_length(self.sense_delay, self.jitter_steps)
        self._ring_time = np.zeros(ring)
        self._ring = {k: np.zeros((ring, N, *shape)) for k, shape in
                      (("q", (n,)), ("qd", (n,)), ("torque", (n,)), ("force", ()),
                       ("tip", (3,)))}
        self._setup_stiction(truth.per_joint("stiction_nm", n), dofs)
        if not self.ideal:
            q, qd = self._qpos[:, self._qpos_adr].copy(), self._qvel[:, self._dof_adr].copy()
            self._record(q, qd)
        # every physics step in C where it can (the NumPy step below is the reference)
        self._compiled = substeps_for(self)

    def _setup_stiction(self, stiction: np.ndarray, dofs: np.ndarray) -> None:
        """Each member's joints switch their dry friction between stuck and sliding, from the
        member's own Coulomb friction (MujocoPlant's ``_setup_stiction``)."""
        self.stiction: Stiction | None = None
        self._friction_dofs = dofs
        if not stiction.any():
            return
        coulomb = np.stack([m.dof_frictionloss[dofs] for m in self._models])
        window = np.stack([stuck_window(m, dofs, c + stiction)
                           for m, c in zip(self._models, coulomb)])
        self.stiction = Stiction(coulomb, np.broadcast_to(stiction, coulomb.shape), window,
                                 self._qvel[:, self._dof_adr])
        self._set_friction(np.arange(self.n_members))
        self.batch.forward()  # (the first step's constraints with the stuck levels)

    def _set_friction(self, members: np.ndarray) -> None:
        levels = self.stiction.frictionloss()
        for k in members.tolist():
            self._models[k].dof_frictionloss[self._friction_dofs] = levels[k]

    def _normal_draws(self, k: int) -> np.ndarray:
        """(N, k) standard normals, each member's next from its own stream (the same stream,
        in the same order, as its MujocoPlant's Senses)."""
        self._reserve_draws(k)
        self._drawn += k
        return self._draws[:, self._drawn - k : self._drawn]

    def _reserve_draws(self, k: int) -> None:
        """At least ``k`` unused columns of draws (blocks of 4096 per member)."""
        if self._draws.shape[1] - self._drawn < k:
            fresh = np.stack([r.standard_normal(4096) for r in self._rngs])
            self._draws = np.concatenate([self._draws[:, self._drawn :], fresh], axis=1)
            self._drawn = 0

    def _position(self, q: np.ndarray) -> np.ndarray:
        if self.exact_q:
            return q
        if self.tick:
            q = self.tick * np.round(q / self.tick)
        if self.q_noise:
            q = q + self.q_noise * self._normal_draws(self.n)
        return q

    def _tip_mm(self) -> np.ndarray:
        x = self._tip_xpos
        return np.einsum("ki,kij->kj", x, self._to_page) - self._page_offset

    def _uniform(self) -> np.ndarray:
        """(N,) uniforms in [0, 1), each member's next from its own stream, in the blocks of
        its MujocoPlant's Senses."""
        if not self._uniforms.shape[1]:
            self._uniforms = np.stack([r.random(JITTER_BLOCK) for r in self._age_rngs])
        out, self._uniforms = self._uniforms[:, 0], self._uniforms[:, 1:]
        return out

    def _record(self, q: np.ndarray, qd: np.ndarray) -> None:
        force = self.pen_force
        if self.force_noise:
            force = force + self.force_noise * self._normal_draws(1)[:, 0]
        force = force + self.force_bias
        slot = self.steps % len(self._ring_time)
        self._ring_time[slot] = self.time
        ring = self._ring
        ring["q"][slot], ring["qd"][slot], ring["torque"][slot] = q, qd, self.motor
        ring["force"][slot], ring["tip"][slot] = force, self._tip_mm()

    def now(self) -> float:
        """The members' shared simulation time [s] (readings may be older)."""
        return self.time

    def read(self) -> BatchState:
        """Every member's reading ``sensing_delay_ms`` old (members that no longer step keep
        their last)."""
        if self.ideal:
            return BatchState(self.time, self._qpos[:, self._qpos_adr].copy(),
                              self._qvel[:, self._dof_adr].copy(), self.motor.copy(),
                              self.pen_force.copy(), self._tip_mm())
        if self.jitter_steps:
            if self._aged is None or self._aged[0] != self.steps:
                self._aged = (self.steps, self._read_aged())
            s = self._aged[1]
            return BatchState(s.time, s.q.copy(), s.qd.copy(), s.torque.copy(), s.force.copy(),
                              s.tip_mm.copy(), s.times.copy())
        slot = max(0, self.steps - self.sense_delay) % (self.sense_delay + 1)
        r = self._ring
        return BatchState(float(self._ring_time[slot]), r["q"][slot].copy(),
                          r["qd"][slot].copy(), r["torque"][slot].copy(),
                          r["force"][slot].copy(), r["tip"][slot].copy())

    def _read_aged(self) -> BatchState:
        """Each member's reading ``d + u J / h`` steps old, interpolated between the two
        recorded steps around it (:mod:`inkarm.sim.senses`, as each member's MujocoPlant)."""
        age = self.sense_delay + self._uniform() * self.jitter_steps
        back = np.floor(age)
        w = age - back
        back = back.astype(np.int64)
        size, k = len(self._ring_time), np.arange(self.n_members)
        new = np.maximum(self.steps - back, 0) % size
        old = np.maximum(self.steps - back - 1, 0) % size

        def blend(a: np.ndarray) -> np.ndarray:
            a_new, a_old = a[new, k], a[old, k]
            weight = w.reshape(-1, *([1] * (a_new.ndim - 1)))
            return a_new + weight * (a_old - a_new)

        r, t = self._ring, self._ring_time
        times = t[new] + w * (t[old] - t[new])
        return BatchState(self.time, blend(r["q"]), blend(r["qd"]), blend(r["torque"]),
                          blend(r["force"]), blend(r["tip"]), times)

    @property
    def dt(self) -> float:
        return self.substeps * self.h

    def command(self, ids: np.ndarray, q: np.ndarray, qd: np.ndarray,
                tau_ff: np.ndarray) -> None:
        """Position goals [rad], velocity [rad/s] and torque feed-forward [N m] for members
        ``ids`` (rows of the arrays), reaching their drives ``actuation_delay_ms`` later."""
        self._queue.append((self.steps + self.act_delay, ids, q, qd, tau_ff))

    def _actuate(self) -> None:
        """One physics step of the drives (MujocoPlant._actuate for every member): due
        commands, then the motor torques (or the affine drives' controls)."""
        queue, drive = self._queue, self.drive
        due = bool(queue) and queue[0][0] <= self.steps
        if not (drive.active or due):
            return
        q_meas = self._position(self._qpos[:, self._qpos_adr])
        while queue and queue[0][0] <= self.steps:
            _, who, q, qd, tau = queue.pop(0)
            for held, new in zip(self._goal, (q, qd, tau)):
                held[who] = new
            drive.set_point(*(g.copy() for g in self._goal), q_link=q_meas)
            if self.native:
                self._u, self._du = drive.affine_control()
        if self.native:
            self._ctrl[:, self._arm_ctrl] = self._u
            self._u = self._u + self._du
            drive.since += self.h
            return
        v = drive.velocity(q_meas, None if self.differences else self._qvel[:, self._dof_adr])
        tau = drive.torque(q_meas, v)
        np.maximum(tau, self._floor, out=tau)
        self.motor = np.minimum(tau, self._limit, out=tau)

    def step(self, ids: np.ndarray) -> dict[int, SimulationError]:
        """Advance members ``ids`` (sorted) one control period; keep their touches. Returns the
        members that diverged, with the error each would have raised."""
        ids = np.asarray(ids, dtype=np.int32)
        every = len(ids) == self.n_members  # (whole-array writes then: no fancy indexing)
        if self._compiled is not None:
            self._compiled.period(ids, every)
            return self._diverged(ids)
        b = self.batch
        vel = int(mujoco.mjtStage.mjSTAGE_VEL)
        for _ in range(self.substeps):
            self._actuate()
            if not self.native:
                if every:
                    self._ctrl[:, self._arm_ctrl] = self.motor
                else:
                    self._ctrl[np.ix_(ids, np.arange(self._ctrl.shape[1])[self._arm_ctrl])] = \
                        self.motor[ids]
            b.step(None if every else ids, 1, vel)
            if self.stiction is not None:
                changed = self.stiction.update(self._qvel[:, self._dof_adr])
                self._set_friction(np.flatnonzero(changed.any(axis=1)))
            if self.native:  # the drives' torques of the step just taken
                self.motor = self._actuator_force[:, self._arm_ctrl].copy()
            self.time += self.h
            force = self._sensordata[:, self._normals].sum(axis=1)
            if every:  # (the touches copy the forces and tips into their rows)
                self.pen_force = force
                self._record_touches(None, force)
                self._tip_prev = self._tip_xpos.copy()
            else:
                self.pen_force[ids] = force[ids]
                self._record_touches(ids, force)
                self._tip_prev[ids] = self._tip_xpos[ids]
            self.steps += 1
            if not self.ideal:
                q = self._qpos[:, self._qpos_adr]
                q = q.copy() if self.exact_q else self._position(q)  # (a new array either way)
                if self.differences:
                    prev = self._sq_prev if self._sq_prev is not None else q
                    self._sq_prev = q
                    qd = (q - prev) / self.h
                else:
                    qd = self._qvel[:, self._dof_adr]
                    qd = (SERVO_VELOCITY_UNIT * np.round(qd / SERVO_VELOCITY_UNIT)
                          if self.servo_units else qd.copy())
                self._record(q, qd)
        return self._diverged(ids)

    def _record_touches(self, ids: np.ndarray | None, force: np.ndarray) -> None:
        """Keep this step's pen forces and tips (N, 3) (of the state the step left:
        ``_tip_prev``, copied into the rows) of members ``ids`` (None: all)."""
        if ids is None:
            self._touches.add(self.time - self.h, True, force, self._tip_prev)
            return
        stepped = np.zeros(self.n_members, dtype=bool)
        stepped[ids] = True
        self._touches.add(self.time - self.h, stepped, np.where(stepped, force, 0.0),
                          self._tip_prev)

    def feed(self, member: int, canvas) -> None:
        """Give ``canvas`` every touch of member ``member`` so far, in order, as MujocoPlant
        gives its canvas during the run (``touch`` while the force is positive, ``lift`` when
        the contact ends, and at the end), in one ``touch_many`` call. The canvas is passive, so
        feeding it afterwards draws the same ink; an ensemble holds one page at a time."""
        self._touches.feed(member, canvas, self._to_page, self._page_offset)

    def _warning_counts(self) -> np.ndarray:
        return self.batch.warning[:, _DIVERGENCE_WARNINGS, 1].astype(np.int64)

    def _diverged(self, ids: np.ndarray) -> dict[int, SimulationError]:
        qvel = self._qvel[ids]
        warnings = self._warning_counts()
        if (np.abs(qvel) <= self.max_joint_speed).all() and (warnings == self._warnings).all():
            return {}  # (the common case in one test: a NaN fails the speed's comparison)
        new = (warnings[ids] > self._warnings[ids]).any(axis=1)
        # a joint faster than max_joint_speed, or not a number (NaN compares false)
        bad = new | ~(np.abs(qvel) <= self.max_joint_speed).all(axis=1)
        out: dict[int, SimulationError] = {}
        for k in np.flatnonzero(bad):
            m = int(ids[k])
            names = [mujoco.mjtWarning(w).name for w, a, b in
                     zip(_DIVERGENCE_WARNINGS, warnings[m], self._warnings[m]) if a > b]
            error = divergence_error(self._models[m], self.time, qvel[k], names,
                                     self.max_joint_speed, bool(np.isfinite(qvel[k]).all()))
            if error is not None:
                out[m] = error
        self._warnings = warnings
        return out

    def close(self) -> None:
        """The members' models get their own Coulomb friction back (stiction switched it)."""
        if self.stiction is not None:
            for model, coulomb in zip(self._models, self.stiction.coulomb):
                model.dof_frictionloss[self._friction_dofs] = coulomb


__all__ = [
    "RUNTIME_REFUSED",
    "RUNTIME_SUPPORTED",
    "BatchPlant",
    "BatchState",
    "check_batchable",
    "member_model",
]
