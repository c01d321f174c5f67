"""The Dynamixel backend: a scenario drawn by a Dynamixel arm, and the MuJoCo twin behind the
emulator (the wiring of :mod:`inkarm.hardware.dynamixel` and :mod:`inkarm.sim`, which never
import each other).

:func:`run_dynamixel` runs the same drawing loop as the simulation
(:func:`inkarm.control.loop.run_drawing`, position commands) on a
:class:`~inkarm.hardware.dynamixel.plant.DynamixelPlant` and returns the same
:class:`~inkarm.jobs.run.Run`; a fault returns a failed Run with the log up to the fault.

:func:`twin_emulator` builds the emulator whose servos are the joints of the scenario's
MuJoCo cell (:class:`TwinJoints`), its pen drawing on an ink canvas, so a hardware-in-the-loop
run leaves ink and metrics like a simulated one.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from inkarm.control.loop import run_drawing
from inkarm.core.plant import PositionCommand, TorqueCommand
from inkarm.errors import InkarmError, RunFault
from inkarm.hardware.dynamixel.calibration import calibration_path, load_calibration
from inkarm.hardware.dynamixel.config import DynamixelConfig, with_dynamixel
from inkarm.hardware.dynamixel.emulator import DynamixelEmulator, Fault, specs_for_profile
from inkarm.hardware.dynamixel.plant import DynamixelPlant, servo_goal, servo_stiffness
from inkarm.ink.canvas import Canvas
from inkarm.jobs.run import (
    FAILED,
    INTERRUPTED,
    OK,
    Run,
    RunInterrupted,
    _metrics,
    _substeps,
    placed_within_budget,
)
from inkarm.jobs.scenario import Scenario, load_scenario
from inkarm.robots.servo import FirmwareGains, JointServos
from inkarm.sim.cell import Cell, build_model, kinematic_model
from inkarm.sim.plant import MujocoPlant


class TwinJoints:
    """The arm joints of a :class:`MujocoPlant` as the emulator's
    :class:`~inkarm.hardware.dynamixel.physics.JointPhysics` (one physics step a period)."""

    def __init__(self, plant: MujocoPlant):
        self.plant = plant
        self.period_s = plant.dt

    def state(self):
        s = self.plant.read()
        return s.q, s.qd

    def advance(self, torque) -> None:
        self.plant.command(TorqueCommand(np.asarray(torque, dtype=float)))
        self.plant.step()


def twin_emulator(scenario: Scenario | str | None = None, faults=(), baudrate: int | None = None,
                  byte_timing: bool = True) -> DynamixelEmulator:
    """An emulator of the scenario's robot whose servos move its MuJoCo twin (module
    docstring); the servos boot holding the home pose with the profile's EEPROM settings.
    ``emulator.canvas`` is the twin's ink."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    profile = scenario.robot
    cfg = DynamixelConfig.of(profile)
    canvas = scenario.ink.canvas(cell.paper_size_mm)
    twin = MujocoPlant(build_model(cell), cell=cell, canvas=canvas, substeps=1)
    emulator = DynamixelEmulator(specs_for_profile(cfg, profile.n), TwinJoints(twin),
                                 baudrate=baudrate or cfg.baudrate, faults=faults,
                                 byte_timing=byte_timing)
    for servo in emulator.bus.servos:  # as the arm's own setup left them: holding
        memory = servo.memory
        memory.set("operating_mode", cfg.mode_number)
        memory.set("return_delay_time", cfg.return_delay_us // 2)
        memory.set("torque_enable", 1)
        emulator.bank.on_write(servo, ["torque_enable"])
    emulator.canvas = canvas
    emulator.twin = twin
    return emulator


def run_dynamixel(scenario: Scenario, port: str, canvas: Canvas | None = None,
                  calibration: str | Path | None = None, trace_path: str | Path | None = None,
                  progress=None) -> Run:
    """Draw ``scenario`` with the Dynamixel arm on ``port`` (module docstring).

    ``canvas``: where the ink is (an emulated twin's canvas; hardware has none: an empty one).
    ``calibration``: the calibration file (default: beside the robot profile, when there).
    """
    profile = scenario.robot
    cell = Cell(scenario.cell, profile)
    try:
        drawing = placed_within_budget(scenario, cell)
        believed = kinematic_model(cell)
        path = Path(calibration) if calibration else calibration_path(profile)
        cal = load_calibration(path, profile.joint_names) if (calibration or path.is_file()) \
            else None
        config = dataclasses.replace(scenario.controller, command="position")
    except InkarmError as e:
        raise e.within(file=scenario.path) from None
    notes = () if cal is not None else (f"no calibration file ({path}): tick 2048 is 0 rad",)
    canvas_given = canvas is not None
    canvas = canvas if canvas is not None else scenario.ink.canvas(cell.paper_size_mm)
    plant = DynamixelPlant(port, profile, cal, trace_path=trace_path)
    try:
        log = run_drawing(drawing, plant, believed, profile.gains, config, progress=progress,
                          speed_limits=profile.speed_limits)
    except RunFault as e:  # a DynamixelFault or a watchdog of the loop
        partial = getattr(e, "log", None)
        return Run(scenario, FAILED, drawing, partial, canvas,
                   _metrics(partial, drawing, believed, canvas, force_sensed=False),
                   reason=str(e),
                   notes=notes + (partial.notes if partial is not None else ()))
    except KeyboardInterrupt as e:
        partial = getattr(e, "log", None)
        raise RunInterrupted(Run(scenario, INTERRUPTED, drawing, partial, canvas,
                                 reason="interrupted by the user (Ctrl-C)")) from None
    finally:
        plant.close()
    metrics = _metrics(log, drawing, believed, canvas, force_sensed=False)
    metrics["bus_overruns"] = plant.overruns
    notes += ("a Dynamixel arm senses no pen force (no force metrics)",)
    if not canvas_given:
        notes += ("the ink is on the paper, not on this run's canvas",)
    return Run(scenario, OK, drawing, log, canvas, metrics, notes=notes + tuple(log.notes))


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
        self._plant = plant
        self.stiffness, self.lead_s = servo_stiffness(DynamixelConfig.of(profile), plant.dt)

    def __getattr__(self, name):
        return getattr(self._plant, name)

    def command(self, command) -> None:
        if isinstance(command, PositionCommand):
            command = PositionCommand(servo_goal(command, self.stiffness, self.lead_s))
        self._plant.command(command)


def simulate_servo_arm(scenario: Scenario, progress=None) -> Run:
    """The scenario on the MuJoCo arm driven by the same servo firmware, registers and goal
    shaping as the Dynamixel backend, without a bus: the pure simulation a hardware-in-the-loop
    run is compared with."""
    profile = scenario.robot
    cell = Cell(scenario.cell, profile)
    drawing = placed_within_budget(scenario, cell)
    believed = kinematic_model(cell)
    canvas = scenario.ink.canvas(cell.paper_size_mm)
    substeps = _substeps(profile.control_period_s, scenario.cell.timestep)
    twin = MujocoPlant(build_model(cell), cell=cell, canvas=canvas, substeps=substeps,
                       firmware=joint_firmware(profile, scenario.cell.timestep))
    config = dataclasses.replace(scenario.controller, command="position")
    try:
        log = run_drawing(drawing, ServoGoals(twin, profile), believed, profile.gains, config,
                          progress=progress, speed_limits=profile.speed_limits)
    except RunFault as e:
        partial = getattr(e, "log", None)
        return Run(scenario, FAILED, drawing, partial, canvas,
                   _metrics(partial, drawing, believed, canvas), reason=str(e))
    finally:
        twin.close()
    return Run(scenario, OK, drawing, log, canvas, _metrics(log, drawing, believed, canvas))


def hil_run(scenario: Scenario, faults=(), trace_path: str | Path | None = None,
            progress=None, **backend) -> Run:
    """A whole hardware-in-the-loop run on this machine: the twin emulator in a child process
    on a pty, :func:`run_dynamixel` through dynamixel-sdk, the twin's canvas brought back and
    the metrics computed on its ink. ``backend`` overrides keys of the profile's
    ``[backends.dynamixel]`` (``latency_ms``, ``watchdog_ms``: a loaded machine answers late)."""
    import functools
    import operator

    from inkarm.hardware.dynamixel.emulator import EmulatorProcess

    if backend:
        scenario = dataclasses.replace(scenario, robot=with_dynamixel(scenario.robot, **backend))
    emulator = EmulatorProcess(functools.partial(twin_emulator, scenario, tuple(faults)),
                               operator.attrgetter("canvas"))  # the twin's ink comes back
    port = emulator.start()
    try:
        result = run_dynamixel(scenario, port, trace_path=trace_path, progress=progress)
    finally:
        canvas = emulator.stop()
    if canvas is None:
        return result
    cell = Cell(scenario.cell, scenario.robot)
    metrics = _metrics(result.log, result.drawing, kinematic_model(cell), canvas,
                       force_sensed=False)
    if "bus_overruns" in result.metrics:
        metrics["bus_overruns"] = result.metrics["bus_overruns"]
    return dataclasses.replace(result, canvas=canvas, metrics=metrics)


__all__ = [
    "Fault",
    "ServoGoals",
    "TwinJoints",
    "hil_run",
    "joint_firmware",
    "run_dynamixel",
    "simulate_servo_arm",
    "twin_emulator",
]
