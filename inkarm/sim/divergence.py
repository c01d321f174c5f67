"""When a MuJoCo simulation has diverged, and where MuJoCo's warnings go.

Divergence: a non-finite state, a MuJoCo warning about a bad qpos/qvel/qacc
(:data:`DIVERGENCE_WARNINGS`), or a joint faster than a threshold in [rad/s] (or [m/s] for a
slide joint); :func:`divergence_error` names which, as a
:class:`inkarm.errors.SimulationError`, for :class:`inkarm.sim.plant.MujocoPlant` and the
batched plant (:mod:`inkarm.sim.batch`).
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

from inkarm.errors import SimulationError

DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)
"""The MuJoCo warnings that mean a diverged state."""

_MUJOCO_LOG = logging.getLogger("inkarm.mujoco")


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warnings to the ``inkarm.mujoco`` logger instead of stdout and a
    ``MUJOCO_LOG.TXT`` in the working folder (a run's divergence is reported by
    the plant itself, as a SimulationError)."""
    mujoco.set_mju_user_warning(_MUJOCO_LOG.warning)


def divergence_error(model: mujoco.MjModel, time: float, qvel: np.ndarray, warned: list[str],
                     max_speed: float, finite: bool = True) -> SimulationError | None:
    """The error of a simulation that diverged at ``time`` [s]: MuJoCo ``warned`` of a bad
    qpos/qvel/qacc or the state is not ``finite``, else the fastest joint of ``qvel`` above
    ``max_speed`` [rad/s or m/s]; None when neither."""
    where = f"simulation diverged at t = {time:.4f} s"
    why = "unstable gains, too large a time step or absurd torques"
    if warned or not finite:
        note = f" (MuJoCo warned {', '.join(warned)})" if warned else ""
        return SimulationError(f"{where}: non-finite or huge joint state{note}; {why}")
    j = int(np.argmax(np.abs(qvel)))
    if abs(qvel[j]) <= max_speed:
        return None  # (a norm over the threshold, no single joint)
    joint = model.joint(model.dof_jntid[j])
    unit = "m/s" if joint.type[0] == mujoco.mjtJoint.mjJNT_SLIDE else "rad/s"
    return SimulationError(f"{where}: {joint.name} moves at {abs(qvel[j]):.1f} {unit}, above the "
                           f"{max_speed:.1f} divergence threshold; {why}")
