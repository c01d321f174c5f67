"""The arms built in code: ``[model] builder`` names (:mod:`inkarm.robots.profile`) and the
module of each (:func:`inkarm.robots.builders.arm_spec` builds them).

Each module has ``add_arm(spec, joint_names, torque_limits_nm) -> flange frame``: joint
torque limits in [N m]; the flange frame is where the pen holder goes. A profile checks its
builder name against this table without loading MuJoCo.
"""

BUILDERS = {"iiwa14": "inkarm.robots.arms.iiwa14", "wx250s": "inkarm.robots.arms.wx250s"}
"""Builder name -> module in :mod:`inkarm.robots.arms`."""

BUILDER_JOINTS = {"iiwa14": 7, "wx250s": 6}
"""Builder name -> the number of joints it builds (a profile must list as many)."""
