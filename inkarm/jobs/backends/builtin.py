"""Registers the built-in backends (imported by the backend registry at its first lookup),
each imported only when it is asked for: a plotter's run never imports the simulator, nor a
simulated one a serial port."""

from __future__ import annotations

from inkarm.jobs.backends import BACKENDS
from inkarm.plugins import Lazy

for _name, _path in (("sim", "inkarm.jobs.backends.sim:SimBackend"),
                     ("plotter", "inkarm.jobs.backends.plotter:PlotterBackend"),
                     ("axidraw", "inkarm.jobs.backends.axidraw:AxiDrawBackend"),
                     ("dynamixel", "inkarm.jobs.backends.dynamixel:DynamixelBackend"),
                     ("servo_sim", "inkarm.jobs.backends.sim:ServoSimBackend")):
    BACKENDS.register(_name, Lazy(_path))
