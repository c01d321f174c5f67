"""Calibration fits: what probes and marks say about the real cell, as corrections to the
controller's belief (:class:`inkarm.robots.calibration.CellCalibration`).

- :mod:`~inkarm.control.calibration.paper`: the sheet's height map from settled probe touches;
- :mod:`~inkarm.control.calibration.kinematics`: link lengths and joint offsets from marks;
- :mod:`~inkarm.control.calibration.pen`: the pen's tool-centre point;
- :mod:`~inkarm.control.calibration.marks`: dot marks found on a canvas or a scanned sheet.

Each fit uses only what a real cell offers: joint readings, the sensed force, the ink (a
canvas in simulation, a scan of the real sheet) and the controller's own kinematic model;
never the simulated plant's truth. Import the modules by their full path.
"""
