"""Exceptions raised by inkarm.

Every error a user can cause derives from :class:`InkarmError`; the CLI prints its message and
exits with status 2 instead of showing a traceback. Messages name the file, field, index or
value at fault and say what was expected.
"""

from __future__ import annotations


class InkarmError(Exception):
    """Base class of every error inkarm raises on purpose."""


class InputError(InkarmError, ValueError):
    """Bad input: a value, array shape, field or file that is not what was expected."""


class PlanError(InputError):
    """A motor plan (targets, covariances, timing) is malformed."""


class ScenarioError(InputError):
    """A scenario or plan file (TOML) has unknown keys, wrong types or bad values."""


class SolverError(InkarmError):
    """A numerical solver failed (singular system, non-finite result)."""


class UnreachableError(InkarmError):
    """A placement or target pose is outside the robot's workspace."""


class SimulationError(InkarmError):
    """The simulation diverged or produced non-finite state."""
