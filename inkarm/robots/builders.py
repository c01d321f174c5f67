"""From a robot profile to an editable MuJoCo model of the arm, pen mount frame included."""

from __future__ import annotations

import importlib

import mujoco

from inkarm.robots.arms import BUILDERS
from inkarm.robots.profile import RobotProfile


def arm_spec(profile: RobotProfile) -> tuple[mujoco.MjSpec, mujoco.MjsFrame]:
    """A new spec holding the arm of ``profile`` (base at the origin, z up), and the frame on its
    last link where the pen holder goes (z out of the flange). Joint ranges are the profile's
    where it gives them; every joint gets a torque motor at the profile's torque limit."""
    names, torques = profile.joint_names, profile.torque_limits.tolist()
    source = profile.model
    if source.builder is not None:
        spec = mujoco.MjSpec()
        builder = importlib.import_module(BUILDERS[source.builder])
        flange = builder.add_arm(spec, names, torques)
    else:
        from inkarm.robots.arms import menagerie

        spec = menagerie.load_spec(source.menagerie)
        flange = menagerie.fit_arm(spec, source.menagerie, names, torques, source.flange_site,
                                   source.armature, source.damping)
    for joint in profile.joints:
        if joint.range is not None:
            spec_joint = spec.joint(joint.name)
            spec_joint.range = list(joint.range)
            spec_joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    return spec, flange
