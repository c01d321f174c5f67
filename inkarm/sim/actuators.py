"""The joint drives as MuJoCo actuators: when they can run in C, and how.

On exact encoders the drive law of :class:`inkarm.sim.drive.JointDrive`, tau = u - K_p q -
K_d qd [N m], is an affine MuJoCo actuator (:func:`affine_drives`), so the drives run inside
the physics step and Python only ramps the set point; :func:`native_drive` says when a plant
may do so.
"""

from __future__ import annotations

import mujoco
import numpy as np

from inkarm.sim.imperfections import PlantTruth


def native_drive(has_drive: bool, truth: PlantTruth, has_transmission: bool) -> bool:
    """Whether the joint drives run as MuJoCo actuators (see
    :class:`inkarm.sim.drive.JointDrive`): exact encoders and velocity (the actuator sees the
    true state), no transmission between motor and link, and no actuation delay (so that the
    drives are on from the first physics step, as a batch of such plants has them)."""
    return (has_drive and not has_transmission and truth.encoder_ticks_per_rev == 0
            and truth.q_noise_rad == 0.0 and truth.velocity == "exact"
            and truth.actuation_delay_ms == 0.0)


def affine_drives(model: mujoco.MjModel, actuators, gains, limit: np.ndarray) -> None:
    """Make the torque motors ``actuators`` the drive law tau = u - K_p q - K_d qd (``gains``
    K_p [N m/rad], K_d [N m s/rad]), clamped to +-``limit`` [N m], integrated by Euler: a
    digital drive samples v and holds its torque for the step, so its damping is explicit
    (implicitfast would treat it as an analogue damper: 0.07 instead of 0.05 mm on the default
    letter). The cell has no other velocity-dependent force where the two integrators differ
    (joint damping is implicit in both)."""
    model.actuator_biastype[actuators] = mujoco.mjtBias.mjBIAS_AFFINE
    prm = np.zeros_like(model.actuator_biasprm[actuators])
    prm[:, 1], prm[:, 2] = -np.asarray(gains.kp), -np.asarray(gains.kd)
    model.actuator_biasprm[actuators] = prm
    model.actuator_ctrllimited[actuators] = 0
    model.actuator_forcelimited[actuators] = 1
    model.actuator_forcerange[actuators] = np.column_stack([-limit, limit])
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
