"""MujocoPlant: the simulated drawing cell behind the Plant protocol.

One control period is ``substeps`` physics steps with the commanded joint torques held. Each
physics step is split MuJoCo's way: ``mj_step2`` (constraint forces, integration) then
``mj_step1`` (positions, velocities, contacts of the new state), so that between control periods
the data is evaluated at the current time and :meth:`read` returns a consistent state.

After each ``mj_step2`` the contact forces belong to the state just left (time t - h): the pen
tip's normal force comes from ``mj_contactForce`` and, while it is positive, the canvas (if any)
receives ``canvas.touch(p_mm, force_n, t)`` with the tip position in page [mm] at that same time;
``canvas.lift()`` is called once when the contact ends.

Divergence (non-finite state, a MuJoCo warning about bad qpos/qvel/qacc, or a joint faster
than ``max_joint_speed``) raises :class:`inkarm.errors.SimulationError`. MuJoCo's automatic
reset is disabled so that a diverging run cannot silently restart from the initial pose.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import mujoco
import numpy as np

from inkarm.core.plant import (
    PlantState,
        TorqueCommand,
    unsupported,
)
from inkarm.errors import InputError, SimulationError
from inkarm.sim.cell import HOME_KEY, PAPER_ORIGIN, PEN_SLIDE, PEN_TIP, Cell, build_model

_DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


_MUJOCO_LOG = logging.getLogger("inkarm.mujoco")


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warnings to the ``inkarm.mujoco`` logger instead of stdout and a
    ``MUJOCO_LOG.TXT`` in the working folder (a run's divergence is reported by
    :class:`MujocoPlant` itself, as a SimulationError)."""
    mujoco.set_mju_user_warning(_MUJOCO_LOG.warning)


def _index(addresses: list[int]) -> slice | np.ndarray:
    """A slice when the addresses are consecutive (cheaper to index with), else an array."""
    first = int(addresses[0])
    if list(addresses) == list(range(first, first + len(addresses))):
        return slice(first, first + len(addresses))
    return np.array(addresses)


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
        self._qpos_adr = _index([m.jnt_qposadr[j] for j in joint_ids])
        self._dof_adr = _index([m.jnt_dofadr[j] for j in joint_ids])
        slide = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, PEN_SLIDE)
        self._tip_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, PEN_TIP)
        self._tip_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, PEN_TIP)
        origin_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
        if min(slide, self._tip_site, self._tip_geom, origin_site) < 0:
            raise InputError(
                f"MujocoPlant: the model needs joint {PEN_SLIDE}, site and geom {PEN_TIP} and "
                f"site {PAPER_ORIGIN}"
            )
        self._slide_adr = m.jnt_qposadr[slide]
        self._contact = np.zeros(6)
        self._touching = False
        self._pen_force = 0.0
        self._closed = False

        key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(m, self.data, key)
        if q0 is not None:
            q0 = np.asarray(q0, dtype=float)
            if q0.shape != (len(joint_names),):
                raise InputError(
                    f"MujocoPlant q0: expected {len(joint_names)} angles, got shape {q0.shape}"
                )
            self.data.qpos[self._qpos_adr] = q0
        mujoco.mj_forward(m, self.data)
        # The paper is static: its frame is fixed once the model is evaluated.
        # page [mm] = (x - o) R 1000 = x (1000 R) - o (1000 R), as two operations per read.
        self._to_page = 1000.0 * self.data.site_xmat[origin_site].reshape(3, 3)
        self._page_offset = self.data.site_xpos[origin_site] @ self._to_page
        # The same map for the canvas's (x, y), on Python floats: a 3 x 2 product is cheaper
        # written out than as a numpy call (and sums in the same order, so gives the same bits).
        self._page_xy = (*self._to_page[:, :2].ravel().tolist(), *self._page_offset[:2].tolist())
        self._timestep = float(m.opt.timestep)
        # Views into MjData (its arrays never move): an attribute of MjData builds a new array
        # object at each look-up, which the per-period calls would pay for again and again.
        self._tip_xpos = self.data.site_xpos[self._tip_site]
        self._qpos = self.data.qpos
        self._qvel = self.data.qvel
        self._ctrl = self.data.ctrl
        self._warning_stats = [self.data.warning[w] for w in _DIVERGENCE_WARNINGS]
        self._warnings = self._warning_counts()
        self._warning_total = int(self._warnings.sum())

    senses = frozenset({"force", "tip", "torque"})
    commands = frozenset({"torque"})

    @property
    def dt(self) -> float:
        """Control period in [s]."""
        return self.substeps * self.model.opt.timestep

    def _warning_counts(self) -> np.ndarray:
        return np.array([w.number for w in self._warning_stats])

    def _tip_mm(self) -> np.ndarray:
        return self._tip_xpos @ self._to_page - self._page_offset

    def read(self) -> SimState:
        """The state at the current time (tip from the current kinematics, force from the last
        physics step)."""
        return SimState(
            time=self.data.time,
            q=self._qpos[self._qpos_adr].copy(),
            qd=self._qvel[self._dof_adr].copy(),
            torque=self._ctrl.copy(),
            force=self._pen_force,
            tip_mm=self._tip_mm(),
            pen_compression_mm=1000.0 * float(self._qpos[self._slide_adr]),
        )

    def command(self, command) -> None:
        """Hold the joint torques of a :class:`TorqueCommand` [N m] (clamped to the motor
        limits) until the next command. The simulated arm has no position servo nor separate
        pen actuator."""
        if type(command) is not TorqueCommand:
            raise InputError(unsupported(self, command))
        self._ctrl[:] = command.torque

    def step(self) -> None:
        """Advance one control period; feed the canvas; raise SimulationError on divergence."""
        m, d, canvas = self.model, self.data, self.canvas
        for _ in range(self.substeps):
            mujoco.mj_step2(m, d)
            force = self._tip_normal_force() if d.ncon else 0.0
            self._pen_force = force
            if force > 0.0:
                self._touching = True
                if canvas is not None:
                    # Forces and positions of this pass belong to time d.time - h.
                    canvas.touch(self._tip_page_xy(), force, d.time - self._timestep)
            elif self._touching:
                self._touching = False
                if canvas is not None:
                    canvas.lift()
            mujoco.mj_step1(m, d)
        self._check_divergence()

    def _tip_page_xy(self) -> tuple[float, float]:
        """Pen tip (x, y) in page [mm]: the first two columns of :meth:`_tip_mm`."""
        x, y, z = self._tip_xpos.tolist()
        a00, a01, a10, a11, a20, a21, o0, o1 = self._page_xy
        return a00 * x + a10 * y + a20 * z - o0, a01 * x + a11 * y + a21 * z - o1

    def _tip_normal_force(self) -> float:
        d = self.data
        force, geom, tip = 0.0, d.contact.geom, self._tip_geom
        for i in range(d.ncon):
            if geom[i, 0] == tip or geom[i, 1] == tip:
                mujoco.mj_contactForce(self.model, d, i, self._contact)
                force += self._contact[0]
        return force

    def _check_divergence(self) -> None:
        # Cheap tests first: one dot product catches NaN/inf (the comparison fails) and runaway
        # speed (the norm bounds every joint's speed), one sum any new MuJoCo warning about a
        # bad qpos/qvel/qacc; the slow path sorts out which.
        qvel, stats = self._qvel, self._warning_stats
        if (
            float(qvel @ qvel) <= self._max_speed_sq
            and stats[0].number + stats[1].number + stats[2].number == self._warning_total
        ):
            return
        d = self.data
        warnings = self._warning_counts()
        names = [w.name for w, a, b in zip(_DIVERGENCE_WARNINGS, warnings, self._warnings) if a > b]
        where = f"simulation diverged at t = {d.time:.4f} s"
        why = "unstable gains, too large a time step or absurd torques"
        if names or not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
            warned = f" (MuJoCo warned {', '.join(names)})" if names else ""
            raise SimulationError(f"{where}: non-finite or huge joint state{warned}; {why}")
        j = int(np.argmax(np.abs(d.qvel)))
        if abs(d.qvel[j]) <= self.max_joint_speed:
            return  # the norm was over the threshold, no single joint is
        joint = self.model.joint(self.model.dof_jntid[j])
        unit = "m/s" if joint.type[0] == mujoco.mjtJoint.mjJNT_SLIDE else "rad/s"
        raise SimulationError(
            f"{where}: {joint.name} moves at {abs(d.qvel[j]):.1f} {unit}, above the "
            f"{self.max_joint_speed:.1f} divergence threshold; {why}"
        )

    def close(self) -> None:
        """Zero the torques and lift the canvas pen. Idempotent."""
        if self._closed:
            return
        self.data.ctrl[:] = 0.0
        if self._touching and self.canvas is not None:
            self.canvas.lift()
        self._touching = False
        self._closed = True
