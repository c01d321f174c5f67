"""Watchdogs: the checks that stop a drawing run before it does harm, one condition a module.

Every control period the executor hands each watchdog of the run what it measured
(:class:`Watched`); a watchdog that fires returns a sentence with the numbers, and the executor
raises :class:`inkarm.errors.RunFault` naming it (``"<name>: <sentence> at t = ... s"``) and
makes the arm safe. Built-ins (:mod:`inkarm.control.watchdogs.builtin`), in the order they are
checked:

* ``force_limit``: the filtered pen force above ``force_limit_n``;
* ``tracking_limit``: the pen farther than ``tracking_limit_mm`` from its reference in the page
  plane for ``watchdog_s`` (not in the joint-space approach and home moves);
* ``joint_limit``: a joint outside its range;
* ``joint_speed``: a joint faster than 1.2 times its speed limit for ``watchdog_s``;
* ``torque_saturated``: a joint torque within 1 % of its limit for ``saturation_s``.

``paper_not_found`` is the force loop's own (its guarded search ran out of range) and
``diverged`` the plant's. A scenario adds its own after the built-ins, by registered name or
``"package.module:Class"``, with the class's keyword arguments in ``[controller.<name>]``::

    [controller]
    watchdogs = ["mylab.watch:PenTilt"]
    [controller."mylab.watch:PenTilt"]
    limit_deg = 20.0
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.errors import InkarmError, InputError, RunFault
from inkarm.plugins import check_settings, registry

WATCHDOGS = registry("watchdog")
BUILTIN_WATCHDOGS = ("force_limit", "tracking_limit", "joint_limit", "joint_speed",
                     "torque_saturated")


@dataclass(frozen=True, eq=False)
class WatchContext:
    """What a watchdog is started with. Limits are None where the robot profile has none.

    Attributes:
        config: The ``[controller]`` thresholds (``force_limit_n``, ``tracking_limit_mm``,
            ``watchdog_s``, ``saturation_s``).
        dt: Control period [s].
        joint_names: For the messages.
        torque_limit: (n,) [N m].
        speed_limit: (n,) [rad/s].
        joint_range: (n, 2) [rad].
    """

    config: LoopConfig
    dt: float
    joint_names: tuple[str, ...]
    torque_limit: np.ndarray | None = None
    speed_limit: np.ndarray | None = None
    joint_range: np.ndarray | None = None

    def periods(self, seconds: float) -> int:
        """How many control periods make ``seconds`` (at least one)."""
        return max(1, round(seconds / self.dt))


class Watched(NamedTuple):
    """What the executor measured this period.

    Attributes:
        time: Plant time of the reading [s].
        q, qd: Joint positions [rad] and velocities [rad/s], (n,).
        torque: Joint torques [N m] (applied or measured), (n,), or None where unknown.
        force: Low-passed pen force along the paper normal [N] (0 where not sensed).
        error_mm: Pen distance from its reference in the page plane [mm] (0 in joint moves).
    """

    time: float
    q: np.ndarray
    qd: np.ndarray
    torque: np.ndarray | None
    force: float
    error_mm: float


@runtime_checkable
class Watchdog(Protocol):
    """A condition that stops a run (module docstring): ``start`` once, ``check`` every
    period, returning None while all is well and a sentence with the numbers when it fires."""

    name: str

    def start(self, context: WatchContext) -> None: ...

    def check(self, watched: Watched) -> str | None: ...


@dataclass(frozen=True)
class WatchdogSpec:
    """A watchdog as a scenario names it and its settings (keyword arguments of its class)."""

    name: str
    settings: tuple[tuple[str, Any], ...] = ()

    def make(self) -> Watchdog:
        return make_watchdog(self.name, dict(self.settings))


def make_watchdog(name: str, settings: dict[str, Any] | None = None) -> Watchdog:
    """A fresh watchdog ``name`` (registered, or ``"package.module:Class"``) with ``settings``;
    refused naming ``controller.watchdogs`` or ``controller.<name>.<setting>``."""
    cls = WATCHDOGS.get(name, key="controller.watchdogs")
    if not inspect.isclass(cls) or not all(hasattr(cls, m) for m in ("start", "check")):
        raise InputError(f"{name!r} is not a watchdog: a watchdog is a class with name, "
                         f"start(context) and check(watched)", key="controller.watchdogs",
                         value=name)
    settings = dict(settings or {})
    if settings:  # (a class's signature costs 50 us: none to check for the built-ins, each run)
        check_settings(cls, settings, f"watchdog {name!r}", f"controller.{name}")
    try:
        dog = cls(**settings)
    except InkarmError as e:
        raise e.within(key=f"controller.{name}") from None
    except (TypeError, ValueError) as e:
        raise InputError(f"watchdog {name!r} refused its settings {settings}: {e}",
                         key=f"controller.{name}", value=settings) from None
    if not getattr(dog, "name", ""):
        dog.name = name
    return dog


class Watchdogs:
    """The watchdogs of one run, checked in order; the first that fires raises
    :class:`RunFault` naming it.

    Args:
        context: Their limits and period.
        extra: Watchdogs added after the built-ins (specs or started instances are not
            accepted: each run makes its own).
    """

    def __init__(self, context: WatchContext, extra: tuple[WatchdogSpec, ...] = ()):
        self.context = context
        self.items = [make_watchdog(name) for name in BUILTIN_WATCHDOGS]
        self.items += [spec.make() for spec in extra]
        for dog in self.items:
            dog.start(context)
        self._checks = [(dog.name, dog.check) for dog in self.items]
        # The common case, every joint strictly inside its range, speed and torque limits, is
        # found in one pass over the joints on Python floats (this runs every period, and on 7
        # joints numpy's per-call cost dominates); the joint watchdogs are then told so
        # (``clear``) instead of checking.
        self._envelope = None
        self._counting = True
        self._joint_dogs = [dog for dog in self.items if hasattr(dog, "clear")]
        limits = (context.joint_range, context.speed_limit, context.torque_limit)
        if len(self._joint_dogs) == 3 and all(limit is not None for limit in limits):
            from inkarm.control.watchdogs.joint_speed import SPEED_TOLERANCE
            from inkarm.control.watchdogs.torque_saturated import SATURATION

            lower, upper = np.asarray(context.joint_range, dtype=float).T
            self._envelope = tuple(zip(((upper + lower) / 2).tolist(),
                                       ((upper - lower) / 2).tolist(),
                                       (SPEED_TOLERANCE * np.asarray(limits[1])).tolist(),
                                       (SATURATION * np.asarray(limits[2])).tolist()))
            self._clears = [dog.clear for dog in self._joint_dogs]
            self._other_checks = [(dog.name, dog.check) for dog in self.items
                                  if dog not in self._joint_dogs]

    def check(self, time: float, q, qd, torque, force: float, error_mm: float) -> None:
        """Raise :class:`RunFault` when a watchdog fires."""
        checks = self._checks
        envelope = self._envelope
        inside = envelope is not None and torque is not None
        if inside:
            for (mid, half, speed, effort), a, v, t in zip(envelope, q.tolist(), qd.tolist(),
                                                           torque.tolist()):
                if not (abs(a - mid) < half and abs(v) < speed and abs(t) < effort):
                    inside = False
                    break
        if inside:
            if self._counting:  # (their counts are zero again; until then nothing to clear)
                for clear in self._clears:
                    clear()
                self._counting = False
            checks = self._other_checks
        else:
            self._counting = True
        watched = Watched(time, q, qd, torque, force, error_mm)
        for name, check in checks:
            message = check(watched)
            if message is not None:
                raise RunFault(f"{name}: {message} at t = {time:.3f} s", watchdog=name,
                               time_s=time)


__all__ = ["BUILTIN_WATCHDOGS", "WATCHDOGS", "WatchContext", "Watchdog", "WatchdogSpec",
           "Watchdogs", "Watched", "make_watchdog"]
