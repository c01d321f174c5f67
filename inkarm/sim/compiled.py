"""The compiled control period (``inkarm/sim/_period.c``): whether this process may use it.

The extension is built by pip from the sources when a C compiler is there (``setup.py``; it is
optional: without a compiler the install succeeds and the plant runs its Python period). It is
used only when all of these hold, else :func:`period_module` returns None and the plant runs the
Python period, which gives the same bits (tests/sim/test_compiled_period.py):

* the environment variable ``INKARM_COMPILED`` is not ``0`` (the switch for comparisons);
* the extension imports, and is of this source (``API``: an extension left from an older
  checkout is not used until it is built again);
* it was built against the ``mujoco`` version this process runs (``MUJOCO_VERSION``, recorded
  at build time: the C code reads MuJoCo's structs, whose layout is the version's);
* the loaded ``libmujoco`` answers ``mj_version()`` as the headers it was built with.

Why a fallback is taken is logged once at debug level on ``inkarm.sim.compiled``.
"""

from __future__ import annotations

import functools
import logging
from pathlib import Path

import mujoco
import numpy as np

from inkarm.core.compiled import SWITCH, extension, switched_on

_LOG = logging.getLogger(__name__)
API = 3  # (inkarm/sim/_period.c's INKARM_PERIOD_API)


def _library() -> Path | None:
    """The libmujoco shipped in the ``mujoco`` package (which its bindings have loaded)."""
    found = sorted(Path(mujoco.__file__).parent.glob("libmujoco*"))
    return found[0] if found else None


@functools.cache
def _load():
    """The bound extension module, or None (why logged once)."""
    reason = _unusable()
    if isinstance(reason, str):
        _LOG.debug("compiled period not used, the plant runs its Python period: %s", reason)
        return None
    return reason  # (the module, or None)


def _unusable():
    """The bound extension module, or why it cannot be used (a string; None: logged already)."""
    _period = extension("inkarm.sim._period", API, "compiled period", _LOG)
    if _period is None:
        return None
    if _period.MUJOCO_VERSION != mujoco.__version__:
        return (f"the extension was built for MuJoCo {_period.MUJOCO_VERSION}, "
                f"this is {mujoco.__version__}")
    library = _library()
    if library is None:
        return f"no libmujoco beside {mujoco.__file__}"
    try:
        _period.bind(str(library), mujoco.FatalError)
    except ImportError as error:
        return str(error)
    return _period


def period_module():
    """The compiled period's module (``Period``), or None: switched off with
    ``INKARM_COMPILED=0``, or not usable here (logged once, debug)."""
    return _load() if switched_on() else None


def period_for(plant):
    """The compiled period of a :class:`inkarm.sim.plant.MujocoPlant` (its drives' ramp path:
    the arm's actuators, the tip, the page map, the divergence threshold; the drives' gains for
    :func:`set_point`, as they are now, as the affine actuators take theirs), or None where the
    plant's period does more than the C one: drives not in MuJoCo, senses not ideal, stiction,
    a relief to follow (or where the extension cannot be used: :func:`period_module`)."""
    if not (plant._native and plant.senses_model.ideal and plant.stiction is None
            and plant._relief is None):
        return None
    module = period_module()
    if module is None:
        return None
    m, d = plant.model, plant.data
    arm = np.arange(m.nu)[plant._arm_ctrl].tolist()
    tip_geom = -1 if plant._only_tip_touches else plant._tip_geom
    drive = plant.drive
    gains = [x for g in (drive.kp, drive.kd, drive.ki, drive.kp_h, drive.limit)  # (_drive.h)
             for x in np.broadcast_to(g, (len(arm),)).tolist()]
    return module.Period((m, d), m._address, d._address, arm, plant._tip_site, tip_geom,
                         plant._page_map, plant.substeps, plant._max_speed_sq,
                         plant._warning_total, gains)


def set_point(period, drive, command, q_link: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``drive.set_point(command.q, command.qd, command.torque, q_link)`` then
    ``drive.affine_control()`` (:class:`inkarm.sim.drive.JointDrive`, rigid joints: the drives of
    a compiled period) with their arithmetic in one call of the compiled ``period``, the same
    bits: the drive's integral in place, its goals kept as ``set_point`` keeps them. Returns
    (u, du) [N m] as ``affine_control``."""
    q = np.ascontiguousarray(command.q, dtype=float)  # (the C call takes contiguous float64)
    qd, tau_ff, n = command.qd, command.torque, len(q)
    if n != len(drive.integral):
        raise ValueError(f"a position command for {n} joints; the drives have "
                         f"{len(drive.integral)}")
    qd = np.zeros(n) if qd is None else np.ascontiguousarray(qd, dtype=float)
    tau_ff = np.zeros(n) if tau_ff is None else np.ascontiguousarray(tau_ff, dtype=float)
    u, du = np.empty(n), np.empty(n)
    period.command(u, du, drive.integral, drive.q_goal, drive.qd_goal, q, qd, tau_ff, q_link,
                   drive.since)
    drive.q_goal, drive.qd_goal, drive.tau_ff, drive.since = q, qd, tau_ff, 0.0
    return u, du


def feed(canvas, touching: bool, steps) -> tuple[bool, float]:
    """Give ``canvas`` (or None) the calls of the Python period for the physics steps
    ``steps`` = ((force [N], x [mm], y [mm], t [s]), ...) of :meth:`Period.step`: ``touch``
    while the force is positive, ``lift`` when it ends; in one call where the canvas has
    ``touch_many`` (:meth:`inkarm.ink.canvas.Canvas.touch_many`). Returns (touching, the last
    force)."""
    if not steps:
        return touching, 0.0
    touch_many = getattr(canvas, "touch_many", None)
    if touch_many is not None:
        touch_many(steps)
    elif canvas is not None:  # a canvas with touch and lift only
        for force, x, y, t in steps:
            if force > 0.0:
                touching = True
                canvas.touch((x, y), force, t)
            elif touching:
                touching = False
                canvas.lift()
    force = steps[-1][0]
    return force > 0.0, force


class Port:
    """A :class:`inkarm.sim.plant.MujocoPlant`'s compiled period as C functions
    (``inkarm/core/_plant.h``): read, command and step without Python, for a compiled member
    (:meth:`inkarm.control.member_lane.Lane.run`). Between :meth:`enter` and :meth:`leave` the
    drives' set point, the pen's force and the canvas's rows live in the period; the plant's own
    calls are not made meanwhile. Its periods give the plant's bits (the same C arithmetic as
    :func:`set_point` and ``Period.step``; tests/control/test_member_lane.py)."""

    def __init__(self, plant):
        self.plant = plant
        m = plant.model
        self._qpos_adr = np.arange(m.nq)[plant._qpos_adr].tolist()
        self._dof_adr = np.arange(m.nv)[plant._dof_adr].tolist()

    def enter(self):
        """Hand the plant's state to its period; its port (a PyCapsule), or None where the plant
        is not where the port can take over (no position goal held by the MuJoCo drives yet, or
        commands queued)."""
        plant = self.plant
        drive, period = plant.drive, plant._period
        if period is None or not plant._affine or plant._queue or drive.q_goal is None:
            return None
        period.enter(plant._u, plant._du, drive.integral, drive.q_goal, drive.qd_goal,
                     drive.since, plant._pen_force, plant.senses_model.force_bias,
                     self._qpos_adr, self._dof_adr, plant._check_divergence)
        return period.port()

    def leave(self) -> None:
        """Take the state back: the drives' set point, the pen's force, the steps taken, and then
        the canvas's ink of those steps (the Python period's calls, in one)."""
        plant = self.plant
        q, qd, tau_ff, since, steps, rows = plant._period.leave()
        if not steps:  # (no period stepped: the plant's state is as it was handed over)
            return
        drive = plant.drive  # (a period stepped is a set point applied: all three are set)
        drive.q_goal = plant._position_goal = np.array(q)
        drive.qd_goal, drive.tau_ff, drive.since = np.array(qd), np.array(tau_ff), since
        plant._steps += steps
        plant._touching, plant._pen_force = feed(plant.canvas, plant._touching, rows)


__all__ = ["SWITCH", "Port", "feed", "period_for", "period_module", "set_point"]
