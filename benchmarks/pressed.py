"""MuJoCo alone on a run's own physics: the reference of issue 22's "the same model with the pen
pressed".

One run of a scenario with the plant's Python period (``INKARM_COMPILED=0``: the same bits as
the compiled one, whose physics steps C takes out of Python's sight) records the model as the
plant stepped it (its drives as MuJoCo's affine actuators), the state before its first physics
step, and the controls at every physics step. Replaying those controls with ``mj_step`` from that
state is the run's physics without any controller: the same trajectory, contacts and pen force
(:func:`replay_s` checks it ends where the run ended, bit for bit). The earlier reference,
the run's logged torques held over each period's steps open loop, drifts off the letter at once:
its pen touches the paper in none of the default's 2,484 physics steps (the run: 1,032), so it
left out the contact solving a drawing needs.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import time
from contextlib import contextmanager

import mujoco
import numpy as np

import inkarm.sim.plant as sim_plant
from inkarm.jobs.run import run
from inkarm.sim import compiled

STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclasses.dataclass
class Physics:
    """A run's physics: its model, the state before its first step, each step's controls, the
    state it ended in, its steps in contact, and the run's logged torques (periods, n)."""

    model: mujoco.MjModel
    start: np.ndarray
    controls: np.ndarray
    end_qpos: np.ndarray
    in_contact: int
    torques: np.ndarray

    @property
    def steps(self) -> int:
        return len(self.controls)


class _Recording:
    """The ``mujoco`` module as the plant sees it, recording what each mj_step2 gets."""

    def __init__(self):
        self.model = self.start = None
        self.controls: list[np.ndarray] = []
        self.in_contact = 0
        self.data = None

    def __getattr__(self, name):
        return getattr(mujoco, name)

    def mj_step2(self, m, d):
        if self.start is None:
            self.model, self.data = copy.deepcopy(m), d
            self.start = np.empty(mujoco.mj_stateSize(m, STATE))
            mujoco.mj_getState(m, d, self.start, STATE)
        self.controls.append(d.ctrl.copy())
        self.in_contact += d.ncon > 0
        mujoco.mj_step2(m, d)


@contextmanager
def period(kind: str):
    """The plant's period for the runs inside: "compiled" (where the extension is usable) or
    "python" (``INKARM_COMPILED=0``)."""
    saved = os.environ.get(compiled.SWITCH)
    os.environ[compiled.SWITCH] = "1" if kind == "compiled" else "0"
    try:
        yield
    finally:
        if saved is None:
            del os.environ[compiled.SWITCH]
        else:
            os.environ[compiled.SWITCH] = saved


def recorded_physics(scenario) -> Physics:
    """The physics of one run of ``scenario`` (module docstring)."""
    recording = _Recording()
    sim_plant.mujoco = recording
    try:
        with period("python"):
            result = run(scenario)
    finally:
        sim_plant.mujoco = mujoco
    return Physics(recording.model, recording.start, np.array(recording.controls),
                   recording.data.qpos.copy(), recording.in_contact, result.log.torque)


def replay_s(physics: Physics, clock=time.thread_time) -> float:
    """Time [s] on ``clock`` of ``mj_step`` through the run's controls from its start state;
    raises if it did not end where the run ended (then it is not the run's physics)."""
    m = physics.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, physics.start, STATE)
    mujoco.mj_forward(m, d)
    ctrl = d.ctrl
    start = clock()
    for u in physics.controls:
        ctrl[:] = u
        mujoco.mj_step(m, d)
    spent = clock() - start
    if not np.array_equal(d.qpos, physics.end_qpos):
        raise RuntimeError("the replay did not end where the run ended: not the run's physics")
    return spent
