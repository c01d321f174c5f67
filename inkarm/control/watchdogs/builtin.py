"""Registers the built-in watchdogs (imported by the watchdog registry at its first lookup)."""

from __future__ import annotations

from inkarm.control.watchdogs import WATCHDOGS
from inkarm.control.watchdogs.force_limit import ForceLimit
from inkarm.control.watchdogs.joint_limit import JointLimit
from inkarm.control.watchdogs.joint_speed import JointSpeed
from inkarm.control.watchdogs.torque_saturated import TorqueSaturated
from inkarm.control.watchdogs.tracking_limit import TrackingLimit

for _dog in (ForceLimit, TrackingLimit, JointLimit, JointSpeed, TorqueSaturated):
    WATCHDOGS.register(_dog.name, _dog)
