"""Registers the built-in control laws (imported by the law registry at its first lookup), each
imported when it is first named: naming ``position`` for a plotter's scenario imports no
MuJoCo, which the arm-model laws use."""

from __future__ import annotations

from inkarm.control.laws import LAWS
from inkarm.plugins import Lazy

for _name, _path in (("position", "inkarm.control.laws.position_goals:PositionGoals"),
                     ("joint_pid", "inkarm.control.laws.joint_pid:JointPIDLaw"),
                     ("impedance", "inkarm.control.laws.impedance:Impedance"),
                     ("sensorimotor", "inkarm.control.laws.sensorimotor:Sensorimotor")):
    LAWS.register(_name, Lazy(_path))
