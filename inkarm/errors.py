"""Exceptions raised by inkarm.

Every error a user can cause derives from :class:`InkarmError`; the CLI prints its message and
exits with status 2 instead of showing a traceback. An error carries its facts as fields, not
only as text: the ``file`` and ``key`` (a dotted path such as ``controller.gains.kp``) where the
bad ``value`` came from, and the ``choices`` that would have been valid. Callers that know more
context add it with :meth:`InkarmError.within` instead of rebuilding the message::

    try:
        LoopConfig(force_n=-1.0)
    except InputError as e:
        raise e.within(file="job.toml", key="controller")   # job.toml: controller.force_n: ...
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any

_UNSET: Any = object()


def closest(name: str, choices: Iterable[str]) -> str | None:
    """The valid name closest to ``name``: the shortest one it begins (a key written without
    its unit, ``force_gain`` for ``force_gain_mm_per_ns``), else the nearest by difflib's
    ratio (>= 0.6), else None."""
    name, options = str(name), [str(c) for c in choices]
    extended = sorted((c for c in options if name and c.startswith(name) and c != name), key=len)
    if extended:
        return extended[0]
    match = difflib.get_close_matches(name, options, n=1, cutoff=0.6)
    return match[0] if match else None


class InkarmError(Exception):
    """Base class of every error inkarm raises on purpose.

    Attributes:
        message: What is wrong and what was expected, without the location.
        file: The file the input came from, or None.
        key: Dotted key (``controller.force_n``) or field name at fault, or None.
        value: The offending value (``InkarmError.NO_VALUE`` when none applies).
        choices: The valid names when the value had to be one of them, else ().
    """

    NO_VALUE: Any = _UNSET

    def __init__(
        self,
        message: str = "",
        *,
        file: str | None = None,
        key: str | None = None,
        value: Any = _UNSET,
        choices: Iterable[str] = (),
    ):
        self.message = str(message)
        self.file = None if file is None else str(file)
        self.key = key
        self.value = value
        self.choices = tuple(choices)
        super().__init__(self.message)

    def __str__(self) -> str:
        return ": ".join(part for part in (self.file, self.key, self.message) if part)

    def __reduce__(self):
        return _rebuild, (type(self), self.message, self.file, self.key, self.value, self.choices,
                          self.__dict__)

    def within(self, file: str | None = None, key: str | None = None) -> InkarmError:
        """Add context in place and return self: ``key`` is prefixed to this error's key
        (``controller`` + ``force_n`` -> ``controller.force_n``), ``file`` fills in the file
        when none is known yet."""
        if key:
            self.key = f"{key}.{self.key}" if self.key else key
        if file is not None and self.file is None:
            self.file = str(file)
        self.args = (str(self),)
        return self


def _rebuild(cls, message, file, key, value, choices, state):
    error = cls.__new__(cls)
    InkarmError.__init__(error, message, file=file, key=key, value=value, choices=choices)
    error.__dict__.update(state)
    return error


class InputError(InkarmError, ValueError):
    """Bad input: a value, array shape, field or file that is not what was expected."""


class PlanError(InputError):
    """A motor plan (targets, covariances, timing) is malformed."""


class ScenarioError(InputError):
    """A scenario, robot profile or plan file (TOML) has unknown keys, wrong types or bad
    values."""


class SolverError(InkarmError):
    """A numerical solver failed (singular system, non-finite result)."""


class UnreachableError(InkarmError):
    """A placement or target pose is outside the robot's workspace, or a reference would drive
    a joint beyond its limits."""


class RunFault(InkarmError):
    """A watchdog stopped a run: the pen was lifted (where the arm could still move) and the
    arm made safe. ``watchdog`` names the check that fired (``paper_not_found``,
    ``force_limit``, ``tracking_limit``, ``torque_saturated``, ``joint_limit``,
    ``joint_speed``, ``diverged``), ``time_s`` is the plant time of the fault and ``log`` (set
    by the loop) the log up to the safe stop."""

    def __init__(self, message: str, *, watchdog: str = "", time_s: float = float("nan"),
                 **context):
        super().__init__(message, **context)
        self.watchdog = watchdog
        self.time_s = time_s


class SimulationError(RunFault):
    """The simulation diverged or produced non-finite state."""

    def __init__(self, message: str = "", **context):
        context.setdefault("watchdog", "diverged")
        super().__init__(message, **context)


def unknown_name(what: str, name: str, choices: Iterable[str], *, key: str | None = None,
                 file: str | None = None, cls: type[InkarmError] = InputError) -> InkarmError:
    """The error for a name that is not one of ``choices``, suggesting the closest one."""
    choices = tuple(choices)
    hint = closest(name, choices)
    suggestion = f" (did you mean {hint!r}?)" if hint else ""
    return cls(f"unknown {what} {name!r}{suggestion}; expected one of "
               f"{', '.join(map(repr, choices))}", file=file, key=key, value=name, choices=choices)
