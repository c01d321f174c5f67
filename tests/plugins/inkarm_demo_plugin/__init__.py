"""inkarm_demo_plugin: a small package that adds one of each kind of inkarm plug-in, for the
tests of :mod:`inkarm.plugins` (``tests/plugins/test_plugins.py`` installs it). Its entry points,
in the group ``inkarm.plugins``::

    law.demo          = inkarm_demo_plugin.law:ScaledFeedForward
    watchdog.stop_after = inkarm_demo_plugin.watchdog:StopAfter
    ink.demo          = inkarm_demo_plugin.ink:StampInk
    robot.demo        = inkarm_demo_plugin:ROBOT
    stroke_kind.circle = inkarm_demo_plugin.circle:Circle
    backend.demo      = inkarm_demo_plugin.backend:BACKEND
"""

from pathlib import Path

ROBOT = Path(__file__).parent / "demo_arm.toml"  # a robot plug-in: its profile file
