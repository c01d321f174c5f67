"""GRBL 1.1 pen plotters: G-code from drawings, a character-counting stream on pyserial,
:class:`GrblPlant` behind the Plant protocol, and a GRBL emulator on a pseudo-terminal.

Modules: :mod:`.profiles` (pen profiles as data), :mod:`.gcode` (travel order, resampling,
lines), :mod:`.gcode_parser` and :mod:`.machine` (GRBL's parser and machine), :mod:`.planner`
(junction deviation and look-ahead), :mod:`.timing` (the time estimate on that planner),
:mod:`.stream` (the sender), :mod:`.plant` (:class:`GrblPlant`), :mod:`.emulator` (the
pseudo-terminal server).
"""

from inkarm.hardware.plotter.emulator import EmulatorConfig, Fault, GrblEmulator
from inkarm.hardware.plotter.gcode import GcodeJob, drawing_to_gcode
from inkarm.hardware.plotter.machine import GrblMachine, PenConfig
from inkarm.hardware.plotter.plant import GrblPlant
from inkarm.hardware.plotter.profiles import PenProfile, load_profile
from inkarm.hardware.plotter.stream import GrblError, GrblStreamer, StatusReport
from inkarm.hardware.plotter.timing import estimate_seconds, simulate

__all__ = ["EmulatorConfig", "Fault", "GcodeJob", "GrblEmulator", "GrblError", "GrblMachine",
           "GrblPlant", "GrblStreamer", "PenConfig", "PenProfile", "StatusReport",
           "drawing_to_gcode", "estimate_seconds", "load_profile", "simulate"]
