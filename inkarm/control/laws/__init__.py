"""Control laws: what turns a reading and the plan's row into a command, as objects.

A law is any class with the three members of :class:`Controller`. The executor
(:mod:`inkarm.control.executor`) makes one instance per plant with the law's settings as keyword
arguments, starts it with the :class:`LawContext` (the plan, the controller's kinematic model,
the profile's gains, the period) and then, every control period, calls

    command(state, setpoint) -> TorqueCommand | PositionCommand

with the plant's reading (:class:`inkarm.core.plant.PlantState`) and the :class:`Setpoint`: the
plan's row as the reference shaper left it (the force loop's depth along the paper normal and
the surface estimate already in ``q``; the actuation lead applied). After a fault the executor
lifts the pen along the normal and asks ``command`` for every period of that lift with
``setpoint.stopping`` true (zero velocity and acceleration, no contact feed-forward).

The executor never branches on which law it runs. Built-ins register in
:mod:`inkarm.control.laws.builtin` (one law a module); a scenario names one by its registered
name or as ``"package.module:Class"`` (:mod:`inkarm.plugins`)::

    [controller]
    law = "impedance"            # or "mylab.laws:GravityPD"
    [controller.impedance]       # the law's own settings: keyword arguments of its class
    stiffness_n_per_mm = 1.0

Units: SI in the joint arrays (rad, rad/s, N m); page millimetres in ``LawContext.plan.page_mm``.
"""

from __future__ import annotations

import copy
import inspect
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.core.plant import Command, PlantState
from inkarm.errors import InkarmError, InputError
from inkarm.plugins import check_settings, registry
from inkarm.robots.gains import PIDGains

if TYPE_CHECKING:  # (naming a law imports no MuJoCo: a plotter's scenario names one too)
    from inkarm.control.kinematics import ArmKinematics
    from inkarm.control.reference import JointReference
    from inkarm.robots.kinematic import KinematicModel


@dataclass(frozen=True, eq=False)
class LawContext:
    """What a law is started with.

    Attributes:
        plan: The joint reference, one row per control period (:class:`JointReference`: q, qd,
            qdd [rad, rad/s, rad/s^2]; page_mm; phase; normal_q; contact_tau, inertia, bias
            [N m]).
        kinematics: The controller's own kinematic model (forward kinematics, Jacobians,
            bias forces c(q, qd) [N m]); never the plant's.
        model: The same model with its placement on the page (``model.placement``).
        gains: The robot profile's joint PID gains at this period.
        config: The ``[controller]`` settings (force set point, watchdog thresholds, ...).
        dt: Control period [s].
        senses: What the plant senses beyond q, qd (``"force"``, ``"tip"``, ...).
    """

    plan: JointReference
    kinematics: ArmKinematics
    model: KinematicModel
    gains: PIDGains
    config: LoopConfig
    dt: float
    senses: frozenset[str]


class Setpoint(NamedTuple):
    """The reference of one control period, as shaped for the law.

    Attributes:
        row: The plan row commanded (the actuation lead included).
        q: Joint goal [rad]: the plan, pushed ``depth`` along the paper normal, led by the
            actuation latency.
        qd: Planned joint velocity [rad/s] (zero while stopping).
        qdd: Planned joint acceleration [rad/s^2] (zero while stopping).
        q_row: The plan row ``row`` pushed ``depth`` along the normal [rad]: ``q`` without the
            actuation lead.
        pressing: Whether the pen should push on the paper now (drawing, or settling at the end
            of a descent): add the contact feed-forward ``plan.contact_tau[row]``.
        depth: How far beyond the model's paper the reference is pressed, along the normal [m]
            (the force loop's correction plus the surface estimate).
        seen: The plan row the reading belongs to (older than ``row`` by the sensing delay).
        blend: Fraction of the way from plan row ``seen`` to the next that the reading is at.
        stopping: A safe stop after a fault: lift to ``q`` and hold.
    """

    row: int
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    q_row: np.ndarray
    pressing: bool
    depth: float
    seen: int
    blend: float
    stopping: bool = False


@runtime_checkable
class Controller(Protocol):
    """A control law (module docstring). ``commands``: the command kinds it sends
    (``"torque"``, ``"position"``); the plant must take every one of them."""

    commands: frozenset[str]

    def start(self, context: LawContext) -> None:
        """Called once before the first period, with the plan and the model."""
        ...

    def command(self, state: PlantState, setpoint: Setpoint) -> Command:
        """The command of this period."""
        ...


LAWS = registry("law")
DEFAULT_LAW = "position"


@dataclass(frozen=True)
class LawSpec:
    """A law as a scenario names it: ``name`` (registered, or ``"package.module:Class"``) and
    its settings (keyword arguments of its class, as a tuple of pairs, arrays as tuples: the
    spec compares and pickles). :meth:`make` builds a fresh, unstarted instance with its own
    copy of the settings: one per plant."""

    name: str = DEFAULT_LAW
    settings: tuple[tuple[str, Any], ...] = ()

    def cls(self) -> type:
        return law_class(self.name)

    def make(self) -> Controller:
        return make_law(self.name, copy.deepcopy(dict(self.settings)))

    @property
    def commands(self) -> frozenset[str]:
        return frozenset(getattr(self.cls(), "commands", frozenset()))


def law_class(name: str, key: str = "controller.law") -> type:
    """The law registered as ``name`` or imported from ``"package.module:Class"``; refused,
    naming ``key``, when it is not a class with ``commands``, ``start`` and ``command``."""
    cls = LAWS.get(name, key=key)
    missing = [m for m in ("commands", "start", "command") if not hasattr(cls, m)]
    if not inspect.isclass(cls) or missing:
        raise InputError(f"{name!r} is not a control law: a law is a class with commands, "
                         f"start(context) and command(state, setpoint)"
                         + (f" (missing: {', '.join(missing)})" if missing else ""),
                         key=key, value=name)
    unknown = set(cls.commands) - {"torque", "position"}
    if not cls.commands or unknown:
        raise InputError(f"law {name!r} declares commands {sorted(cls.commands)}; expected a "
                         f"non-empty subset of ['position', 'torque']", key=key, value=name)
    return cls


def make_law(name: str, settings: dict[str, Any] | None = None) -> Controller:
    """A fresh instance of law ``name`` with ``settings``; a bad setting is refused naming
    ``controller.<name>.<setting>`` and the settings the law takes."""
    cls = law_class(name)
    settings = dict(settings or {})
    key = f"controller.{name}"
    check_settings(cls, settings, f"law {name!r}", key)
    try:
        return cls(**settings)
    except InkarmError as e:
        raise e.within(key=key) from None
    except (TypeError, ValueError) as e:
        raise InputError(f"law {name!r} refused its settings {settings}: {e}", key=key,
                         value=settings) from None


__all__ = ["DEFAULT_LAW", "LAWS", "Controller", "LawContext", "LawSpec", "Setpoint", "law_class",
           "make_law"]
