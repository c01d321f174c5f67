"""The simulated backends: ``sim``, the scenario's MuJoCo arm with its plant truth (the default),
and ``servo_sim``, the arm driven by the same servo firmware, registers and goal shaping as the
Dynamixel backend, without a bus (the pure simulation a hardware-in-the-loop run is compared
with).

A law that sends position goals drives the simulated joints through their drives (the profile's
``[drive]`` gains) or, for a robot whose joints are Dynamixel servos, through the servos'
firmware model with goals shaped as :class:`~inkarm.hardware.dynamixel.plant.DynamixelPlant`
sends them; a law that sends torques drives the motors directly (servos in current mode).
"""

from __future__ import annotations

import numpy as np

from inkarm.core.plant import PositionCommand
from inkarm.core.run import Metrics
from inkarm.hardware.dynamixel.config import DynamixelConfig
from inkarm.jobs.backends import BackendOptions
from inkarm.jobs.backends.arm import ArmSession
from inkarm.jobs.calibration import believed_model
from inkarm.jobs.outcome import SIM_SENSES
from inkarm.jobs.preflight import placed_within_budget, substeps
from inkarm.jobs.scenario import Scenario
from inkarm.robots.servo import FirmwareGains, JointServos
from inkarm.sim.cell import Cell, build_model
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant


class SimSession(ArmSession):
    """A scenario on its simulated arm (``servo``: the servo-only simulation)."""

    senses = SIM_SENSES
    notes = ()

    def __init__(self, scenario: Scenario, servo: bool = False):
        self.scenario = scenario
        cell = Cell(scenario.cell, scenario.robot)
        self.drawing = placed_within_budget(scenario, cell)
        # the controller's own model: of the nominal cell, or as the scenario's calibration says
        self.believed, said = believed_model(scenario, cell)
        self.notes = (*type(self).notes, *said)  # (a subclass's own notes kept)
        self.canvas = scenario.ink.canvas(cell.paper_size_mm)
        steps = substeps(scenario.robot.control_period_s, scenario.cell.timestep)
        if servo:  # the nominal arm, its firmware as the emulator's servos run it
            self.plant = ServoGoals(MujocoPlant(
                build_model(cell), cell=cell, canvas=self.canvas, substeps=steps,
                firmware=joint_firmware(scenario.robot, scenario.cell.timestep)),
                scenario.robot)
            return
        truth = scenario.plant.realised()
        servos = (servo_firmware(scenario.robot, scenario.cell.timestep)
                  if "position" in scenario.law.commands else None)
        plant = MujocoPlant(plant_model(cell, truth), cell=cell, canvas=self.canvas,
                            substeps=steps, truth=truth, firmware=servos,
                            # the servos' own loop holds the goals, not the profile's drives
                            drive_gains=scenario.robot.drive if servos is None else None)
        self.plant = plant if servos is None else ServoGoals(plant, scenario.robot)

    def measure(self, log, finished: bool) -> Metrics | None:
        return None



class SimBackend:
    name = "sim"
    help = "the MuJoCo arm of the scenario (default)"
    needs_port = False

    def check(self, scenario: Scenario, options: BackendOptions) -> str | None:
        return None

    def open(self, scenario: Scenario, options: BackendOptions) -> SimSession:
        return SimSession(scenario)


class ServoSimBackend(SimBackend):
    name = "servo_sim"
    help = ("the MuJoCo arm driven by its Dynamixel servos' firmware model, as the dynamixel "
            "backend drives it, without a bus")

    def open(self, scenario: Scenario, options: BackendOptions) -> SimSession:
        DynamixelConfig.of(scenario.robot)  # (refused, naming the table, for other robots)
        return SimSession(scenario, servo=True)


def servo_firmware(robot, step_s: float) -> JointServos | None:
    """The servo firmware of a robot whose joints are Dynamixel servos with position-loop
    registers in its profile (``[backends.dynamixel] position_p``), in joint units: with
    position commands its simulated plant runs as it would on its servos (goals shaped as
    :class:`inkarm.hardware.dynamixel.plant.DynamixelPlant` sends them). With torque commands
    the servos are in current mode and the host's loop drives them. None for other robots."""
    return joint_firmware(robot, step_s) if robot.servo_firmware else None


def joint_firmware(profile, period_s: float) -> JointServos:
    """The profile's servos (:class:`inkarm.robots.servo.ServoFirmware` with the registers of
    ``[backends.dynamixel]``, shadows doubling their joints) in joint units: the firmware of
    the pure simulation of the arm the emulator serves."""
    cfg = DynamixelConfig.of(profile)
    gains = FirmwareGains(**{k: np.asarray(v, dtype=float) for k, v in cfg.gains.items()})
    return JointServos(cfg.models, gains, period_s, cfg.servos_per_joint)


class ServoGoals:
    """A plant whose position goals pass through :func:`servo_goal` first, as
    :class:`DynamixelPlant` sends them (every other call goes to ``plant``)."""

    def __init__(self, plant, profile):
        # (the driver's own shaping, imported only for a servo arm: it comes with the SDK)
        from inkarm.hardware.dynamixel.plant import servo_goal, servo_stiffness

        self._plant = plant
        self._shaped = servo_goal
        self.stiffness, self.lead_s = servo_stiffness(DynamixelConfig.of(profile), plant.dt)

    def __getattr__(self, name):
        return getattr(self._plant, name)

    def command(self, command) -> None:
        if isinstance(command, PositionCommand):
            command = PositionCommand(self._shaped(command, self.stiffness, self.lead_s))
        self._plant.command(command)


__all__ = ["ServoGoals", "ServoSimBackend", "SimBackend", "SimSession", "joint_firmware",
           "servo_firmware"]
