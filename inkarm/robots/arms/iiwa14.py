"""The KUKA LBR iiwa 14 R820, built in code with :class:`mujoco.MjSpec`.

Kinematics (zero pose: arm straight up, every link frame aligned with the base frame), in [mm]:

    base -> joint 2 (shoulder)   d1 = 360     joint axes: 1 z, 2 y, 3 z, 4 -y, 5 z, 6 y, 7 z
    joint 2 -> joint 4 (elbow)   d3 = 420     (the DH twists -90, 90, 90, -90, -90, 90, 0 deg
    joint 4 -> joint 6 (wrist)   d5 = 400      of the iiwa datasheet give exactly these axes)
    joint 6 -> flange            d7 = 126

Joints 1, 3, 5 and 7 sit on the link axes, so where they are placed along them changes nothing
kinematically; they are placed as on the real links (157.5, 564.5, 964.5, 1261 mm above the
base). Masses, centres of mass and principal inertias are the published ones of the iiwa 14
description kept by the Drake project (``iiwa14_no_collision.urdf``: KUKA CAD masses, 25.6 kg
moving), rotated from its link frames into these (every link frame here is aligned with the base
at the zero pose); the centres of mass sit off the link axes as on the real arm. Joint damping,
armature and dry friction are plausible values for harmonic-drive joints (dry friction about 1 %
of the rated torque). Position, speed and torque limits are the robot profile's
(``inkarm/robots/data/iiwa14.toml``).
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco

# Body offsets along the parent link axis in [m] and joint axes, zero pose straight up.
LINK_OFFSETS_M = (0.1575, 0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081)
JOINT_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))
FLANGE_OFFSET_M = 0.045  # link 7 joint -> flange; 0.081 + 0.045 = d7 = 0.126
# Capsule length along each link (to the next joint) and radius, in [m].
LINK_LENGTHS_M = (0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081, 0.045)
LINK_RADII_M = (0.075, 0.07, 0.07, 0.065, 0.06, 0.06, 0.045)
LINK_MASSES_KG = (5.76, 6.35, 3.5, 3.5, 3.5, 1.8, 1.2)
# Centre of mass [m] and principal inertia about it [kg m^2], in the link frames here.
LINK_COMS_M = ((0.0, -0.03, 0.12), (-0.0003, 0.042, 0.059), (0.0, 0.03, 0.13),
               (0.0, -0.034, 0.067), (-0.0001, -0.021, 0.076), (0.0, 0.0004, 0.0006),
               (0.0, 0.0, 0.02))
LINK_INERTIAS = ((0.033, 0.0333, 0.0123), (0.0305, 0.0304, 0.011), (0.025, 0.0238, 0.0076),
                 (0.017, 0.0164, 0.006), (0.01, 0.0087, 0.00449), (0.0049, 0.0036, 0.0047),
                 (0.001, 0.001, 0.001))
FRICTION_NM = (2.0, 2.0, 1.2, 1.2, 0.8, 0.3, 0.3)  # dry joint friction [N m]
ARMATURE = (0.4, 0.4, 0.2, 0.2, 0.1, 0.05, 0.05)  # reflected rotor inertia [kg m^2]
DAMPING = (0.5, 0.5, 0.3, 0.3, 0.2, 0.1, 0.1)  # viscous joint friction [N m s/rad]


def add_motor(spec: mujoco.MjSpec, name: str, joint: str, torque_limit_nm: float) -> None:
    """Torque motor ``name`` on ``joint``, saturating at +-``torque_limit_nm``."""
    act = spec.add_actuator(name=name, target=joint)
    act.set_to_motor()
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [-torque_limit_nm, torque_limit_nm]


def add_arm(
    spec: mujoco.MjSpec, joint_names: Sequence[str], torque_limits_nm: Sequence[float]
) -> mujoco.MjsFrame:
    """Add the arm under ``spec.worldbody`` (base at the origin, z up) with hinge joints
    ``joint_names`` and torque motors ``motor1..7``; returns its flange frame (on link 7, z out
    of the flange). Joint ranges are left to the caller (the robot profile)."""
    world = spec.worldbody
    grey, orange = [0.85, 0.85, 0.85, 1.0], [1.0, 0.45, 0.05, 1.0]
    world.add_geom(
        name="base",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.1, LINK_OFFSETS_M[0] / 2, 0],
        pos=[0.0, 0.0, LINK_OFFSETS_M[0] / 2],
        rgba=grey,
        contype=0,
        conaffinity=0,
    )
    parent = world
    for i, name in enumerate(joint_names):
        body = parent.add_body(name=f"link{i + 1}", pos=[0.0, 0.0, LINK_OFFSETS_M[i]],
                               mass=LINK_MASSES_KG[i], ipos=LINK_COMS_M[i],
                               inertia=LINK_INERTIAS[i])
        body.explicitinertial = True
        body.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=JOINT_AXES[i],
            armature=ARMATURE[i],
            damping=[DAMPING[i], 0.0, 0.0],
            frictionloss=FRICTION_NM[i],
        )
        body.add_geom(
            name=f"link{i + 1}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, 0, 0, 0, LINK_LENGTHS_M[i]],
            size=[LINK_RADII_M[i], 0, 0],
            rgba=orange if i % 2 else grey,
            contype=0,
            conaffinity=0,
        )
        add_motor(spec, f"motor{i + 1}", name, torque_limits_nm[i])
        parent = body
    return parent.add_frame(pos=[0.0, 0.0, FLANGE_OFFSET_M])
