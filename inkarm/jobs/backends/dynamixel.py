"""The Dynamixel backend: a scenario drawn by a Dynamixel arm, and the MuJoCo twin behind the
emulator (the wiring of :mod:`inkarm.hardware.dynamixel` and :mod:`inkarm.sim`, which never
import each other).

The ``dynamixel`` backend opens a :class:`~inkarm.hardware.dynamixel.plant.DynamixelPlant` on
the port and the one assembly (:func:`inkarm.jobs.backends.run_backend`) draws with the
scenario's law on it, as on the simulated arm: position goals to the servos' own loop when the
profile's servos are in a position mode, torques (goal currents) from a torque law when the
profile (or the scenario's ``[dynamixel] operating_mode``) puts them in current mode. A fault
returns a failed Run with the log up to the fault. The judge does not judge what the arm cannot
sense: its pen force, the gaps (found from the force) and, on real paper, the ink.

:func:`twin_emulator` builds the emulator whose servos are the joints of the scenario's
MuJoCo cell (:class:`TwinJoints`), its pen drawing on an ink canvas, so a hardware-in-the-loop
run (:func:`hil_run`) leaves ink and is judged on it like a simulated one.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from inkarm.core.plant import TorqueCommand
from inkarm.core.run import Metrics, Senses
from inkarm.errors import InputError
from inkarm.hardware.dynamixel.calibration import find_calibration, load_calibration
from inkarm.hardware.dynamixel.config import DynamixelConfig, with_dynamixel
from inkarm.hardware.dynamixel.emulator import DynamixelEmulator, Fault, specs_for_profile
from inkarm.jobs.backends import BackendOptions, Progress, run_backend
from inkarm.jobs.backends.arm import ArmSession
from inkarm.jobs.calibration import believed_model
from inkarm.jobs.outcome import Run, failed_run, finished_run, measured
from inkarm.jobs.preflight import placed_within_budget
from inkarm.jobs.scenario import Scenario, load_scenario
from inkarm.sim.cell import Cell, build_model
from inkarm.sim.plant import MujocoPlant

NO_FORCE = "a Dynamixel arm senses no pen force"
PAPER_INK = "the ink is on the paper, not on this run's canvas"


def dynamixel_senses(ink: bool) -> Senses:
    """What a Dynamixel arm senses for the judge: the tip (its encoders through the kinematic
    model), never the pen's force nor, found from it, its contact; the ink only where the run
    has it (an emulated twin's canvas), not on a real sheet."""
    lacking = {"contact": f"{NO_FORCE}, and the gaps are found from the force",
               "force": NO_FORCE}
    if not ink:
        lacking["ink"] = PAPER_INK
    return Senses.without(**lacking)


class DynamixelSession(ArmSession):
    """A scenario on the Dynamixel arm at ``options.port`` (module docstring)."""


    def __init__(self, scenario: Scenario, options: BackendOptions):
        from inkarm.hardware.dynamixel.plant import DynamixelPlant

        profile = scenario.robot
        self.scenario = scenario
        cell = Cell(scenario.cell, profile)
        self.drawing = placed_within_budget(scenario, cell)
        self.believed, believed_notes = believed_model(scenario, cell)
        _check_law(scenario, DynamixelConfig.of(profile))
        given = options.profile or dict(scenario.dynamixel).get("calibration")
        path = Path(given) if given else find_calibration(profile)
        cal = load_calibration(path, profile.joint_names) if (given or path.is_file()) else None
        self.canvas = (options.canvas if options.canvas is not None
                       else scenario.ink.canvas(cell.paper_size_mm))
        self.senses = dynamixel_senses(ink=options.canvas is not None)
        self.notes = believed_notes + (
            () if cal is not None else (f"no calibration file ({path}): tick 2048 is 0 rad",))
        self.notes += (f"{NO_FORCE} (no force metrics)",)
        if options.canvas is None:
            self.notes += (PAPER_INK,)
        self.plant = DynamixelPlant(options.port, profile, cal, trace_path=options.trace_path)

    def measure(self, log, finished: bool) -> Metrics | None:
        metrics = measured(log, self.drawing, self.believed, self.canvas, senses=self.senses)
        return metrics.replace(bus_overruns=self.plant.overruns) if finished and metrics \
            else metrics



def _check_law(scenario: Scenario, cfg: DynamixelConfig) -> None:
    """Refuse, before the port opens, a law whose commands the servos' operating mode does not
    take, saying how to match them."""
    from inkarm.hardware.dynamixel.tables import table

    takes = {"torque"} if cfg.operating_mode == "current" else {"position"}
    if scenario.law.commands <= takes:
        return
    blind = sorted({m for m in cfg.models if "current_limit" not in table(m)})
    if "position" in scenario.law.commands:
        fix = 'set [dynamixel] operating_mode = "extended_position", or use a torque law'
    elif blind:  # the servos cannot take torques at all
        fix = (f"{', '.join(blind)} cannot run in current mode: use a law that sends position "
               f'goals (law = "position")')
    else:
        fix = 'set [dynamixel] operating_mode = "current" (the host closes the joint loop)'
    raise InputError(f"law {scenario.law.name!r} sends "
                     f"{', '.join(sorted(scenario.law.commands))} commands, but the servos run "
                     f"in {cfg.operating_mode!r} mode and take {', '.join(sorted(takes))}; "
                     f"{fix}", key="controller.law", value=scenario.law.name)


class DynamixelBackend:
    name = "dynamixel"
    help = "a Dynamixel X-series arm (Protocol 2.0) on a serial port"
    needs_port = True
    senses_force = False  # (``calibrate paper`` refuses it before anything moves)

    def check(self, scenario: Scenario, options: BackendOptions) -> str | None:
        _check_law(scenario, DynamixelConfig.of(scenario.robot))
        return None

    def open(self, scenario: Scenario, options: BackendOptions) -> DynamixelSession:
        return DynamixelSession(scenario, options)


def simulate_servo_arm(scenario: Scenario, progress: Progress = None) -> Run:
    """The scenario on the MuJoCo arm driven by the same servo firmware, registers and goal
    shaping as the Dynamixel backend, without a bus (the ``servo_sim`` backend): the pure
    simulation a hardware-in-the-loop run is compared with."""
    return run_backend("servo_sim", scenario, progress=progress)


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
                  byte_timing: bool = True, status_return_level: int = 2,
                  truth: bool = False) -> DynamixelEmulator:
    """An emulator of the scenario's robot whose servos move its MuJoCo twin (module
    docstring); the servos boot holding the home pose with the profile's EEPROM settings and
    Status Return Level ``status_return_level`` (2: every instruction answered; 1: PING and
    reads only). ``emulator.canvas`` is the twin's ink. ``truth``: the twin is the arm as the
    scenario's ``[sim.plant]`` says it really is (relief, pen and link errors, ...: what a
    calibration through the emulator finds out); default the nominal arm."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    profile = scenario.robot
    cfg = DynamixelConfig.of(profile)
    canvas = scenario.ink.canvas(cell.paper_size_mm)
    if truth:
        from inkarm.sim.perturb import plant_model

        real = scenario.plant.realised()
        twin = MujocoPlant(plant_model(cell, real), cell=cell, canvas=canvas, substeps=1,
                           truth=real)
    else:
        twin = MujocoPlant(build_model(cell), cell=cell, canvas=canvas, substeps=1)
    emulator = DynamixelEmulator(specs_for_profile(cfg, profile.n), TwinJoints(twin),
                                 baudrate=baudrate or cfg.baudrate, faults=faults,
                                 byte_timing=byte_timing)
    for servo in emulator.bus.servos:  # as the arm's own setup left them: holding
        memory = servo.memory
        memory.set("operating_mode", cfg.mode_number)
        memory.set("return_delay_time", cfg.return_delay_us // 2)
        memory.set("torque_enable", 1)
        memory.set("status_return_level", status_return_level)
        emulator.bank.on_write(servo, ["torque_enable"])
    emulator.canvas = canvas
    emulator.twin = twin
    return emulator


def hil_run(scenario: Scenario, faults=(), trace_path: str | Path | None = None,
            progress=None, boot_status_return_level: int = 2, linger_s: float = 1.0,
            truth: bool = False, **backend) -> Run:
    """A whole hardware-in-the-loop run on this machine: the twin emulator in a child process
    on a pty, the ``dynamixel`` backend through dynamixel-sdk, the twin's canvas brought back
    and the run judged on its ink. ``trace_path``: where the bus trace goes on a fault. ``backend`` overrides keys of the profile's
    ``[backends.dynamixel]`` (``latency_ms``, ``watchdog_ms``: a loaded machine answers late).
    ``boot_status_return_level``: the servos' Status Return Level (68) at power-on.
    ``linger_s``: how long [s] the twin goes on after the driver closed the port before its ink
    is taken, as a user's emulator (or arm) goes on: ink that an arm left by the driver makes
    (falling on the sheet) shows. ``truth``: the twin is the scenario's real arm
    (:func:`twin_emulator`)."""
    import functools
    import operator

    from inkarm.hardware.dynamixel.emulator import EmulatorProcess

    if backend:
        scenario = dataclasses.replace(scenario, robot=with_dynamixel(scenario.robot, **backend))
    emulator = EmulatorProcess(functools.partial(twin_emulator, scenario, tuple(faults),
                                                 status_return_level=boot_status_return_level,
                                                 truth=truth),
                               operator.attrgetter("canvas"))  # the twin's ink comes back
    port = emulator.start()
    try:
        result = run_backend("dynamixel", scenario,
                             BackendOptions(port=port, trace_path=trace_path), progress=progress)
        time.sleep(linger_s)
    finally:
        canvas = emulator.stop()
    if canvas is None:
        return result
    # Judged again on the twin's ink, by the same judge
    believed, _ = believed_model(scenario, Cell(scenario.cell, scenario.robot))
    senses = dynamixel_senses(ink=True)
    metrics = measured(result.log, result.drawing, believed, canvas, senses=senses)
    if metrics and "bus_overruns" in result.metrics:
        metrics = metrics.replace(bus_overruns=result.metrics["bus_overruns"])
    notes = tuple(n for n in result.notes if n != PAPER_INK)
    if not result.finished:
        return failed_run(scenario, result.drawing, result.reason, canvas, believed,
                          senses=senses, log=result.log, metrics=metrics, notes=notes)
    return finished_run(scenario, result.drawing, result.log, canvas, believed, senses=senses,
                        metrics=metrics, notes=notes)


__all__ = [
    "DynamixelBackend",
    "DynamixelSession",
    "Fault",
    "TwinJoints",
    "dynamixel_senses",
    "hil_run",
    "simulate_servo_arm",
    "twin_emulator",
]
