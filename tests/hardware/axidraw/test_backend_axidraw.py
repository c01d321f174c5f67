"""The ``axidraw`` backend end to end on the emulated EiBotBoard: the default scenario drawn
with the ink on the emulator's sheet matching the plan, every fault (a lost reply, an ``!``
error, a disconnect) a failed run with the pen up, the reason named and the log kept, and the
command line: ``inkarm draw --backend axidraw --port PORT`` (exit 0), a point beyond the
travel refused before a byte is sent (exit 2), ``--check`` with and without a port."""

from __future__ import annotations

import json
import re
import textwrap

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.hardware.axidraw import bus as bus_module
from inkarm.hardware.axidraw.emulator import EbbEmulator, Fault
from inkarm.jobs.backends import BackendOptions, check_backend, run_backend
from inkarm.jobs.backends.axidraw import planned_motions, prepared, run_axidraw_scenario
from inkarm.jobs.backends.plotter import page_size_mm
from inkarm.jobs.scenario import load_scenario
from tests.hardware.scenario_files import scenario_file

QUICK = "scenarios/quick_stroke.toml"
SPEEDUP = 10.0

pytestmark = pytest.mark.hardware_emulated


def draw_on_emulator(scenario, faults=(), speedup: float = SPEEDUP):
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    with EbbEmulator(speedup=speedup, canvas=canvas, model="V3", faults=faults) as emu:
        run = run_axidraw_scenario(scenario, emu.port, time_scale=speedup, canvas=canvas)
        state = {"pen_up": emu.machine.pen_up, "touching": emu.machine.servo.touching,
                 "steps": emu.stats.steps, "lines": emu.stats.lines,
                 "in_contact": canvas.in_contact}
    return run, state


def test_the_default_scenario_draws_on_the_axidraw_with_the_ink_on_the_plan():
    scenario = load_scenario(None)
    run, state = draw_on_emulator(scenario, speedup=5.0)  # (1.3 s: judged on its timing)
    m = run.metrics
    assert run.status == "ok", (run.reason, dict(m))
    assert m["ink_chamfer_mm"] <= 0.3
    assert m["gap_mm"] == 0.0
    assert np.isnan(m["contact_force_mean_n"])  # not sensed: never passed in silence
    assert any("force" in u for u in run.unjudged)
    profile, _, drawing, placement = prepared(scenario, None)
    sent = len(planned_motions(scenario, profile, placement, drawing).motions)
    assert any(f"axidraw: {sent} EBB motion commands" in n for n in run.notes)
    assert state["pen_up"] and not state["touching"]  # left with the pen up, back home
    assert len(run.log) > 20 and run.log.time[-1] > 3.0


@pytest.mark.parametrize("fault, why", [
    (Fault("drop", 60), "no reply to"),
    (Fault("error", 60, code=6), "!6 Err:"),
    (Fault("disconnect", 60), "the EBB disconnected"),
])
def test_each_fault_ends_the_run_failed_with_the_pen_up_and_the_log_kept(monkeypatch, fault,
                                                                         why):
    monkeypatch.setattr(bus_module, "REPLY_TIMEOUT_S", 0.3)
    scenario = load_scenario(None)
    run, state = draw_on_emulator(scenario, faults=(fault,))
    assert run.status == "failed" and not run.finished
    assert run.reason.startswith("the AxiDraw stopped: ") and why in run.reason
    assert re.search(r"'(SM|SP|QS|QP|QB|QM)[0-9,-]*'", run.reason)  # names the command
    assert run.log is not None and len(run.log) > 0  # the readings so far
    assert not state["in_contact"] and not state["touching"]
    if fault.kind != "disconnect":
        assert state["pen_up"]  # ES, SP,1, EM,0,0 after the fault


def test_draw_on_the_command_line_with_the_port(tmp_path, capsys):
    out = tmp_path / "run"
    with EbbEmulator(speedup=SPEEDUP, model="V3") as emu:
        code = main(["draw", QUICK, "--backend", "axidraw", "--port", emu.port,
                     "--time-scale", str(SPEEDUP), "--quiet", "--out", str(out)])
        assert not emu.machine.servo.touching
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert "note: axidraw:" in printed.out and "firmware 3.0.3" in printed.out
    status = json.loads((out / "status.json").read_text())
    assert status["status"] in ("ok", "degraded")
    assert (out / "trace.npz").exists() and (out / "canvas.png").exists()


def test_a_point_beyond_the_travel_is_refused_before_anything_is_sent(tmp_path, capsys):
    path = scenario_file(tmp_path, "below the V3's reach",
                         "[placement]\ncentre_mm = [105.0, 40.0]\n", "beyond.toml")
    with EbbEmulator(speedup=SPEEDUP, model="V3") as emu:
        code = main(["draw", str(path), "--backend", "axidraw", "--port", emu.port,
                     "--quiet", "--out", str(tmp_path / "o")])
        assert emu.stats.lines == 0  # not a byte
    err = capsys.readouterr().err.strip()
    assert code == 2 and "Traceback" not in err and "\n" not in err
    assert str(path) in err and "stroke 1 point 1 at page" in err
    assert "beyond the AxiDraw V3's travel, x 0 to 299.974 mm and y 0 to 217.932 mm" in err
    # on the A3 machine the same drawing fits
    assert "ok:" in check_backend("axidraw", load_scenario(path),
                                  BackendOptions(profile="v3_a3"))


def test_check_without_and_with_a_port(tmp_path, capsys):
    assert main(["draw", QUICK, "--check", "--backend", "axidraw", "--out",
                 str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "ok:" in out and "EBB motion commands" in out and "nothing sent" in out
    with EbbEmulator(speedup=SPEEDUP, model="V3") as emu:
        assert main(["draw", QUICK, "--check", "--backend", "axidraw", "--port", emu.port,
                     "--out", str(tmp_path / "o")]) == 0
        assert emu.stats.steps == 0
    assert "firmware 3.0.3; nothing moved" in capsys.readouterr().out
    with pytest.raises(Exception, match="--port: the axidraw backend needs a serial port"):
        run_backend("axidraw", load_scenario(QUICK))


def test_the_same_scenario_draws_on_the_arm_the_grbl_plotter_and_the_axidraw():
    from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
    from inkarm.jobs.backends.plotter import run_plotter_scenario
    from inkarm.jobs.run import run as run_arm

    scenario = load_scenario(QUICK)
    arm = run_arm(scenario)
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    with GrblEmulator(EmulatorConfig(speedup=SPEEDUP), canvas=canvas) as emu:
        plotter = run_plotter_scenario(scenario, emu.port, time_scale=SPEEDUP, canvas=canvas)
    axidraw, _ = draw_on_emulator(scenario)
    for name, result in (("arm", arm), ("plotter", plotter), ("axidraw", axidraw)):
        assert result.finished, (name, result.reason)
        assert result.metrics["ink_chamfer_mm"] <= 0.3, (name, dict(result.metrics))
    # one drawing: the same strokes were planned on every backend
    assert np.allclose(arm.drawing.strokes[0].pos, axidraw.drawing.strokes[0].pos)
    assert np.allclose(plotter.drawing.strokes[0].pos, axidraw.drawing.strokes[0].pos)


def test_an_axidraw_run_never_imports_mujoco():
    import subprocess
    import sys

    code = textwrap.dedent(f"""
        import sys
        from inkarm.hardware.axidraw.emulator import EbbEmulator
        from inkarm.jobs.backends.axidraw import run_axidraw_scenario
        from inkarm.jobs.scenario import load_scenario
        scenario = load_scenario({QUICK!r})
        with EbbEmulator(speedup=10.0) as emu:
            result = run_axidraw_scenario(scenario, emu.port, time_scale=10.0)
        print(result.finished, "mujoco" in sys.modules)
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-2:] == ["True", "False"]


def test_ctrl_c_stops_the_axidraw_and_keeps_the_partial_trace(tmp_path):
    from inkarm.jobs.outcome import RunInterrupted
    from inkarm.jobs.outputs import write_run

    scenario = load_scenario(None)

    def progress(fraction, stage):
        if stage == "stream" and fraction > 0.25:
            raise KeyboardInterrupt

    with EbbEmulator(speedup=SPEEDUP, model="V3") as emu, \
            pytest.raises(RunInterrupted) as caught:
        try:
            run_axidraw_scenario(scenario, emu.port, time_scale=SPEEDUP, progress=progress)
        finally:
            assert emu.machine.pen_up and not emu.machine.servo.touching
    run = caught.value.run
    assert run.status == "interrupted" and run.log is not None and len(run.log) > 0
    files = write_run(run, tmp_path / "out")
    status = json.loads(files["status.json"].read_text())
    assert status["status"] == "interrupted" and "Ctrl-C" in status["reason"]
    assert "motors turned off" in status["reason"]


def test_the_pause_button_stops_the_run_with_the_pen_up():
    scenario = load_scenario(None)
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    with EbbEmulator(speedup=SPEEDUP, canvas=canvas, model="V3") as emu:

        def progress(fraction, stage):
            if stage == "stream" and fraction > 0.2:
                emu.press_button()

        run = run_axidraw_scenario(scenario, emu.port, time_scale=SPEEDUP, canvas=canvas,
                                   progress=progress)
        assert emu.machine.pen_up and not emu.machine.servo.touching
    assert run.status == "failed" and "the pause button was pressed" in run.reason
    assert run.log is not None and 0 < run.log.time[-1] < 5.0


def test_a_device_refusing_the_set_up_is_a_one_line_error_before_anything_moves(tmp_path,
                                                                                 capsys):
    with EbbEmulator(speedup=SPEEDUP, model="V3", faults=(Fault("error", 4),)) as emu:
        code = main(["draw", QUICK, "--backend", "axidraw", "--port", emu.port, "--quiet",
                     "--out", str(tmp_path / "o")])
        assert emu.stats.steps == 0
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err
    assert "--port" in err and "the EBB refused 'SC,4," in err and "!6 Err:" in err
