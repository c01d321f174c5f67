"""A :class:`inkarm.sim.batch.BatchPlant`'s physics steps in C (``inkarm/sim/_batch.c``): whether
this process may use them, and the plant's state handed to them.

One call of :meth:`CompiledSubsteps.period` runs a control period: per physics step the joint
drives of every member (due set points, the encoder, velocity, torque, clip), the control
write, the batch's step (``Batch.step``, called back), the pen forces, touches and tips, and
the recorded reading (encoder, velocity, force noise and bias, the ring) -- what
``BatchPlant.step`` does in NumPy, which stays the reference and gives the same bits
(tests/sim/test_batch_substeps.py): the same normals, drawn from the same pre-drawn blocks in
the same order. The C writes into the plant's own arrays, which it then keeps (it never
replaces them, as the NumPy step does).

Not covered (the plant keeps its NumPy step): stiction (friction switched in the members'
models between steps). Used only when the extension is built by pip (``setup.py``; optional),
is of this source (``API``), and the environment variable ``INKARM_COMPILED`` is not ``0``
(the switch of every compiled part); why not is logged once at debug level.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

from inkarm.core.compiled import loader, switched_on
from inkarm.sim.imperfections import SERVO_VELOCITY_UNIT

_LOG = logging.getLogger(__name__)
API = 2  # (inkarm/sim/_batch.c's INKARM_BATCH_API)


# the module, or None (why logged once)
_load = loader("inkarm.sim._batch", API, "compiled batch substeps", _LOG)


def substeps_module():
    """The extension module (``Substeps``), or None: switched off with ``INKARM_COMPILED=0``,
    or not usable here (logged once, debug)."""
    return _load() if switched_on() else None


def _indices(index, size: int) -> list[int]:
    return np.arange(size)[index].tolist()


class CompiledSubsteps:
    """The C substeps of ``plant`` (a :class:`inkarm.sim.batch.BatchPlant` just built), with
    ``module`` the extension."""

    def __init__(self, plant, module):
        self.plant = p = plant
        N, n, drive = p.n_members, p.n, p.drive
        # the arrays the C keeps writing (the NumPy step would replace them)
        p._tip_prev = np.array(p._tip_prev)
        p.pen_force = np.array(p.pen_force)
        p.motor = np.array(p.motor)
        self._goals = [np.zeros((N, n)) for _ in range(3)]
        self._prev, self._sq_prev = np.zeros((N, n)), np.zeros((N, n))
        self._u, self._du = np.zeros((N, n)), np.zeros((N, n))
        site_xpos = p.batch.bind("site_xpos")
        gains = np.ascontiguousarray(np.stack([np.broadcast_to(g, (n,)) for g in (
            drive.kp, drive.kd, drive.ki, drive.kp_h, drive.limit)]), dtype=float)  # (_drive.h)
        r = p._ring
        arrays = (p._qpos, p._qvel, p._ctrl, p._sensordata, p._actuator_force, site_xpos,
                  np.ascontiguousarray(p._floor), np.ascontiguousarray(p._limit),
                  p._to_page, p._page_offset, drive.integral, drive.v, self._prev,
                  self._sq_prev, p.motor, p.pen_force, p._tip_prev, *self._goals, self._u,
                  self._du, r["q"], r["qd"], r["torque"], r["force"], r["tip"], p._ring_time,
                  gains)
        m = p._models[0]
        tip_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "pen_tip")
        self.per_step = (0 if p.exact_q or not p.q_noise else 2 * n) + \
            (1 if p.force_noise and not p.ideal else 0)
        self.c = module.Substeps(
            arrays, _indices(p._qpos_adr, m.nq), _indices(p._dof_adr, m.nv),
            _indices(p._arm_ctrl, m.nu),
            (p._normals.start, len(range(*p._normals.indices(m.nsensordata))), tip_site),
            (N, n, p.substeps, len(p._ring_time), int(mujoco.mjtStage.mjSTAGE_VEL), p.native,
             p.exact_q, p.differences, p.servo_units, p.ideal),
            (p.h, drive.alpha, p.tick, p.q_noise, p.force_noise, p.force_bias,
             SERVO_VELOCITY_UNIT))

    def _events(self) -> tuple[list, list[list], list | None]:
        """The set points that come due in the coming period, as (substep, q, qd, tau_ff) with
        the goals held then (the queue's commands merged as ``BatchPlant._actuate`` merges
        them: all that come due at one step are one set point, the integral's once), the
        queue's entries each one merged (taken off the queue), and the goals held before (a
        copy; None where nothing came due)."""
        p, events, taken, before = self.plant, [], [], None
        queue = p._queue
        for s in range(p.substeps):
            merged = []
            while queue and queue[0][0] <= p.steps + s:
                if before is None:
                    before = [g.copy() for g in p._goal]
                entry = queue.pop(0)
                for held, new in zip(p._goal, entry[2:]):
                    held[entry[1]] = new
                merged.append(entry)
            if merged:
                events.append((s, *(np.array(g) for g in p._goal)))
                taken.append(merged)
        return events, taken, before

    def period(self, ids: np.ndarray, every: bool) -> None:
        """One control period of members ``ids`` (``every``: all of them). Where the C call
        raises (a Ctrl-C in the batch's step, an array refused), the plant keeps what the steps
        it completed did and the commands it did not reach stay queued, as the NumPy step
        leaves them."""
        p, drive, touches = self.plant, self.plant.drive, self.plant._touches
        events, taken, held = self._events()
        p._reserve_draws(p.substeps * self.per_step)
        touches.reserve(p.substeps)
        stepped = None
        if not every:
            stepped = np.zeros(p.n_members, dtype=bool)
            stepped[ids] = True
        try:
            self.c.period(
                p.batch.step, None if every else ids, stepped, events, p._draws, p._drawn,
                touches.t, touches.on, touches.force, touches.tip, touches.count, drive.since,
                p.time, p.steps, drive.active, drive.q_prev is not None,
                p._sq_prev is not None)
        except BaseException:
            applied = self.c.progress()[-1]
            if applied < len(events):  # (the goals held after the last set point applied)
                p._goal = [np.array(g) for g in events[applied - 1][1:]] if applied else held
                p._queue[:0] = [entry for merged in taken[applied:] for entry in merged]
            raise
        finally:  # (the counters are the C's after every call, whatever ended it)
            self._take(self.c.progress()[:-1])

    def _take(self, done: tuple) -> None:
        """The plant's counters and the drives' state after the physics steps ``done`` says
        were taken (:meth:`period`'s C call, or its progress when it raised)."""
        p, drive, touches = self.plant, self.plant.drive, self.plant._touches
        (drive.since, p.time, p.steps, p._drawn, touches.count, active, have_prev,
         have_sq_prev) = done
        if active:
            drive.q_goal, drive.qd_goal, drive.tau_ff = self._goals
        drive.q_prev = self._prev if have_prev else None
        p._sq_prev = self._sq_prev if have_sq_prev else None
        if p.native:
            p._u, p._du = self._u, self._du


def substeps_for(plant) -> CompiledSubsteps | None:
    """The compiled substeps of ``plant``, or None where its step does more than the C one
    (stiction) or the extension cannot be used here (:func:`substeps_module`)."""
    if plant.stiction is not None:
        return None
    module = substeps_module()
    return None if module is None else CompiledSubsteps(plant, module)


__all__ = ["API", "CompiledSubsteps", "substeps_for", "substeps_module"]
