"""Backends as objects: one assembly for every backend, a backend of one's own as its module
plus one registration, the plotter's path free of MuJoCo, and what each backend refuses before
it opens anything."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from inkarm.core.run import Metrics, Senses
from inkarm.errors import InputError
from inkarm.jobs.backends import (
    BACKENDS,
    BackendOptions,
    backend_names,
    get_backend,
    register,
    run_backend,
)
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario

QUICK = "scenarios/quick_stroke.toml"


class TwinSession:
    """A backend of one's own: the scenario's nominal arm (no plant truth) whose pen is not
    sensed, on the same executor and judge as every backend."""

    interrupted = "interrupted"
    notes = ("twin: the nominal arm",)
    senses = Senses.without(force="the twin's pen has no force sensor (a test backend)")

    def __init__(self, scenario):
        from inkarm.control.executor import run_drawing
        from inkarm.jobs.preflight import placed_within_budget
        from inkarm.sim.cell import Cell, build_model, kinematic_model
        from inkarm.sim.plant import MujocoPlant

        cell = Cell(scenario.cell, scenario.robot)
        self.scenario, self.run_drawing = scenario, run_drawing
        self.drawing = placed_within_budget(scenario, cell)
        self.believed = kinematic_model(cell)
        self.canvas = scenario.ink.canvas(cell.paper_size_mm)
        self.plant = MujocoPlant(build_model(cell), cell=cell, canvas=self.canvas,
                                 drive_gains=scenario.robot.drive)

    def execute(self, progress):
        s = self.scenario
        return self.run_drawing(self.drawing, self.plant, self.believed, s.robot.gains,
                                s.controller, law=s.law, progress=progress)

    def measure(self, log, finished):
        return None

    def close(self):
        self.plant.close()


class TwinBackend:
    name = "twin"
    help = "the nominal arm, for a test"
    needs_port = False

    def check(self, scenario, options):
        return None

    def open(self, scenario, options):
        return TwinSession(scenario)


@pytest.fixture
def twin():
    register(TwinBackend)  # the one registration
    yield
    BACKENDS._items.pop("twin", None)


@pytest.mark.sim
def test_a_backend_of_ones_own_is_one_registration_and_is_judged_as_every_backend(twin):
    scenario = load_scenario(QUICK)
    assert "twin" in backend_names()
    result = run_backend("twin", scenario)
    alone = run(scenario)  # the exact twin: the same drawing
    assert result.status == alone.status == "ok"
    assert np.array_equal(result.log.q, alone.log.q)
    assert result.notes[0] == "twin: the nominal arm"
    # what it cannot sense is not judged, and said so
    assert result.unjudged and all("not judged" in u for u in result.unjudged)
    assert np.isnan(result.metrics["contact_force_mean_n"])
    strict = run_backend("twin", scenario.with_overrides({"judge.tracking_rms_mm": 0.001}))
    assert strict.status == "degraded" and strict.reason.startswith("tracking RMS")


def test_unknown_backends_and_missing_ports_are_refused_before_anything_opens():
    with pytest.raises(InputError, match=r"--backend: unknown backend 'plotr' \(did you mean "
                                         r"'plotter'\?\)"):
        get_backend("plotr")
    with pytest.raises(InputError, match=r"--port: the plotter backend needs a serial port"):
        run_backend("plotter", load_scenario(QUICK))
    assert set(backend_names()) >= {"sim", "servo_sim", "plotter", "dynamixel"}


def test_a_torque_law_on_servos_in_position_mode_is_refused_before_the_port_opens():
    from inkarm.jobs.backends import check_backend

    scenario = load_scenario("scenarios/wx250s_letter_N.toml").with_overrides(
        {"controller.law": "joint_pid"})
    with pytest.raises(InputError, match=r"controller.law: law 'joint_pid' sends torque "
                                         r"commands, but the servos run in 'extended_position' "
                                         r"mode and take position; XL430-W250 cannot run in "
                                         r"current mode: use a law that sends position goals"):
        check_backend("dynamixel", scenario)
    with pytest.raises(InputError, match="controller.law: law 'joint_pid'"):
        run_backend("dynamixel", scenario, BackendOptions(port="/nonexistent/tty"))
    assert check_backend("dynamixel", load_scenario("scenarios/wx250s_letter_N.toml")) is None


@pytest.mark.hardware_emulated
def test_a_plotter_run_and_gcode_import_no_mujoco(tmp_path):
    """The plotter's whole path (scenario, backend, emulator, judge) and `inkarm gcode` in a
    fresh process: MuJoCo is never imported."""
    code = textwrap.dedent(f"""
        import sys
        from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
        from inkarm.jobs.backends.plotter import page_size_mm, run_plotter_scenario
        from inkarm.jobs.scenario import load_scenario
        scenario = load_scenario({QUICK!r})
        canvas = scenario.ink.canvas(page_size_mm(scenario))
        with GrblEmulator(EmulatorConfig(speedup=10), canvas=canvas) as emulator:
            result = run_plotter_scenario(scenario, emulator.port, time_scale=10,
                                          canvas=canvas)
        from inkarm.cli import main
        assert main(["gcode", {QUICK!r}, "--out", {str(tmp_path / "job.gcode")!r}]) == 0
        print(result.status, "mujoco" in sys.modules)
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    status, imported = done.stdout.split()[-2:]
    assert status in ("ok", "degraded") and imported == "False"


def test_every_backend_reports_what_it_cannot_sense():
    from inkarm.jobs.backends.dynamixel import dynamixel_senses
    from inkarm.jobs.backends.plotter import plotter_senses
    from inkarm.jobs.outcome import SIM_SENSES

    assert SIM_SENSES == Senses()
    assert not dynamixel_senses(ink=True).senses("force")
    assert not dynamixel_senses(ink=False).senses("ink")
    assert not plotter_senses(ink=True).senses("force")
    assert isinstance(Metrics(), Metrics)
