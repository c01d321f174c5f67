"""MujocoPlant: the simulated drawing cell behind the Plant protocol.

One control period is ``substeps`` physics steps with the commanded joint torques held. Each
physics step is split MuJoCo's way: ``mj_step2`` (constraint forces, integration) then
``mj_step1`` (positions, velocities, contacts of the new state), so that between control periods
the data is evaluated at the current time and :meth:`read` returns a consistent state. On the
default path (drives in MuJoCo, ideal senses, no stiction or relief) the whole period runs in C
when the extension is built (:mod:`inkarm.sim.compiled`; ``INKARM_COMPILED=0`` switches it
off), with the same bits.

After each ``mj_step2`` the contact forces belong to the state just left (time t - h): the pen
tip's normal force comes from ``mj_contactForce`` and, while it is positive, the canvas (if any)
receives ``canvas.touch(p_mm, force_n, t)`` with the tip position in page [mm] at that same time;
``canvas.lift()`` is called once when the contact ends.

Commands. A :class:`TorqueCommand` is held for the period. A :class:`PositionCommand` goes to
the joint drives (:class:`inkarm.sim.drive.JointDrive`, the profile's gains) which close the loop
at physics rate, as a real arm's drives do, with the command's velocity and torque feed-forward;
the plant takes position commands only when it was given ``drive_gains`` or a ``firmware``.

The plant's truth (:class:`inkarm.sim.imperfections.PlantTruth`) acts here where it is not in the
model: measurements and their ages (:mod:`inkarm.sim.senses`), an actuation delay (commands
queued for whole physics steps), stiction (:mod:`inkarm.sim.stiction`: the joints' dry friction
switched between stuck and sliding after each physics step), series elasticity and backlash
(:mod:`inkarm.sim.transmission`). When a joint's transmission mode is too fast for the time
step, the step is subdivided.

Divergence (:mod:`inkarm.sim.divergence`, a joint faster than ``max_joint_speed``) raises
:class:`inkarm.errors.SimulationError`; MuJoCo's auto-reset is off (no silent restart).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from inkarm.core.plant import PlantState, PositionCommand, TorqueCommand, unsupported
from inkarm.errors import InputError
from inkarm.robots.gains import PIDGains
from inkarm.sim.actuators import affine_drives, native_drive
from inkarm.sim.cell import HOME_KEY, PAPER_ORIGIN, PEN_SLIDE, PEN_TIP, Cell, build_model
from inkarm.sim.compiled import Port, feed, period_for, set_point
from inkarm.sim.divergence import DIVERGENCE_WARNINGS, divergence_error, route_mujoco_warnings
from inkarm.sim.drive import JointDrive
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.lookups import address_index, only_geom_touches
from inkarm.sim.perturb import relief_follower
from inkarm.sim.senses import Senses
from inkarm.sim.stiction import Stiction, stuck_window
from inkarm.sim.transmission import Transmission


@dataclass(slots=True)
class SimState(PlantState):
    """A :class:`PlantState` plus what only a simulator can measure: the pen slide's
    compression in [mm]."""

    pen_compression_mm: float = 0.0


class MujocoPlant:
    """The drawing cell in MuJoCo, driven by joint torques.

    Args:
        model: A cell model (see :mod:`inkarm.sim.cell`); built from ``config`` when None. The
            plant owns it: its auto-reset flag is switched off.
        config: Cell configuration used when ``model`` is None.
        substeps: Physics steps per control period (default 3 x 2 ms: 167 Hz control, cheap
            enough for a real-time factor above 30 with the loop in Python).
        canvas: Optional ink raster with ``touch(p_mm, force_n, t)`` and ``lift()``.
        q0: Initial arm joint angles in [rad]; the model's ``home`` keyframe when None.
        max_joint_speed: Joint speed in [rad/s] above which the run counts as diverged.
        truth: How the plant differs from the controller's model at run time (the model-level
            differences are in ``model``: :func:`inkarm.sim.perturb.plant_model`).
        drive_gains: Joint drive gains for position commands; the robot profile's ``drive``
            when None.
        firmware: A servo firmware model (``inkarm.robots.servo.ServoFirmware``-like: ``reset``,
            ``torque(goal_q, q, qd)`` in [rad], [rad/s] -> [N m]) used instead of the drive.
    """

    def __init__(
        self,
        model: mujoco.MjModel | None = None,
        cell: Cell | None = None,
        joint_names=None,
        substeps: int = 3,
        canvas=None,
        q0=None,
        max_joint_speed: float = 50.0,
        truth: PlantTruth | None = None,
        drive_gains: PIDGains | None = None,
        firmware=None,
    ):
        if int(substeps) < 1:
            raise InputError(f"MujocoPlant: substeps must be >= 1, got {substeps}")
        from inkarm.sim.cell import make_cell

        cell = cell or make_cell()
        joint_names = tuple(joint_names or cell.robot.joint_names)
        self.joint_names = joint_names
        route_mujoco_warnings()
        self.model = build_model(cell) if model is None else model
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.data = mujoco.MjData(self.model)
        self.substeps = int(substeps)
        self.canvas = canvas
        self.max_joint_speed = float(max_joint_speed)
        self._max_speed_sq = self.max_joint_speed**2
        m = self.model
        joint_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in joint_names]
        if min(joint_ids) < 0:
            raise InputError(f"MujocoPlant: the model lacks one of the joints {joint_names}")
        self._qpos_adr = address_index([m.jnt_qposadr[j] for j in joint_ids])
        self._dof_adr = address_index([m.jnt_dofadr[j] for j in joint_ids])
        slide = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, PEN_SLIDE)
        self._tip_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, PEN_TIP)
        self._tip_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, PEN_TIP)
        origin_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
        if min(slide, self._tip_site, self._tip_geom, origin_site) < 0:
            raise InputError(f"MujocoPlant: the model needs joint {PEN_SLIDE}, site and geom "
                             f"{PEN_TIP} and site {PAPER_ORIGIN}")
        self._slide_adr = m.jnt_qposadr[slide]
        self._contact = np.zeros(6)
        self._only_tip_touches = only_geom_touches(m, self._tip_geom)
        self._touching = False
        self._pen_force = 0.0
        self._closed = False

        key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(m, self.data, key)
        if q0 is not None:
            q0 = np.asarray(q0, dtype=float)
            if q0.shape != (len(joint_names),):
                raise InputError(f"MujocoPlant q0: expected {len(joint_names)} angles, got "
                                 f"shape {q0.shape}")
            self.data.qpos[self._qpos_adr] = q0
        mujoco.mj_forward(m, self.data)
        # The paper is static: its frame is fixed once the model is evaluated.
        # page [mm] = (x - o) R 1000 = x (1000 R) - o (1000 R), as two operations per read.
        self._to_page = 1000.0 * self.data.site_xmat[origin_site].reshape(3, 3)
        self._page_offset = self.data.site_xpos[origin_site] @ self._to_page
        # The same map for the canvas's (x, y), on Python floats: a 3 x 2 product is cheaper
        # written out than as a numpy call (and sums in the same order, so gives the same bits).
        self._page_map = (*self._to_page.ravel().tolist(), *self._page_offset.tolist())
        self._timestep = float(m.opt.timestep)
        # Views into MjData (its arrays never move): an attribute of MjData builds a new array
        # object at each look-up, which the per-period calls would pay for again and again.
        self._tip_xpos = self.data.site_xpos[self._tip_site]
        self._qpos = self.data.qpos
        self._qvel = self.data.qvel
        self._ctrl = self.data.ctrl
        self._actuator_force = self.data.actuator_force
        self._warning_stats = [self.data.warning[w] for w in DIVERGENCE_WARNINGS]
        self._warnings = np.array([w.number for w in self._warning_stats])
        self._warning_total = int(self._warnings.sum())
        if drive_gains is None and firmware is None:
            drive_gains = cell.robot.drive
        self._setup_truth(truth or PlantTruth(), drive_gains, firmware)
        self._relief = relief_follower(m, cell, self.truth)  # (after any mj_setConst)
        self._period = period_for(self)  # (None off the default path, or without the extension)

    def _setup_truth(self, truth: PlantTruth, drive_gains, firmware) -> None:
        m, d, n = self.model, self.data, len(self.joint_names)
        if truth.random:
            truth = truth.realised()
        self.truth = truth
        self._arm_ctrl = self._actuators_of_joints()
        self._limit = m.actuator_ctrlrange[self._arm_ctrl, 1].copy()
        dofs = np.arange(m.nv)[self._dof_adr]
        stiffness = truth.per_joint("elasticity_nm_per_rad", n)
        backlash = np.deg2rad(truth.per_joint("backlash_deg", n))
        rotor = m.dof_armature[dofs].copy()
        self.transmission = Transmission(stiffness, backlash, rotor, m.opt.timestep)
        if self.transmission:
            loose = dofs[self.transmission.joints]
            m.dof_armature[loose] = 0.0  # the rotor is the transmission's own body now
            state = d.qpos.copy(), d.qvel.copy()
            mujoco.mj_setConst(m, d)  # (which leaves d at the model's qpos0)
            d.qpos[:], d.qvel[:] = state
            mujoco.mj_forward(m, d)
            # The link side sees tau_c held over a step: keep sqrt(k / J_link) h <= 1.
            dense = np.zeros((m.nv, m.nv))
            mujoco.mj_fullM(m, d, dense)
            link_inertia = np.diag(dense)[loose]
            omega = float(np.max(np.sqrt(self.transmission.k / np.maximum(link_inertia, 1e-9))))
            split = max(1, int(np.ceil(omega * m.opt.timestep)))
            if split > 1:
                m.opt.timestep /= split
                self.substeps *= split
                self._timestep = float(m.opt.timestep)
                self.transmission = Transmission(stiffness, backlash, rotor, m.opt.timestep)
            self.transmission.reset(self._qpos[self._qpos_adr], self._qvel[self._dof_adr])
        self._setup_stiction(truth.per_joint("stiction_nm", n), dofs)
        self.senses_model = Senses(truth, n, m.opt.timestep)
        self._delay_steps = round(truth.actuation_delay_ms / 1000.0 / m.opt.timestep)
        self._queue: list = []
        self._steps = 0
        self.drive = JointDrive(drive_gains, m.opt.timestep) if drive_gains is not None else None
        if self.drive is not None and self.transmission:
            self.drive.elastic(self.transmission.joints, self.transmission.k)
        self.firmware = firmware
        if firmware is not None and hasattr(firmware, "set_period"):
            firmware.set_period(m.opt.timestep)  # the step may have been refined above
        self._position_goal: np.ndarray | None = None
        self._motor_torque = np.zeros(n)
        # On exact encoders the drive law is an affine MuJoCo actuator (see JointDrive): the
        # drives run in C, Python only ramps the set point once per physics step.
        self._native = native_drive(self.drive is not None and firmware is None, truth,
                                    bool(self.transmission))
        self._affine = False
        self._motor_params = (m.actuator_biastype[self._arm_ctrl].copy(),
                              m.actuator_biasprm[self._arm_ctrl].copy(),
                              m.actuator_ctrllimited[self._arm_ctrl].copy(),
                              m.actuator_forcelimited[self._arm_ctrl].copy(),
                              m.actuator_forcerange[self._arm_ctrl].copy())
        self._u = self._du = None
        # Torque commands on an ideal plant go straight to MuJoCo (the per-step work is skipped).
        self._fast = (self.senses_model.ideal and self._delay_steps == 0
                      and not self.transmission)
        if not self.senses_model.ideal:
            self.senses_model.record(self._snapshot(self._qpos[self._qpos_adr].copy(),
                                                    self._qvel[self._dof_adr].copy()))

    def _setup_stiction(self, stiction: np.ndarray, dofs: np.ndarray) -> None:
        """Joints with stiction switch their friction, stuck/sliding (:mod:`inkarm.sim.stiction`)."""
        self.stiction: Stiction | None = None
        self._friction_dofs = dofs
        if not stiction.any():
            return
        m, d = self.model, self.data
        coulomb = m.dof_frictionloss[dofs].copy()
        self.stiction = Stiction(coulomb, stiction, stuck_window(m, dofs, coulomb + stiction),
                                  self._qvel[self._dof_adr])
        m.dof_frictionloss[dofs] = self.stiction.frictionloss()
        mujoco.mj_forward(m, d)  # (the first step's constraints with the stuck levels)

    def _set_affine(self, on: bool) -> None:
        """Switch the arm's motors between plain torque motors and the drive law as an affine
        actuator."""
        if on:
            affine_drives(self.model, self._arm_ctrl, self.drive, self._limit)
        else:
            m, arm = self.model, self._arm_ctrl
            (m.actuator_biastype[arm], m.actuator_biasprm[arm], m.actuator_ctrllimited[arm],
             m.actuator_forcelimited[arm], m.actuator_forcerange[arm]) = self._motor_params
        self._affine = on

    senses = frozenset({"force", "tip", "torque"})

    @property
    def commands(self) -> frozenset[str]:
        """Torque always; position goals when the plant has drives or servo firmware."""
        if self.drive is not None or self.firmware is not None:
            return frozenset({"torque", "position"})
        return frozenset({"torque"})

    @property
    def dt(self) -> float:
        """Control period in [s]."""
        return self.substeps * self.model.opt.timestep

    def _actuators_of_joints(self) -> slice | np.ndarray:
        m = self.model
        dof_of_actuator = {int(m.jnt_dofadr[m.actuator_trnid[a, 0]]): a for a in range(m.nu)}
        dofs = np.arange(m.nv)[self._dof_adr]
        missing = [self.joint_names[i] for i, dof in enumerate(dofs) if dof not in dof_of_actuator]
        if missing:
            raise InputError(f"MujocoPlant: no motor drives the joints {missing}")
        return address_index([dof_of_actuator[int(dof)] for dof in dofs])

    def _tip_page(self) -> tuple[float, float, float]:
        """Pen tip (x, y, z) in page [mm], on Python floats: a 3 x 3 map is cheaper written out
        than as a numpy call (and sums in the same order as ``x @ A - o``, so gives its bits)."""
        x, y, z = self._tip_xpos.tolist()
        a00, a01, a02, a10, a11, a12, a20, a21, a22, o0, o1, o2 = self._page_map
        return (a00 * x + a10 * y + a20 * z - o0, a01 * x + a11 * y + a21 * z - o1,
                a02 * x + a12 * y + a22 * z - o2)

    def _snapshot(self, q_measured: np.ndarray, qd_reported: np.ndarray) -> SimState:
        return SimState(
            time=self.data.time,
            q=q_measured,
            qd=qd_reported,
            # (every command is clamped to the limits when it is applied)
            torque=(self._actuator_force[self._arm_ctrl] if self._affine else
                    self._motor_torque).copy(),
            force=self.senses_model.force(self._pen_force),
            tip_mm=np.array(self._tip_page()),
            pen_compression_mm=1000.0 * float(self._qpos[self._slide_adr]),
        )

    def compiled_port(self) -> Port | None:
        """Its period in C for a compiled member (:class:`Port`; None: the Python period's)."""
        return Port(self) if self._period is not None and type(self) is MujocoPlant else None

    def now(self) -> float:
        """The simulation's time [s] (a reading may be older: ``sensing_delay_ms``)."""
        return self.data.time

    def read(self) -> SimState:
        """The state at the current time as the devices report it (tip from the current
        kinematics, force from the last physics step), ``sensing_delay_ms`` old."""
        if not self.senses_model.ideal:
            return self.senses_model.latest()
        return self._snapshot(self._qpos[self._qpos_adr].copy(), self._qvel[self._dof_adr].copy())

    def command(self, command) -> None:
        """A :class:`TorqueCommand` [N m] is held until the next command (clamped to the motor
        limits); a :class:`PositionCommand` goes to the drives (or servo firmware). Either
        reaches the joints ``actuation_delay_ms`` later."""
        kind = type(command)
        if kind is not TorqueCommand and not (kind is PositionCommand and (
                self.drive is not None or self.firmware is not None)):
            raise InputError(unsupported(self, command))
        if self._fast and kind is TorqueCommand:
            self._position_goal = None
            if self._affine:
                self._set_affine(False)
            self._motor_torque = np.clip(command.torque, -self._limit, self._limit)
            self._ctrl[self._arm_ctrl] = command.torque
            return
        self._queue.append((self._steps + self._delay_steps, command))

    def _apply(self, command, q_link: np.ndarray) -> None:
        if type(command) is TorqueCommand:
            self._position_goal = None
            self._motor_torque = np.clip(command.torque, -self._limit, self._limit)
            if self._affine:
                self._set_affine(False)
        elif self.drive is not None:
            self._position_goal = command.q
            if self._period is not None:  # (set_point and affine_control in C: the same bits)
                self._u, self._du = set_point(self._period, self.drive, command, q_link)
            else:
                self.drive.set_point(command.q, command.qd, command.torque, q_link)
                if self._native:
                    self._u, self._du = self.drive.affine_control()
            if self._native and not self._affine:
                self._set_affine(True)
        else:
            self._position_goal = np.asarray(command.q, dtype=float)

    def step(self) -> None:
        """Advance one control period; feed the canvas; raise SimulationError on divergence."""
        m, d, canvas = self.model, self.data, self.canvas
        ramp = False
        if self._native:  # no actuation delay: the commands are due now
            queue = self._queue
            while queue:
                self._apply(queue.pop(0)[1], self._qpos[self._qpos_adr])
            ramp = self._affine
            ctrl, arm, u, du, drive = self._ctrl, self._arm_ctrl, self._u, self._du, self.drive
            if ramp and self._period is not None:  # the same period in C (u advanced in place)
                drive.since, suspect, steps = self._period.step(u, du, drive.since)
                self._touching, self._pen_force = feed(canvas, self._touching, steps)
                self._steps += self.substeps
                if suspect:  # (the C test is conservative: this one decides)
                    self._check_divergence()
                return
        fast = self._fast and self._position_goal is None and not self._queue
        h, senses, stiction, relief = self._timestep, self.senses_model, self.stiction, self._relief
        for _ in range(self.substeps):
            if ramp:  # the drives run in MuJoCo; the set point moves with its velocity
                ctrl[arm] = u
                u = u + du
                drive.since += h
            elif not fast:
                self._actuate()
            mujoco.mj_step2(m, d)
            force = self._tip_normal_force() if d.ncon else 0.0
            self._pen_force = force
            if force > 0.0:
                self._touching = True
                if canvas is not None:
                    # Forces and positions of this pass belong to time d.time - h.
                    canvas.touch(self._tip_page()[:2], force, d.time - h)
            elif self._touching:
                self._touching = False
                if canvas is not None:
                    canvas.lift()
            if relief is not None:
                relief.follow(d)
            mujoco.mj_step1(m, d)
            if stiction is not None and stiction.step(self._qvel[self._dof_adr].tolist()):
                m.dof_frictionloss[self._friction_dofs] = stiction.frictionloss()
            if not fast:
                self._steps += 1
                if not senses.ideal:
                    q = senses.position(self._qpos[self._qpos_adr].copy())
                    qd = senses.velocity(q, self._qvel[self._dof_adr].copy())
                    senses.record(self._snapshot(q, qd))
        if ramp:
            self._u = u
        self._check_divergence()

    def _actuate(self) -> None:
        """One physics step of the drives and transmission: due commands, motor torques,
        torques on the links."""
        queue = self._queue
        due = bool(queue) and queue[0][0] <= self._steps
        q_true = self._qpos[self._qpos_adr]
        qd_true = self._qvel[self._dof_adr]
        trans = self.transmission
        if self._position_goal is not None or due:
            senses = self.senses_model
            q_meas = senses.position(q_true if senses.exact_q else q_true.copy())
            q_link = q_meas
            if trans:  # the drives' encoders are on the motors (see JointDrive)
                q_meas = q_meas.copy()
                q_meas[trans.joints] = trans.theta
                qd_motor = qd_true.copy()
                qd_motor[trans.joints] = trans.omega
            else:
                qd_motor = qd_true
            while queue and queue[0][0] <= self._steps:
                self._apply(queue.pop(0)[1], q_link)
            if self._position_goal is not None:
                if self.drive is not None:
                    v = self.drive.velocity(q_meas, None if senses.differences else qd_motor)
                    tau = self.drive.torque(q_meas, v)
                else:
                    # (a Dynamixel's encoder is on its output shaft: the backlash is inside
                    # its loop)
                    on_output = getattr(self.firmware, "encoder_on_output", False)
                    tau = self.firmware.torque(self._position_goal,
                                               q_link if on_output else q_meas, qd_motor)
                self._motor_torque = np.minimum(np.maximum(tau, -self._limit), self._limit)
        tau = self._motor_torque
        if trans:
            j = trans.joints
            coupling = trans.advance(tau[j], q_true, qd_true)
            tau = tau.copy()
            tau[j] = 0.0
            self.data.qfrc_applied[np.arange(self.model.nv)[self._dof_adr][j]] = coupling
        self._ctrl[self._arm_ctrl] = tau

    def _tip_normal_force(self) -> float:
        m, d, contact = self.model, self.data, self._contact
        force = 0.0
        if self._only_tip_touches:  # (every contact is the tip's: no look at d.contact)
            for i in range(d.ncon):
                mujoco.mj_contactForce(m, d, i, contact)
                force += contact[0]
            return force
        geom, tip = d.contact.geom, self._tip_geom
        for i in range(d.ncon):
            if geom[i, 0] == tip or geom[i, 1] == tip:
                mujoco.mj_contactForce(m, d, i, contact)
                force += contact[0]
        return force

    def _check_divergence(self) -> None:
        # Cheap tests first: one dot product catches NaN/inf and runaway speed (the norm bounds
        # every joint's), one sum any new MuJoCo warning of a bad qpos/qvel/qacc.
        qvel, stats = self._qvel, self._warning_stats
        if (qvel.dot(qvel) <= self._max_speed_sq
                and stats[0].number + stats[1].number + stats[2].number == self._warning_total):
            return
        d, warnings = self.data, np.array([w.number for w in self._warning_stats])
        names = [w.name for w, a, b in zip(DIVERGENCE_WARNINGS, warnings, self._warnings) if a > b]
        finite = bool(np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all())
        error = divergence_error(self.model, d.time, d.qvel, names, self.max_joint_speed, finite)
        if error is not None:
            raise error

    def brake(self) -> None:
        """Engage the joint brakes (as a real arm does on a safety stop): every arm joint held
        by dry friction of 100 times its torque limit, motors off."""
        m = self.model
        dofs = np.arange(m.nv)[self._dof_adr]
        self.stiction = None  # (the brakes hold whatever the joints' state)
        m.dof_frictionloss[dofs] = 100.0 * np.maximum(self._limit, 1.0)
        if self._affine:
            self._set_affine(False)
        self._position_goal = None
        self._queue.clear()
        self._motor_torque = np.zeros(len(self.joint_names))
        self.data.ctrl[:] = 0.0
        self.data.qfrc_applied[:] = 0.0
        self._fast = False

    def close(self) -> None:
        """Zero the torques and lift the canvas pen. Idempotent."""
        if self._closed:
            return
        if self._affine:
            self._set_affine(False)
        self.data.ctrl[:] = 0.0
        if self.stiction is not None:  # (the model's own Coulomb friction back, for its next use)
            self.model.dof_frictionloss[self._friction_dofs] = self.stiction.coulomb
        self._motor_torque = np.zeros(len(self.joint_names))
        self._position_goal = None
        self._queue.clear()
        if self._touching and self.canvas is not None:
            self.canvas.lift()
        self._touching = False
        self._closed = True
