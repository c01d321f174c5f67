"""inkarm: a testbed for drawing robots.

Movement models (``inkarm.models``) turn sparse motor plans into human-like pen trajectories;
a controller (``inkarm.control``) makes a robot (``inkarm.robots``: profiles as data) track
them on a plant: a MuJoCo cell (``inkarm.sim``) or real devices (``inkarm.hardware``). A
scenario is data, and ``run(scenario)`` a pure function. Millimetres and seconds at every
public surface.

    >>> import inkarm
    >>> result = inkarm.run(inkarm.load_scenario())   # the embedded default: a letter N
    >>> result.status, round(result.metrics["tracking_rms_mm"], 2)
    ('ok', 0.05)
"""

from __future__ import annotations

from inkarm.core.lazy import lazy_names
from inkarm.errors import (
    InkarmError,
    InputError,
    PlanError,
    ScenarioError,
    SimulationError,
    SolverError,
    UnreachableError,
)

__version__ = "0.2.0"

# Public names -> the module that defines them, imported on first use (``import inkarm`` stays
# light: MuJoCo and SciPy load only when a name that needs them is touched).
_LAZY = {
    "Trajectory": "inkarm.core.trajectory",
    "Drawing": "inkarm.core.trajectory",
    "GaussianTarget": "inkarm.core.plan",
    "StrokePlan": "inkarm.core.plan",
    "MotorPlan": "inkarm.core.plan",
    "DrawLog": "inkarm.core.log",
    "Plant": "inkarm.core.plant",
    "PlantState": "inkarm.core.plant",
    "TorqueCommand": "inkarm.core.plant",
    "PositionCommand": "inkarm.core.plant",
    "PenCommand": "inkarm.core.plant",
    "PagePlacement": "inkarm.core.frames",
    "LQT": "inkarm.models.lqt",
    "LQTConfig": "inkarm.models.lqt",
    "RobotProfile": "inkarm.robots.profile",
    "load_robot": "inkarm.robots.registry",
    "robot_names": "inkarm.robots.registry",
    "Scenario": "inkarm.jobs.scenario",
    "load_scenario": "inkarm.jobs.scenario",
    "Run": "inkarm.jobs.run",
    "run": "inkarm.jobs.run",
    "run_backend": "inkarm.jobs.backends",
    "Status": "inkarm.core.run",
    "Metrics": "inkarm.core.run",
    "Bounds": "inkarm.core.run",
    "Controller": "inkarm.control.laws",
    "LawContext": "inkarm.control.laws",
    "LawSpec": "inkarm.control.laws",
    "Setpoint": "inkarm.control.laws",
    "Watchdog": "inkarm.control.watchdogs",
    "execute": "inkarm.control.executor",
    "run_drawing": "inkarm.control.executor",
    "write_run": "inkarm.jobs.outputs",
}

__all__ = [
    "LQT",
    "Bounds",
    "Controller",
    "DrawLog",
    "Drawing",
    "GaussianTarget",
    "InkarmError",
    "InputError",
    "LQTConfig",
    "LawContext",
    "LawSpec",
    "Metrics",
    "MotorPlan",
    "PagePlacement",
    "PenCommand",
    "PlanError",
    "Plant",
    "PlantState",
    "PositionCommand",
    "RobotProfile",
    "Run",
    "Scenario",
    "ScenarioError",
    "Setpoint",
    "SimulationError",
    "SolverError",
    "Status",
    "StrokePlan",
    "TorqueCommand",
    "Trajectory",
    "UnreachableError",
    "Watchdog",
    "__version__",
    "execute",
    "load_robot",
    "load_scenario",
    "robot_names",
    "run",
    "run_backend",
    "run_drawing",
    "write_run",
]


__getattr__ = lazy_names(__name__, globals(), _LAZY)


def __dir__() -> list[str]:
    return __all__
